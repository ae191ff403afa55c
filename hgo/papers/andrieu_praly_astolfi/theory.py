"""Andrieu, Praly & Astolfi (2007) Section 3: the set-up constants and the order of the bounds.

* :func:`setup_constants`: eps1, eps2, df2max (with its maximiser) and the constant L of the
  df2max observer, for a model hbar (reading C2: the invariance equalities with that hbar).
* :func:`order_check`: the chain printed after the observer of Section 3,
  df2/dx2(x1, x2, u) <= Omega2(u, x1, x2) <= Omega1(u, x1, x2) <= df2max on M_x x M_u, on a
  grid (u, x1 log-spaced in [eps1, 1 - eps2], x2 in [x2lo(x1), x2hi(x1)]): each inequality
  separately, with the share of grid points where it fails and the largest excess.
* :func:`c_inf_literal`: c_inf with the OCR's literal range of x^2 (theory only, C14).
"""

from __future__ import annotations

import numpy as np

from hgo.engine.jit import kernel_helper
from hgo.plants.contois import (
    df2_dx2,
    df2max,
    invariance_eps,
    m_coeffs,
    rate_bound,
    x2_high,
    x2_low,
)


def setup_constants(hbar: float, u_min: float = 0.01, u_max: float = 0.7,
                    phi1: float = 3.0, phi2: float = 0.01, phi3: float = 3.0) -> dict[str, float]:
    """eps1, eps2, df2max and its maximiser, and L = phi2 + (phi3/phi1) df2max (C4)."""
    out = dict(df2max(hbar, u_min, u_max))
    out["L_df2max"] = phi2 + phi3 / phi1 * out["df2max"]
    return out


@kernel_helper
def _chain(U, X1, frac, hbar, eps2, p, out):
    """out[k] = (df2/dx2, Omega2, Omega1, u, x1, x2) at every grid point."""
    k = 0
    for u in U:
        for x1 in X1:
            lo, hi = x2_low(x1, eps2, hbar), x2_high(x1, hbar)
            for f in frac:
                x2 = lo + f * (hi - lo)
                out[k, 0] = df2_dx2(x1, x2, u, hbar)
                out[k, 1] = rate_bound(u, x1, x2, lo, hi, hbar, p)
                out[k, 2] = rate_bound(u, x1, x2, lo, hi, hbar, 0.0)
                out[k, 3] = u
                out[k, 4] = x1
                out[k, 5] = x2
                k += 1


def _excess(lhs: np.ndarray, rhs: np.ndarray, where: np.ndarray) -> dict[str, float]:
    """Share of points with lhs > rhs (beyond 1e-12 relative) and the largest excess."""
    gap = lhs - rhs
    fails = gap > 1e-12 * np.maximum(1.0, np.abs(rhs))
    k = int(np.argmax(gap))
    rel = gap / np.maximum(np.abs(rhs), 1e-300)
    return {"share_fail": float(fails.mean()), "max_excess": float(max(gap[k], 0.0)),
            "max_rel_excess": float(max(rel.max(), 0.0)), "at_u": float(where[k, 0]),
            "at_x1": float(where[k, 1]), "at_x2": float(where[k, 2])}


def order_check(hbar: float = 0.8, p: float = 0.9, u_min: float = 0.01, u_max: float = 0.7,
                n_u: int = 24, n_x1: int = 300, n_x2: int = 60) -> dict[str, dict[str, float]]:
    """Each inequality of the chain on the grid; keys 'rate<=Omega2', '|rate|<=Omega2',
    'Omega2<=Omega1', 'Omega1<=df2max' -> share of failing points, largest excess
    (absolute, relative to the right side) and where (u, x1, x2)."""
    eps1, eps2 = invariance_eps(hbar, u_min, u_max)
    dmax = df2max(hbar, u_min, u_max)["df2max"]
    U = np.linspace(u_min, u_max, n_u)
    X1 = np.geomspace(eps1, 1.0 - eps2, n_x1)
    frac = np.linspace(0.0, 1.0, n_x2)
    out = np.empty((n_u * n_x1 * n_x2, 6))
    _chain(U, X1, frac, hbar, eps2, p, out)
    rate, om2, om1, where = out[:, 0], out[:, 1], out[:, 2], out[:, 3:]
    return {"rate<=Omega2": _excess(rate, om2, where),
            "|rate|<=Omega2": _excess(np.abs(rate), om2, where),
            "Omega2<=Omega1": _excess(om2, om1, where),
            "Omega1<=df2max": _excess(om1, np.full_like(om1, dmax), where)}


def c_inf_literal(hbar: float = 0.8, p: float = 0.9, u_min: float = 0.01, u_max: float = 0.7,
                  n: int = 200) -> float:
    """c_inf = max |(m2 + m3 xh) x2^(1-p) + m3 x2^(2-p)| over M_u x M_x and the OCR's literal
    xh range [x2lo(eps1), x2hi(1 - eps2)] (reading C14: theory only, used by no observer).
    Grid maximum (u at both ends: the expression is affine in u)."""
    eps1, eps2 = invariance_eps(hbar, u_min, u_max)
    xh = np.linspace(x2_low(eps1, eps2, hbar), x2_high(1.0 - eps2, hbar), n)
    best = 0.0
    for u in (u_min, u_max):
        for x1 in np.geomspace(eps1, 1.0 - eps2, n):
            _, _, m2, m3 = m_coeffs(u, x1, hbar)
            x2 = np.linspace(x2_low(x1, eps2, hbar), x2_high(x1, hbar), n)[:, None]
            val = np.abs((m2 + m3 * xh[None, :]) * x2 ** (1 - p) + m3 * x2 ** (2 - p))
            best = max(best, float(val.max()))
    return best
