"""High-gain observer with switched gain, Ahrens & Khalil (8)-(10) and (26)-(28), any r >= 1.

    dx^/dt = A x^ + B phi0(x^, w, u) + H (y - C x^),                  Ahrens & Khalil (8), (26)
    H = H_j = [alpha_1^j / eps_j, alpha_2^j / eps_j^2, ..., alpha_r^j / eps_j^r]^T,  (27)-(28)

with (A, B, C) the chain of integrators of (1)-(3), y = x1 + v the noisy measurement
(channel 0) and the nominal model

    phi0(x^, w, u) = sum_i m_i sat(x^_i) + b0 * w * u,   w = y[w_index] (measured, e.g. x3).

For the field-controlled DC motor (r = 2, Ahrens & Khalil Section 4) m = (0, -0.11),
b0 = 0.1 and w = x3: phi0 = -0.11 x^2 + 0.1 x3 u against the true phi = -0.1 x2 + 0.1 x3 u.

Switching scheme, Ahrens & Khalil Section 3.1 (read "|y - x^1| > delta"), evaluated by
``update`` after every integration step, so switching instants are step boundaries:

1. H = H1 and the delay timer is reset whenever |y - x^1| > delta;
2. when y - x^1 enters (or starts in) [-delta, delta] the timer starts, H stays H1;
3. after T_d spent inside the zone without leaving it, H = H2.

After the switch, an exit from the zone switches back to H1 (rule 1) and restarts the cycle.
A fixed-gain observer is the same class with one gain (``eps2=None``): the zone timer is
still kept (it tells when the error settled) but the gain never changes.

Saturation (Ahrens & Khalil Section 4, "the estimates are saturated outside [-100, 100]"):
the *exposed* estimate (``estimate``: what the controller and the error metrics see) and the
argument of phi0 are saturated at +-``saturation``; the observer state z itself is not (a
saturated state would change the observer's dynamics and its convergence). This makes the
controller and phi0 globally bounded in x^ (Assumptions 2(2) and 3), which is what protects
the closed loop from the peaking of x^2, ..., x^r. x^1 is *not* saturated by default: it
does not peak (it tracks the measurement) and the rotor position grows without bound in
speed tracking, so a saturated x^1 would only corrupt the position error; pass
``saturate_x1=True`` to saturate it as well (the paper's literal wording).

Continuous state z = [x^1, ..., x^r]. Parameters (by name): constants r, n_gains (1 or 2),
saturate_x1, w_index; values delta, T_d, saturation, b0, eps1, eps2, alpha1 (r),
alpha2 (r), m (r), H1 (r), H2 (r), rho1, rho2, where H_j = (alpha^j_i / eps_j^i) are the
injection gains (27)-(28), precomputed by the factory so that ``f`` does no division or
power per evaluation, and rho_j the spectral radius of the injection matrix with gain H_j
(the opt-in hook ``stiffness`` returns the active one). Derived entries: change alpha or
eps through the factory, not by editing p.
Discrete state d (``DISC_NAMES``) = [gain (active index 1 or 2), eps (active eps, for
plotting eps(t)), t_enter (time the error entered the zone, -1 when outside), timer (time
spent in the zone so far, 0 outside), n_switches (number of gain changes, both directions),
t_switch (time of the last gain change, -1 before any)].
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np

from hgo.core.components import Observer, Params
from hgo.engine.jit import record_helper

#: Names of the discrete state entries (see module docstring).
DISC_NAMES = ["gain", "eps", "t_enter", "timer", "n_switches", "t_switch"]
_TIME_TOL = 1e-12


@record_helper
def saturated(i, value, p):
    """Estimate i (0-based) saturated at +-p.saturation; x^1 only if p.saturate_x1."""
    if i == 0 and not p.saturate_x1:
        return value
    return min(max(value, -p.saturation), p.saturation)


@record_helper
def nominal_model(z, y, u, p):
    """phi0(x^, w, u) = sum_i m_i sat(x^_i) + b0 w u (Ahrens & Khalil (8), Assumption 3)."""
    phi = 0.0
    for i in range(p.r):
        mi = p.m[i]
        if mi != 0.0:
            phi += mi * saturated(i, z[i], p)
    if p.w_index >= 0 and p.b0 != 0.0:
        phi += p.b0 * y[p.w_index] * u[0]
    return phi


def f(t, z, d, y, u, p, dz):
    """Ahrens & Khalil (26) with H = H1 (27) or H2 (28) as selected by d[0]."""
    H = p.H1 if d[0] < 1.5 else p.H2  # precomputed alpha_i / eps^i
    e = y[0] - z[0]
    for i in range(p.r - 1):
        dz[i] = z[i + 1] + H[i] * e
    dz[p.r - 1] = nominal_model(z, y, u, p) + H[p.r - 1] * e


def stiffness(t, z, d, p):
    """Spectral radius of the injection matrix of the *active* gain (H1 or H2, from d[0]).

    Opt-in ``Observer.stiffness`` hook (``obs.stiffness = switched_hgo.stiffness``; the
    factory does not attach it): RK4 then takes the step of the active gain's margin, i.e.
    much longer steps after a switch to H2. That also samples the switching condition
    (evaluated after every step) less often, which changes the discrete switching pattern
    when T_d = 0 (tests/test_ak_claims.py::test_claim1_no_delay_switches_repeatedly), so
    the paper's experiments keep the constant worst-case ``spectral_radius``.
    """
    return p.rho1 if d[0] < 1.5 else p.rho2


def update(t, z, d, y, u, p):
    """Switching scheme of Ahrens & Khalil Section 3.1 on the output error y - x^1."""
    e = y[0] - z[0]
    if abs(e) > p.delta:  # rule 1: outside the zone, reset the timer, H = H1
        d[2] = -1.0
        d[3] = 0.0
        if d[0] > 1.5:
            d[0] = 1.0
            d[4] += 1.0
            d[5] = t
    else:
        if d[2] < 0.0:  # rule 2: entered (or started in) the zone, start the timer
            d[2] = t
        d[3] = t - d[2]
        # rule 3: after T_d inside the zone, H = H2
        if p.n_gains > 1 and d[0] < 1.5 and d[3] >= p.T_d - _TIME_TOL * max(1.0, t):
            d[0] = 2.0
            d[4] += 1.0
            d[5] = t
    d[1] = p.eps1 if d[0] < 1.5 else p.eps2


def estimate(t, z, d, p, xhat):
    """The saturated estimate x^ fed to the controller and to the error metrics."""
    for i in range(p.r):
        xhat[i] = saturated(i, z[i], p)


def injection_matrix(alpha: Sequence[float], eps: float,
                     model: Sequence[float] | None = None) -> np.ndarray:
    """A - H C + B m^T: the linear part of (26) with gain (9) (saturation inactive)."""
    alpha = np.asarray(alpha, float)
    r = alpha.size
    mat = np.diag(np.ones(r - 1), 1)
    mat[:, 0] -= alpha / eps ** np.arange(1, r + 1)
    if model is not None:
        mat[r - 1, :] += np.asarray(model, float)
    return mat


def spectral_radius(alphas: Sequence[Sequence[float]], epss: Sequence[float],
                    model: Sequence[float] | None = None) -> float:
    """Largest |eigenvalue| of the injection matrix over all gains (bounds the RK4 step)."""
    return max(float(np.max(np.abs(np.linalg.eigvals(injection_matrix(a, e, model)))))
               for a, e in zip(alphas, epss, strict=True))


def _check(cond: bool, message: str) -> None:
    if not cond:
        raise ValueError(message)


def _check_alpha(name: str, key: str, alpha: np.ndarray, r: int) -> None:
    _check(alpha.shape == (r,), f"observer.{name}.{key} must have r={r} entries, "
           f"got {alpha.size}")
    _check(bool(np.all(np.isfinite(alpha))), f"observer.{name}.{key} must be finite")
    roots = np.roots(np.concatenate([[1.0], alpha]))
    _check(bool(np.all(roots.real < 0)), f"observer.{name}.{key}: the roots of "
           f"s^r + alpha_1 s^(r-1) + ... + alpha_r (Ahrens & Khalil (10)) must have negative "
           f"real parts, got {np.round(roots, 6).tolist()}")


def switched_hgo(name: str, alpha1: Sequence[float], eps1: float,
                 alpha2: Sequence[float] | None = None, eps2: float | None = None,
                 delta: float = 0.05, T_d: float = 0.15,
                 xhat0: Sequence[float] = (math.pi, 0.0), saturation: float = 100.0,
                 saturate_x1: bool = False, model: Sequence[float] = (0.0, -0.11),
                 input_gain: float = 0.1, w_index: int = 1) -> Observer:
    """The (switched-gain) high-gain observer, Ahrens & Khalil (8)-(10), (26)-(28), 3.1.

    ``alpha1, eps1``: the gain H1 (27) used first; ``alpha2, eps2``: the gain H2 (28) used
    after the switch (``alpha2`` defaults to ``alpha1``); ``eps2=None`` gives a fixed-gain
    observer (8)-(9). ``delta``: half-width of the switching zone [-delta, delta];
    ``T_d``: delay timer (s). ``model`` (m_1..m_r), ``input_gain`` (b0) and ``w_index``
    define phi0 = sum m_i sat(x^_i) + b0 y[w_index] u (``w_index=-1``: no w u term); the
    defaults are the DC motor's phi0 = -0.11 x^2 + 0.1 x3 u. Defaults of delta, T_d, xhat0
    and saturation are Ahrens & Khalil Section 4 (delta = 0.05, T_d = 0.15 s,
    x^(0) = (pi, 0), saturation at 100).
    """
    _check(isinstance(name, str) and name != "", "observer name must be a non-empty string")
    a1 = np.atleast_1d(np.asarray(alpha1, float))
    r = a1.size
    _check(r >= 1, f"observer.{name}.alpha1 must have r >= 1 entries")
    _check_alpha(name, "alpha1", a1, r)
    _check(math.isfinite(eps1) and eps1 > 0, f"observer.{name}.eps1 must be in (0, inf), "
           f"got {eps1}")
    if eps2 is None:
        _check(alpha2 is None, f"observer.{name}.alpha2 given without eps2: a switched "
               "observer needs both (or neither, for a fixed gain)")
        n_gains, a2, e2 = 1, a1, float(eps1)
    else:
        n_gains = 2
        a2 = a1 if alpha2 is None else np.atleast_1d(np.asarray(alpha2, float))
        _check_alpha(name, "alpha2", a2, r)
        e2 = float(eps2)
        _check(math.isfinite(e2) and e2 >= eps1, f"observer.{name}.eps2 must be in "
               f"[eps1={eps1}, inf) (Ahrens & Khalil (28): 0 < eps1 < eps2), got {eps2}")
    _check(math.isfinite(delta) and delta > 0, f"observer.{name}.delta must be in (0, inf), "
           f"got {delta}")
    _check(math.isfinite(T_d) and T_d >= 0, f"observer.{name}.T_d must be in [0, inf), "
           f"got {T_d}")
    _check(saturation > 0, f"observer.{name}.saturation must be in (0, inf] (inf: none), "
           f"got {saturation}")
    _check(len(xhat0) == r, f"observer.{name}.xhat0 must have r={r} entries, "
           f"got {len(xhat0)}")
    m = np.asarray(model, float)
    _check(m.shape == (r,), f"observer.{name}.model must have r={r} entries "
           f"(m_1..m_r of phi0), got {m.size}")
    _check(isinstance(w_index, (int, np.integer)) and w_index >= -1,
           f"observer.{name}.w_index must be an output channel index >= 0, or -1 for none, "
           f"got {w_index}")
    h1 = a1 / float(eps1) ** np.arange(1, r + 1)
    h2 = a2 / e2 ** np.arange(1, r + 1)
    rho1 = spectral_radius([a1], [eps1], m)
    rho2 = spectral_radius([a2], [e2], m)
    p = Params({"r": r, "n_gains": n_gains, "saturate_x1": bool(saturate_x1),
                "w_index": int(w_index)},
               delta=delta, T_d=T_d, saturation=saturation, b0=input_gain, eps1=eps1, eps2=e2,
               alpha1=a1, alpha2=a2, m=m, H1=h1, H2=h2, rho1=rho1, rho2=rho2)
    rho = max(rho1, rho2)
    d0 = np.array([1.0, eps1, -1.0, 0.0, 0.0, -1.0])
    uses_w = w_index >= 0 and input_gain != 0.0  # phi0's b0 w u term reads y[w_index], u[0]
    return Observer(name=name, state_names=[f"xhat{i + 1}" for i in range(r)],
                    disc_names=list(DISC_NAMES), estimated_states=list(range(r)),
                    z0=np.asarray(xhat0, float), d0=d0, p=p, f=f, estimate=estimate,
                    update=update, spectral_radius=rho,
                    reads_outputs=[0, w_index] if uses_w else [0],
                    reads_inputs=[0] if uses_w else [])
