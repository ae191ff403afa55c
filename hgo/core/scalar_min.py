"""A bounded scalar minimiser: Brent's method on an interval, as ``scipy.optimize``'s
``minimize_scalar(method="bounded")`` computes it (``_minimize_scalar_bounded``, scipy
1.17), operation for operation, so that it gives the same bits
(``tests/test_scalar_min.py``). Importing ``scipy.optimize`` for it cost a run 0.8 s on a
2-core VM: the continuous extensions' maxima (:func:`hgo.postprocess.dense.maximum`) and
Moreno's sector bound (:func:`hgo.plants.sector.sector_lower`) need nothing else of it.
"""

from __future__ import annotations

from collections.abc import Callable
from math import sqrt

import numpy as np

SQRT_EPS = sqrt(2.2e-16)
GOLDEN_MEAN = 0.5 * (3.0 - sqrt(5.0))


def bounded_minimum(func: Callable[[float], float], lo: float, hi: float,
                    xatol: float = 1e-5, maxiter: int = 500) -> tuple[float, float]:
    """``(x, func(x))`` minimising ``func`` on [lo, hi] to ``xatol`` (absolute, in x), at
    most ``maxiter`` evaluations: golden-section steps, parabolic ones where the last
    three points allow (Brent, *Algorithms for minimization without derivatives*, 1973,
    ch. 5)."""
    if not (np.isfinite(lo) and np.isfinite(hi)) or lo > hi:
        raise ValueError(f"bounded_minimum: need finite lo <= hi, got [{lo}, {hi}]")
    a, b = lo, hi
    fulc = a + GOLDEN_MEAN * (b - a)
    nfc, xf = fulc, fulc
    rat = e = 0.0
    x = xf
    fx = func(x)
    num = 1
    ffulc = fnfc = fx
    xm = 0.5 * (a + b)
    tol1 = SQRT_EPS * np.abs(xf) + xatol / 3.0
    tol2 = 2.0 * tol1
    while np.abs(xf - xm) > (tol2 - 0.5 * (b - a)):
        golden = 1
        if np.abs(e) > tol1:  # a parabola through the last three points
            golden = 0
            r = (xf - nfc) * (fx - ffulc)
            q = (xf - fulc) * (fx - fnfc)
            p = (xf - fulc) * q - (xf - nfc) * r
            q = 2.0 * (q - r)
            if q > 0.0:
                p = -p
            q = np.abs(q)
            r = e
            e = rat
            if (np.abs(p) < np.abs(0.5 * q * r)) and (p > q * (a - xf)) and (p < q * (b - xf)):
                rat = (p + 0.0) / q
                x = xf + rat
                if ((x - a) < tol2) or ((b - x) < tol2):
                    si = np.sign(xm - xf) + ((xm - xf) == 0)
                    rat = tol1 * si
            else:
                golden = 1
        if golden:
            e = a - xf if xf >= xm else b - xf
            rat = GOLDEN_MEAN * e
        si = np.sign(rat) + (rat == 0)
        x = xf + si * np.maximum(np.abs(rat), tol1)
        fu = func(x)
        num += 1
        if fu <= fx:
            if x >= xf:
                a = xf
            else:
                b = xf
            fulc, ffulc = nfc, fnfc
            nfc, fnfc = xf, fx
            xf, fx = x, fu
        else:
            if x < xf:
                a = x
            else:
                b = x
            if (fu <= fnfc) or (nfc == xf):
                fulc, ffulc = nfc, fnfc
                nfc, fnfc = x, fu
            elif (fu <= ffulc) or (fulc == xf) or (fulc == nfc):
                fulc, ffulc = x, fu
        xm = 0.5 * (a + b)
        tol1 = SQRT_EPS * np.abs(xf) + xatol / 3.0
        tol2 = 2.0 * tol1
        if num >= maxiter:
            break
    return xf, fx
