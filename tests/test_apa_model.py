"""Andrieu, Praly & Astolfi Section 3: the Contois model (11), its observability form (12),
the sets and bounds (eps, x2lo/x2hi, df2max) and the exact evaluation of Omega1/Omega2."""

from __future__ import annotations

import numpy as np
import pytest

from hgo.plants.contois import (
    df2_dx2,
    df2max,
    eta2_of_x,
    f2,
    invariance_eps,
    rate_bound,
    reaction_rate,
    x2_high,
    x2_low,
)

U_MIN, U_MAX = 0.01, 0.7


def _points(hbar: float, n: int, seed: int = 0):
    """Random (u, eta) with eta in M_eta (eps of hbar)."""
    rng = np.random.default_rng(seed)
    eps1, eps2 = invariance_eps(hbar, U_MIN, U_MAX)
    out = []
    while len(out) < n:
        e1, e2 = rng.uniform(eps1, 1 - eps2), rng.uniform(eps2, 1 - eps1)
        if e1 + e2 <= 1:
            out.append((rng.uniform(U_MIN, U_MAX), e1, e2))
    return out


@pytest.mark.parametrize("hbar", [0.8, 1.0])
def test_form_12_is_the_plant_11_in_x_coordinates(hbar):
    """Along (11) with hbar, x = F(eta) obeys x1' = x2 - u x1 and x2' = f2 of (12), at 500
    random points of M_eta x M_u (chain rule with the exact Jacobian of F), to 1e-11."""
    for u, e1, e2 in _points(hbar, 500):
        r = reaction_rate(e1, e2, hbar)
        d1, d2 = r - u * e1, -r + u * (1 - e2)
        den = (hbar * e1 + e2) ** 2
        x2dot = e2 * e2 / den * d1 + hbar * e1 * e1 / den * d2
        assert d1 == pytest.approx(r - u * e1)
        assert f2(e1, r, u, hbar) == pytest.approx(x2dot, rel=1e-11, abs=1e-13)
        assert eta2_of_x(e1, r, hbar) == pytest.approx(e2, rel=1e-12)


@pytest.mark.parametrize("hbar", [0.8, 1.0])
def test_sets_and_bounds(hbar):
    """eps meet both invariance conditions of Sec. 3 with equality; x2lo is the rate at
    eta2 = eps2 and x2hi the rate on eta1 + eta2 = 1."""
    eps1, eps2 = invariance_eps(hbar, U_MIN, U_MAX)
    assert U_MIN == pytest.approx(eps2 / (hbar * (1 - eps2) + eps2), rel=1e-14)
    assert eps1 == pytest.approx((1 - U_MAX) * eps2 / (hbar * U_MAX), rel=1e-14)
    for x1 in np.geomspace(eps1, 1 - eps2, 50):
        assert x2_low(x1, eps2, hbar) == pytest.approx(reaction_rate(x1, eps2, hbar), rel=1e-14)
        assert x2_high(x1, hbar) == pytest.approx(reaction_rate(x1, 1 - x1, hbar), rel=1e-14)


@pytest.mark.parametrize("hbar", [0.8, 1.0])
def test_df2max_against_a_dense_grid(hbar):
    """df2max (search + refinement) >= the max of |df2/dx2| on 40 u x 4000 x1 x 200 x2, and
    within 1e-3 of it."""
    res = df2max(hbar, U_MIN, U_MAX)
    eps1, eps2 = res["eps1"], res["eps2"]
    x1 = np.geomspace(eps1, 1 - eps2, 4000)[:, None]
    frac = np.linspace(0, 1, 200)[None, :]
    best = 0.0
    for u in np.linspace(U_MIN, U_MAX, 40):
        x2 = x2_low(x1, eps2, hbar) + frac * (x2_high(x1, hbar) - x2_low(x1, eps2, hbar))
        best = max(best, float(np.abs(df2_dx2(x1, x2, u, hbar)).max()))
    assert res["df2max"] >= best * (1 - 1e-12)
    assert res["df2max"] <= best * (1 + 1e-3)


@pytest.mark.parametrize("q", [0.0, 0.9])
def test_rate_bound_exact_against_dense_grid(q):
    """Omega (q = 0: Omega1, q = 0.9: Omega2) by ends + critical point equals the max over
    2e4 grid points of x2 at 1000 random (u, x1, xh): never below it, and at most 1e-6
    above it relatively (the grid misses the exact maximiser by <= half a cell)."""
    hbar = 0.8
    eps1, eps2 = invariance_eps(hbar, U_MIN, U_MAX)
    rng = np.random.default_rng(1)
    worst = 0.0
    for _ in range(1000):
        u, x1 = rng.uniform(U_MIN, U_MAX), np.exp(rng.uniform(np.log(eps1), np.log(1 - eps2)))
        lo, hi = x2_low(x1, eps2, hbar), x2_high(x1, hbar)
        xh = rng.uniform(lo, hi)
        x2 = np.linspace(lo, hi, 20000)
        a2 = (2 / (hbar * x1) + u / (hbar * x1 ** 2)) + (hbar - 1) / (hbar * x1 ** 2) * xh
        m1 = -u - 1 / hbar - 2 * u / (hbar * x1)
        m3 = (hbar - 1) / (hbar * x1 ** 2)
        g = np.abs(m1 + xh ** q * (a2 * (xh ** (1 - q) + x2 ** (1 - q)) + m3 * x2 ** (2 - q)))
        exact = rate_bound(u, x1, xh, lo, hi, hbar, q)
        assert exact >= g.max() * (1 - 1e-12)
        worst = max(worst, (exact - g.max()) / exact)
    assert worst < 1e-6, worst


def test_omega2_tends_to_omega1_as_p_to_0():
    """Omega2 at p = 1e-9 equals Omega1 to 1e-7 (the nested family of the notes, §4)."""
    hbar = 0.8
    eps1, eps2 = invariance_eps(hbar, U_MIN, U_MAX)
    for u, e1, e2 in _points(hbar, 200, seed=3):
        lo, hi = x2_low(e1, eps2, hbar), x2_high(e1, hbar)
        xh = reaction_rate(e1, e2, hbar)
        assert rate_bound(u, e1, xh, lo, hi, hbar, 1e-9) == pytest.approx(
            rate_bound(u, e1, xh, lo, hi, hbar, 0.0), rel=1e-7)
