"""hgo's bounded minimiser gives the bits of ``scipy.optimize.minimize_scalar(method=
"bounded")`` (whose algorithm it copies, to spare a run importing ``scipy.optimize``)."""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.optimize import minimize_scalar

from hgo.core.scalar_min import bounded_minimum

CASES = [  # (function, lo, hi, xatol): smooth, kinked, flat, at an end, oscillating
    (lambda x: (x - 0.3) ** 2, -1.0, 2.0, 1e-5),
    (lambda x: -np.abs(np.sin(7.0 * x)) * math.exp(-x), 0.0, 0.5, 1e-12),
    (lambda x: abs(x - 1.0 / 3.0), 0.0, 1.0, 1e-12),
    (lambda x: 1.0, 0.0, 1.0, 1e-8),
    (lambda x: x ** 3, 0.5, 4.0, 1e-12),
    (lambda x: math.cos(40.0 * x) + 0.1 * x, -3.0, 3.0, 1e-12),
    (lambda x: -(x * (1.0 - x)) ** 0.5, 0.0, 1.0, 1e-12),
    (lambda x: 1e6 * (x - 1e3) ** 2, 999.0, 1001.5, 1e-12),
]


@pytest.mark.parametrize("k", range(len(CASES)))
def test_bounded_minimum_is_scipys_bit_for_bit(k):
    """For eight functions (smooth, |x - 1/3|, constant, minimum at an end, many local
    minima, a square root, far from 0), x and f(x) equal scipy's to the bit."""
    f, lo, hi, xatol = CASES[k]
    ref = minimize_scalar(f, bounds=(lo, hi), method="bounded", options={"xatol": xatol})
    x, fx = bounded_minimum(f, lo, hi, xatol=xatol)
    assert (float(x), float(fx)) == (float(ref.x), float(ref.fun))


def test_bounded_minimum_stops_after_maxiter_evaluations():
    """A slow function evaluated at most ``maxiter`` times, as scipy's."""
    calls = []

    def f(x):
        calls.append(x)
        return math.cos(40.0 * x)

    bounded_minimum(f, -3.0, 3.0, xatol=1e-15, maxiter=7)
    assert len(calls) == 7


def test_bad_interval_is_refused():
    with pytest.raises(ValueError, match="finite lo <= hi"):
        bounded_minimum(abs, 1.0, 0.0)
