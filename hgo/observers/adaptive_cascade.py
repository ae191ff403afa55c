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

phi and psi are known functions of the class; they are compiled, chosen by ``model``
(:data:`MODELS`): ``robot_arm`` is Dimassi et al. (25) with phi = 0 and psi = [u, -sin x1]
(regressor order A1, so theta = (1/I, m g l/(2 I))).

Continuous state z = [z_h (N) | x^ (n) | th^ (q) | w^ (1)]. Discrete state d
(``disc_names``) = [t_sat_first, t_sat_last]: the first and last integration step end at
which the saturation was active (-1: never); the adaptive step is short while it is (the
HGO peaking), so no output grid is involved. (d changes only then: the integrator's
first-same-as-last evaluation is kept on every other step.)

Parameters p: a header (``HEAD``) then the row-major arrays A (n x n), B (n x m),
E (n x r), H (N x n), L (n x N), M (m x N), C (p x n), C^+ (n x p), Bz2 (N x r: b_i2 rows),
Gamma (N), S (N), out (N: output of the block), first (N: index of the block's z_hi1),
last (N: 1 for the block's last entry), direct (N: 1 when q_i = 1). Offsets: :func:`_layout`.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np

from hgo.core.components import Observer
from hgo.engine.jit import kernel_helper

HEAD = ["n", "N", "m", "q", "r", "p", "eps", "delta", "sigma", "sigma2", "psi_at",
        "omega_law", "ideal", "model"]
_NH = len(HEAD)
#: model name -> (id, m, q, K_phi, K_psi): the compiled phi, psi of :func:`regressor`.
MODELS = {"robot_arm": (0, 1, 2, 0.0, 1.0)}
PSI_AT = {"y": 0, "xhat": 1}
HGO_MODES = ("observer", "ideal")


@kernel_helper
def _layout(p):
    """Offsets of A, B, E, H, L, M, C, Cp, Bz2, Gamma, S, out, first, last, direct."""
    n, nn, m, r, po = int(p[0]), int(p[1]), int(p[2]), int(p[4]), int(p[5])
    o_a = _NH
    o_b = o_a + n * n
    o_e = o_b + n * m
    o_h = o_e + n * r
    o_l = o_h + nn * n
    o_m = o_l + n * nn
    o_c = o_m + m * nn
    o_cp = o_c + po * n
    o_bz = o_cp + n * po
    o_g = o_bz + nn * r
    o_s = o_g + nn
    return (o_a, o_b, o_e, o_h, o_l, o_m, o_c, o_cp, o_bz, o_g, o_s, o_s + nn, o_s + 2 * nn,
            o_s + 3 * nn, o_s + 4 * nn)


@kernel_helper
def _arg_state(i, xh, y, p, o_c, o_cp):
    """Entry i of the point where phi, psi are evaluated: x^ (psi_at = xhat) or
    x^ + C^+ (y - C x^) (psi_at = y)."""
    if p[10] > 0.5:
        return xh[i]
    n, po = int(p[0]), int(p[5])
    v = xh[i]
    for o in range(po):
        cx = 0.0
        for j in range(n):
            cx += p[o_c + o * n + j] * xh[j]
        v += p[o_cp + i * po + o] * (y[o] - cx)
    return v


@kernel_helper
def regressor(j, k, xh, y, u, p, o_c, o_cp):
    """psi_jk(x^a, u) of the model p[13] (robot_arm: psi = [u, -sin x1], one row)."""
    if k == 0:
        return u[0]
    return -math.sin(_arg_state(0, xh, y, p, o_c, o_cp))


@kernel_helper
def nonlinearity(j, xh, y, u, p, o_c, o_cp):
    """phi_j(x^a, u) of the model p[13] (robot_arm: phi = 0)."""
    return 0.0


@kernel_helper
def passed_on(k, zh, y, p, o_s, o_out, o_dir):
    """Entry k of z_h^s: the saturated HGO output, y_i for q_i = 1, or H x (ideal)."""
    if p[12] > 0.5:
        return y[k]
    if p[o_dir + k] > 0.5:
        return y[int(p[o_out + k])]
    s = p[o_s + k]
    return min(max(zh[k], -s), s)


@kernel_helper
def innovation(k, zh, xh, y, p, o_h, o_s, o_out, o_dir):
    """Entry k of z_h^s - H x^."""
    n = int(p[0])
    v = passed_on(k, zh, y, p, o_s, o_out, o_dir)
    for j in range(n):
        v -= p[o_h + k * n + j] * xh[j]
    return v


@kernel_helper
def _miswired(y, u, p):
    """The plant gives fewer outputs (p, or N for ``hgo=ideal``) or inputs (r) than the
    observer reads: ``update`` then makes the state non-finite (the run stops at t = 0
    with "non-finite state") and ``f`` returns zeros, instead of reading past y or u."""
    need_y = int(p[1]) if p[12] > 0.5 else int(p[5])
    return y.shape[0] < need_y or u.shape[0] < max(int(p[4]), 1)


def f(t, z, d, y, u, p, dz):
    """Dimassi et al. (6) (HGO), (5) (state), (7) (parameters), (11) (w^, when enabled)."""
    if _miswired(y, u, p):
        for i in range(dz.shape[0]):
            dz[i] = 0.0
        return
    n, nn, m, q, r = int(p[0]), int(p[1]), int(p[2]), int(p[3]), int(p[4])
    delta, sigma, sigma2, omega_on, ideal = p[7], p[8], p[9], p[11], p[12]
    (o_a, o_b, o_e, o_h, o_l, o_m, o_c, o_cp, o_bz, o_g, o_s, o_out, o_first, o_last,
     o_dir) = _layout(p)
    zh = z[:nn]
    xh = z[nn:nn + n]
    th = z[nn + n:nn + n + q]
    w_hat = z[nn + n + q]
    for k in range(nn):  # (6): chain of integrators + output injection + b_i2 u
        if ideal > 0.5 or p[o_dir + k] > 0.5:
            dz[k] = 0.0
            continue
        e = y[int(p[o_out + k])] - zh[int(p[o_first + k])]
        v = p[o_g + k] * e
        if p[o_last + k] < 0.5:
            v += zh[k + 1]
        for j in range(r):
            v += p[o_bz + k * r + j] * u[j]
        dz[k] = v
    for i in range(n):  # (5): A x^ + E u, then + L (z_h^s - H x^)
        v = 0.0
        for j in range(n):
            v += p[o_a + i * n + j] * xh[j]
        for j in range(r):
            v += p[o_e + i * r + j] * u[j]
        dz[nn + i] = v
    for k in range(nn):
        inn = innovation(k, zh, xh, y, p, o_h, o_s, o_out, o_dir)
        for i in range(n):
            dz[nn + i] += p[o_l + i * nn + k] * inn
    for k in range(q):  # (7): th^' = delta psi^T M (z_h^s - H x^) - sigma th^
        dz[nn + n + k] = -sigma * th[k]
    mi_sq = 0.0
    for j in range(m):  # row j of M (z_h^s - H x^) and of psi: (5) + B g, (7), (11)
        mi = 0.0
        for k in range(nn):
            mi += p[o_m + j * nn + k] * innovation(k, zh, xh, y, p, o_h, o_s, o_out, o_dir)
        mi_sq += mi * mi
        g = nonlinearity(j, xh, y, u, p, o_c, o_cp)
        if omega_on > 0.5:
            g += w_hat * mi  # (11), reconstructed injection w^ B M (z_h^s - H x^)
        for k in range(q):
            psi = regressor(j, k, xh, y, u, p, o_c, o_cp)
            g += psi * th[k]
            dz[nn + n + k] += delta * psi * mi
        for i in range(n):
            dz[nn + i] += p[o_b + i * m + j] * g
    dz[nn + n + q] = mi_sq - sigma2 * w_hat if omega_on > 0.5 else 0.0


def update(t, z, d, y, u, p):
    """First and last step end at which the saturation was active (some |z_hk| > S_k)."""
    if _miswired(y, u, p):
        z[0] = math.nan
        return
    if p[12] > 0.5:
        return
    nn = int(p[1])
    offsets = _layout(p)
    o_s, o_dir = offsets[10], offsets[14]
    for k in range(nn):
        if p[o_dir + k] < 0.5 and abs(z[k]) > p[o_s + k]:  # (q_i = 1: no HGO)
            if d[0] < 0.0:
                d[0] = t
            d[1] = t
            return


def estimate(t, z, d, p, xhat):
    """x^ of (5)."""
    nn, n = int(p[1]), int(p[0])
    for i in range(n):
        xhat[i] = z[nn + i]


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
                     model: str = "robot_arm", q: Sequence[int] = (2,),
                     gamma: Sequence[Sequence[float]] = ((6.0, 8.0),), eps: float = 0.006,
                     S: Sequence[float] = (150.0, 150.0), L: Sequence = ((5.0, 0.0), (1.0, 10.0)),
                     M: Sequence = ((0.0, 1.0),), delta: float = 100.0, sigma: float = 0.01,
                     psi_at: str = "y", omega_law: bool = False, sigma2: float = 0.01,
                     hgo: str = "observer", zh0: Sequence[float] | None = None,
                     xhat0: Sequence[float] | None = None,
                     theta_hat0: Sequence[float] | None = None,
                     omega_hat0: float = 0.0) -> Observer:
    """The cascade (6) -> (5), (7) [, (11)] for the class (1); defaults: Dimassi et al. Sec. IV.

    ``A`` (n x n), ``B`` (n x m), ``C`` (p x n), ``E`` (n x r, default zeros with r = 1),
    ``q``: the integers q_i (one per output) building H; ``gamma[i]``: the q_i gains of
    block i (s^qi + g_i1 s^(qi-1) + ... + g_iqi must be Hurwitz); ``eps`` in (0, 1);
    ``S``: one saturation level per entry of z (inf: none); ``L`` (n x N), ``M`` (m x N);
    ``delta`` > 0, ``sigma`` >= 0; see the module docstring for the rest. Initial states
    default to zero (the paper's choice).
    """
    key = f"observer.{name}"
    _check(model in MODELS, f"{key}.model must be one of {sorted(MODELS)}, got '{model}'")
    model_id, m, nq, _, _ = MODELS[model]
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
    head = [n, nn, m, nq, r, po, eps, delta, sigma, sigma2, PSI_AT[psi_at], float(omega_law),
            float(hgo == "ideal"), model_id]
    p = np.concatenate([head, A.ravel(), B.ravel(), E.ravel(), H.ravel(), L.ravel(), M.ravel(),
                        C.ravel(), np.linalg.pinv(C).ravel(), np.asarray(bz2).ravel(), gains, S,
                        out, first, last, direct]).astype(float)
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


def unpack(p: np.ndarray) -> dict[str, np.ndarray | float]:
    """The named blocks of the parameter vector (for post-processing and theory)."""
    n, nn, m, q, r, po = (int(v) for v in p[:6])
    offs = _layout(np.asarray(p, float))
    shapes = {"A": (n, n), "B": (n, m), "E": (n, r), "H": (nn, n), "L": (n, nn), "M": (m, nn),
              "C": (po, n), "Cp": (n, po), "Bz2": (nn, r), "Gamma": (nn,), "S": (nn,),
              "out": (nn,), "first": (nn,), "last": (nn,), "direct": (nn,)}
    blocks = {k: np.asarray(p[o:o + int(np.prod(s))]).reshape(s)
              for (k, s), o in zip(shapes.items(), offs, strict=True)}
    blocks.update({h: float(v) for h, v in zip(HEAD, p[:_NH], strict=True)})
    return blocks
