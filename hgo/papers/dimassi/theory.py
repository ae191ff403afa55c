"""Dimassi et al. conditions (8)-(10), the LMI (28), the HGO constants (15) and Theorem 1 (20)-(23).

* :func:`check_conditions`: for given L, M, the best P of (8)-(9), i.e. the largest
  r* = lambda_min(Q)/lambda_max(P) with (A - L H)^T P + P (A - L H) = -2 Q and B^T P = M H
  (quasi-convex: bisection on r of an LMI in (P, s); ``M=None`` leaves M free, and the
  problem, homogeneous then, is normalised by P <= I: one SDP), and the margin of (10),
  r* - |B| (K_phi + K_psi |theta|).
* :func:`lmi28`: the LMI (28), reconstructed (implementation notes A6): minimise rho s.t.
  P >= p_min I, P A - K H + (.)^T <= -nu I, [[rho I, B^T P - M H], [., rho I]] >= 0,
  L = P^-1 K. With ``p_min`` -> 0 the problem is homogeneous and rho* -> 0 even where (9) is
  infeasible: the normalisation P >= I is what makes rho* = 0 mean "(9) holds".
  :func:`lmi_equality` imposes (9) as B^T P == M H instead and reports feasibility.
* :func:`beta_analytic`, :func:`theorem1`: the constants beta of (15) and K0..K3, R of
  (20), (23) (OCR fixes A7, A9: K_psi |theta|, sqrt(V) moved in (21)).

The SDPs reuse the cvxpy + Clarabel set-up and the monotone bisection of
:mod:`hgo.core.lmi` (shared with Sanfelice & Praly (8)-(10)). cvxpy (~1 s to import) is
imported by the first SDP solved, and :func:`check_conditions`, :func:`lmi28` and
:func:`lmi_equality` are cached on disk by their inputs (:func:`hgo.core.memo.disk_cached`):
a run or claim whose LMIs were solved before neither imports nor solves anything.
"""

from __future__ import annotations

import math
import warnings
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np
import scipy.linalg as sla

from hgo.core.lmi import bisect, sym
from hgo.core.memo import disk_cached
from hgo.observers.adaptive_cascade import hgo_matrix

if TYPE_CHECKING:
    import cvxpy as cp

SOLVER = "CLARABEL"


def _cvxpy():
    """cvxpy, imported by the first SDP that is solved (not by importing this module)."""
    import cvxpy

    return cvxpy


@dataclass(frozen=True)
class ConditionCheck:
    """Best certificate of (8)-(9) for given (L, M): r* and the maximising P, Q, M."""

    r_star: float  # max lambda_min(Q)/lambda_max(P) subject to (8)-(9); -inf: infeasible
    P: np.ndarray | None
    Q: np.ndarray | None
    M: np.ndarray | None
    eig_closed_loop: np.ndarray  # eig(A - L H)

    def margin10(self, norm_B: float, K_phi: float, K_psi_theta: float) -> float:
        """r* - |B| (K_phi + K_psi |theta|): (10) holds for some P of (8)-(9) iff > 0."""
        return self.r_star - norm_B * (K_phi + K_psi_theta)


def _solve(problem: cp.Problem) -> bool:
    """Solve; True when (nearly) optimal. Clarabel's "inaccurate" status at the edge of a
    bisection counts as feasible (its warning is silenced: r* is then within rtol)."""
    cp = _cvxpy()
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", UserWarning)
            problem.solve(solver=SOLVER)
    except cp.error.SolverError:
        return False
    return problem.status in (cp.OPTIMAL, cp.OPTIMAL_INACCURATE)


