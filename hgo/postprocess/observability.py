"""Observability metrics of the observers derived from a plant's equations (issue 42).

For every observer that records them (:mod:`hgo.observers.symbolic_hgo`):

* ``min_abs_det_dPhi``: min over the run's step ends (t = 0 included) of |det dPhi/dx(x^)|,
  how close the estimate came to where Phi is no change of coordinates;
* ``guard_step_ends``: at how many step ends the correction's guard of ``hgo_original``
  acted.

Both are kept by the observer's discrete update after every integration step (running
minimum, count) and read at the run's end: they do not depend on the output grid.
"""

from __future__ import annotations

from hgo.engine.simulate import Trajectory
from hgo.engine.system import System
from hgo.postprocess import PostOutput

QUANTITIES = ("min_abs_det_dPhi", "guard_step_ends")


class ObservabilityMetrics:
    """Post-processor: the quantities of the module doc, one row each per observer."""

    def apply(self, system: System, traj: Trajectory) -> PostOutput:
        rows = []
        for obs, (a, _) in zip(system.observers, system.d_slices, strict=True):
            for quantity in QUANTITIES:
                if quantity in obs.disc_names and len(traj.d):
                    value = float(traj.d[-1, a + obs.disc_names.index(quantity)])
                    rows.append({"observer": obs.name, "quantity": quantity,
                                 "empirical": value})
        return PostOutput(rows=rows)


def observability() -> ObservabilityMetrics:
    """Factory for the ``postprocess`` group."""
    return ObservabilityMetrics()
