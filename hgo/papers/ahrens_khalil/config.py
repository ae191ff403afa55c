"""Structured-config schemas of the Ahrens & Khalil (2008) components.

Stored from :data:`SCHEMAS` by :func:`hgo.core.config.register_configs`:

* ``schema/plant/dc_motor``: the field-controlled DC motor (38)-(39)
  (:func:`hgo.plants.dc_motor.dc_motor_plant`);
* ``schema/observer/switched_hgo``: the (switched-gain) high-gain observer (8)-(10),
  (26)-(28) with the scheme of Section 3.1 (:func:`hgo.observers.switched_hgo.switched_hgo`);
  ``eps2: null`` (and ``alpha2: null``) gives a fixed-gain observer;
* ``schema/controller/dc_motor_speed``: speed tracking by feedback linearisation
  (:func:`hgo.controllers.dc_motor_speed.dc_motor_speed_controller`);
* ``schema/controller/open_loop``: u = a + b sin(omega t)
  (:func:`hgo.controllers.open_loop.open_loop_controller`);
* ``schema/postprocess/ak_metrics``: velocity tracking error e2 = x2 - r', transient and
  late-window metrics, switch log, ultimate bound of ||x - x^||
  (:func:`hgo.papers.ahrens_khalil.postprocess.ak_metrics`).

Defaults are the paper's Section 4 values where it gives them; the choices it leaves open
(reference, controller gain, x3(0)) are documented in the factories' modules.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field


@dataclass
class DCMotorPlantConf:
    """Ahrens & Khalil (38)-(39): x' = (x2, -a x2 + b x3 u, -c x3 - d x2 u + e)."""

    _target_: str = "hgo.plants.dc_motor.dc_motor_plant"
    x0: list[float] = field(default_factory=lambda: [0.0, 0.0, 100.0])
    a: float = 0.1
    b: float = 0.1
    c: float = 2.0
    d: float = 0.2
    e: float = 200.0


@dataclass
class SwitchedHGOConf:
    """Ahrens & Khalil (8)-(10), (26)-(28), Section 3.1; eps2 = null: fixed gain."""

    _target_: str = "hgo.observers.switched_hgo.switched_hgo"
    alpha1: list[float] = field(default_factory=lambda: [71.0, 70.0])
    eps1: float = 0.0005
    alpha2: list[float] | None = field(default_factory=lambda: [2.0, 1.0])
    eps2: float | None = 0.01
    delta: float = 0.05
    T_d: float = 0.15
    xhat0: list[float] = field(default_factory=lambda: [math.pi, 0.0])
    saturation: float = 100.0
    saturate_x1: bool = False
    model: list[float] = field(default_factory=lambda: [0.0, -0.11])
    input_gain: float = 0.1
    w_index: int = 1


@dataclass
class DCMotorSpeedConf:
    """u = (v + a x^2)/(b x3), v = r'' - k (x^2 - r'); r' a smoothed step (+ sinusoid)."""

    _target_: str = "hgo.controllers.dc_motor_speed.dc_motor_speed_controller"
    observer: str | None = None
    k: float = 5.0
    w0: float = 0.0
    w_step: float = 10.0
    t_step: float = 0.0
    T_rise: float = 1.0
    a_sin: float = 0.0
    omega_sin: float = 0.0
    a: float = 0.1
    b: float = 0.1
    x3_min: float = 1.0
    u_max: float = math.inf


@dataclass
class OpenLoopConf:
    """u(t) = a + b sin(omega t), no feedback."""

    _target_: str = "hgo.controllers.open_loop.open_loop_controller"
    a: float = 1.0
    b: float = 0.5
    omega: float = 1.0


@dataclass
class AKMetricsConf:
    """Windows (s) of the Ahrens & Khalil metrics; late_window: trailing [t_end - w, t_end]."""

    _target_: str = "hgo.papers.ahrens_khalil.postprocess.ak_metrics"
    transient: float = 0.5
    late_window: float = 1.0


# what hgo.core.config.register_configs stores: "<group>/<name>" -> schema, under schema/
SCHEMAS = {
    "plant/dc_motor": DCMotorPlantConf,
    "observer/switched_hgo": SwitchedHGOConf,
    "controller/dc_motor_speed": DCMotorSpeedConf,
    "controller/open_loop": OpenLoopConf,
    "postprocess/ak_metrics": AKMetricsConf,
}
