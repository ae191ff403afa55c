"""Contois bioreactor, Andrieu, Praly & Astolfi (11), and its observability form (12).

    eta1' =  eta1 eta2 / (hbar eta1 + eta2) - u eta1,
    eta2' = -eta1 eta2 / (hbar eta1 + eta2) + u (1 - eta2),          y = eta1 (+ noise)

(normalised biomass eta1 and substrate eta2; normalised time, no units). The change of
coordinates F: (eta1, eta2) -> (x1, x2) = (eta1, eta1 eta2 / (hbar eta1 + eta2)) (x2 is
the reaction rate) gives the observability form x1' = x2 - u x1, x2' = f2(x1, x2, u),
f2 = m0 + m1 x2 + m2 x2^2 + m3 x2^3 (12). The compiled helpers below evaluate, for a
model value ``hbar`` (the observer's hbar_o): F and F^{-1}, the m_i, f2, df2/dx2, the
bounds x2lo(x1) <= x2 <= x2hi(x1) of M_x, and the incremental-rate bound
Omega(u, x1, xh) of Section 3 (Omega1 at p = 0, Omega2 at p in (0, 1)).

The invariant set M_eta = {eta1 >= eps1, eta2 >= eps2, eta1 + eta2 <= 1} (Section 3) has
eps1, eps2 from :func:`invariance_eps` (both conditions of the paper with equality,
reading C2 of the implementation notes), and df2max = max |df2/dx2| over
M_u x M_x is computed by :func:`df2max` (an exact search, reported with its maximiser).

Plant parameter hbar (by name); input u (one channel), output y = eta1.
"""

from __future__ import annotations

import functools
import math
from collections.abc import Sequence

import numpy as np

from hgo.core.components import Params, Plant
from hgo.engine.jit import kernel_helper


@kernel_helper
def reaction_rate(eta1, eta2, hbar):
    """The Contois rate eta1 eta2 / (hbar eta1 + eta2) = x2 of F."""
    return eta1 * eta2 / (hbar * eta1 + eta2)


def f(t, x, u, p, dx):
    """Andrieu, Praly & Astolfi (11)."""
    r = reaction_rate(x[0], x[1], p.hbar)
    dx[0] = r - u[0] * x[0]
    dx[1] = -r + u[0] * (1.0 - x[1])


def h(t, x, p, y):
    """y = eta1 (before noise)."""
    y[0] = x[0]


@kernel_helper
def eta2_of_x(x1, x2, hbar):
    """F^{-1}, second component: eta2 = hbar x1 x2 / (x1 - x2) (needs x2 < x1)."""
    return hbar * x1 * x2 / (x1 - x2)


@kernel_helper
def x2_low(x1, eps2, hbar):
    """x2lo(x1) = x1 eps2 / (hbar x1 + eps2): the rate at eta2 = eps2."""
    return x1 * eps2 / (hbar * x1 + eps2)


@kernel_helper
def x2_high(x1, hbar):
    """x2hi(x1) = x1 (1 - x1) / (1 - x1 + hbar x1): the rate at eta1 + eta2 = 1."""
    return x1 * (1.0 - x1) / (1.0 - x1 + hbar * x1)


@kernel_helper
def clip(v, lo, hi):
    """max{lo, min{hi, v}} (the saturations x1s, x2s of Section 3)."""
    return max(lo, min(hi, v))


@kernel_helper
def m_coeffs(u, x1, hbar):
    """(m0, m1, m2, m3) of (12)."""
    m0 = u / hbar
    m1 = -u - 1.0 / hbar - 2.0 * u / (hbar * x1)
    m2 = 2.0 / (hbar * x1) + u / (hbar * x1 * x1)
    m3 = (hbar - 1.0) / (hbar * x1 * x1)
    return m0, m1, m2, m3


@kernel_helper
def cubic(m0, m1, m2, m3, x2):
    """m0 + m1 x2 + m2 x2^2 + m3 x2^3 (Horner)."""
    return m0 + x2 * (m1 + x2 * (m2 + x2 * m3))


@kernel_helper
def f2(x1, x2, u, hbar):
    """f2 of (12) = m0 + m1 x2 + m2 x2^2 + m3 x2^3."""
    m0, m1, m2, m3 = m_coeffs(u, x1, hbar)
    return cubic(m0, m1, m2, m3, x2)


@kernel_helper
def df2_dx2(x1, x2, u, hbar):
    """df2/dx2 = m1 + 2 m2 x2 + 3 m3 x2^2 (the local incremental rate, Fig. 1)."""
    _, m1, m2, m3 = m_coeffs(u, x1, hbar)
    return m1 + x2 * (2.0 * m2 + 3.0 * x2 * m3)


@kernel_helper
def _g(A, B, C, x2, q):
    """|A + B x2^(1-q) + C x2^(2-q)| for x2 > 0."""
    w = x2 if q == 0.0 else math.pow(x2, 1.0 - q)
    return abs(A + B * w + C * w * x2)


@kernel_helper
def rate_bound(u, x1, xh, lo, hi, hbar, q):
    """Omega(u, x1, xh) = max over x2 in [lo, hi] of
    |m1 + xh^q ([m2 + m3 xh][xh^(1-q) + x2^(1-q)] + m3 x2^(2-q))|: Omega2 of Section 3
    for q in (0, 1), exactly Omega1 (|m1 + m2 (xh + x2) + m3 (xh^2 + xh x2 + x2^2)|) at
    q = 0. Exact: the expression is A + B x2^(1-q) + C x2^(2-q) with
    A = m1 + (m2 + m3 xh) xh, B = xh^q (m2 + m3 xh), C = xh^q m3, whose only interior
    critical point is x2* = -B (1-q) / (C (2-q)); the max of |.| is at lo, hi or x2*.
    Needs 0 < lo <= xh, hi (xh is the saturated estimate).
    """
    _, m1, m2, m3 = m_coeffs(u, x1, hbar)
    return rate_bound_m(m1, m2, m3, xh, lo, hi, q)


