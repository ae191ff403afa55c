"""Period and amplitude of the steady oscillation of the estimates (Sanfelice & Praly (20)).

Over the trailing window [t_end - T, t_end] (T = the run's metrics window), for every
observer and every estimate x^_k (and every internal signal such as r):

* ``period_<sig>``: mean spacing of the upward zero crossings of the de-meaned signal
  (crossing instants linearly interpolated between samples); NaN with fewer than two
  crossings (no oscillation in the window);
* ``period_fft_<sig>``: 1 / the frequency of the largest peak of the periodogram of the
  de-meaned, Hann-windowed signal (zero-padded x8, peak refined by a parabola through the
  three bins around it), a check of the zero-crossing value;
* ``amplitude_<sig>``: peak-to-peak amplitude max - min over the window (the paper's
  figures show peak-to-peak excursions; half of it is the usual amplitude).

The paper tunes its notch filter with a period of 2.23 s for p2 = 1.5; the measured value is
in metrics.csv (``period_xhat1`` of that run).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from hgo.core.errors import ConfigError
from hgo.engine.simulate import Trajectory
from hgo.engine.system import System
from hgo.postprocess import PostOutput


def window_slice(traj: Trajectory, window: float | None = None) -> slice:
    """Samples of the trailing window: the run's metrics window unless ``window`` is given."""
    T = float(traj.acc[-1]) if window is None else float(window)
    if not T > 0:
        T = traj.t[-1] / 4
    t0 = traj.t[-1] - T
    k0 = int(np.searchsorted(traj.t, t0 - 1e-9))
    return slice(k0, len(traj.t))


def zero_crossing_period(t: np.ndarray, v: np.ndarray) -> float:
    """Mean spacing of upward zero crossings of v - mean(v); NaN with fewer than 2."""
    w = v - v.mean()
    k = np.nonzero((w[:-1] < 0) & (w[1:] >= 0))[0]
    if len(k) < 2:
        return math.nan
    tc = t[k] - w[k] * (t[k + 1] - t[k]) / (w[k + 1] - w[k])
    return float((tc[-1] - tc[0]) / (len(tc) - 1))


def spectral_period(t: np.ndarray, v: np.ndarray, pad: int = 8) -> float:
    """1 / frequency of the largest periodogram peak of the de-meaned, Hann-windowed v."""
    if len(v) < 8:
        return math.nan
    dt = float(t[1] - t[0])
    w = (v - v.mean()) * np.hanning(len(v))
    nfft = pad * len(v)
    spec = np.abs(np.fft.rfft(w, nfft)) ** 2
    freq = np.fft.rfftfreq(nfft, dt)
    spec[0] = 0.0
    k = int(np.argmax(spec))
    if k == 0 or spec[k] <= 1e-300:
        return math.nan
    if 0 < k < len(spec) - 1:  # parabolic refinement on the log spectrum
        a, b, c = np.log(spec[k - 1:k + 2] + 1e-300)
        den = a - 2 * b + c
        delta = 0.5 * (a - c) / den if den != 0 else 0.0
        f0 = freq[k] + delta * (freq[1] - freq[0])
    else:
        f0 = freq[k]
    return float(1.0 / f0) if f0 > 0 else math.nan


def peak_to_peak(v: np.ndarray) -> float:
    """max - min."""
    return float(v.max() - v.min()) if len(v) else math.nan


def oscillation_rows(observer: str, names: list[str], t: np.ndarray, values: np.ndarray,
                     spectrum: bool = True) -> list[dict]:
    """Rows period_/period_fft_/amplitude_<name> for each column of ``values``."""
    rows = []
    for name, v in zip(names, values.T, strict=True):
        rows.append({"observer": observer, "quantity": f"period_{name}",
                     "empirical": zero_crossing_period(t, v)})
        if spectrum:
            rows.append({"observer": observer, "quantity": f"period_fft_{name}",
                         "empirical": spectral_period(t, v)})
        rows.append({"observer": observer, "quantity": f"amplitude_{name}",
                     "empirical": peak_to_peak(v)})
    return rows


def observer_signals(system: System, traj: Trajectory, index: int) -> tuple[list[str], np.ndarray]:
    """Names and columns (estimates, then internal signals) of observer ``index``."""
    obs = system.observers[index]
    xa, xb = system.xh_slices[index]
    za, _ = system.z_slices[1 + index]
    names = [f"xhat{i + 1}" for i in obs.estimated_states]
    cols = [traj.xh[:, xa:xb]]
    for sig, idx in obs.signals.items():
        label = sig.replace("/", "_")
        names += [label] if len(idx) == 1 else [f"{label}{k + 1}" for k in range(len(idx))]
        cols.append(traj.z[:, [za + c for c in idx]])
    return names, np.hstack(cols)


@dataclass
class Oscillation:
    """Post-processor: period and peak-to-peak amplitude over the trailing window."""

    window: float | None = None  # seconds; None: the run's metrics window
    spectrum: bool = True

    def check(self, system: System, solver, key: str) -> None:
        """The window lies inside the run (a longer one would be clipped silently)."""
        if self.window is not None and self.window > solver.t_end:
            raise ConfigError(f"{key}.window", f"{self.window} s is longer than the run "
                              f"(solver.t_end = {solver.t_end})", f"(0, {solver.t_end}]")

    def apply(self, system: System, traj: Trajectory) -> PostOutput:
        sl = window_slice(traj, self.window)
        rows = []
        for k, obs in enumerate(system.observers):
            names, values = observer_signals(system, traj, k)
            rows += oscillation_rows(obs.name, names, traj.t[sl], values[sl], self.spectrum)
        return PostOutput(rows=rows)


def oscillation(window: float | None = None, spectrum: bool = True) -> Oscillation:
    """Factory for the ``postprocess`` group."""
    if window is not None and not window > 0:
        raise ValueError(f"postprocess.oscillation.window must be > 0, got {window}")
    return Oscillation(window, spectrum)
