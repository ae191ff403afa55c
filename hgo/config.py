"""Structured configs: one dataclass schema per config-group option.

Each YAML option in ``conf/<group>/`` starts from a schema stored here under
``schema/<group>/<name>``, so a misspelt key, a wrong type or an unknown option fails
when Hydra composes the config, with Hydra's message naming the full key. A user's own
plant or observer needs no schema: a YAML with ``_target_`` pointing at their factory
is enough (the factory's signature then checks the keys).
"""

from __future__ import annotations

import importlib
from dataclasses import dataclass, field
from typing import Any

from hydra.core.config_store import ConfigStore


@dataclass
class SPLinearPlantConf:
    """Sanfelice & Praly (18)."""

    _target_: str = "hgo.plants.sp_linear.sp_linear_plant"
    nu1: float = 0.01
    nu2: float = 0.01
    x0: list[float] = field(default_factory=lambda: [-1.0, 0.0])


@dataclass
class TriangularHGOConf:
    """Sanfelice & Praly (5)-(7); ``law`` in {constant, sign_indefinite, dead_zone}."""

    _target_: str = "hgo.observers.triangular.triangular_hgo"
    K: list[float] = field(default_factory=lambda: [2.0, 2.0])
    xhat0: list[float] = field(default_factory=lambda: [3.0, 3.0])
    r0: float = 1.0
    law: str = "sign_indefinite"
    p1: float = 4 / 3
    p2: float = 0.008
    b: float = 0.28
    M: list[list[float]] | None = None
    c: list[float] | None = None


@dataclass
class NoiseConf:
    """Sample-and-hold measurement noise; ``kind`` in {none, uniform, gaussian}."""

    _target_: str = "hgo.noise.noise_model"
    kind: str = "none"
    amplitude: float = 0.0
    std: float = 0.0
    period: float = 0.01
    channels: list[int] = field(default_factory=lambda: [0])


@dataclass
class SolverConf:
    """Integrator settings (see :class:`hgo.engine.simulate.SolverSettings`), seconds."""

    method: str = "dopri5"
    t_end: float = 100.0
    dt_out: float = 0.01
    h_max: float = 0.01
    rtol: float = 1e-8
    atol: float = 1e-10
    state_bound: float = 1e6
    stability_safety: float = 0.9


@dataclass
class MetricsConf:
    """Trailing window [t_end - window, t_end] of the mean-error estimates (11)-(12)."""

    window: float = 25.0


@dataclass
class EnsembleConf:
    """``size`` members (0: a single run); ``vary``: dotted key -> [low, high] (scalar) or
    [[low, high], ...] (vector), drawn uniformly with ``seed``."""

    size: int = 0
    seed: int = 0
    vary: dict[str, Any] = field(default_factory=dict)


def register_configs() -> None:
    """Store every schema in Hydra's ConfigStore (idempotent)."""
    cs = ConfigStore.instance()
    cs.store(group="schema/plant", name="sp_linear", node=SPLinearPlantConf)
    cs.store(group="schema/observer", name="triangular", node=TriangularHGOConf)
    cs.store(group="schema/noise", name="noise", node=NoiseConf)
    cs.store(group="schema/solver", name="solver", node=SolverConf)
    cs.store(group="schema", name="metrics", node=MetricsConf)
    cs.store(group="schema/ensemble", name="ensemble", node=EnsembleConf)
    for module, function in _EXTENSIONS:
        try:
            getattr(importlib.import_module(module), function)()
        except ModuleNotFoundError as err:
            if err.name != module:
                raise


# Modules that store the schemas of one paper's components, and their register function.
_EXTENSIONS = [("hgo.sp_config", "register_sp_configs"), ("hgo.ak_config", "register_ak_configs")]
