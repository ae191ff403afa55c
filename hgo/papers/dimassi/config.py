"""Structured-config schemas of the Dimassi et al. (STA 2019) components.

Stored from :data:`SCHEMAS` by :func:`hgo.core.config.register_configs`:

* ``schema/plant/robot_arm``: the arm (24)-(25) (:func:`hgo.plants.robot_arm.robot_arm_plant`);
* ``schema/controller/sinusoids``: u = sum a_k sin(w_k t) + b_k cos(w_k t)
  (:func:`hgo.controllers.sinusoids.sinusoids_controller`);
* ``schema/observer/adaptive_cascade``: HGO (6) in cascade with (5), (7) [, (11)]
  (:func:`hgo.observers.adaptive_cascade.adaptive_cascade`);
* ``schema/postprocess/dhlm_metrics``: :func:`hgo.papers.dimassi.postprocess.dhlm_metrics`.

Defaults are the paper's Sec. IV values; the open choices (implementation notes
``shared/specs/dhlm.md`` A1-A16) are documented in the factories' modules and the YAMLs.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any


@dataclass
class RobotArmPlantConf:
    """Dimassi et al. (24)-(25); outputs: y (paper) or Hx (diagnostic)."""

    _target_: str = "hgo.plants.robot_arm.robot_arm_plant"
    x0: list[float] = field(default_factory=lambda: [1.0, 1.0])
    I: float = 0.5  # noqa: E741
    m: float = 1.0
    g: float = 9.81
    l: float = 1.0  # noqa: E741
    outputs: str = "y"


@dataclass
class SinusoidsConf:
    """u(t) = sum_k a_k sin(omega_k t) + b_k cos(omega_k t)."""

    _target_: str = "hgo.controllers.sinusoids.sinusoids_controller"
    omega: list[float] = field(default_factory=lambda: [2.0, 3.0])
    a: list[float] = field(default_factory=lambda: [5.0, 0.0])
    b: list[float] = field(default_factory=lambda: [0.0, 5.0])


@dataclass
class AdaptiveCascadeConf:
    """Dimassi et al. (5)-(7), (11); matrices as nested lists (rows)."""

    _target_: str = "hgo.observers.adaptive_cascade.adaptive_cascade"
    A: Any = field(default_factory=lambda: [[0.0, 1.0], [0.0, 0.0]])
    B: Any = field(default_factory=lambda: [[0.0], [1.0]])
    C: Any = field(default_factory=lambda: [[1.0, 0.0]])
    E: Any = None
    model: str = "robot_arm"
    q: list[int] = field(default_factory=lambda: [2])
    gamma: Any = field(default_factory=lambda: [[6.0, 8.0]])
    eps: float = 0.006
    S: list[float] = field(default_factory=lambda: [150.0, 150.0])
    L: Any = field(default_factory=lambda: [[5.0, 0.0], [1.0, 10.0]])
    M: Any = field(default_factory=lambda: [[0.0, 1.0]])
    delta: float = 100.0
    sigma: float = 0.01
    psi_at: str = "y"
    omega_law: bool = False
    sigma2: float = 0.01
    hgo: str = "observer"
    zh0: Any = None
    xhat0: Any = None
    theta_hat0: Any = None
    omega_hat0: float = 0.0


@dataclass
class DHLMMetricsConf:
    """Window W = [window_start, t_end], T(eps) = T_eps_factor eps, bands; theory rows."""

    _target_: str = "hgo.papers.dimassi.postprocess.dhlm_metrics"
    window_start: float = 10.0
    T_eps_factor: float = 25.0
    peak_band: float = 1.0
    state_bands: list[float] = field(default_factory=lambda: [0.2, 0.05, 0.01])
    theta_pcts: list[float] = field(default_factory=lambda: [1.0, 5.0, 10.0, 25.0])
    theta: Any = None
    theory: bool = True
    beta: str = "measured"


# what hgo.core.config.register_configs stores: "<group>/<name>" -> schema, under schema/
SCHEMAS = {
    "plant/robot_arm": RobotArmPlantConf,
    "controller/sinusoids": SinusoidsConf,
    "observer/adaptive_cascade": AdaptiveCascadeConf,
    "postprocess/dhlm_metrics": DHLMMetricsConf,
}
