"""Peaking of the estimates and their late error, per observer (issue 24, item 4).

For every observer and every plant state x_j it estimates:

* ``peak_abs_xhat<j>``: max |x^_j(t)| over the transient [0, ``transient``] (the peak of
  the estimate itself, as the high-gain literature plots it);
* ``peak_abs_err<j>``: max |x^_j(t) - x_j(t)| over the same interval;
* ``rms_err<j>_late``: the RMS of x^_j - x_j over the trailing window (the run's metrics
  window): the steady-state error, which measurement noise sets.

All on the output grid (its spacing bounds how well a peak is caught: a peak lasting
~eps needs dt_out << eps).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from hgo.core.errors import ConfigError
from hgo.engine.simulate import Trajectory
from hgo.engine.system import System
from hgo.postprocess import PostOutput
from hgo.postprocess.oscillation import window_slice


def peaking_rows(observer: str, states: list[int], t: np.ndarray, x: np.ndarray,
                 xhat: np.ndarray, transient: float, late: slice) -> list[dict]:
    """The rows of one observer (``xhat`` column k estimates plant state ``states[k]``)."""
    early = t <= transient + 1e-12
    rows = []
    for k, j in enumerate(states):
        err = xhat[:, k] - x[:, j]
        values = {f"peak_abs_xhat{j + 1}": np.abs(xhat[early, k]).max(),
                  f"peak_abs_err{j + 1}": np.abs(err[early]).max(),
                  f"rms_err{j + 1}_late": np.sqrt(np.mean(err[late] ** 2))}
        rows += [{"observer": observer, "quantity": q, "empirical": float(v)}
                 for q, v in values.items()]
    return rows


@dataclass
class Peaking:
    """Post-processor: peaks over the transient and late RMS errors of every estimate."""

    transient: float = 1.0  # seconds from t = 0

    def check(self, system: System, solver, key: str) -> None:
        """The transient lies inside the run."""
        if not 0 < self.transient <= solver.t_end:
            raise ConfigError(f"{key}.transient", f"must be in (0, solver.t_end = "
                              f"{solver.t_end}], got {self.transient}", f"(0, {solver.t_end}]")

    def apply(self, system: System, traj: Trajectory) -> PostOutput:
        x = traj.z[:, :system.plant.nx]
        late = window_slice(traj)
        rows = []
        for k, obs in enumerate(system.observers):
            xa, xb = system.xh_slices[k]
            rows += peaking_rows(obs.name, list(obs.estimated_states), traj.t, x,
                                 traj.xh[:, xa:xb], self.transient, late)
        return PostOutput(rows=rows)


def peaking(transient: float = 1.0) -> Peaking:
    """Factory for the ``postprocess`` group."""
    if not transient > 0:
        raise ValueError(f"postprocess.peaking.transient must be > 0, got {transient}")
    return Peaking(float(transient))
