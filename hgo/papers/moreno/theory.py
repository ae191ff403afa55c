"""Sector tools of Moreno: LMI (7), sector maximisation (8), exact SPR test, Theorem 3 data.

Everything is for r = m = 1 (scalar sigma and y), the class of the example; the error
system (5) is given by (A_L, G, H_N).

* **LMI (7a)** at sector [K1, inf] and rate eps. With P G = -H_N^T, P G K1 H_N =
  -H_N^T K1 H_N, so (7a) is equivalent to the LMI (linear in P for fixed K1, eps)

      P A_L + A_L^T P - 2 K1 H_N^T H_N + eps P <= 0,   P G = -H_N^T,   P >= mu I

  (R is free, so "= -R^T R - eps P" is "<= -eps P"). ``lmi_7a`` maximises the margin t
  with the left side <= -t I; feasible (non-strict) iff t >= -1e-9. Every P returned is
  re-checked on the *unsubstituted* (7a), with A~_L = A_L + G K1 H_N.
* **K1^a** = inf{K1 : (7a) feasible with eps = 0} (the stability sector (K1^a, inf]):
  ``k1a_sdp`` (one SDP: minimise rho), ``k1a_fd`` (bisection on the exact SPR test of
  H_rho = G/(1 + rho G)), ``k1a_closed`` (closed form for the example, notes section 8.4).
* **(8) over the gains** (``k1a_over_gains``): Y = P L, Schur complement for the term
  -2 rho H_N^T H_N with rho < 0, bisection on rho in [rho_lo, 0) (rho >= 0 not covered).
* **eps_max(K1)** = sup{eps : (7a) feasible}: bisection on the LMI (``eps_max_lmi``) or
  on the shifted SPR test (``eps_max_fd``, eps = 2 sup{mu : H_rho(s - mu) SPR}).
* **(7b)** for a sector [K1, K2] (``lmi_7b``), corner -I (the paper's W^T W = I) or -2I.
* **Theorem 3 data** (``certificate_design``): K~1 = max(K1, K1^a + delta/2) (reading R2
  of A5), eps = f eps_max(K~1), P = argmax lambda_min(P) subject to (7a) at (K~1, eps).

Structural fact (the example, a = 0): P G = -H_N^T forces P21 = -1, then the (2, 2)
entry of P A~_L + A~_L^T P is -2(1 + rho + a P22): at a = 0 (7a) needs rho >= -1 for
every gain, and rho > -1 once eps > 0, so K1^a >= -1 > -2 = K1: no strong observer.
"""

from __future__ import annotations

import functools
import warnings
from dataclasses import dataclass

import numpy as np

from hgo.core.lmi import LazyCvxpy, bisect, sym
from hgo.core.memo import disk_cached

cp = LazyCvxpy()  # imported by the first LMI solved, not with this module

SOLVER = "CLARABEL"
FEAS_TOL = 1e-9  # t* >= -FEAS_TOL: (7a) feasible (non-strict)


