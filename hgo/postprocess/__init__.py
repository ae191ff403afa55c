"""Post-processing of a run: signals derived from the trajectory, extra metrics, bounds.

The ``postprocess`` config group is a mapping name -> ``_target_`` factory; each factory
returns an object with ``apply(system, traj) -> PostOutput``. The runner logs the
returned series in the recording, appends the rows to ``metrics.csv`` and uses
``bounds`` to fill the ``bound`` column of matching (observer, quantity) rows.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Protocol

from hgo.engine.simulate import Trajectory
from hgo.engine.system import System
from hgo.outputs.recording import Series


@dataclass
class PostOutput:
    """What a post-processor adds to a run."""

    series: list[Series] = field(default_factory=list)
    # extra metric rows: dicts with at least observer, quantity, empirical (bound optional)
    rows: list[dict] = field(default_factory=list)
    # (observer, quantity) -> theoretical bound for the runner's own metric rows
    bounds: dict[tuple[str, str], float] = field(default_factory=dict)


class PostProcessor(Protocol):
    def apply(self, system: System, traj: Trajectory) -> PostOutput: ...
