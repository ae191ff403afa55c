"""Structured-config schemas of the Andrieu, Praly & Astolfi (2007) components.

Stored from :data:`SCHEMAS` by :func:`hgo.core.config.register_configs`:

* ``schema/plant/contois``: the Contois bioreactor (11) (:func:`hgo.plants.contois.contois_plant`);
* ``schema/observer/homogeneous_dynamic_hgo``: observer (7)-(8) on the form (12)
  (:func:`hgo.observers.homogeneous_dynamic.homogeneous_dynamic_hgo`);
* ``schema/controller/schedule``: the piecewise-constant input of Section 3.1
  (:func:`hgo.controllers.schedule.schedule_input`);
* ``schema/postprocess/apa_metrics``: rates Omega, df2/dx2, errors and window metrics
  (:func:`hgo.papers.andrieu_praly_astolfi.postprocess.apa_metrics`).

Defaults are the paper's values (Section 3.1) and, where it is silent, the readings
C1-C18 of ``shared/specs/apa.md`` (named next to each key).
"""

from __future__ import annotations

from dataclasses import dataclass, field


@dataclass
class ContoisPlantConf:
    """Andrieu, Praly & Astolfi (11); eta0 not in the paper (C5)."""

    _target_: str = "hgo.plants.contois.contois_plant"
    eta0: list[float] = field(default_factory=lambda: [0.3, 0.5])
    hbar: float = 1.0


@dataclass
class HomogeneousDynamicHGOConf:
    """Observer (7)-(8); rate_bound in {df2max, omega1, omega2}, gain in {dynamic,
    constant}, correction in {homogeneous, linear} (C3), L0 null: equilibrium (C6)."""

    _target_: str = "hgo.observers.homogeneous_dynamic.homogeneous_dynamic_hgo"
    rate_bound: str = "omega2"
    p: float = 0.9
    b: float = 0.5
    phi1: float = 3.0
    phi2: float = 0.01
    phi3: float = 3.0
    ell: float = 3.0
    gain: str = "dynamic"
    correction: str = "homogeneous"
    hbar: float = 0.8
    u_min: float = 0.01
    u_max: float = 0.7
    eta_hat0: list[float] = field(default_factory=lambda: [0.5, 0.3])
    L0: float | None = None


@dataclass
class ScheduleConf:
    """u(t) = values[k] on [times[k-1], times[k]) (Section 3.1; C1: 10 <= t < 20)."""

    _target_: str = "hgo.controllers.schedule.schedule_input"
    times: list[float] = field(default_factory=lambda: [10.0, 20.0, 35.0])
    values: list[float] = field(default_factory=lambda: [0.5, 0.02, 0.6, 0.1])


@dataclass
class APAMetricsConf:
    """Windows of the metrics (notes section 8): late, post-transient, transient, steady
    parts of the input segments; thresholds of the convergence times."""

    _target_: str = "hgo.papers.andrieu_praly_astolfi.postprocess.apa_metrics"
    late: list[float] = field(default_factory=lambda: [40.0, 50.0])
    post: list[float] = field(default_factory=lambda: [10.0, 50.0])
    transient: list[float] = field(default_factory=lambda: [0.0, 10.0])
    steady: list[list[float]] = field(default_factory=lambda: [[3.0, 10.0], [13.0, 20.0],
                                                               [23.0, 35.0], [38.0, 50.0]])
    thresholds: list[float] = field(default_factory=lambda: [0.1, 0.01])


# what hgo.core.config.register_configs stores: "<group>/<name>" -> schema, under schema/
SCHEMAS = {
    "plant/contois": ContoisPlantConf,
    "observer/homogeneous_dynamic_hgo": HomogeneousDynamicHGOConf,
    "controller/schedule": ScheduleConf,
    "postprocess/apa_metrics": APAMetricsConf,
}
