"""Homogeneous observer with dynamic high gain, Andrieu, Praly & Astolfi (7)-(8).

Generic part, for the observability form (4) of any order n >= 2 with A(y) = I:

    correction_i = L^(i+b) K_i(s),  s = (x^1 - y_s) / L^b,  i = 1..n          (7)
    K_1 = k_1(s),  K_i = k_i(ell K_(i-1)),  k_i(w) = w + w^((r_i + d)/r_i),
    r_i = 1 - d (n - i)   (weights of the homogeneity in the bi-limit, degree d = d_inf)
    L' = L [phi1 (phi2 - L) + phi3 Omega]                                     (8)

with signed powers w^r = sign(w)|w|^r. At n = 2 this is the paper's observer of Section 3,
K = (k1(s), k2(ell k1(s))) with k1(s) = s + s^(1/(1-p)), k2(w) = w + w^(1+p), p = d.
``correction="linear"`` drops the power terms (k_i(w) = w; reading C3 "unit" of the
notes). Every power (r_i + d)/r_i is >= 1, so K is C^1 at 0 (only Hoelder-continuous
derivatives for d > 0: the integrators lose order, not convergence, where s crosses 0);
near 0 the correction is linear with gains c_i L^i, c_i = prod_(j<=i) kappa_j ell^(i-1),
kappa_j = 2 where the power is 1 (d = 0, homogeneous) and 1 otherwise. The builder checks
that lambda^n + c_1 lambda^(n-1) + ... + c_n is Hurwitz (n = 2: always).

Signed powers w^r with r < 1 (not Lipschitz at 0) occur only in Omega2 (x2^(1-p), x^2s^p),
always at saturated arguments >= x2lo(y_s) > 0, so the vector field is locally Lipschitz
(kinks at the saturations); the adaptive integrators (DOP853 in the presets) resolve the
kinks and the Hoelder point s = 0 by error control: tests/test_apa_numerics.py shows the
convergence against a tighter integration.

Instance (Section 3): the Contois bioreactor in the coordinates x = F(eta)
(:mod:`hgo.plants.contois`), n = 2, f1 = -u y, f2 of (12) evaluated at the saturated
(y_s, x^2s) with the model hbar_o:

    x^1' = x^2 - u y - L^(1+b) K_1(s)               (raw y in -u y, reading C15)
    x^2' = f2(y_s, x^2s, u) - L^(2+b) K_2(s)        (L^(2+b): the power (7) gives, C10)
    y_s = clip(y, eps1, 1 - eps2),  x^2s = clip(x^2, x2lo(y_s), x2hi(y_s))   (C16, C17)
    Omega = df2max (constant), Omega1(u, y_s, x^2s) or Omega2(u, y_s, x^2s) (``rate_bound``)
    eta^ = F^{-1}(x^1s, x^2s'), saturated with the observer's own x^1 (reading C7).

``gain="constant"`` freezes L at L(0) (the df2max observer, reading C4: the equilibrium
phi2 + (phi3/phi1) df2max of (8)). ``L0=None`` starts L at the equilibrium of (8),
phi2 + (phi3/phi1) Omega(u(0), y_s(0), x^2s(0)) with y(0) including the first noise
sample (reading C6); it is set by the discrete update at t = 0.

The model is the user's (issue 24): ``model(y, u, x1, x2, p) -> (y_s, f1, f2, Omega)``
gives, at the observer's estimate (x1, x2), the output as the correction reads it (y_s),
the drifts of x^1' = x^2 + f1 and x^2' = f2, and the bound Omega of (8);
``to_state(x1, x2, p) -> (eta1, eta2)`` maps the estimate to the plant's coordinates. Both
read their own parameters by name from the observer's ``p`` (``model_params`` of the
factory). The Contois instance above is :func:`contois_model` / :func:`contois_state`
(the default), with parameters hbar, eps1, eps2, df2max and the constant kind.

State z = [x^1, x^2, L] (x^ unsaturated); discrete d = [L initialised (0/1)];
parameters (by name): constants model, to_state, dynamic, homogeneous (and the Contois
model's kind: 0 df2max, 1 Omega1, 2 Omega2); values q (= d_inf), b, phi1, phi2, phi3, ell,
rho_lin (the spectral radius of the linear error dynamics at L = 1), then the model's
(Contois: hbar, eps1, eps2, df2max).
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np

from hgo.core.components import Observer, Params, model_values, user_function
from hgo.engine.jit import kernel_helper
from hgo.plants.contois import (
    check_hbar,
    clip,
    cubic,
    eta2_of_x,
    invariance_eps,
    m_coeffs,
    rate_bound_m,
    to_x,
    x2_high,
    x2_low,
)
from hgo.plants.contois import df2max as df2max_search

RATE_BOUNDS = {"df2max": 0, "omega1": 1, "omega2": 2}
CORRECTIONS = ("homogeneous", "linear")
GAINS = ("dynamic", "constant")


@kernel_helper
def spow(w, r):
    """Signed power w^r = sign(w) |w|^r (the paper's notation); w itself at r = 1."""
    if r == 1.0:
        return w
    return math.copysign(math.pow(abs(w), r), w)


@kernel_helper
def correction(s, L, Lb, d, ell, homogeneous, n, out):
    """out[i] = L^(i+1+b) K_(i+1)(s) for i < n: the correction of (7) with A(y) = I
    (Lb = L^b, computed once by the caller)."""
    arg = s
    Lp = L * Lb
    for i in range(n):
        r = 1.0 - d * (n - 1 - i)
        K = arg + spow(arg, (r + d) / r) if homogeneous else arg
        out[i] = Lp * K
        Lp *= L
        arg = ell * K


@kernel_helper
def gain_rate(L, phi1, phi2, phi3, omega):
    """L' of (8)."""
    return L * (phi1 * (phi2 - L) + phi3 * omega)


@kernel_helper
def model_terms(kind, u, ys, xh2, q, hbar, eps2, dfmax):
    """(f2(y_s, x^2s, u), Omega) of the observer: f2 of (12) and its bound df2max, Omega1 or
    Omega2 at (u, y_s, x^2s), from one evaluation of the m_i and of x2lo, x2hi."""
    lo, hi = x2_low(ys, eps2, hbar), x2_high(ys, hbar)
    xs = clip(xh2, lo, hi)
    m0, m1, m2, m3 = m_coeffs(u, ys, hbar)
    if kind == 0:
        return cubic(m0, m1, m2, m3, xs), dfmax
    omega = rate_bound_m(m1, m2, m3, xs, lo, hi, 0.0 if kind == 1 else q)
    return cubic(m0, m1, m2, m3, xs), omega


@kernel_helper
def omega_now(kind, u, ys, xh2, q, hbar, eps2, dfmax):
    """The bound Omega of the observer at (u, y_s, x^2s): df2max, Omega1 or Omega2."""
    return model_terms(kind, u, ys, xh2, q, hbar, eps2, dfmax)[1]


def contois_model(y, u, x1, x2, p):
    """The Contois model (12) of Section 3: y_s = clip(y, eps1, 1 - eps2) (C16), f1 = -u y
    with the raw y (C15), f2 at (y_s, x^2s) with the model hbar_o (C17) and its bound
    Omega (df2max, Omega1 or Omega2 by the constant p.kind)."""
    ys = clip(y, p.eps1, 1.0 - p.eps2)
    f2s, omega = model_terms(p.kind, u, ys, x2, p.q, p.hbar, p.eps2, p.df2max)
    return ys, -u * y, f2s, omega


def contois_state(x1, x2, p):
    """eta^ = F^{-1} of the saturated x^ (bounds at the observer's own x^1s, reading C7)."""
    x1s = clip(x1, p.eps1, 1.0 - p.eps2)
    x2s = clip(x2, x2_low(x1s, p.eps2, p.hbar), x2_high(x1s, p.hbar))
    return x1s, eta2_of_x(x1s, x2s, p.hbar)


def f(t, z, d, y, u, p, dz):
    """Andrieu, Praly & Astolfi (7)-(8) on the model p.model (module doc)."""
    L = z[2]
    ys, f1, f2s, omega = p.model(y[0], u[0], z[0], z[1], p)
    Lb = math.sqrt(L) if p.b == 0.5 else math.pow(L, p.b)
    correction((z[0] - ys) / Lb, L, Lb, p.q, p.ell, p.homogeneous, 2, dz)
    dz[0] = z[1] + f1 - dz[0]
    dz[1] = f2s - dz[1]
    dz[2] = gain_rate(L, p.phi1, p.phi2, p.phi3, omega) if p.dynamic else 0.0


def update(t, z, d, y, u, p):
    """At the first call (t = 0): L(0) = phi2 + (phi3/phi1) Omega(0), the equilibrium of (8)."""
    if d[0] > 0.5:
        return
    omega = p.model(y[0], u[0], z[0], z[1], p)[3]
    z[2] = p.phi2 + p.phi3 / p.phi1 * omega
    d[0] = 1.0


def estimate(t, z, d, p, xhat):
    """The plant state of the estimate: p.to_state of x^ (Contois: eta^ = F^{-1})."""
    xhat[0], xhat[1] = p.to_state(z[0], z[1], p)


def stiffness(t, z, d, p):
    """Spectral radius of the linear error dynamics now: rho_lin L."""
    return p.rho_lin * z[2]


def identity_state(x1, x2, p):
    """The estimate in the plant's coordinates when the model is written in them."""
    return x1, x2


def linear_gains(n: int, d: float, ell: float, homogeneous: bool) -> np.ndarray:
    """c_1..c_n: the correction near s = 0 is c_i L^i (x^1 - y) (see the module doc)."""
    c, prev = [], 1.0
    for i in range(n):
        r = 1.0 - d * (n - 1 - i)
        kappa = 2.0 if homogeneous and abs((r + d) / r - 1.0) < 1e-15 else 1.0
        prev = kappa * prev * (ell if i > 0 else 1.0)
        c.append(prev)
    return np.array(c)


def _check(cond: bool, message: str) -> None:
    if not cond:
        raise ValueError(message)


def homogeneous_dynamic_hgo(name: str, rate_bound: str = "omega2", p: float = 0.9,
                            b: float = 0.5, phi1: float = 3.0, phi2: float = 0.01,
                            phi3: float = 3.0, ell: float = 3.0, gain: str = "dynamic",
                            correction: str = "homogeneous", hbar: float = 0.8,
                            u_min: float = 0.01, u_max: float = 0.7,
                            eta_hat0: Sequence[float] = (0.5, 0.3),
                            L0: float | None = None, model=None, to_state=None,
                            model_params: dict | None = None,
                            xhat0: Sequence[float] | None = None) -> Observer:
    """Build the observer. Default model: Contois, whose eps1, eps2 and df2max are computed
    from (hbar, u_min, u_max), with rate bound ``rate_bound``. A user's ``model`` (and
    ``to_state``, default the identity) with its named ``model_params`` and the initial
    estimate ``xhat0`` replaces it (module doc); rate_bound, hbar, u_min, u_max and
    eta_hat0 are then unused. L0 = null starts at the equilibrium of (8) with the model's
    Omega."""
    key = f"observer.{name}"
    _check(rate_bound in RATE_BOUNDS, f"{key}.rate_bound: '{rate_bound}' not in "
           f"{sorted(RATE_BOUNDS)}")
    _check(gain in GAINS, f"{key}.gain: '{gain}' not in {list(GAINS)}")
    _check(correction in CORRECTIONS, f"{key}.correction: '{correction}' not in "
           f"{list(CORRECTIONS)}")
    _check(0.0 <= p < 1.0, f"{key}.p must be in [0, 1/(n-1)) = [0, 1) (Theorem 1), got {p}")
    for k, v in (("b", b), ("phi1", phi1), ("phi2", phi2), ("phi3", phi3), ("ell", ell)):
        _check(math.isfinite(v) and v > 0, f"{key}.{k} must be > 0, got {v}")
    check_hbar(f"{key}.hbar", hbar)
    _check(0.0 < u_min < u_max < 1.0, f"{key}: need 0 < u_min < u_max < 1, got "
           f"u_min={u_min}, u_max={u_max}")
    _check(len(eta_hat0) == 2 and all(v > 0 for v in eta_hat0) and sum(eta_hat0) <= 1.0,
           f"{key}.eta_hat0 must be 2 entries > 0 with sum <= 1, got {list(eta_hat0)}")
    _check(L0 is None or (math.isfinite(L0) and L0 >= phi2),
           f"{key}.L0 must be null (equilibrium of (8)) or >= phi2={phi2}, got {L0}")
    hom = correction == "homogeneous"
    c = linear_gains(2, p, ell, hom)
    roots = np.roots(np.concatenate([[1.0], c]))
    if not np.all(roots.real < 0):  # (the message formats an array: only when it fails)
        raise ValueError(f"{key}: the linear part of the correction is not Hurwitz (roots "
                         f"{roots})")
    constants = {"dynamic": gain == "dynamic", "homogeneous": hom}
    values = {"q": p, "b": b, "phi1": phi1, "phi2": phi2, "phi3": phi3, "ell": ell,
              "rho_lin": float(np.max(np.abs(roots)))}
    if model is None:
        eps1, eps2 = invariance_eps(hbar, u_min, u_max)
        constants.update(model=contois_model, to_state=contois_state,
                         kind=RATE_BOUNDS[rate_bound])
        values.update(hbar=hbar, eps1=eps1, eps2=eps2,
                      df2max=df2max_search(hbar, u_min, u_max)["df2max"])
        x_hat0 = to_x(eta_hat0, hbar)
    else:
        constants.update(model=user_function(f"{key}.model", model),
                         to_state=identity_state if to_state is None
                         else user_function(f"{key}.to_state", to_state))
        own = {k: "a parameter of the observer (7)-(8)" for k in (*constants, *values)}
        values.update(model_values(key, model_params, own))
        _check(xhat0 is not None and len(xhat0) == 2, f"{key}.xhat0 must be 2 numbers (the "
               f"initial x^ of a user's model), got {xhat0}")
        x_hat0 = np.asarray(xhat0, float)
    z0 = np.array([*x_hat0, math.nan if L0 is None else L0], float)
    if L0 is None:
        z0[2] = phi2  # replaced at t = 0 by the equilibrium (update)
    return Observer(name=name, state_names=["xhat1", "xhat2", "L"], disc_names=["L_set"],
                    estimated_states=[0, 1], z0=z0,
                    d0=np.array([0.0 if L0 is None else 1.0]), p=Params(constants, **values),
                    f=f,
                    estimate=estimate, update=update, stiffness=stiffness,
                    signals={"x": [0, 1], "L": [2]})
