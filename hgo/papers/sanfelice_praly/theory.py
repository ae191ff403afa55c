"""Conditions (8)-(10) of Sanfelice & Praly (2010): check them, and design K~, P by an SDP.

Sanfelice & Praly (8)-(10) ask, for the triangular form (3) of dimension n, for a nominal gain
K~ in R^n, reals d0, d1 and a symmetric P with

    (8)   0 < d0,  0 < d1,  0 < P,
    (9)   (A - K~ C)^T P + P (A - K~ C) <= -2 d0 P,
    (10)  (b/2) P <= R P + P R <= d1 P,

where A is the n x n upper shift matrix, C = [1, 0, ..., 0] and R = b I + diag(0, 1, ..., n-1),
with b in (0, 1/2).

Checking is plain linear algebra (eigenvalues and generalised eigenvalues with respect to P).

Design (``design_gains``) uses an LMI / SDP. With the change of variables Y = P K~, (9) is linear
in (P, Y) for a fixed d0, and (10) is linear in P for a fixed d1; d0 is maximised by bisection
(feasibility is monotone in d0), then d1 is minimised by bisection at that d0.

Normalisation. (9)-(10) are homogeneous in P, and with D = diag(l, l^2, ..., l^n), l > 1, the
high-gain scaling K~ -> D K~, P -> D^-1 P D^-1 multiplies d0 by l while leaving (10) unchanged
(R commutes with D). So "maximise d0" is meaningless without bounding the condition
number of P: we impose I <= P <= kappa I (``kappa``, default 10; the paper's example P has
lambda_max/lambda_min ~ 6.85). Bounding the condition number bounds d0 (peaking of the
observer error), and it also keeps c0 = 2 lambda_max(P)/d0 of Sanfelice & Praly Remark 2.4 small.

Why cvxpy + Clarabel: cvxpy is a maintained, open-source modelling layer that accepts LMIs
(``>>``) directly and supports parameters, so the bisections reuse one compiled problem;
Clarabel is a maintained, open-source (Apache-2.0) interior-point conic solver with SDP
support, shipped as pip wheels, so no licence or system library is needed.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from hgo.core.lmi import bisect, sym

__all__ = [
    "ConditionReport",
    "Design",
    "triangular_matrices",
    "check_conditions",
    "design_gains",
]


@dataclass(frozen=True)
class ConditionReport:
    """Margins of Sanfelice & Praly (8)-(10) for given (K~, P, b, d0, d1).

    Attributes
    ----------
    lambda_min_P : float
        Smallest eigenvalue of P; (8) needs > 0.
    lyapunov_max_eig : float
        Largest eigenvalue of (A - K~C)^T P + P (A - K~C) + 2 d0 P; (9) needs <= 0.
    decay_margin : float
        -mu_max/2 - d0, with mu_max the largest generalised eigenvalue of
        (A - K~C)^T P + P (A - K~C) with respect to P; (9) holds iff >= 0 (P > 0). The
        largest d0 this P and K~ certify is d0 + decay_margin.
    r_lower_margin : float
        mu_min(RP + PR, P) - b/2; left inequality of (10) holds iff >= 0.
    r_upper_margin : float
        d1 - mu_max(RP + PR, P); right inequality of (10) holds iff >= 0.
    holds : bool
        All of (8)-(10) hold up to the tolerance ``tol``.
    tol : float
        Absolute tolerance used for ``holds`` (scaled by max(1, ||P||) for (8)-(9)).
    """

    lambda_min_P: float
    lyapunov_max_eig: float
    decay_margin: float
    r_lower_margin: float
    r_upper_margin: float
    holds: bool
    tol: float


@dataclass(frozen=True)
class Design:
    """Result of ``design_gains``: K~, P, d0, d1 satisfying Sanfelice & Praly (8)-(10).

    Attributes
    ----------
    K : numpy.ndarray
        Nominal gain K~ (shape (n,)); the observer gain is K(r) = Lambda(r) K~.
    P : numpy.ndarray
        Symmetric positive definite matrix, normalised I <= P <= kappa I.
    b, d0, d1 : float
        Constants of (9)-(10).
    d0_max : float or None
        Largest d0 found feasible by bisection (then d0 == d0_max); None when d0 was imposed.
        For n = 1 there is no peaking and d0 is only limited by ``d0_cap``.
    kappa : float
        Condition-number cap used in the SDP.
    report : ConditionReport
        ``check_conditions`` evaluated on the result.
    """

    K: np.ndarray
    P: np.ndarray
    b: float
    d0: float
    d1: float
    d0_max: float | None
    kappa: float
    report: ConditionReport


def triangular_matrices(n: int, b: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Return A, C, R of Sanfelice & Praly (3) and (10) for dimension n.

    Parameters
    ----------
    n : int
        State dimension.
    b : float
        Exponent parameter of the adaptation law (6), b in (0, 1/2).

    Returns
    -------
    A : numpy.ndarray
        Upper shift matrix (n, n).
    C : numpy.ndarray
        Output row [1, 0, ..., 0], shape (1, n).
    R : numpy.ndarray
        b I + diag(0, 1, ..., n-1) (notation section: R = b I + N_{n-1}).
    """
    A = np.eye(n, k=1)
    C = np.zeros((1, n))
    C[0, 0] = 1.0
    R = b * np.eye(n) + np.diag(np.arange(n, dtype=float))
    return A, C, R


