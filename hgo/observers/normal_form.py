"""High-gain observers for any plant in observability normal form (issue 24, item 4).

The plant, of order n >= 2:

    x1' = x2,  ...,  x(n-1)' = xn,  xn' = phi0(x, u),   y = x1 (+ noise),

with phi0 the user's function ``phi0(x, u, p) -> float`` (x the estimate fed to it, u the
plant's inputs, p this observer's parameters: a function reads model constants such as
``p.mu`` that the observer declares in ``model_params``), or 0 (a chain of integrators).
In a config: ``phi0: {_target_: module.function, _partial_: true}``.

* :func:`standard_hgo`, the standard high-gain observer (Khalil's form):

      x^i' = x^(i+1) + (alpha_i / eps^i) (y - x^1),   i = 1..n-1,
      x^n' = phi0(x^, u) + (alpha_n / eps^n) (y - x^1),

  alpha from the Hurwitz polynomial s^n + alpha_1 s^(n-1) + ... + alpha_n with the given
  ``roots`` (default all at -1: alpha_i = C(n, i)). Its estimate x^n peaks like
  eps^-(n-1) = ell^(n-1) after an initial error in x1.

* :func:`lowpower_hgo`, the low-power high-gain observer of Astolfi & Marconi (*A
  high-gain nonlinear observer with limited gain power*, IEEE TAC 60(11), 2015): n - 1
  blocks xi_i in R^2,

      xi_i' = A2 xi_i + N2 xi_(i+1) + D(ell) K_i e_i,     i = 1..n-2,
      xi_(n-1)' = A2 xi_(n-1) + B2 phi0(x^, u) + D(ell) K_(n-1) e_(n-1),
      A2 = [[0, 1], [0, 0]], N2 = [[0, 0], [0, 1]], B2 = [0, 1]^T, D(ell) = diag(ell, ell^2),
      e_1 = y - xi_1,1,   e_i = xi_(i-1),2 - xi_i,1,
      x^ = (xi_1,1, xi_1,2, xi_2,2, ..., xi_(n-1),2),

  gains K_i = (k_i1, k_i2). No gain exceeds ell^2, whatever n: x^n peaks like ell.

For both, ``saturation`` (a level M, scalar or one per state) clips the estimate fed to
phi0 to [-M, M] (peaking protection; the state itself is not clipped), and eps = 1 / ell
(give one of them). The state z is the observer's own (x^ for the standard observer, the
estimate x^ = (xi_1,1, xi_1,2, ..., xi_(n-1),2) first, then xi_2,1, ..., xi_(n-1),1 for the
low-power one).

Design checks in the factories (one line each on failure): alpha from roots with negative
real parts; the low-power observer's linear error system (phi0 = 0) Hurwitz at the chosen
ell and K_i (:func:`lowpower_error_matrix`). Its default gains (:func:`lowpower_default_gains`)
give block i its own characteristic polynomial (s + c_i)^2 with c_i = 2^(n-1-i), the block
nearest the measurement the fastest: the error system is then Hurwitz for n = 2..8 (largest
real part between -0.23 ell (n = 4) and -1.0 ell (n = 2)); equal gains in every block are
not, from n = 4 on (e.g. K_i = (2, 1): +0.099 ell at n = 4).
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence

import numpy as np

from hgo.core.components import Observer, Params, model_values, user_function


def zero_phi0(x, u, p):  # noqa: ARG001 - the signature of phi0
    """phi0 = 0: the plant is a chain of integrators."""
    return 0.0


# ---------------------------------------------------------------------- kernel functions
# No allocation in a kernel function: an array allocated per evaluation hangs the parallel
# ensemble kernel (measured: two members of the low-power observer, np.empty in f, never
# returned). The estimate goes to phi0 as a view of z (the low-power state is ordered so
# that x^ is its first n entries); the saturated estimate is written into d, the
# observer's discrete state, used here as a work area that only f writes (no update: d
# never triggers a re-evaluation).
def standard_f(t, z, d, y, u, p, dz):
    """x^i' = x^(i+1) + (alpha_i / eps^i) (y - x^1); x^n' = phi0(x^, u) + (alpha_n / eps^n) e."""
    e = y[0] - z[0]
    gain = 1.0
    for i in range(p.n - 1):
        gain /= p.eps
        dz[i] = z[i + 1] + p.alpha[i] * gain * e
    gain /= p.eps
    if p.saturate:  # (a constant: one branch is compiled)
        for i in range(p.n):
            d[i] = min(max(z[i], -p.sat_level[i]), p.sat_level[i])
        phi = p.phi0(d, u, p)
    else:
        phi = p.phi0(z, u, p)
    dz[p.n - 1] = phi + p.alpha[p.n - 1] * gain * e


def standard_estimate(t, z, d, p, xhat):
    """x^ = z."""
    for i in range(p.n):
        xhat[i] = z[i]


def lowpower_f(t, z, d, y, u, p, dz):
    """Astolfi & Marconi's blocks b = 1..n-1: xi_b,1' = xi_b,2 + ell k_b1 e_b,
    xi_b,2' = xi_(b+1),2 (phi0(x^, u) in the last block) + ell^2 k_b2 e_b, with
    z = (xi_1,1, xi_1,2, xi_2,2, ..., xi_(n-1),2, xi_2,1, ..., xi_(n-1),1)."""
    n = p.n
    ell2 = p.ell * p.ell
    if p.saturate:
        for i in range(n):
            d[i] = min(max(z[i], -p.sat_level[i]), p.sat_level[i])
        phi = p.phi0(d, u, p)
    else:
        phi = p.phi0(z[:n], u, p)
    for b in range(n - 1):  # (0-based: block b + 1 of the paper)
        first = 0 if b == 0 else n + b - 1  # where xi_(b+1),1 is; xi_(b+1),2 is z[b + 1]
        e = y[0] - z[0] if b == 0 else z[b] - z[first]
        dz[first] = z[b + 1] + p.ell * p.K[b, 0] * e
        dz[b + 1] = (z[b + 2] if b < n - 2 else phi) + ell2 * p.K[b, 1] * e


def lowpower_estimate(t, z, d, p, xhat):
    """x^ = (xi_1,1, xi_1,2, xi_2,2, ..., xi_(n-1),2): the first n entries of z."""
    for i in range(p.n):
        xhat[i] = z[i]


# ---------------------------------------------------------------------- design
def hurwitz_alpha(n: int, roots: Sequence[float] | None = None,
                  key: str = "roots") -> np.ndarray:
    """alpha_1..alpha_n of prod (s - r_i) = s^n + alpha_1 s^(n-1) + ... + alpha_n;
    default: every root at -1 (alpha_i = C(n, i)). ``key``: the config key in messages."""
    roots = [-1.0] * n if roots is None else list(roots)
    if len(roots) != n:
        raise ValueError(f"{key} must have n = {n} entries, got {len(roots)}")
    if not all(np.real(r) < 0 for r in roots):
        raise ValueError(f"{key} must have negative real parts (Hurwitz), got {roots}")
    return np.real(np.poly(roots))[1:]


def lowpower_default_gains(n: int) -> np.ndarray:
    """K_i = (2 c_i, c_i^2), c_i = 2^(n-1-i), i = 1..n-1 (module doc)."""
    c = 2.0 ** np.arange(n - 2, -1, -1)
    return np.column_stack([2.0 * c, c * c])


def lowpower_error_matrix(n: int, ell: float, K: np.ndarray) -> np.ndarray:
    """The linear error system of the low-power observer (phi0 = 0): the observer's own
    matrix with y = 0 (the error xi - (x_i, x_(i+1)) obeys it), 2(n-1) x 2(n-1)."""
    m = n - 1
    M = np.zeros((2 * m, 2 * m))
    for i in range(m):
        e = np.zeros(2 * m)  # e_i as a row over the states
        if i > 0:
            e[2 * i - 1] = 1.0
        e[2 * i] = -1.0
        M[2 * i] += ell * K[i, 0] * e
        M[2 * i, 2 * i + 1] += 1.0
        M[2 * i + 1] += ell * ell * K[i, 1] * e
        if i < m - 1:
            M[2 * i + 1, 2 * i + 3] += 1.0
    return M


# ---------------------------------------------------------------------- factories
def _phi0(phi0: Callable | float | None, key: str) -> Callable:
    """phi0 as the kernel calls it: the user's function (:func:`user_function`: a callable
    or ``{_target_: module.function, _partial_: true}``), or :func:`zero_phi0` for 0 / None."""
    if phi0 is None or (isinstance(phi0, (int, float)) and phi0 == 0):
        return zero_phi0
    return user_function(f"{key}.phi0", phi0)


def _gain(eps: float | None, ell: float | None, key: str) -> float:
    """ell = 1 / eps (exactly one of them given, > 0)."""
    if (eps is None) == (ell is None):
        raise ValueError(f"{key}: give exactly one of eps and ell (= 1/eps)")
    value = ell if ell is not None else 1.0 / eps if eps else math.nan
    if not (math.isfinite(value) and value > 0):
        raise ValueError(f"{key}.{'ell' if ell is not None else 'eps'} must be > 0 and finite, "
                         f"got {ell if ell is not None else eps}")
    return float(value)


#: the parameters both observers own (name -> what it is); a model's may not take them
OWN = {"n": "the order", "phi0": "the model function", "saturate": "saturation on or off",
       "sat_level": "the saturation levels M"}
OWN_STANDARD = {**OWN, "eps": "the gain parameter eps = 1/ell",
                "alpha": "the Hurwitz coefficients alpha_1..alpha_n, from roots"}
OWN_LOWPOWER = {**OWN, "ell": "the gain ell = 1/eps", "K": "the block gains (k_i1, k_i2)"}


def _common(key: str, n: int, phi0, saturation, model_params, xhat0,
            own: dict[str, str]) -> tuple[dict, dict, np.ndarray]:
    """Constants (n, phi0, saturate), run-time values (sat_level, model_params), x^(0);
    the model's names checked against the observer's ``own``."""
    if not (isinstance(n, int) and n >= 2):
        raise ValueError(f"{key}.n must be an integer >= 2, got {n!r}")
    level = np.full(n, np.inf) if saturation is None else np.asarray(saturation, float)
    if level.size == 1:  # one level for every state
        level = np.full(n, float(level.reshape(-1)[0]))
    if level.shape != (n,) or not np.all(level > 0):
        raise ValueError(f"{key}.saturation must be > 0 (one level or n = {n}), "
                         f"got {saturation}")
    x0 = np.zeros(n) if xhat0 is None else np.asarray(xhat0, float).reshape(-1)
    if x0.shape != (n,) or not np.all(np.isfinite(x0)):
        raise ValueError(f"{key}.xhat0 must have n = {n} finite entries, got {xhat0}")
    constants = {"n": n, "phi0": _phi0(phi0, key), "saturate": saturation is not None}
    return constants, {"sat_level": level, **model_values(key, model_params, own)}, x0


def _work_names(constants: dict) -> list[str]:
    """The discrete state: with saturation, the work area of the saturated estimate fed to
    phi0 (kernel functions' comment); it holds the last evaluation's value, not a signal."""
    return [f"phi0_arg{i + 1}" for i in range(constants["n"])] if constants["saturate"] else []


def standard_hgo(name: str, n: int, eps: float | None = None, ell: float | None = None,
                 phi0: Callable | float | None = 0.0, roots: Sequence[float] | None = None,
                 saturation: float | Sequence[float] | None = None,
                 model_params: dict | None = None,
                 xhat0: Sequence[float] | None = None) -> Observer:
    r"""The standard high-gain observer (Khalil's form) of order $n$, gain $1/\varepsilon$.

    For a plant in observability normal form $\dot x_i = x_{i+1}$ ($i < n$),
    $\dot x_n = \varphi_0(x, u)$, $y = x_1$ + noise:

    $$\dot{\hat x}_i = \hat x_{i+1} + \frac{\alpha_i}{\varepsilon^i}\,(y - \hat x_1),
    \quad i = 1, \dots, n-1, \qquad
    \dot{\hat x}_n = \varphi_0(\hat x, u) + \frac{\alpha_n}{\varepsilon^n}\,(y - \hat x_1),$$

    $\alpha$ the coefficients of the Hurwitz polynomial
    $s^n + \alpha_1 s^{n-1} + \dots + \alpha_n = \prod_i (s - r_i)$.
    After an initial error in $x_1$ the estimate $\hat x_n$ peaks like
    $\varepsilon^{-(n-1)}$. With measurement noise of size $\mu$ and a model error in
    $\varphi_0$, the error of $\hat x_i$ is of order
    $\varepsilon^{n-i+1} + \mu / \varepsilon^{i-1}$: the trade-off in $\varepsilon$
    appears only with a model error (with $\varphi_0$ exact the noise term alone remains,
    smallest at the largest $\varepsilon$).

    Args:
        name: the observer's name: its key under ``observer:`` and its signals'
            ``/observer/<name>/...`` in the recording.
        n: the order, an integer $\ge 2$; states ``xhat1`` ... ``xhat<n>``.
        eps: $\varepsilon > 0$ (in the plant's time unit, s). Give exactly one of ``eps`` and
            ``ell``.
        ell: $\ell = 1/\varepsilon$ (1/s).
        phi0: the model $\varphi_0$: ``phi0(x, u, p) -> float`` with ``x`` the estimate
            (n), ``u`` the plant's inputs, ``p`` this observer's parameters (``p.mu`` of
            ``model_params``); in a config ``{_target_: module.phi0, _partial_: true}``. It
            is compiled with the kernel: it and every function it calls must compile in
            numba's nopython mode (decorate a helper with ``numba.njit``). Default ``0.0``:
            a chain of integrators.
        roots: the $n$ roots $r_i$ of the Hurwitz polynomial, real parts $< 0$. Default:
            all at $-1$, $\alpha_i = \binom{n}{i}$ (for $n = 2$: $\alpha = (2, 1)$).
        saturation: a level $M > 0$ (one, or one per state): $\varphi_0$ is fed the estimate
            clipped to $[-M, M]$ (peaking protection; the state is not clipped). Default
            ``None``: no saturation.
        model_params: named run-time values ``phi0`` reads (``{mu: 1.0}`` -> ``p.mu``). A
            name may not be one of the observer's own: ``n``, ``eps``, ``alpha``, ``phi0``,
            ``saturate``, ``sat_level`` (one-line error naming both).
        xhat0: $\hat x(0)$, $n$ finite numbers. Default zeros.

    Returns:
        The observer: state $z = \hat x$ ($n$), estimate of every plant state,
            ``spectral_radius`` $= \max_i |r_i| / \varepsilon$.

    Example:
        ```python
        from hgo.observers.normal_form import standard_hgo

        obs = standard_hgo("std", n=2, eps=0.01, xhat0=[0.5, 0.0])
        print(obs.p.alpha, obs.p.eps, obs.spectral_radius)  # (2.0, 1.0) 0.01 100.0
        ```

        In a config (``conf/observer/vdp_standard.yaml``): ``standard: {_target_:
        hgo.observers.normal_form.standard_hgo, n: 2, eps: 0.05, phi0: {_target_:
        hgo.plants.van_der_pol.phi0, _partial_: true}, model_params: {mu: ${plant.mu}}}``.
    """
    key = f"observer.{name}"
    gain = _gain(eps, ell, key)
    constants, values, x0 = _common(key, n, phi0, saturation, model_params, xhat0,
                                    OWN_STANDARD)
    alpha = hurwitz_alpha(n, roots, f"{key}.roots")
    constants["alpha"] = tuple(alpha.tolist())
    radius = gain * float(np.max(np.abs(np.roots(np.concatenate([[1.0], alpha])))))
    return Observer(name=name, state_names=[f"xhat{i + 1}" for i in range(n)],
                    disc_names=_work_names(constants),
                    estimated_states=list(range(n)), z0=x0,
                    d0=np.zeros(len(_work_names(constants))),
                    p=Params(constants, eps=1.0 / gain, **values), f=standard_f,
                    estimate=standard_estimate, spectral_radius=radius)


def lowpower_hgo(name: str, n: int, ell: float | None = None, eps: float | None = None,
                 phi0: Callable | float | None = 0.0, K: Sequence[Sequence[float]] | None = None,
                 saturation: float | Sequence[float] | None = None,
                 model_params: dict | None = None,
                 xhat0: Sequence[float] | None = None) -> Observer:
    r"""Astolfi & Marconi's low-power high-gain observer of order $n$, gain $\ell$.

    Astolfi & Marconi, *A high-gain nonlinear observer with limited gain power*, IEEE TAC
    60(11), 2015: $n - 1$ blocks $\xi_i \in \mathbb{R}^2$,

    $$\dot\xi_i = A_2 \xi_i + N_2 \xi_{i+1} + D(\ell) K_i e_i, \quad i = 1..n-2, \qquad
    \dot\xi_{n-1} = A_2 \xi_{n-1} + B_2 \varphi_0(\hat x, u) + D(\ell) K_{n-1} e_{n-1},$$

    $$A_2 = \begin{pmatrix} 0 & 1 \\ 0 & 0 \end{pmatrix},\;
    N_2 = \begin{pmatrix} 0 & 0 \\ 0 & 1 \end{pmatrix},\;
    B_2 = \begin{pmatrix} 0 \\ 1 \end{pmatrix},\;
    D(\ell) = \operatorname{diag}(\ell, \ell^2),\;
    e_1 = y - \xi_{1,1},\; e_i = \xi_{i-1,2} - \xi_{i,1},$$

    estimate $\hat x = (\xi_{1,1}, \xi_{1,2}, \xi_{2,2}, \dots, \xi_{n-1,2})$. No gain
    exceeds $\ell^2$ whatever $n$, and $\hat x_n$ peaks like $\ell$ (the standard
    observer's like $\ell^{n-1}$). For $n = 2$ there is one block, and with the default
    gains $K_1 = (2, 1)$ it *is* the standard observer with $\alpha = (2, 1)$,
    $\varepsilon = 1/\ell$.

    Args:
        name: the observer's name (key under ``observer:``, ``/observer/<name>/...``).
        n: the order, an integer $\ge 2$.
        ell: $\ell > 0$ (1/s). Give exactly one of ``ell`` and ``eps``.
        eps: $\varepsilon = 1/\ell$ (s).
        phi0: the model $\varphi_0(x, u, p)$, as for :func:`standard_hgo` (numba-compilable;
            default ``0.0``).
        K: the gains $K_i = (k_{i1}, k_{i2})$, an $(n-1) \times 2$ array. Default
            :func:`lowpower_default_gains`: block $i$'s polynomial $(s + c_i)^2$,
            $c_i = 2^{n-1-i}$ (Hurwitz error system for $n = 2..8$). The factory refuses
            gains whose linear error system (:func:`lowpower_error_matrix`) is not Hurwitz.
        saturation: level(s) $M$ of the estimate fed to $\varphi_0$, as for
            :func:`standard_hgo`. Default ``None``.
        model_params: named run-time values ``phi0`` reads. Reserved (the observer's own):
            ``n``, ``ell``, ``K``, ``phi0``, ``saturate``, ``sat_level``.
        xhat0: $\hat x(0)$ ($n$ numbers; block $i$ starts at
            $(\hat x_i(0), \hat x_{i+1}(0))$). Default zeros.

    Returns:
        The observer: state $z = (\xi_{1,1}, \xi_{1,2}, \xi_{2,2}, \dots, \xi_{n-1,2},
            \xi_{2,1}, \dots, \xi_{n-1,1})$ ($2n - 2$; its first $n$ entries are $\hat x$),
            ``spectral_radius`` that of the linear error system.

    Example:
        ```python
        import numpy as np
        from hgo.observers.normal_form import lowpower_hgo, standard_hgo

        low = lowpower_hgo("low", n=2, ell=100.0)
        std = standard_hgo("std", n=2, eps=0.01)
        print(low.p.K.tolist(), low.state_names)  # [[2.0, 1.0]] ['xi1_1', 'xi1_2']
        assert np.isclose(low.spectral_radius, std.spectral_radius)  # n = 2: the same observer
        ```
    """
    key = f"observer.{name}"
    gain = _gain(eps, ell, key)
    constants, values, x0 = _common(key, n, phi0, saturation, model_params, xhat0,
                                    OWN_LOWPOWER)
    K = lowpower_default_gains(n) if K is None else np.asarray(K, float)
    if K.shape != (n - 1, 2) or not np.all(np.isfinite(K)):
        raise ValueError(f"{key}.K must be n - 1 = {n - 1} pairs (k_i1, k_i2), got "
                         f"{np.asarray(K).tolist()}")
    eig = np.linalg.eigvals(lowpower_error_matrix(n, gain, K))
    if not np.all(eig.real < 0):
        raise ValueError(f"{key}: the linear error system is not Hurwitz at ell = {gain:g} "
                         f"with K = {K.tolist()} (largest real part of its eigenvalues "
                         f"{eig.real.max():.3g}); the default K = "
                         f"{lowpower_default_gains(n).tolist()} is")
    z0 = np.concatenate([x0, x0[1:n - 1]])  # block i starts at (x^i(0), x^(i+1)(0))
    states = ["xi1_1", *(f"xi{i + 1}_2" for i in range(n - 1)),
              *(f"xi{i + 1}_1" for i in range(1, n - 1))]
    return Observer(name=name, state_names=states, disc_names=_work_names(constants),
                    estimated_states=list(range(n)), z0=z0,
                    d0=np.zeros(len(_work_names(constants))),
                    p=Params(constants, ell=gain, K=K, **values), f=lowpower_f,
                    estimate=lowpower_estimate, spectral_radius=float(np.abs(eig).max()))
