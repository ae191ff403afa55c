"""The Kalman filters' tuning: Q, R, P0 and the sampling period, checked, with their
defaults from the noise model.

Q, R, P0 are each given as a scalar (times the identity), a list of n numbers (the
diagonal) or an n x n matrix, n the number of the signals they cover (the plant's states
for Q and P0, its measured outputs for R); a wrong shape, an asymmetric matrix or one
that is not positive definite (Q: semidefinite) fails in one line naming the key.

``R`` left out (None) is taken from the noise model of the run (the observer's
``noise`` argument, ``{kind, std, amplitude, period, channels}`` of the ``noise`` group,
interpolated in its config): the variance of each held sample, std^2 (Gaussian) or
amplitude^2 / 3 (uniform in [-amplitude, amplitude]), on the noisy channels. That is R
of the continuous-discrete filters, whose measurement at an instant carries one sample.
The continuous (Kalman–Bucy) filter needs the noise's spectral density instead: noise
held over periods Delta with variance sigma^2 has autocorrelation
sigma^2 max(0, 1 - |tau| / Delta), whose integral is sigma^2 Delta, the density at
frequencies well below 1 / Delta; its default R is that, sigma^2 Delta. A channel
measured without noise, or ``noise.kind=none``, leaves R undetermined (singular): give R.

``sample_period`` left out is the noise model's ``period`` (one measurement per held
sample).
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence

import numpy as np

from hgo.core.components import Plant


def covariance(key: str, value: object, names: Sequence[str], definite: bool) -> np.ndarray:
    """``value`` (scalar, diagonal or matrix; module doc) as an n x n matrix for the signals
    ``names``, symmetric and positive definite (``definite``) or semidefinite."""
    n = len(names)
    try:
        arr = np.asarray(value, float)
    except (TypeError, ValueError):
        arr = np.full((0, 0), np.nan)
    shape = arr.shape
    if arr.ndim == 0:
        arr = arr * np.eye(n)
    elif arr.shape == (n,):
        arr = np.diag(arr)
    if arr.shape != (n, n):
        raise ValueError(f"{key} must be a scalar, {n} numbers (the diagonal) or a {n}x{n} "
                         f"matrix for ({', '.join(names)}), got shape {shape}")
    if not np.all(np.isfinite(arr)) or not np.array_equal(arr, arr.T):
        raise ValueError(f"{key} must be finite and symmetric, got {arr.tolist()}")
    low = float(np.linalg.eigvalsh(arr)[0])
    if low < 0 or (definite and low <= 0):
        kind = "positive definite" if definite else "positive semidefinite"
        raise ValueError(f"{key} must be {kind}; its smallest eigenvalue is {low:.3g}")
    return arr


def noise_variance(key: str, noise: Mapping | None, outputs: Sequence[str],
                   continuous: bool) -> np.ndarray:
    """The default R (module doc): the held samples' variance on each output channel
    (times the period for the ``continuous`` filter), as a diagonal matrix."""
    if noise is None:
        raise ValueError(f"{key}.R: give it (no noise model to take its default from)")
    kind = noise.get("kind", "none")
    if kind not in ("gaussian", "uniform"):
        raise ValueError(f"{key}.R: noise.kind={kind} gives no measurement variance; give R")
    var = float(noise["std"]) ** 2 if kind == "gaussian" else float(noise["amplitude"]) ** 2 / 3
    if continuous:
        var *= float(noise["period"])
    channels = list(noise.get("channels", [0]))
    quiet = [name for k, name in enumerate(outputs) if k not in channels]
    if quiet or not var > 0:
        which = f"outputs {quiet} are measured without noise" if quiet else "the noise is 0"
        raise ValueError(f"{key}.R: {which} (noise.channels = {channels}), so R would be "
                         "singular; give R")
    return var * np.eye(len(outputs))


def sample_period(key: str, value: float | None, noise: Mapping | None) -> float:
    """The measurement period: ``value``, else the noise model's ``period``."""
    if value is None:
        if noise is None or noise.get("kind", "none") == "none":
            raise ValueError(f"{key}.sample_period: give it (no noisy samples to take it "
                             "from: noise.kind=none)")
        value = noise["period"]
    if isinstance(value, bool) or not isinstance(value, (int, float)) or not (
            math.isfinite(value) and value > 0):
        raise ValueError(f"{key}.sample_period must be a number > 0 (seconds), got {value!r}")
    return float(value)


def initial_estimate(key: str, value: Sequence[float] | None, plant: Plant) -> np.ndarray:
    """x^(0): ``value`` (one finite number per state), default the plant's x(0) (as the
    observers derived from a plant's equations: a filter then starts where the plant
    does, never at a point where the plant's f is undefined; give xhat0 to see a
    transient)."""
    names = plant.state_names
    x0 = np.array(plant.x0, float) if value is None else np.asarray(value, float).reshape(-1)
    if x0.shape != (len(names),) or not np.all(np.isfinite(x0)):
        raise ValueError(f"{key}.xhat0 must have {len(names)} finite entries "
                         f"({', '.join(names)}), got {value}")
    return x0
