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

from hgo.core.errors import ConfigError
from hgo.engine.simulate import Noise


@dataclass(frozen=True)
class NoiseModel:
    r"""Sample-and-hold measurement noise $m$ added to the measured channels: $y = h(x) + m$.

    Sample $k$ holds on $[k T, (k+1) T)$, $T$ = ``period``; the engine ends a step at
    every sample instant. Samples are drawn once per run from ``numpy.random.default_rng
    (seed)``.

    Attributes:
        kind: ``none``, ``uniform`` ($m_k \sim U[-M, M]$) or ``gaussian``
            ($m_k \sim \mathcal N(0, \sigma^2)$). Default ``none``.
        amplitude: $M \ge 0$ (uniform; units of $y$); must stay 0 for the other kinds.
        std: $\sigma \ge 0$ (gaussian; units of $y$); must stay 0 for the other kinds.
        period: $T > 0$ (s), the hold time of one sample. Default 0.01.
        channels: the noisy output channels (default ``(0,)``); the others are exact.

    Example:
        ```python
        from hgo.noise import noise_model

        m = noise_model("gaussian", std=1e-3, period=0.01)
        noise = m.sample(t_end=1.0, n_outputs=1, seed=0)
        print(noise.samples.shape, m.bound)  # (101, 1) inf
        ```
    """

    kind: str = "none"
    amplitude: float = 0.0
    std: float = 0.0
    period: float = 0.01
    channels: Sequence[int] = (0,)

    KINDS = ("none", "uniform", "gaussian")

    def __post_init__(self) -> None:
        if self.kind not in self.KINDS:
            raise ConfigError("noise.kind", f"'{self.kind}' is not a noise kind",
                              ", ".join(self.KINDS))
        for key in ("amplitude", "std", "period"):
            value = getattr(self, key)
            if not (math.isfinite(value) and value >= 0):
                raise ConfigError(f"noise.{key}", f"must be >= 0 and finite, got {value}")
        if self.kind != "none" and not self.period > 0:
            raise ConfigError("noise.period", f"must be > 0 (seconds), got {self.period}")
        used = {"none": (), "uniform": ("amplitude",), "gaussian": ("std",)}[self.kind]
        for key in ("amplitude", "std"):  # a value the chosen kind ignores is a mistake
            if key not in used and getattr(self, key) != 0:
                raise ConfigError(f"noise.{key}", f"is ignored by noise.kind={self.kind}, "
                                  f"got {getattr(self, key)}", "0, or noise.kind="
                                  + ("uniform" if key == "amplitude" else "gaussian"))
        if not self.channels:
            raise ConfigError("noise.channels", "is empty", "a list of output channels")
        if len(set(self.channels)) != len(self.channels):
            raise ConfigError("noise.channels", f"lists a channel twice: {list(self.channels)}")

    def check_channels(self, n_outputs: int) -> None:
        """Every noisy channel is an output of the plant (before any sample is drawn)."""
        for ch in self.channels:
            if not 0 <= ch < n_outputs:
                raise ConfigError("noise.channels", f"{ch} is not a channel of a plant with "
                                  f"{n_outputs} outputs", f"0..{n_outputs - 1}")

    @property
    def bound(self) -> float:
        """M_inf = ess sup |m| (Sanfelice & Praly, Theorem 2.2 B); inf for Gaussian noise."""
        if self.kind == "uniform":
            return self.amplitude
        return math.inf if self.kind == "gaussian" and self.std > 0 else 0.0

    def sample(self, t_end: float, n_outputs: int, seed: int) -> Noise:
        """Draw the held samples covering [0, t_end] for ``n_outputs`` measured channels."""
        self.check_channels(n_outputs)
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
    """The ``noise`` config group's factory (``noise=uniform noise.amplitude=1e-3``):
    :class:`NoiseModel` after checking every argument's type (one-line errors)."""
    for key, value in (("amplitude", amplitude), ("std", std), ("period", period)):
        if isinstance(value, bool) or not isinstance(value, (int, float)):
            raise ConfigError(f"noise.{key}", f"must be a number, got {value!r}")
    if any(isinstance(c, bool) or not isinstance(c, int) for c in channels):
        raise ConfigError("noise.channels", f"must be integers, got {list(channels)}")
    return NoiseModel(kind, float(amplitude), float(std), float(period), tuple(channels))