@disk_cached
def check_conditions(A, B, H, L, M=None, rtol: float = 1e-6) -> ConditionCheck:
    """r* = max over P (and M if None) of lambda_min(Q)/lambda_max(P) s.t. (8)-(9).

    M fixed: B^T P = M H pins the scale of P, so the ratio is maximised by bisection on r of
    the LMI in (P, s): 1e-8 I <= P <= s I, -(1/2)[(A-LH)^T P + P (A-LH)] >= r s I,
    B^T P = M H; feasibility is monotone in r, and r <= -max Re eig(A - L H).
    M free: (8)-(9) are homogeneous in (P, M), so the scale is fixed instead (P <= I: any
    certificate scaled to lambda_max(P) = 1) and r* is one SDP, max r s.t. 0 <= P <= I,
    Q >= r I, B^T P = M H. Without that normalisation the solver stopped at P ~ 1e-8 I and
    r* came out below the M-fixed value (4.99967 against 4.999998 on the Sec. IV example),
    which a relaxation cannot be.
    """
    A, B, H, L = (np.asarray(v, float) for v in (A, B, H, L))
    acl = A - L @ H
    eig = np.linalg.eigvals(acl)
    alpha = -float(np.max(eig.real))
    if alpha <= 0:
        return ConditionCheck(-math.inf, None, None, None, eig)
    found = _best_p_free(acl, B, H) if M is None else _best_p_fixed(acl, B, H, M, alpha, rtol)
    if found is None:
        return ConditionCheck(-math.inf, None, None, None, eig)
    P, Mval = found
    Pv = 0.5 * (P + P.T)
    Q = -0.5 * (acl.T @ Pv + Pv @ acl)
    ev_q, ev_p = np.linalg.eigvalsh(Q), np.linalg.eigvalsh(Pv)
    return ConditionCheck(float(ev_q[0] / ev_p[-1]), Pv, Q, Mval, eig)


def _closed_loop_lmi(acl: np.ndarray, P, rhs):
    """-(1/2)[(A - L H)^T P + P (A - L H)] >= rhs (a cvxpy constraint)."""
    return -sym(acl.T @ P + P @ acl) / 2 >> rhs


def _best_p_fixed(acl, B, H, M, alpha: float, rtol: float):
    """(P, M) maximising the ratio with M fixed (bisection, see check_conditions); None if
    infeasible."""
    cp = _cvxpy()
    n = acl.shape[0]
    P = cp.Variable((n, n), symmetric=True)
    s = cp.Variable()
    r = cp.Parameter(nonneg=True)
    M = np.asarray(M, float)
    cons = [P >> 1e-8 * np.eye(n), P << s * np.eye(n),
            _closed_loop_lmi(acl, P, r * s * np.eye(n)), B.T @ P == M @ H]
    prob = cp.Problem(cp.Minimize(0), cons)

    def feasible(value: float) -> bool:
        r.value = value
        return _solve(prob)

    if not feasible(0.0):
        return None
    feasible(bisect(feasible, 0.0, alpha * (1 + 1e-9), rtol))
    return P.value, M


def _best_p_free(acl, B, H):
    """(P, M) maximising the ratio with M free, P normalised to P <= I (one SDP); None
    if no P > 0 has Q > 0."""
    cp = _cvxpy()
    n = acl.shape[0]
    P = cp.Variable((n, n), symmetric=True)
    r = cp.Variable()
    Mv = cp.Variable((B.shape[1], H.shape[0]))
    cons = [P >> 0, P << np.eye(n), _closed_loop_lmi(acl, P, r * np.eye(n)),
            B.T @ P == Mv @ H]
    prob = cp.Problem(cp.Maximize(r), cons)
    if not _solve(prob) or not r.value > 0:
        return None
    return P.value, np.asarray(Mv.value, float)


@dataclass(frozen=True)
class Lmi28:
    """Solution of the LMI (28): rho*, P, L = P^-1 K, M (status: the solver's)."""

    rho: float
    P: np.ndarray | None
    L: np.ndarray | None
    M: np.ndarray | None
    status: str


@disk_cached
def lmi28(A, B, H, L=None, M=None, p_min: float = 1.0, nu: float = 1e-3) -> Lmi28:
    """Dimassi et al. (28) (reconstructed, A6): minimise rho; L, M fixed when given."""
    cp = _cvxpy()
    A, B, H = (np.asarray(v, float) for v in (A, B, H))
    n, m, nn = A.shape[0], B.shape[1], H.shape[0]
    P = cp.Variable((n, n), symmetric=True)
    rho = cp.Variable()
    K = P @ np.asarray(L, float) if L is not None else cp.Variable((n, nn))
    Mv = cp.Variable((m, nn)) if M is None else np.asarray(M, float)
    G = B.T @ P - Mv @ H
    block = cp.bmat([[rho * np.eye(m), G], [G.T, rho * np.eye(n)]])
    cons = [P >> p_min * np.eye(n), sym(P @ A - K @ H) << -nu / 2 * np.eye(n),
            sym(block) >> 0]
    prob = cp.Problem(cp.Minimize(rho), cons)
    if not _solve(prob):
        return Lmi28(math.nan, None, None, None, str(prob.status))
    Pv = 0.5 * (P.value + P.value.T)
    Lv = np.asarray(L, float) if L is not None else np.linalg.solve(Pv, K.value)
    Mval = np.asarray(Mv.value if M is None else Mv, float)
    return Lmi28(max(float(rho.value), 0.0), Pv, Lv, Mval, str(prob.status))


