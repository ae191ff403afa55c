"""Peaking exponents: the slope of log(peak) against log(ell) (least squares)."""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np


def loglog_slope(ell: Sequence[float], peak: Sequence[float]) -> float:
    """d log(peak) / d log(ell) fitted over the given points."""
    x, y = np.log(np.asarray(ell, float)), np.log(np.asarray(peak, float))
    return float(np.polyfit(x, y, 1)[0])


def local_slopes(ell: Sequence[float], peak: Sequence[float]) -> list[float]:
    """The slope between neighbouring points (how far the asymptotic regime reaches)."""
    x, y = np.log(np.asarray(ell, float)), np.log(np.asarray(peak, float))
    return (np.diff(y) / np.diff(x)).tolist()
