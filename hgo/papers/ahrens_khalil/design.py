"""Design rules of the switched-gain high-gain observer, Ahrens & Khalil Section 3.

* :func:`observer_alphas`: the observer polynomial (31),
  (s^(r-1) + beta_1 s^(r-2) + ... + beta_(r-1)) (s + kappa) = s^r + alpha_1 s^(r-1) + ...
  + alpha_r, whose large root -kappa makes y - x^1 decay monotonically into the zone.
  Ahrens & Khalil (40): beta = [1], kappa = 70 gives H1's alpha = (71, 70).
* :func:`eps1_from_eps2`: eps1 = k_eps eps2^(r/(r-1)) (37).
* :func:`ultimate_bound`: F_r(eps, mu) = eps c1 + mu c2 / eps^(r-1) (25), the ultimate
  bound of ||x - x^|| under noise of amplitude mu; :func:`fit_ultimate_bound` fits (c1, c2)
  to measured (eps, mu, bound) points by (relative) linear least squares;
  :func:`optimal_eps` is its minimiser eps* = ((r-1) mu c2 / c1)^(1/r) (the O(mu^(1/r))
  lower bound of Theorem 4);
  :func:`fit_power_law` fits eps* = C mu^q on a log-log scale (q = 1/r for exact F_r).
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import NamedTuple

import numpy as np


class UltimateBoundFit(NamedTuple):
    """Least-squares fit of F_r(eps, mu) = eps c1 + mu c2 / eps^(r-1) (25)."""

    c1: float
    c2: float
    rms_residual: float


class PowerLawFit(NamedTuple):
    """log y = log prefactor + exponent log x, with the OLS standard error of the exponent."""

    exponent: float
    stderr: float
    prefactor: float


def observer_alphas(beta: Sequence[float], kappa: float) -> np.ndarray:
    """alpha_1..alpha_r of (10) from the factored polynomial (31); r = len(beta) + 1."""
    beta = np.asarray(beta, float).ravel()
    if not kappa > 0:
        raise ValueError(f"kappa must be in (0, inf) (Ahrens & Khalil (31)), got {kappa}")
    slow = np.concatenate([[1.0], beta])
    if beta.size and not np.all(np.roots(slow).real < 0):
        raise ValueError("beta: s^(r-1) + beta_1 s^(r-2) + ... + beta_(r-1) must be Hurwitz "
                         f"(Ahrens & Khalil (32)), roots {np.roots(slow).tolist()}")
    return np.polymul(slow, [1.0, kappa])[1:]


def eps1_from_eps2(eps2: float | np.ndarray, k_eps: float, r: int) -> float | np.ndarray:
    """eps1 = k_eps eps2^(r/(r-1)), Ahrens & Khalil (37); needs r >= 2."""
    if r < 2:
        raise ValueError(f"r must be in [2, inf) for (37) (exponent r/(r-1)), got {r}")
    if not k_eps > 0:
        raise ValueError(f"k_eps must be in (0, inf), got {k_eps}")
    return k_eps * np.asarray(eps2, float) ** (r / (r - 1))


def ultimate_bound(eps: float | np.ndarray, mu: float | np.ndarray, c1: float, c2: float,
                   r: int) -> float | np.ndarray:
    """F_r(eps, mu) = eps c1 + mu c2 / eps^(r-1), Ahrens & Khalil (25)."""
    eps = np.asarray(eps, float)
    return eps * c1 + np.asarray(mu, float) * c2 / eps ** (r - 1)


def fit_ultimate_bound(eps: Sequence[float], mu: Sequence[float], bound: Sequence[float],
                       r: int, relative: bool = True) -> UltimateBoundFit:
    """Least-squares (c1, c2) of (25) from measured points (eps_i, mu_i, bound_i).

    ``relative=True`` minimises the relative residuals sum ((F_r - b_i) / b_i)^2: measured
    bounds span decades over an eps sweep (mu c2 / eps^(r-1) blows up at small eps), and an
    absolute fit would let the largest bounds decide c1. ``rms_residual`` is reported in
    the same (relative or absolute) sense.
    """
    eps, mu, bound = (np.asarray(v, float).ravel() for v in (eps, mu, bound))
    if not eps.size == mu.size == bound.size:
        raise ValueError(f"eps, mu, bound must have the same length, got "
                         f"{eps.size}, {mu.size}, {bound.size}")
    if eps.size < 2:
        raise ValueError("need at least 2 points to fit (c1, c2)")
    if r < 1:
        raise ValueError(f"r must be in [1, inf), got {r}")
    if np.any(eps <= 0):
        raise ValueError("eps must be in (0, inf)")
    if relative and np.any(bound <= 0):
        raise ValueError("bound must be in (0, inf) for a relative fit")
    design = np.column_stack([eps, mu / eps ** (r - 1)])
    weight = 1.0 / bound if relative else np.ones_like(bound)
    if np.linalg.matrix_rank(design * weight[:, None]) < 2:
        raise ValueError("the points do not separate c1 from c2: vary eps (and mu) more")
    (c1, c2), *_ = np.linalg.lstsq(design * weight[:, None], bound * weight, rcond=None)
    resid = (bound - design @ np.array([c1, c2])) * weight
    return UltimateBoundFit(float(c1), float(c2), float(np.sqrt(np.mean(resid ** 2))))


def least_upper_envelope(eps: Sequence[float], mu: Sequence[float], bound: Sequence[float],
                         r: int) -> UltimateBoundFit:
    """The least (c1, c2) >= 0 with bound_i <= F_r(eps_i, mu_i) of (25) at every point: a
    linear programme minimising the sum of F_r / bound_i (``rms_residual``: of the relative
    gaps F_r / bound - 1)."""
    from scipy.optimize import linprog

    eps, mu, bound = (np.asarray(v, float).ravel() for v in (eps, mu, bound))
    rel = np.column_stack([eps, mu / eps ** (r - 1)]) / bound[:, None]
    res = linprog(rel.sum(axis=0), A_ub=-rel, b_ub=-np.ones(bound.size),
                  bounds=[(0, None), (0, None)])
    if not res.success:
        raise ValueError(f"no envelope of (25) found: {res.message}")
    c1, c2 = (float(v) for v in res.x)
    gap = rel @ res.x - 1.0
    return UltimateBoundFit(c1, c2, float(np.sqrt(np.mean(gap ** 2))))


def optimal_eps(mu: float | np.ndarray, c1: float, c2: float, r: int) -> float | np.ndarray:
    """Minimiser of F_r(., mu): eps* = ((r-1) mu c2 / c1)^(1/r) (Ahrens & Khalil (25))."""
    if r < 2:
        raise ValueError(f"r must be in [2, inf) (F_1 has no interior minimum), got {r}")
    if not (c1 > 0 and c2 > 0):
        raise ValueError(f"c1 and c2 must be in (0, inf), got c1={c1}, c2={c2}")
    return ((r - 1) * np.asarray(mu, float) * c2 / c1) ** (1.0 / r)


def fit_power_law(x: Sequence[float], y: Sequence[float]) -> PowerLawFit:
    """OLS fit of log y = log C + q log x (e.g. eps* versus mu; q = 1/r for exact (25))."""
    x, y = (np.asarray(v, float).ravel() for v in (x, y))
    if x.size != y.size:
        raise ValueError(f"x and y must have the same length, got {x.size}, {y.size}")
    if x.size < 3:
        raise ValueError("need at least 3 points for an exponent with a standard error")
    if np.any(x <= 0) or np.any(y <= 0):
        raise ValueError("x and y must be in (0, inf) for a log-log fit")
    lx, ly = np.log(x), np.log(y)
    sxx = np.sum((lx - lx.mean()) ** 2)
    if sxx == 0:
        raise ValueError("x must take at least two distinct values")
    q = np.sum((lx - lx.mean()) * (ly - ly.mean())) / sxx
    c = ly.mean() - q * lx.mean()
    resid = ly - (c + q * lx)
    stderr = np.sqrt(np.sum(resid ** 2) / (x.size - 2) / sxx)
    return PowerLawFit(float(q), float(stderr), float(np.exp(c)))
