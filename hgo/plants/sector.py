"""Sector of phi(z, sigma) = psi(sigma) - psi(sigma - z) w.r.t. z, Moreno (4), (6), (10).

For r = 1, phi is in the sector [K1(sigma), inf] with K1(sigma) = inf_{z != 0} phi / z.
For a polynomial psi, phi(z, sigma) / z is a polynomial q(z) in z (phi(0, sigma) = 0),
so the infimum is exact: the least value of q at its real critical points (when q has
even degree and a positive leading coefficient; otherwise it is -inf). ``numerical_sector_lower``
is the grid-plus-minimiser checker of the implementation notes (section 4) for any
callable phi; it cross-checks the exact one.

Example (Moreno Section 5): q(z) = z^2 - 3 sigma z + 3 sigma^2 - 2, K1(sigma) =
3 sigma^2 / 4 - 2 at z = 3 sigma / 2.
"""

from __future__ import annotations

from collections.abc import Callable
from math import comb

import numpy as np

from hgo.core.scalar_min import bounded_minimum


def quotient_coeffs(psi: np.ndarray, sigma: np.ndarray) -> np.ndarray:
    """Ascending coefficients in z of q(z) = phi(z, sigma) / z, shape (len(sigma), deg psi).

    psi(sigma - z) = sum_k c_k sum_j C(k, j) sigma^(k-j) (-z)^j, so the z^j coefficient of
    phi is -sum_{k >= j} c_k C(k, j) sigma^(k-j) (-1)^j for j >= 1 (j = 0 cancels)."""
    sigma = np.atleast_1d(np.asarray(sigma, float))
    deg = len(psi) - 1
    out = np.zeros((sigma.size, max(deg, 1)))
    # each power once (the K~1 search calls this ~30000 times on a few instants, where
    # the cost is the number of numpy calls); the sums in the same order
    powers = [sigma ** p for p in range(deg)]
    for j in range(1, deg + 1):
        acc = np.zeros(sigma.size)
        for k in range(j, deg + 1):
            acc += psi[k] * comb(k, j) * powers[k - j]
        out[:, j - 1] = -((-1) ** j) * acc
    return out


def _poly_inf(q: np.ndarray) -> float:
    """inf over real z of the polynomial with ascending coefficients q."""
    q = np.trim_zeros(q, "b")
    if q.size <= 1:
        return float(q[0]) if q.size else 0.0
    if (q.size - 1) % 2 == 1 or q[-1] < 0:
        return -np.inf
    crit = np.polynomial.polynomial.polyroots(np.polynomial.polynomial.polyder(q))
    real = crit[np.abs(crit.imag) <= 1e-9 * (1 + np.abs(crit.real))].real
    return float(np.min(np.polynomial.polynomial.polyval(real, q)))


def sector_lower(psi: np.ndarray, sigma: np.ndarray | float) -> np.ndarray:
    """K1(sigma) = inf_{z != 0} phi(z, sigma) / z for each sigma (exact, polynomial psi)."""
    q = quotient_coeffs(np.asarray(psi, float), sigma)
    if q.shape[1] == 3 and np.all(q[:, 2] > 0):  # quadratic in z: vectorised vertex
        return q[:, 0] - q[:, 1] ** 2 / (4 * q[:, 2])
    if q.shape[1] <= 2 and np.all(q[:, 1:] == 0):
        return q[:, 0].copy()
    return np.array([_poly_inf(row) for row in q])


def global_sector_lower(psi: np.ndarray, span: float = 100.0, n: int = 20001) -> float:
    """K1 = inf over sigma in [-span, span] of K1(sigma) (a grid through 0; the example's
    minimum -2 is at sigma = 0)."""
    return float(np.min(sector_lower(psi, np.linspace(-span, span, n))))


def numerical_sector_lower(phi: Callable[[np.ndarray | float, float], np.ndarray | float],
                           sigma: float, z_min: float = 1e-6, z_max: float = 1e3,
                           n: int = 400) -> float:
    """inf_{z != 0} phi(z, sigma) / z for a callable phi (elementwise in z: the grid is one
    call): a symmetric log grid of z, the z -> 0 limit (central difference), refined around
    the best grid point by a bounded scalar minimiser (implementation notes, section 4)."""
    mag = np.logspace(np.log10(z_min), np.log10(z_max), n)
    zs = np.concatenate([-mag[::-1], mag])
    vals = phi(zs, sigma) / zs
    h = 1e-7
    best = min(float(np.min(vals)), (phi(h, sigma) - phi(-h, sigma)) / (2 * h))
    i = int(np.argmin(vals))
    lo, hi = zs[max(i - 1, 0)], zs[min(i + 1, zs.size - 1)]
    if lo < 0 < hi:
        hi = -z_min if zs[i] < 0 else hi
        lo = z_min if zs[i] > 0 else lo
    _, low = bounded_minimum(lambda z: phi(z, sigma) / z, lo, hi, xatol=1e-12)
    return float(min(best, low))