def ss2tf_siso(A: np.ndarray, B: np.ndarray, C: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """C (sI - A)^-1 B as (numerator, denominator), descending powers, for one input and
    one output (D = 0): the operations of ``scipy.signal.ss2tf`` (den = poly(A), num =
    poly(A - B C) + (D - 1) den), so the same bits (the test compares them), without
    importing ``scipy.signal`` (~1 s of every Moreno claims task and theory row)."""
    A = np.asarray(A, float)
    B, C = np.asarray(B, float).reshape(-1, 1), np.asarray(C, float).reshape(1, -1)
    den = np.poly(A)
    return np.poly(A - np.dot(B, C)) + (np.zeros(1) - 1) * den, den


@dataclass(frozen=True)
class ErrorSystem:
    """Moreno (5) linear part: e' = A_L e + G phi, z = H_N e (r = m = 1)."""

    A_L: np.ndarray
    G: np.ndarray
    H_N: np.ndarray

    @classmethod
    def from_gains(cls, A, G, C, H, L, N) -> ErrorSystem:
        A, G, C, H, L = (np.asarray(v, float) for v in (A, G, C, H, L))
        return cls(A - np.outer(L, C), G.reshape(-1), (H - N * C).reshape(-1))

    @property
    def n(self) -> int:
        return self.A_L.shape[0]

    def key(self) -> tuple:
        return (self.A_L.tobytes(), self.G.tobytes(), self.H_N.tobytes())

    def rhs(self, e: np.ndarray, phi: np.ndarray | float) -> np.ndarray:
        """Moreno (5): e' = A_L e + G phi (e of shape (n,) or (n, N))."""
        return self.A_L @ e + np.multiply.outer(self.G, phi)

    def transfer(self) -> tuple[np.ndarray, np.ndarray]:
        """G(s) = -H_N (sI - A_L)^-1 G as (numerator, denominator), descending powers."""
        num, den = ss2tf_siso(self.A_L, -self.G, self.H_N)
        return np.trim_zeros(num, "f"), den

    def check_kyp(self) -> bool:
        """(A_L, G) controllable and (A_L, H_N) observable (the KYP lemma's hypotheses,
        needed for LMI <-> SPR); warns when not."""
        n = self.n
        ctrb = np.column_stack([np.linalg.matrix_power(self.A_L, i) @ self.G for i in range(n)])
        obsv = np.vstack([self.H_N @ np.linalg.matrix_power(self.A_L, i) for i in range(n)])
        ok = np.linalg.matrix_rank(ctrb) == n and np.linalg.matrix_rank(obsv) == n
        if not ok:
            warnings.warn("(A_L, G) not controllable or (A_L, H_N) not observable: the LMI "
                          "and SPR sectors need not agree", RuntimeWarning, stacklevel=2)
        return bool(ok)


# --------------------------------------------------------------------------- LMI (7a)
class _Lmi7a:
    """max t s.t. P A_L + A_L^T P - 2 K1 H_N^T H_N + eps P <= -t I, P G = -H_N^T,
    P >= mu I, t <= 1e3 (parameters K1, eps); optional objective max lambda_min(P)."""

    def __init__(self, es: ErrorSystem, mu: float, max_min_eig: bool = False) -> None:
        n = es.n
        self.P = cp.Variable((n, n), symmetric=True)
        self.t = cp.Variable()
        self.s = cp.Variable()
        self.K1 = cp.Parameter()
        self.eps = cp.Parameter(nonneg=True)
        P, eye = self.P, np.eye(n)
        hh = np.outer(es.H_N, es.H_N)
        M = P @ es.A_L + es.A_L.T @ P - 2 * self.K1 * hh + self.eps * P
        cons = [P @ es.G == -es.H_N, P >> mu * eye]
        if max_min_eig:
            cons += [sym(M) << 0, P >> self.s * eye]
            obj = cp.Maximize(self.s)
        else:
            cons += [sym(M) << -self.t * eye, self.t <= 1e3]
            obj = cp.Maximize(self.t)
        self.problem = cp.Problem(obj, cons)

    def solve(self, K1: float, eps: float) -> float:
        self.K1.value, self.eps.value = float(K1), float(eps)
        try:
            # no warm start: the LMI object is shared (_lmi) and cvxpy would start from the
            # last solve's data, so a result would depend on what the process solved
            # before (lambda_min(P) of moreno_fig1's design 0.8183145599629091 fresh,
            # ...051 after any earlier solve): hgo reproduce's workers run tasks in any order
            self.problem.solve(solver=SOLVER, warm_start=False)
        except cp.error.SolverError:
            return -np.inf
        if self.problem.status not in (cp.OPTIMAL, cp.OPTIMAL_INACCURATE):
            return -np.inf
        return float(self.problem.value)


@functools.lru_cache(maxsize=64)
def _lmi(key: tuple, mu: float, max_min_eig: bool = False) -> _Lmi7a:
    A_L, G, H_N = (np.frombuffer(b) for b in key)
    n = G.size
    return _Lmi7a(ErrorSystem(A_L.reshape(n, n), G, H_N), mu, max_min_eig)


def unsubstituted_7a(es: ErrorSystem, P: np.ndarray, K1: float, eps: float) -> tuple[float, float]:
    """(largest eigenvalue of P A~_L + A~_L^T P + eps P, max |P G + H_N^T|), A~_L = A_L +
    G K1 H_N: (7a) as the paper writes it, to verify a P found through the substitution."""
    At = es.A_L + K1 * np.outer(es.G, es.H_N)
    M = P @ At + At.T @ P + eps * P
    return float(np.max(np.linalg.eigvalsh(0.5 * (M + M.T)))), float(
        np.max(np.abs(P @ es.G + es.H_N)))


@dataclass(frozen=True)
class Lmi7aResult:
    feasible: bool
    margin: float  # t*
    P: np.ndarray | None


def lmi_7a(es: ErrorSystem, K1: float, eps: float, mu: float = 1e-7) -> Lmi7aResult:
    """Feasibility of (7a) at (K1, eps) with its margin t* and P."""
    lmi = _lmi(es.key(), mu)
    t = lmi.solve(K1, eps)
    P = None if lmi.P.value is None else 0.5 * (lmi.P.value + lmi.P.value.T)
    return Lmi7aResult(bool(t >= -FEAS_TOL), t, P)


@disk_cached
def eps_max_lmi(es: ErrorSystem, K1: float, rtol: float = 1e-6, mu: float = 1e-7,
                cap: float = 1e4) -> float:
    """sup{eps : (7a) feasible at K1} by doubling then bisection (relative ``rtol``);
    -inf when (7a) is infeasible already at eps = 0 (K1 is not in the stability sector)."""
    ok = lambda e: lmi_7a(es, K1, e, mu).feasible  # noqa: E731
    if not ok(0.0):
        return -np.inf
    lo, hi = 0.0, 1.0
    while ok(hi):
        lo, hi = hi, 2 * hi
        if hi > cap:
            return lo
    if lo == 0.0:  # bracket below 1
        lo = hi / 2
        while not ok(lo):
            hi, lo = lo, lo / 2
            if lo < 1e-9:
                return 0.0
    return bisect(ok, lo, hi, rtol)


@disk_cached
def k1a_sdp(es: ErrorSystem, mu: float = 1e-7, bound: float = 1e3) -> float:
    """K1^a by one SDP (notes 6.1, r = 1): min rho s.t. (7a) at (rho, eps = 0).
    Returns -inf when rho reaches -bound (unbounded below) and +inf if infeasible."""
    n = es.n
    P = cp.Variable((n, n), symmetric=True)
    rho = cp.Variable()
    M = P @ es.A_L + es.A_L.T @ P - 2 * rho * np.outer(es.H_N, es.H_N)
    prob = cp.Problem(cp.Minimize(rho), [sym(M) << 0, P @ es.G == -es.H_N,
                                         P >> mu * np.eye(n), rho >= -bound, rho <= bound])
    prob.solve(solver=SOLVER)
    if prob.status not in (cp.OPTIMAL, cp.OPTIMAL_INACCURATE):
        return np.inf
    val = float(rho.value)
    return -np.inf if val <= -bound + 1e-6 * bound else val


# --------------------------------------------------------------------- exact SPR test
def _hurwitz(poly: np.ndarray) -> bool:
    r = np.roots(poly)
    return bool(np.all(r.real < 0))


# np.poly1d's arithmetic on plain arrays, the same numpy operations in the same order (so
# the same numbers to the last bit), without its objects: poly1d and np.trim_zeros cost
# ~1 ms an SPR test, and eps_max_fd makes thousands (the K~1 search of C14)
def _from_first_nonzero(c: np.ndarray) -> np.ndarray:
    """``np.trim_zeros(c, "f")`` of a 1-d array (empty if every entry is zero)."""
    nonzero = np.flatnonzero(c)
    return c[nonzero[0]:] if nonzero.size else c[:0]


def _poly1d_coeffs(c) -> np.ndarray:
    """``np.poly1d(c).coeffs``: leading zeros dropped, ``[0]`` if nothing is left."""
    c = _from_first_nonzero(np.atleast_1d(c))
    return c if c.size else np.zeros(1, c.dtype)


def compose(p: np.ndarray, x: np.ndarray) -> np.ndarray:
    """p(x(s)) (descending coefficients): ``np.poly1d(p)(np.poly1d(x)).coeffs``, by numpy's
    Horner scheme on poly1d (``y = y * x + pv`` from ``y = 0``, every intermediate in
    poly1d's form)."""
    x = _poly1d_coeffs(x)
    y = _poly1d_coeffs(0 * x)
    for k, pv in enumerate(_poly1d_coeffs(np.asarray(p))):
        if k:
            y = _poly1d_coeffs(np.convolve(y, x))
        y = _poly1d_coeffs(np.polyadd(y, _poly1d_coeffs(pv)))
    return y


_JW = np.array([1j, 0])  # s = j w


def spr_exact(num: np.ndarray, den: np.ndarray) -> bool:
    """Exact SPR test of num/den (Khalil, Nonlinear Systems 3rd ed., Lemma 6.1), no grid:
    den Hurwitz; q(w) = Re[n(jw) conj(d(jw))] > 0 for all w >= 0 (an even polynomial:
    q(0) > 0 and no positive real root in w^2); relative degree 0 with H(inf) > 0, or
    relative degree 1 with the leading coefficient of q positive."""
    num = _from_first_nonzero(np.asarray(num, float))
    den = _from_first_nonzero(np.asarray(den, float))
    if num.size == 0 or not _hurwitz(den):
        return False
    reldeg = den.size - num.size
    if reldeg not in (0, 1):
        return False
    # n(jw) conj d(jw): evaluate the real part as a polynomial in w
    jn, jd = compose(num, _JW), compose(den, _JW)
    q = np.real(_poly1d_coeffs(np.convolve(jn, _poly1d_coeffs(np.conj(jd)))))
    q = _from_first_nonzero(np.where(np.abs(q) < 1e-12 * np.max(np.abs(q)), 0.0, q))
    if q.size == 0 or q[-1] <= 0:
        return False
    if reldeg == 0 and num[0] / den[0] <= 0:
        return False
    if q[0] <= 0:  # leading coefficient: the w -> inf behaviour (H(inf) > 0 or w^2 Re H > 0)
        return False
    # q is even in w: roots in v = w^2 of qv(v) with coefficients q[::2] (descending)
    if (q.size - 1) % 2:
        return False
    qv = q[::2]
    roots = np.roots(qv) if qv.size > 1 else np.array([])
    pos = roots[(np.abs(roots.imag) <= 1e-10 * (1 + np.abs(roots))) & (roots.real > 0)]
    return pos.size == 0


def loop_transformed(num: np.ndarray, den: np.ndarray, rho: float) -> tuple[np.ndarray, np.ndarray]:
    """H_rho = G / (1 + rho G) = n / (d + rho n)."""
    return num, np.polyadd(den, rho * num)


def shifted(poly: np.ndarray, mu: float) -> np.ndarray:
    """p(s - mu)."""
    return compose(poly, np.array([1.0, -mu]))


def k1a_fd(es: ErrorSystem, lo: float = -1e3, hi: float = 1e3, tol: float = 1e-12) -> float:
    """K1^a = inf{rho : H_rho SPR} by bisection on the exact test (notes 6.2); -inf / +inf
    when SPR already holds at ``lo`` / still fails at ``hi``."""
    num, den = es.transfer()
    spr = lambda r: spr_exact(*loop_transformed(num, den, r))  # noqa: E731
    if spr(lo):
        return -np.inf
    if not spr(hi):
        return np.inf
    while hi - lo > tol * max(1.0, abs(hi)):
        mid = 0.5 * (lo + hi)
        lo, hi = (lo, mid) if spr(mid) else (mid, hi)
    return hi


def eps_max_fd(es: ErrorSystem, rho: float, rtol: float = 1e-9, cap: float = 1e4) -> float:
    """eps_max(rho) = 2 sup{mu >= 0 : H_rho(s - mu) SPR}; -inf if H_rho is not SPR.

    Remembered by G's coefficients and the arguments (~100 exact SPR tests a call; the K~1
    search of :func:`hgo.papers.moreno.postprocess.best_K1t` asks for the same 60 values
    on every run of one observer)."""
    num, den = es.transfer()
    return _eps_max_fd(tuple(map(float, num)), tuple(map(float, den)), float(rho),
                       float(rtol), float(cap))


@functools.lru_cache(maxsize=4096)
def _eps_max_fd(num_g: tuple[float, ...], den_g: tuple[float, ...], rho: float, rtol: float,
                cap: float) -> float:
    num, den = loop_transformed(np.array(num_g), np.array(den_g), rho)
    ok = lambda m: spr_exact(shifted(num, m), shifted(den, m))  # noqa: E731
    if not ok(0.0):
        return -np.inf
    lo, hi = 0.0, 1.0
    while ok(hi):
        lo, hi = hi, 2 * hi
        if hi > cap:
            return 2 * lo
    while hi - lo > rtol * max(hi, 1e-12):
        mid = 0.5 * (lo + hi)
        lo, hi = (mid, hi) if ok(mid) else (lo, mid)
    return 2 * lo


def k1a_closed(k: float, l1: float, l2: float, a: float) -> float:
    """Closed form of K1^a for the example (notes 8.4; k > 0, k a + l2 > 0, else +inf)."""
    if not (k > 0 and k * a + l2 > 0):
        return np.inf
    return max(-((l1 + 1) * a + l2) / (k * a + l2), (l2 / k - l1 - 1) / k)


def example_transfer(k: float, l1: float, l2: float, a: float) -> tuple[np.ndarray, np.ndarray]:
    """The paper's G(s) = (k (s + a) + l2) / (s^2 + (l1 + a + 1) s + (l1 + 1) a + l2)."""
    return np.array([k, k * a + l2]), np.array([1.0, l1 + a + 1, (l1 + 1) * a + l2])


def paper_spr_condition(k: float, l1: float, l2: float, a: float, rho: float) -> bool:
    """The paper's SPR condition for H = G / (1 + rho G): numerator and denominator
    Hurwitz and (rho k + l1 + a + 1) > a + l2 / k > 0."""
    num, den = loop_transformed(*example_transfer(k, l1, l2, a), rho)
    return bool(_hurwitz(num) and _hurwitz(den) and k != 0
                and rho * k + l1 + a + 1 > a + l2 / k > 0)


# ------------------------------------------------------------- (8) over the gains
@disk_cached
def k1a_over_gains(A, G, C, H, rho_lo: float = -50.0, eps0: float = 1e-4, mu: float = 1e-4,
                   tol: float = 1e-4) -> tuple[float, np.ndarray | None, float | None]:
    """inf over (L, N) of K1^a, rho < 0 only (notes 6.3): bisection on the LMI in
    (P, Y = P L, N) [[He(P A - Y C) + eps0 P, H_N^T], [H_N, -1/(2|rho|)]] <= 0,
    P G = -(H - N C)^T, P >= mu I. Returns (rho*, L, N); rho* = -inf (with the gains at
    rho_lo) when feasible at rho_lo, +inf (no gains) when infeasible near 0."""
    A, G, C, H = (np.asarray(v, float) for v in (A, G, C, H))
    n = A.shape[0]
    P = cp.Variable((n, n), symmetric=True)
    Y = cp.Variable((n, 1))
    N = cp.Variable()
    w = cp.Parameter(pos=True)  # 1 / (2 |rho|)
    HN = cp.reshape(H - N * C, (1, n), order="C")
    top = sym(P @ A + A.T @ P - Y @ C.reshape(1, -1) - C.reshape(-1, 1) @ Y.T) + eps0 * P
    blk = cp.bmat([[top, HN.T], [HN, -w * np.ones((1, 1))]])
    prob = cp.Problem(cp.Minimize(0), [sym(blk) << 0, P @ G == -(H - N * C),
                                       P >> mu * np.eye(n)])

    def feasible(rho: float) -> bool:
        w.value = 1.0 / (2.0 * abs(rho))
        try:
            with warnings.catch_warnings():  # an inaccurate solve counts as infeasible
                warnings.simplefilter("ignore", UserWarning)
                prob.solve(solver=SOLVER)
        except cp.error.SolverError:
            return False
        return prob.status == cp.OPTIMAL

    def gains() -> tuple[np.ndarray, float]:
        Pv = 0.5 * (P.value + P.value.T)
        return np.linalg.solve(Pv, Y.value).reshape(-1), float(N.value)

    if feasible(rho_lo):
        return -np.inf, *gains()
    hi = -tol
    if not feasible(hi):
        return np.inf, None, None
    lo = rho_lo
    while hi - lo > tol:
        mid = 0.5 * (lo + hi)
        lo, hi = (lo, mid) if feasible(mid) else (mid, hi)
    feasible(hi)
    return hi, *gains()


# ----------------------------------------------------------------------------- (7b)
def lmi_7b(es: ErrorSystem, K1: float, K2: float, eps: float, corner: int = 1,
           mu: float = 1e-7) -> bool:
    """(7b), sector [K1, K2] with K = K2 - K1 > 0, W, R eliminated:
    [[P A~_L + A~_L^T P + eps P, P G + H_N^T K], [G^T P + K H_N, -corner]] <= 0, P >= mu I.
    ``corner`` 1 is the paper's W^T W = I; 2 the textbook circle criterion with V = e'Pe/2."""
    if corner not in (1, 2):
        raise ValueError(f"design.corner must be 1 or 2, got {corner}")
    n, K = es.n, K2 - K1
    P = cp.Variable((n, n), symmetric=True)
    At = es.A_L + K1 * np.outer(es.G, es.H_N)
    off = cp.reshape(P @ es.G + K * es.H_N, (n, 1), order="C")
    blk = cp.bmat([[P @ At + At.T @ P + eps * P, off], [off.T, -corner * np.ones((1, 1))]])
    prob = cp.Problem(cp.Minimize(0), [sym(blk) << 0, P >> mu * np.eye(n)])
    prob.solve(solver=SOLVER)
    return prob.status == cp.OPTIMAL


# ------------------------------------------------------------------ Theorem 3 data
@dataclass(frozen=True)
class CertificateDesign:
    """(K~1, eps, P) of Theorem 3 and the constants of (11)."""

    K1: float  # the nonlinearity's sector lower bound
    K1a: float  # K1^a (SDP)
    K1t: float  # K~1
    eps_max: float  # at K~1
    eps: float
    P: np.ndarray
    lam_m: float
    lam_M: float
    lam_H: float
    strong: bool  # K1^a < K1: Theorem 2 applies with K~1 = K1

    @property
    def kappa(self) -> float:
        return float(np.sqrt(self.lam_M / self.lam_m))

    def c(self, lambda_P: str, es: ErrorSystem) -> float:
        """Constant c of (11): half_min_eig 2 lam_H / lam_m (default), min_eig lam_H / lam_m
        (the OCR literally), sharp 2 lambda_max(P^-1/2 H_N^T H_N P^-1/2)."""
        if lambda_P == "half_min_eig":
            return 2 * self.lam_H / self.lam_m
        if lambda_P == "min_eig":
            return self.lam_H / self.lam_m
        if lambda_P == "sharp":
            return float(2 * es.H_N @ np.linalg.solve(self.P, es.H_N))
        raise ValueError(f"postprocess.moreno.lambda_P: '{lambda_P}' not in "
                         "['half_min_eig', 'min_eig', 'sharp']")


@disk_cached  # (a warm run then imports no cvxpy: ~0.55 s)
def certificate_design(es: ErrorSystem, K1: float, delta: float = 0.1,
                       eps_fraction: float = 0.99, K1t: float | None = None,
                       regularisation: str = "margin", mu: float = 1e-7) -> CertificateDesign:
    """K~1 (``regularisation`` margin: max(K1, K1^a + delta/2), reading R2 of A5; decay:
    K~1 = inf{rho : (7a) feasible with eps = delta}, reading R3; or the given ``K1t``),
    eps = eps_fraction eps_max(K~1), P = argmax lambda_min(P) s.t. (7a) at (K~1, eps)."""
    K1a = k1a_sdp(es, mu)
    if K1t is None:
        if regularisation == "margin":
            K1t = max(K1, K1a + delta / 2)
        elif regularisation == "decay":
            K1t = max(K1, bisect(lambda r: lmi_7a(es, r, delta, mu).feasible,
                                  K1a + 1e3, K1a, 1e-9))
        else:
            raise ValueError("postprocess.moreno.regularisation must be 'margin' or "
                             f"'decay', got '{regularisation}'")
    e_max = eps_max_lmi(es, K1t, mu=mu)
    if not e_max > 0:
        raise ValueError(f"(7a) has no eps > 0 at K~1 = {K1t} (K1^a = {K1a})")
    eps = eps_fraction * e_max
    lmi = _lmi(es.key(), mu, True)
    lmi.solve(K1t, eps)
    P = 0.5 * (lmi.P.value + lmi.P.value.T)
    top, eq = unsubstituted_7a(es, P, K1t, eps)
    if top > 1e-6 * max(1.0, np.max(np.abs(P))) or eq > 1e-6:
        raise RuntimeError(f"P fails the unsubstituted (7a): max eig {top:.3g}, |PG + H_N^T| "
                           f"{eq:.3g}")
    lam = np.linalg.eigvalsh(P)
    lam_H = float(es.H_N @ es.H_N)  # lambda_max(H_N^T H_N) for r = 1
    return CertificateDesign(K1, K1a, float(K1t), e_max, eps, P, float(lam[0]),
                             float(lam[-1]), lam_H, bool(K1a < K1))