def _gen_eigs(M: np.ndarray, P: np.ndarray) -> np.ndarray:
    """Generalised eigenvalues of the symmetric pencil (M, P), P > 0, ascending: those of
    L^-1 M L^-T with P = L L^T (LAPACK's sygv reduction; numpy's, so a run needing only
    this does not import scipy.linalg); raises LinAlgError when P is not positive definite."""
    L_inv = np.linalg.inv(np.linalg.cholesky(0.5 * (P + P.T)))
    return np.linalg.eigvalsh(L_inv @ (0.5 * (M + M.T)) @ L_inv.T)


def check_conditions(
    K: np.ndarray,
    P: np.ndarray,
    b: float,
    d0: float,
    d1: float,
    tol: float = 1e-9,
) -> ConditionReport:
    """Check Sanfelice & Praly (8)-(10) and report margins.

    Parameters
    ----------
    K : array_like, shape (n,)
        Nominal gain K~.
    P : array_like, shape (n, n)
        Symmetric candidate matrix.
    b, d0, d1 : float
        Constants of (9)-(10).
    tol : float
        Tolerance; (8)-(9) are tested relative to max(1, ||P||), (10) absolutely.

    Returns
    -------
    ConditionReport
        Margins (>= 0 means satisfied, except ``lyapunov_max_eig`` which must be <= 0).
    """
    K = np.asarray(K, dtype=float).reshape(-1)
    P = np.asarray(P, dtype=float)
    A, C, R = triangular_matrices(K.size, b)
    AK = A - np.outer(K, C[0])
    lam_min = float(np.linalg.eigvalsh(0.5 * (P + P.T))[0])
    lyap = AK.T @ P + P @ AK
    lyap_max = float(np.linalg.eigvalsh(0.5 * (lyap + lyap.T) + 2 * d0 * P)[-1])
    scale = max(1.0, float(np.linalg.norm(P, 2)))
    if lam_min > tol * scale:
        decay = float(-_gen_eigs(lyap, P)[-1] / 2 - d0)
        mu = _gen_eigs(R @ P + P @ R, P)
        r_lo, r_hi = float(mu[0] - b / 2), float(d1 - mu[-1])
    else:
        decay = r_lo = r_hi = float("-inf")
    holds = (
        d0 > 0
        and d1 > 0
        and lam_min > tol * scale
        and lyap_max <= tol * scale
        and min(r_lo, r_hi) >= -tol
    )
    return ConditionReport(lam_min, lyap_max, decay, r_lo, r_hi, bool(holds), tol)