@disk_cached  # (a claims task then imports no cvxpy when its LMIs are cached: ~0.7 s)
def lmi_equality(A, B, H, L=None, M=None, nu: float = 1e-3) -> bool:
    """(8)-(9) with (9) as the equality B^T P == M H (P >= I if M is free, else >= 1e-6 I)."""
    cp = _cvxpy()
    A, B, H = (np.asarray(v, float) for v in (A, B, H))
    n, m, nn = A.shape[0], B.shape[1], H.shape[0]
    P = cp.Variable((n, n), symmetric=True)
    K = P @ np.asarray(L, float) if L is not None else cp.Variable((n, nn))
    Mv = cp.Variable((m, nn)) if M is None else np.asarray(M, float)
    p_min = 1.0 if M is None else 1e-6
    cons = [P >> p_min * np.eye(n), sym(P @ A - K @ H) << -nu / 2 * np.eye(n),
            B.T @ P == Mv @ H]
    return _solve(cp.Problem(cp.Minimize(0), cons))


def beta_analytic(gamma, h_max: float) -> float:
    """beta of (15) from P_a a-bar + a-bar^T P_a = -I: 2 |P_a b_1| h_max sqrt(cond(P_a))."""
    a = hgo_matrix(gamma)
    Pa = sla.solve_continuous_lyapunov(a.T, -np.eye(a.shape[0]))
    b1 = np.zeros(a.shape[0])
    b1[-1] = 1.0
    ev = np.linalg.eigvalsh(Pa)
    return float(2 * np.linalg.norm(Pa @ b1) * h_max * math.sqrt(ev[-1] / ev[0]))


@dataclass(frozen=True)
class Theorem1:
    """Constants of Dimassi et al. (20), (23); R2 = R^2 (NaN where undefined, see status)."""

    tau: float
    K0: float
    K1: float
    K2: float
    K3: float
    R2: float
    status: str


def theorem1(P, Q, L, M, B, theta, delta: float, sigma: float, eps: float, beta: float,
             psi_max: float, K_phi: float, K_psi: float) -> Theorem1:
    """tau, K0..K3 of (20) and R^2 = ((K2 eps + K3)/(K0 - K1 eps))^2 of (23)."""
    P, Q, L, M, B = (np.atleast_2d(np.asarray(v, float)) for v in (P, Q, L, M, B))
    th = float(np.linalg.norm(theta))
    ev_p, ev_q = np.linalg.eigvalsh(P), np.linalg.eigvalsh(Q)
    nM = float(np.linalg.norm(M, 2))
    tau = ev_q[0] / ev_p[-1] - float(np.linalg.norm(B, 2)) * (K_phi + K_psi * th)
    K0 = min(tau, sigma)
    K1 = 2 * beta * max(1 / (2 * ev_p[0]), delta / 2) * K_psi * nM
    K2 = (2 * beta * float(np.linalg.norm(P @ L, 2)) / math.sqrt(ev_p[0])
          + math.sqrt(delta) * beta * psi_max * nM)
    K3 = 2 * sigma * th / math.sqrt(delta)
    if tau <= 0:
        return Theorem1(tau, K0, K1, K2, K3, math.nan, "tau <= 0: Theorem 1 does not apply")
    if K0 - K1 * eps <= 0:
        return Theorem1(tau, K0, K1, K2, K3, math.nan, "undefined: K0 - K1 eps <= 0")
    R = (K2 * eps + K3) / (K0 - K1 * eps)
    return Theorem1(tau, K0, K1, K2, K3, R * R, "ok")
