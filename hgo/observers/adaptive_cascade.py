"""High-gain observer in cascade with an adaptive observer, Dimassi et al. (5)-(7), (11).

For the class Dimassi et al. (1), x' = A x + B phi(x, u) + B psi(x, u) theta + E u, y = C x
(theta constant, unknown), with auxiliary outputs z = H x (:func:`auxiliary_outputs`):

    z_hi' = a_i z_hi + Gamma_i (y_i - z_hi1) + b_i2 u,  Gamma_i = [g_i1/eps, ..., g_iqi/eps^qi]  (6)
    z_h^s = [S_k sat(z_hk / S_k)]_k            (Sec. IV; only what feeds the second stage, A3)
    x^'   = A x^ + B phi(x^a, u) + B psi(x^a, u) th^ + E u + L (z_h^s - H x^)
            [+ w^ B M (z_h^s - H x^)]                                         (5) [+ (11)]
    th^'  = delta psi(x^a, u)^T M (z_h^s - H x^) - sigma th^                  (7)
    w^'   = |M (z_h^s - H x^)|^2 - sigma2 w^       (11), reconstructed, off by default (A10)

Choices the paper leaves open (config keys of ``observer.<name>``, defaults = implementation
notes ``shared/specs/dhlm.md``):

* ``psi_at`` (A2): ``"y"`` (default) evaluates phi, psi at x^a = x^ + C^+ (y - C x^), i.e. x^
  with its measured coordinates replaced by y (the example writes psi(y, u)); ``"xhat"``
  evaluates them at x^ (the class (5), (7) as printed).
* saturation (A3): the HGO integrates its own state z_h unsaturated; only z_h^s is passed
  on, to (5), (7) and (11). ``S`` may hold ``inf`` (no saturation).
* ``omega_law`` (A10): the injection of w^ is not printed in the paper; the term
  w^ B M (z_h^s - H x^) is a reconstruction (the one that closes the Lyapunov argument).
* q_i = 1: no HGO for output i, z_hi = y_i directly.
* ``hgo="ideal"``: diagnostic, not in the paper: z_h^s = H x read from the plant's outputs
  (the plant must output z = H x, e.g. ``plant.outputs: Hx`` of the robot arm); no HGO, no
  saturation. A plant with fewer outputs (or fewer inputs than E has columns) makes the
  run stop at t = 0 with "non-finite state" (:func:`_miswired`).

phi and psi are known functions of the class, the user's: ``phi(x, u, out)`` writes
phi(x, u) (m entries) and ``psi(x, u, out)`` writes psi(x, u) (m x q); any function numba
can compile (or plain Python, on the slower path), given in Python or as a ``_target_``
(``{_target_: module.function, _partial_: true}``), with their Lipschitz constants K_phi,
K_psi (theory rows). ``model`` names an instance (:data:`MODELS`): ``robot_arm`` is
Dimassi et al. (25) with phi = 0 and psi = [u, -sin x1] (regressor order A1, so
theta = (1/I, m g l/(2 I)); :func:`hgo.plants.robot_arm.dimassi_psi`).

Continuous state z = [z_h (N) | x^ (n) | th^ (q) | w^ (1)]. Discrete state d
(``disc_names``) = [t_sat_first, t_sat_last]: the first and last integration step end at
which the saturation was active (-1: never); the adaptive step is short while it is (the
HGO peaking), so no output grid is involved. (d changes only then: the integrator's
first-same-as-last evaluation is kept on every other step.)

Parameters (by name): constants n, N (entries of z), m, q, r (inputs), n_y (outputs), the
flags psi_at_y, omega_law, ideal, the functions phi (or None: phi = 0) and psi, and per
entry k of z: out (its output), first (the index of its block's z_hi1), last (its block's
last entry), direct (q_i = 1), and selects (C selects coordinates) with measured (per
state, the output that measures it, or -1); values eps, delta, sigma, sigma2, K_phi,
K_psi, A (n x n), B (n x m), E (n x r), H (N x n), L (n x N), M (m x N), C (n_y x n),
Cp (n x n_y: C^+), Bz2 (N x r: b_i2 rows), Gamma (N), S (N).
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np

from hgo.core.components import Observer, Params, user_function
from hgo.engine.jit import matrix_view, record_helper
from hgo.plants.robot_arm import dimassi_psi


def zero_phi(x, u, out):
    """phi = 0 (not called: the flag has_phi is False; it only gives the record a type)."""
    for j in range(out.shape[0]):
        out[j] = 0.0


#: model name -> (phi, psi, m, q, K_phi, K_psi): the instances of the class (1).
MODELS = {"robot_arm": (None, dimassi_psi, 1, 2, 0.0, 1.0)}
PSI_AT = {"y": 0, "xhat": 1}
HGO_MODES = ("observer", "ideal")


@record_helper
def passed_on(k, zh, y, p):
    """Entry k of z_h^s: the saturated HGO output, y_i for q_i = 1, or H x (ideal)."""
    if p.ideal:
        return y[k]
    if p.direct[k]:
        return y[p.out[k]]
    s = p.S[k]
    return min(max(zh[k], -s), s)


@record_helper
def innovation(k, zh, xh, y, p):
    """Entry k of z_h^s - H x^."""
    v = passed_on(k, zh, y, p)
    for j in range(p.n):
        v -= p.H[k, j] * xh[j]
    return v


@record_helper
def _miswired(y, u, p):
    """The plant gives fewer outputs (n_y, or N for ``hgo=ideal``) or inputs (r) than the
    observer reads: ``update`` then makes the state non-finite (the run stops at t = 0
    with "non-finite state") and ``f`` returns zeros, instead of reading past y or u."""
    need_y = p.N if p.ideal else p.n_y
    return y.shape[0] < need_y or u.shape[0] < max(p.r, 1)


@record_helper
def _argument(xh, y, p, xa):
    """The point where phi, psi are evaluated, into xa: x^ + C^+ (y - C x^) (psi_at_y), i.e.
    x^ with its measured coordinates replaced by y, or x^. When C selects coordinates
    (``selects``), the replacement is exact: y itself, not x^ + (y - x^)."""
    for i in range(p.n):
        if p.psi_at_y and p.selects:
            xa[i] = y[p.measured[i]] if p.measured[i] >= 0 else xh[i]
            continue
        v = xh[i]
        if p.psi_at_y:
            for o in range(p.n_y):
                cx = 0.0
                for j in range(p.n):
                    cx += p.C[o, j] * xh[j]
                v += p.Cp[i, o] * (y[o] - cx)
        xa[i] = v


def f(t, z, d, y, u, p, dz):
    """Dimassi et al. (6) (HGO), (5) (state), (7) (parameters), (11) (w^, when enabled)."""
    if _miswired(y, u, p):
        for i in range(dz.shape[0]):
            dz[i] = 0.0
        return
    nn, n, m, q = p.N, p.n, p.m, p.q
    zh = z[:nn]
    xh = z[nn:nn + n]
    th = z[nn + n:nn + n + q]
    w_hat = z[nn + n + q]
    for k in range(nn):  # (6): chain of integrators + output injection + b_i2 u
        if p.ideal or p.direct[k]:
            dz[k] = 0.0
            continue
        e = y[p.out[k]] - zh[p.first[k]]
        v = p.Gamma[k] * e
        if not p.last[k]:
            v += zh[k + 1]
        for j in range(p.r):
            v += p.Bz2[k, j] * u[j]
        dz[k] = v
    for i in range(n):  # (5): A x^ + E u, then + L (z_h^s - H x^)
        v = 0.0
        for j in range(n):
            v += p.A[i, j] * xh[j]
        for j in range(p.r):
            v += p.E[i, j] * u[j]
        dz[nn + i] = v
    # scratch space (no heap): [x^a (n) | phi (m) | psi (m x q) | z_h^s - H x^ (N)]
    work = p.scratch
    inn = work[n + m + m * q:n + m + m * q + nn]  # each entry once: (5) and (7) read it
    for k in range(nn):
        inn[k] = innovation(k, zh, xh, y, p)
        for i in range(n):
            dz[nn + i] += p.L[i, k] * inn[k]
    for k in range(q):  # (7): th^' = delta psi^T M (z_h^s - H x^) - sigma th^
        dz[nn + n + k] = -p.sigma * th[k]
    xa = work[:n]  # phi(x^a, u) and psi(x^a, u), evaluated once
    _argument(xh, y, p, xa)
    phi = work[n:n + m]
    if p.has_phi:
        p.phi(xa, u, phi)
    psi = matrix_view(work, n + m, m, q)
    p.psi(xa, u, psi)
    mi_sq = 0.0
    for j in range(m):  # row j of M (z_h^s - H x^) and of psi: (5) + B g, (7), (11)
        mi = 0.0
        for k in range(nn):
            mi += p.M[j, k] * inn[k]
        mi_sq += mi * mi
        g = phi[j] if p.has_phi else 0.0
        if p.omega_law:
            g += w_hat * mi  # (11), reconstructed injection w^ B M (z_h^s - H x^)
        for k in range(q):
            g += psi[j, k] * th[k]
            dz[nn + n + k] += p.delta * psi[j, k] * mi
        for i in range(n):
            dz[nn + i] += p.B[i, j] * g
    dz[nn + n + q] = mi_sq - p.sigma2 * w_hat if p.omega_law else 0.0


def update(t, z, d, y, u, p):
    """First and last step end at which the saturation was active (some |z_hk| > S_k)."""
    if _miswired(y, u, p):
        z[0] = math.nan
        return
    if p.ideal:
        return
    for k in range(p.N):
        if not p.direct[k] and abs(z[k]) > p.S[k]:  # (q_i = 1: no HGO)
            if d[0] < 0.0:
                d[0] = t
            d[1] = t
            return


def estimate(t, z, d, p, xhat):
    """x^ of (5)."""
    for i in range(p.n):
        xhat[i] = z[p.N + i]


# --- construction --------------------------------------------------------------------------


def _matrix(name: str, key: str, value, shape: tuple[int, int]) -> np.ndarray:
    mat = np.asarray(value, float)
    if mat.ndim == 1 and shape[1] == 1 and mat.size == shape[0]:
        mat = mat.reshape(shape)
    if mat.shape != shape:
        raise ValueError(f"observer.{name}.{key} must be a {shape[0]}x{shape[1]} matrix, "
                         f"got shape {mat.shape}")
    if not np.all(np.isfinite(mat)):
        raise ValueError(f"observer.{name}.{key} must be finite, got {mat.tolist()}")
    return mat


def relative_degrees(A: np.ndarray, B: np.ndarray, C: np.ndarray, tol: float = 1e-12
                     ) -> list[int]:
    """r_i: the smallest j with C_i A^(j-1) B != 0 (n + 1 when there is none)."""
    n = A.shape[0]
    out = []
    for ci in C:
        row, deg = ci.copy(), n + 1
        for j in range(1, n + 1):
            if np.max(np.abs(row @ B)) > tol:
                deg = j
                break
            row = row @ A
        out.append(deg)
    return out


def auxiliary_outputs(A: np.ndarray, B: np.ndarray, C: np.ndarray, q: Sequence[int],
                      name: str = "observer") -> np.ndarray:
    """H = [C_1; C_1 A; ...; C_1 A^(q_1-1); ...; C_p A^(q_p-1)] of Dimassi et al. (5).

    Checks 1 <= q_i <= r_i (relative degree of y_i w.r.t. theta) and rank(HB) = rank(B)
    (observer matching for (H, B)); raises ValueError naming ``<name>.q`` otherwise.
    """
    if len(q) != C.shape[0] or not all(isinstance(v, (int, np.integer)) for v in q):
        raise ValueError(f"{name}.q must be {C.shape[0]} integers (one per output), got {q}")
    degrees = relative_degrees(A, B, C)
    rows = []
    for i, (qi, ri) in enumerate(zip(q, degrees, strict=True)):
        if not 1 <= qi <= min(ri, A.shape[0]):
            raise ValueError(f"{name}.q[{i}] must be in [1, r_{i + 1}={min(ri, A.shape[0])}] "
                             f"(relative degree of y_{i + 1} w.r.t. theta), got {qi}")
        rows += [C[i] @ np.linalg.matrix_power(A, j) for j in range(qi)]
    H = np.array(rows)
    rank_hb, rank_b = np.linalg.matrix_rank(H @ B), np.linalg.matrix_rank(B)
    if rank_hb != rank_b:
        raise ValueError(f"{name}.q = {list(q)}: rank(HB) = {rank_hb} != rank(B) = {rank_b} "
                         "(Dimassi et al. (5) needs observer matching for (H, B)); raise q_i")
    return H


def hgo_matrix(gamma: Sequence[float]) -> np.ndarray:
    """a-bar_i of Dimassi et al. (13)-(15): first column -gamma, identity above the diagonal."""
    g = np.asarray(gamma, float)
    mat = np.eye(g.size, k=1)
    mat[:, 0] = -g
    return mat


def _check(cond: bool, message: str) -> None:
    if not cond:
        raise ValueError(message)


def adaptive_cascade(name: str, A: Sequence, B: Sequence, C: Sequence, E: Sequence | None = None,
                     model: str | None = "robot_arm", q: Sequence[int] = (2,),
                     gamma: Sequence[Sequence[float]] = ((6.0, 8.0),), eps: float = 0.006,
                     S: Sequence[float] = (150.0, 150.0), L: Sequence = ((5.0, 0.0), (1.0, 10.0)),
                     M: Sequence = ((0.0, 1.0),), delta: float = 100.0, sigma: float = 0.01,
                     psi_at: str = "y", omega_law: bool = False, sigma2: float = 0.01,
                     hgo: str = "observer", zh0: Sequence[float] | None = None,
                     xhat0: Sequence[float] | None = None,
                     theta_hat0: Sequence[float] | None = None,
                     omega_hat0: float = 0.0, phi=None, psi=None, n_theta: int | None = None,
                     K_phi: float = 0.0, K_psi: float | None = None) -> Observer:
    """The cascade (6) -> (5), (7) [, (11)] for the class (1); defaults: Dimassi et al. Sec. IV.

    ``A`` (n x n), ``B`` (n x m), ``C`` (p x n), ``E`` (n x r, default zeros with r = 1),
    ``q``: the integers q_i (one per output) building H; ``gamma[i]``: the q_i gains of
    block i (s^qi + g_i1 s^(qi-1) + ... + g_iqi must be Hurwitz); ``eps`` in (0, 1);
    ``S``: one saturation level per entry of z (inf: none); ``L`` (n x N), ``M`` (m x N);
    ``delta`` > 0, ``sigma`` >= 0; see the module docstring for the rest. Initial states
    default to zero (the paper's choice). ``model`` names an instance of :data:`MODELS`;
    ``model=None`` takes the user's ``psi`` (and ``phi``, default 0) with ``n_theta``
    unknown parameters, m = the columns of B, and their Lipschitz constants ``K_phi``,
    ``K_psi`` (module doc).
    """
    key = f"observer.{name}"
    phi, psi, m, nq, K_phi, K_psi = _model(key, model, B, phi, psi, n_theta, K_phi, K_psi)
    A = np.asarray(A, float)
    _check(A.ndim == 2 and A.shape[0] == A.shape[1], f"{key}.A must be square, got {A.shape}")
    n = A.shape[0]
    A = _matrix(name, "A", A, (n, n))
    B = _matrix(name, "B", B, (n, m))
    C = np.atleast_2d(np.asarray(C, float))
    C = _matrix(name, "C", C, (C.shape[0], n))
    po = C.shape[0]
    E = np.zeros((n, 1)) if E is None else np.atleast_2d(np.asarray(E, float))
    E = _matrix(name, "E", E, (n, E.shape[1] if E.shape[0] == n else E.shape[0]))
    r = E.shape[1]
    H = auxiliary_outputs(A, B, C, list(q), key)
    nn = H.shape[0]
    _check(len(gamma) == po, f"{key}.gamma must have {po} rows (one per output), got {len(gamma)}")
    _check(math.isfinite(eps) and 0 < eps < 1, f"{key}.eps must be in (0, 1), got {eps}")
    gains, out, first, last, direct, bz2 = [], [], [], [], [], []
    for i, qi in enumerate(q):
        g = np.asarray(gamma[i], float)
        _check(g.shape == (qi,), f"{key}.gamma[{i}] must have q_{i + 1}={qi} entries, "
               f"got {g.size}")
        poles = np.linalg.eigvals(hgo_matrix(g))
        _check(bool(np.all(np.isfinite(g)) and np.all(poles.real < 0)),
               f"{key}.gamma[{i}]: s^{qi} + gamma_1 s^{qi - 1} + ... must be Hurwitz "
               f"(Dimassi et al. (13)), roots {np.round(poles, 6).tolist()}")
        k0 = len(gains)
        for j in range(qi):
            gains.append(g[j] / eps ** (j + 1))
            out.append(i)
            first.append(k0)
            last.append(1.0 if j == qi - 1 else 0.0)
            direct.append(1.0 if qi == 1 else 0.0)
            bz2.append(C[i] @ np.linalg.matrix_power(A, j) @ E)
    S = np.asarray(S, float)
    _check(S.shape == (nn,) and bool(np.all(S > 0)) and not np.any(np.isnan(S)),
           f"{key}.S must be {nn} levels in (0, inf] (one per entry of z), got {S.tolist()}")
    L = _matrix(name, "L", L, (n, nn))
    M = _matrix(name, "M", M, (m, nn))
    _check(math.isfinite(delta) and delta > 0, f"{key}.delta must be in (0, inf), got {delta}")
    _check(math.isfinite(sigma) and sigma >= 0, f"{key}.sigma must be in [0, inf), got {sigma}")
    _check(math.isfinite(sigma2) and sigma2 >= 0,
           f"{key}.sigma2 must be in [0, inf), got {sigma2}")
    _check(psi_at in PSI_AT, f"{key}.psi_at must be one of {sorted(PSI_AT)}, got '{psi_at}'")
    _check(hgo in HGO_MODES, f"{key}.hgo must be one of {list(HGO_MODES)}, got '{hgo}'")
    init = {}
    for k, value, size in (("zh0", zh0, nn), ("xhat0", xhat0, n), ("theta_hat0", theta_hat0, nq)):
        v = np.zeros(size) if value is None else np.asarray(value, float)
        _check(v.shape == (size,) and bool(np.all(np.isfinite(v))),
               f"{key}.{k} must be {size} finite numbers, got {np.asarray(value).tolist()}")
        init[k] = v
    _check(math.isfinite(omega_hat0), f"{key}.omega_hat0 must be finite, got {omega_hat0}")
    p = Params({"n": n, "N": nn, "m": m, "q": nq, "r": r, "n_y": po,
                "psi_at_y": psi_at == "y", "omega_law": bool(omega_law),
                "ideal": hgo == "ideal", "has_phi": phi is not None,
                "phi": zero_phi if phi is None else phi, "psi": psi,
                "out": out, "first": first, "last": [bool(v) for v in last],
                "direct": [bool(v) for v in direct], **_measured(C),
                "scratch": n + m + m * nq + nn},
               eps=eps, delta=delta, sigma=sigma, sigma2=sigma2, K_phi=K_phi, K_psi=K_psi,
               A=A, B=B, E=E, H=H, L=L, M=M, C=C, Cp=np.linalg.pinv(C),
               Bz2=np.asarray(bz2).reshape(nn, r), Gamma=gains, S=S)
    z0 = np.concatenate([init["zh0"], init["xhat0"], init["theta_hat0"], [omega_hat0]])
    # stiffest linear parts: the HGO poles eig(a-bar_i)/eps and eig(A - L H)
    rho = max([float(np.max(np.abs(np.linalg.eigvals(hgo_matrix(g))))) / eps
               for g, qi in zip(gamma, q, strict=True) if qi > 1]
              + [float(np.max(np.abs(np.linalg.eigvals(A - L @ H))))])
    zn = [f"zh{out[k] + 1}{k - first[k] + 1}" for k in range(nn)]
    return Observer(
        name=name, state_names=zn + [f"xhat{i + 1}" for i in range(n)]
        + [f"theta_hat{k + 1}" for k in range(nq)] + ["omega_hat"],
        disc_names=["t_sat_first", "t_sat_last"],
        estimated_states=list(range(n)), z0=z0,
        d0=np.array([-1.0, -1.0]), p=p, f=f,
        estimate=estimate, update=update, spectral_radius=rho,
        signals={"theta_hat": list(range(nn + n, nn + n + nq)), "omega_hat": [nn + n + nq]})


def _measured(C: np.ndarray) -> dict:
    """``selects``: whether every row of C is a unit vector e_i, with distinct i (y_o
    measures x_i); ``measured``: per state, the output that measures it, or -1."""
    rows = [np.flatnonzero(row) for row in C]
    units = [int(r[0]) for o, r in enumerate(rows) if r.size == 1 and C[o, r[0]] == 1.0]
    selects = len(units) == len(rows) and len(set(units)) == len(units)
    measured = [-1] * C.shape[1]
    for o, i in enumerate(units if selects else []):
        measured[i] = o
    return {"selects": selects, "measured": measured}


def _model(key: str, model: str | None, B, phi, psi, n_theta, K_phi, K_psi) -> tuple:
    """(phi or None, psi, m, q, K_phi, K_psi) of a named instance or of the user's."""
    if model is not None:
        _check(model in MODELS, f"{key}.model must be one of {sorted(MODELS)} or null (the "
               f"user's phi, psi), got '{model}'")
        _check(phi is None and psi is None, f"{key}: give model or phi/psi, not both")
        return MODELS[model]
    _check(psi is not None, f"{key}.psi is required when model is null (psi(x, u, out))")
    _check(isinstance(n_theta, (int, np.integer)) and n_theta >= 1,
           f"{key}.n_theta must be an integer >= 1 (the unknown parameters), got {n_theta}")
    _check(K_psi is not None and math.isfinite(K_psi) and K_psi >= 0 and math.isfinite(K_phi)
           and K_phi >= 0, f"{key}: K_phi and K_psi must be Lipschitz constants >= 0, got "
           f"{K_phi}, {K_psi}")
    m = np.atleast_2d(np.asarray(B, float)).shape[1]
    return (None if phi is None else user_function(f"{key}.phi", phi),
            user_function(f"{key}.psi", psi), m, int(n_theta), float(K_phi), float(K_psi))


def unpack(p) -> dict[str, np.ndarray | float]:
    """The named parameters of an observer's ``p`` as one dict (for post-processing and
    theory): every value, the dimensions, the per-entry tuples as arrays, and the flags
    psi_at (0: y, 1: x^), ideal and omega_law as 0/1."""
    spec = p.spec
    blocks = {name: spec.get(p, name) for name in spec.names}
    blocks.update({k: spec.constants[k] for k in ("n", "N", "m", "q", "r", "n_y")})
    blocks.update({k: np.asarray(spec.constants[k], float)
                   for k in ("out", "first", "last", "direct")})
    blocks.update(psi_at=0.0 if p.psi_at_y else 1.0, ideal=float(p.ideal),
                  omega_law=float(p.omega_law))
    return blocks