@kernel_helper
def rate_bound_m(m1, m2, m3, xh, lo, hi, q):
    """:func:`rate_bound` from the coefficients m1, m2, m3 of (12) at (u, x1)."""
    a2 = m2 + m3 * xh
    xq = 1.0 if q == 0.0 else math.pow(xh, q)
    A = m1 + a2 * xh
    B = xq * a2
    C = xq * m3
    best = max(_g(A, B, C, lo, q), _g(A, B, C, hi, q))
    if C != 0.0:
        xs = -B * (1.0 - q) / (C * (2.0 - q))
        if lo < xs < hi:
            best = max(best, _g(A, B, C, xs, q))
    return best


def to_x(eta: Sequence[float], hbar: float) -> np.ndarray:
    """F(eta) with the model value hbar: (x1, x2) = (eta1, rate)."""
    eta1, eta2 = float(eta[0]), float(eta[1])
    return np.array([eta1, reaction_rate(eta1, eta2, hbar)])


def invariance_eps(hbar: float, u_min: float, u_max: float) -> tuple[float, float]:
    """(eps1, eps2) meeting both invariance conditions of Section 3 with equality:
    u_min = eps2 / (hbar (1 - eps2) + eps2) and eps1 = (1 - u_max) eps2 / (hbar u_max)."""
    eps2 = u_min * hbar / (1.0 - u_min * (1.0 - hbar))
    return (1.0 - u_max) * eps2 / (hbar * u_max), eps2


@functools.lru_cache(maxsize=16)
def df2max(hbar: float, u_min: float, u_max: float, n_grid: int = 4000) -> dict[str, float]:
    """df2max = max |df2/dx2| over M_u x M_x (Section 3, mean-value bound), with its
    maximiser (u, x1, x2).

    |df2/dx2| is affine in u, so u in {u_min, u_max}; it is quadratic in x2, so the max
    over [x2lo(x1), x2hi(x1)] is at an end or at the vertex -m2/(3 m3). x1 runs over a
    log grid of [eps1, 1 - eps2] (``n_grid`` points), then a golden-section refinement
    around the best grid point (relative change below 1e-12).
    """
    eps1, eps2 = invariance_eps(hbar, u_min, u_max)

    def best_at(u: float, x1: float) -> tuple[float, float]:
        lo, hi = x2_low(x1, eps2, hbar), x2_high(x1, hbar)
        cands = [lo, hi]
        _, _, m2, m3 = m_coeffs(u, x1, hbar)
        if m3 != 0.0 and lo < -m2 / (3.0 * m3) < hi:
            cands.append(-m2 / (3.0 * m3))
        vals = [abs(df2_dx2(x1, x2, u, hbar)) for x2 in cands]
        k = int(np.argmax(vals))
        return vals[k], cands[k]

    grid = np.geomspace(eps1, 1.0 - eps2, n_grid)
    best = (-1.0, 0.0, 0.0, 0.0)
    for u in (u_min, u_max):
        vals = [best_at(u, x1)[0] for x1 in grid]
        k = int(np.argmax(vals))
        a, b = grid[max(k - 1, 0)], grid[min(k + 1, n_grid - 1)]
        phi = (math.sqrt(5.0) - 1.0) / 2.0
        while b - a > 1e-13 * b:  # golden section on the bracket of the grid maximum
            c, d = b - phi * (b - a), a + phi * (b - a)
            if best_at(u, c)[0] > best_at(u, d)[0]:
                b = d
            else:
                a = c
        for x1 in (grid[k], 0.5 * (a + b)):
            val, x2 = best_at(u, x1)
            if val > best[0]:
                best = (val, u, x1, x2)
    return {"df2max": float(best[0]), "u": float(best[1]), "x1": float(best[2]),
            "x2": float(best[3]),
            "eps1": eps1, "eps2": eps2}


#: The range of hbar (Contois constant, dimensionless) a run accepts: the paper's values
#: are 1 (plant) and 0.8 (observers' model); outside, the rate eta1 eta2/(hbar eta1 + eta2)
#: is ~0 or ~eta2 and the invariance bounds (C2) degenerate (hbar = 1e300 ran silently).
HBAR_RANGE = (1e-3, 1e3)


def check_hbar(key: str, hbar: float) -> None:
    low, high = HBAR_RANGE
    if not (math.isfinite(hbar) and low <= hbar <= high):
        raise ValueError(f"{key} must be in [{low:g}, {high:g}] (Contois constant; the "
                         f"paper's 1 and 0.8), got {hbar}")


def contois_plant(eta0: Sequence[float] = (0.3, 0.5), hbar: float = 1.0) -> Plant:
    """The bioreactor (11) with initial state eta0 (reading C5: (0.3, 0.5)) and hbar."""
    if len(eta0) != 2:
        raise ValueError(f"plant.eta0 must have 2 entries [eta1, eta2], got {list(eta0)}")
    if not all(math.isfinite(v) and v > 0 for v in eta0) or sum(eta0) > 1.0:
        raise ValueError(f"plant.eta0 must be > 0 with eta1 + eta2 <= 1, got {list(eta0)}")
    check_hbar("plant.hbar", hbar)
    return Plant(name="contois", state_names=["eta1", "eta2"], output_names=["y"],
                 input_names=["u"], x0=np.asarray(eta0, float), p=Params(hbar=hbar),
                 f=f, h=h, output_state=0, spectral_radius=2.0)