class _LmiProblem:
    """Parametrised SDP in (P, Y = P K~) for fixed (d0, d1): Sanfelice & Praly (8)-(10)."""

    def __init__(self, n: int, b: float, kappa: float, margin: float, solver: str) -> None:
        import cvxpy as cp  # 1 s to import: only when an LMI is solved

        A, C, R = triangular_matrices(n, b)
        eye = np.eye(n)
        self.P = cp.Variable((n, n), symmetric=True)
        self.Y = cp.Variable((n, 1))
        self.d0 = cp.Parameter(nonneg=True)
        self.d1 = cp.Parameter(nonneg=True)
        P, Y = self.P, self.Y
        lyap = A.T @ P + P @ A - C.T @ Y.T - Y @ C + 2 * self.d0 * P
        rsum = sym(R @ P + P @ R)
        constraints = [
            P >> eye,
            P << kappa * eye,
            sym(lyap) << -margin * eye,
            rsum - (b / 2) * P >> margin * eye,
            self.d1 * P - rsum >> margin * eye,
        ]
        self.problem = cp.Problem(cp.Minimize(cp.trace(P)), constraints)
        self.solver = solver

    def feasible(self, d0: float, d1: float) -> bool:
        import cvxpy as cp

        self.d0.value, self.d1.value = d0, d1
        try:
            self.problem.solve(solver=self.solver)
        except cp.error.SolverError:
            return False
        return self.problem.status == cp.OPTIMAL

    def solution(self) -> tuple[np.ndarray, np.ndarray]:
        P = 0.5 * (self.P.value + self.P.value.T)
        K = np.linalg.solve(P, self.Y.value).reshape(-1)
        return K, P


def _max_d0(lmi: _LmiProblem, d1_big: float, d0_cap: float, rtol: float) -> float:
    """Maximise d0 in (9) by doubling then bisection (Sanfelice & Praly (9))."""
    lo, hi = 0.0, 1.0
    while lmi.feasible(hi, d1_big):
        lo, hi = hi, 2 * hi
        if hi > d0_cap:
            return lo
    if lo == 0.0:
        lo = hi
        while not lmi.feasible(lo, d1_big):
            lo /= 2
            if lo < 1e-6:
                raise RuntimeError("conditions (8)-(10) infeasible for this (n, b, kappa)")
    return bisect(lambda d0: lmi.feasible(d0, d1_big), lo, hi, rtol)


def design_gains(
    n: int,
    b: float,
    d0: float | None = None,
    *,
    kappa: float = 10.0,
    margin: float = 1e-6,
    rtol: float = 1e-3,
    d0_cap: float = 1e3,
    solver: str = "CLARABEL",
) -> Design:
    """Find K~, P, d0, d1 satisfying Sanfelice & Praly (8)-(10) by an SDP.

    With Y = P K~, (9) reads A^T P + P A - C^T Y^T - Y C + 2 d0 P <= 0 (linear for fixed d0)
    and (10) is linear for fixed d1. If ``d0`` is None it is maximised by bisection, then d1 is
    minimised by bisection at that d0; finally trace(P) is minimised.

    Parameters
    ----------
    n : int
        State dimension of the triangular form (3).
    b : float
        Exponent parameter, b in (0, 1/2).
    d0 : float, optional
        Impose this decay rate instead of maximising it.
    kappa : float
        Normalisation I <= P <= kappa I (bounds the condition number; see module docstring).
    margin : float
        Strictness margin of each LMI (so that check_conditions passes despite solver error).
    rtol : float
        Relative tolerance of the bisections on d0 and d1.
    d0_cap : float
        Stop the search for the largest d0 beyond this value.
    solver : str
        cvxpy solver name; Clarabel by default.

    Returns
    -------
    Design
        K~, P, d0, d1 and the margins of ``check_conditions``.
    """
    if not 0 < b < 0.5:
        raise ValueError("Sanfelice & Praly (6) need b in (0, 1/2)")
    lmi = _LmiProblem(n, b, kappa, margin, solver)
    d1_big = 2 * (b + n - 1) * kappa + 1.0  # always satisfies (10)-right when I <= P <= kappa I
    d0_max = _max_d0(lmi, d1_big, d0_cap, rtol) if d0 is None else None
    d0_val = float(d0) if d0 is not None else d0_max
    if not lmi.feasible(d0_val, d1_big):
        raise RuntimeError(f"(9) infeasible with d0={d0_val} and kappa={kappa}")
    d1_lo = 2 * b + n - 1  # mean of the generalised eigenvalues of RP + PR: trace(2R)/n
    d1 = bisect(lambda x: lmi.feasible(d0_val, x), d1_big, d1_lo, rtol)
    if not lmi.feasible(d0_val, d1):  # re-solve at the returned d1 (leaves the solution in lmi)
        raise RuntimeError("SDP not reproducible at the bisected d1")
    K, P = lmi.solution()
    report = check_conditions(K, P, b, d0_val, d1)
    return Design(K, P, float(b), d0_val, d1, d0_max, float(kappa), report)
