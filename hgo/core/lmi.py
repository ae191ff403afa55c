"""Small helpers shared by the papers' LMI designs (cvxpy + Clarabel).

Used by Sanfelice & Praly (8)-(10), Dimassi et al. (8)-(10)/(28) and Moreno (7)-(8).
"""

from __future__ import annotations

import math
from collections.abc import Callable

#: Rounds after which a bisection or zoom stops even if its tolerance is not reached
#: (each halves its bracket: 200 rounds go below any float spacing).
MAX_ROUNDS = 200


class NonFiniteError(ValueError):
    """An iterative routine met NaN or infinity where it needs finite numbers (it would
    otherwise loop forever or return a meaningless value)."""


def require_finite(what: str, **values: float) -> None:
    """Raise :class:`NonFiniteError` naming ``what`` and the values when any is NaN/inf."""
    bad = {k: v for k, v in values.items() if not math.isfinite(v)}
    if bad:
        shown = ", ".join(f"{k} = {v}" for k, v in values.items())
        raise NonFiniteError(f"{what}: needs finite numbers, got {shown}")


def sym(M):
    """Symmetric part ``(M + Mᵀ)/2`` of a matrix or a cvxpy expression (cvxpy needs it
    explicitly before ``<<``/``>>`` on a non-symmetric expression)."""
    return 0.5 * (M + M.T)


def bisect(pred: Callable[[float], bool], good: float, bad: float, rtol: float) -> float:
    """Bisection on a monotone predicate: ``pred(good)`` is True, ``pred(bad)`` False.

    Returns a point where ``pred`` is True, within ``rtol`` (relative) of the boundary,
    or as close as float spacing allows (at most :data:`MAX_ROUNDS` rounds). NaN or
    infinite ends raise :class:`NonFiniteError` (a NaN end used to return ``good``
    unchanged, silently).
    """
    require_finite("bisection bracket", good=good, bad=bad, rtol=rtol)
    for _ in range(MAX_ROUNDS):
        if not abs(good - bad) > rtol * max(abs(good), abs(bad)):
            break
        mid = 0.5 * (good + bad)
        if mid in (good, bad):  # adjacent floats: the bracket cannot shrink further
            break
        if pred(mid):
            good = mid
        else:
            bad = mid
    return good


class LazyCvxpy:
    """cvxpy, imported by the first attribute looked up (``cp.Variable``): a module that
    solves LMIs on demand does not pay cvxpy's ~1 s import when it is imported."""

    def __getattr__(self, name: str):
        import cvxpy

        return getattr(cvxpy, name)
