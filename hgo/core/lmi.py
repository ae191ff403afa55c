"""Small helpers shared by the papers' LMI designs (cvxpy + Clarabel).

Used by Sanfelice & Praly (8)-(10), Dimassi et al. (8)-(10)/(28) and Moreno (7)-(8).
"""

from __future__ import annotations

from collections.abc import Callable


def sym(M):
    """Symmetric part ``(M + Mᵀ)/2`` of a matrix or a cvxpy expression (cvxpy needs it
    explicitly before ``<<``/``>>`` on a non-symmetric expression)."""
    return 0.5 * (M + M.T)


def bisect(pred: Callable[[float], bool], good: float, bad: float, rtol: float) -> float:
    """Bisection on a monotone predicate: ``pred(good)`` is True, ``pred(bad)`` False.

    Returns a point where ``pred`` is True, within ``rtol`` (relative) of the boundary.
    """
    while abs(good - bad) > rtol * max(abs(good), abs(bad)):
        mid = 0.5 * (good + bad)
        if pred(mid):
            good = mid
        else:
            bad = mid
    return good
