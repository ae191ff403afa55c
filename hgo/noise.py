"""Measurement noise models, sampled once per run from a seeded generator.

Every model is sample-and-hold: sample k holds on [k*period, (k+1)*period), and the
engine cuts its steps at the sample instants (a held signal is piecewise constant, so no
step may straddle a jump). Noise is added to the measured channels listed in
``channels`` (default: channel 0, y = x1 + m in Sanfelice & Praly (1)); other channels
are measured noise-free.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from hgo.engine.simulate import Noise


@dataclass(frozen=True)
class NoiseModel:
    """``kind`` in {none, uniform, gaussian}; amplitude M_inf (uniform) or std (gaussian)."""

    kind: str = "none"
    amplitude: float = 0.0
    std: float = 0.0
    period: float = 0.01
    channels: Sequence[int] = (0,)

    KINDS = ("none", "uniform", "gaussian")

    def __post_init__(self) -> None:
        if self.kind not in self.KINDS:
            raise ValueError(f"noise.kind: '{self.kind}' not in {list(self.KINDS)}")
        if self.kind != "none" and not self.period > 0:
            raise ValueError(f"noise.period must be > 0 (seconds), got {self.period}")
        if self.amplitude < 0 or self.std < 0:
            raise ValueError("noise.amplitude and noise.std must be >= 0")

    @property
    def bound(self) -> float:
        """M_inf = ess sup |m| (Sanfelice & Praly, Theorem 2.2 B); inf for Gaussian noise."""
        if self.kind == "uniform":
            return self.amplitude
        return math.inf if self.kind == "gaussian" and self.std > 0 else 0.0

    def sample(self, t_end: float, n_outputs: int, seed: int) -> Noise:
        """Draw the held samples covering [0, t_end] for ``n_outputs`` measured channels."""
        for ch in self.channels:
            if not 0 <= ch < n_outputs:
                raise ValueError(f"noise.channels: {ch} is not a channel of a plant with "
                                 f"{n_outputs} outputs (0..{n_outputs - 1})")
        if self.kind == "none":
            return Noise(np.zeros((1, n_outputs)), math.inf)
        n = int(math.ceil(t_end / self.period)) + 1
        rng = np.random.default_rng(seed)
        samples = np.zeros((n, n_outputs))
        for ch in self.channels:
            if self.kind == "uniform":
                samples[:, ch] = rng.uniform(-self.amplitude, self.amplitude, n)
            else:
                samples[:, ch] = rng.normal(0.0, self.std, n)
        return Noise(samples, float(self.period))


def noise_model(kind: str = "none", amplitude: float = 0.0, std: float = 0.0,
                period: float = 0.01, channels: Sequence[int] = (0,)) -> NoiseModel:
    """Factory used by the ``noise`` config group."""
    return NoiseModel(kind, float(amplitude), float(std), float(period), tuple(channels))
