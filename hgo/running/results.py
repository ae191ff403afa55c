"""What a run is made of and what it gives: the built :class:`Experiment` and the
:class:`RunResult` that figures, reports and the Python API read."""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

import pandas as pd

from hgo.engine.simulate import SolverSettings, Trajectory
from hgo.engine.system import System
from hgo.noise import NoiseModel
from hgo.outputs.recording import Series


@dataclass
class Experiment:
    system: System
    solver: SolverSettings
    noise: NoiseModel
    seed: int
    post: dict = field(default_factory=dict)  # name -> post-processor, built and checked


@dataclass
class RunResult:
    experiment: Experiment
    trajectory: Trajectory
    metrics: pd.DataFrame
    out_dir: Path
    series: list[Series]
    # seconds: compile (numba, new kernels only), simulate (without compiling), write
    timings: dict[str, float] = field(default_factory=dict)
