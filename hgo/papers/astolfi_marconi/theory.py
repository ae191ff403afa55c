"""Peaking and gain exponents: slopes of log(quantity) against log(ell), the largest
output-injection gain of each observer (what Astolfi & Marconi 2015 limit to ell^2), and
the gain from measurement noise to x^n at a frequency (phi0 = 0: the observers' linear
part)."""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from hgo.core.components import Observer
from hgo.observers.normal_form import lowpower_error_matrix, lowpower_f, standard_f


def loglog_slope(ell: Sequence[float], peak: Sequence[float]) -> float:
    """d log(peak) / d log(ell) fitted over the given points."""
    x, y = np.log(np.asarray(ell, float)), np.log(np.asarray(peak, float))
    return float(np.polyfit(x, y, 1)[0])


def local_slopes(ell: Sequence[float], peak: Sequence[float]) -> list[float]:
    """The slope between neighbouring points (how far the asymptotic regime reaches)."""
    x, y = np.log(np.asarray(ell, float)), np.log(np.asarray(peak, float))
    return (np.diff(y) / np.diff(x)).tolist()


def largest_gain(obs: Observer) -> float:
    """The largest output-injection gain of a normal-form observer: max alpha_i / eps^i of
    the standard one, max(ell k_i1, ell^2 k_i2) of the low-power one."""
    p = obs.p
    if obs.f is standard_f:
        return float(max(a / p.eps ** (i + 1) for i, a in enumerate(p.alpha)))
    if obs.f is lowpower_f:
        return float(max(np.max(p.ell * p.K[:, 0]), np.max(p.ell ** 2 * p.K[:, 1])))
    raise ValueError(f"observer {obs.name}: not a normal-form observer")


def _linear_part(obs: Observer) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(F, G, H) of the observer with phi0 = 0: z' = F z + G y, x^n = H z (the low-power
    observer's states block by block, as :func:`lowpower_error_matrix`)."""
    p = obs.p
    if obs.f is standard_f:
        n = len(p.alpha)
        G = np.array([a / p.eps ** (i + 1) for i, a in enumerate(p.alpha)])
        F = np.diag(np.ones(n - 1), 1) - np.outer(G, np.eye(n)[0])
        return F, G, np.eye(n)[n - 1]
    if obs.f is lowpower_f:
        m = p.K.shape[0]
        F = lowpower_error_matrix(m + 1, p.ell, p.K)
        G = np.zeros(2 * m)
        G[:2] = p.ell * p.K[0, 0], p.ell ** 2 * p.K[0, 1]
        return F, G, np.eye(2 * m)[2 * m - 1]
    raise ValueError(f"observer {obs.name}: not a normal-form observer")


def noise_gain(obs: Observer, omega: float) -> float:
    """|x^n / y| at s = j omega: how much of a measurement noise at that frequency reaches
    the estimate of the last state (phi0 = 0)."""
    F, G, H = _linear_part(obs)
    return float(abs(H @ np.linalg.solve(1j * omega * np.eye(F.shape[0]) - F, G)))
