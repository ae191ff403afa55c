"""Structured-config schemas of the Moreno components.

Stored from :data:`SCHEMAS` by :func:`hgo.core.config.register_configs`:

* ``schema/plant/moreno_example``: the example of Section 5 in form (2)
  (:func:`hgo.plants.circle_form.moreno_example_plant`);
* ``schema/plant/circle_form``: any plant of form (2) with polynomial psi
  (:func:`hgo.plants.circle_form.circle_form_plant`);
* ``schema/observer/circle_criterion``: the observer (3) built from the plant's matrices
  (the runner hands its factory the built plant,
  :func:`hgo.running.runner.plant_argument`)
  (:func:`hgo.observers.circle_criterion.circle_criterion_observer`);
* ``schema/controller/profile_input``: inputs u = r' + a r of a profile r
  (:func:`hgo.controllers.profile_input.profile_input`);
* ``schema/postprocess/moreno_certificate``: (9)-(14), Theorems 2-3 along a run
  (:func:`hgo.papers.moreno.postprocess.moreno_certificate`);
* ``schema/postprocess/moreno_sector``: the sector table of (7)-(8)
  (:func:`hgo.papers.moreno.sector_table.sector_table`).
"""

from __future__ import annotations

from dataclasses import dataclass, field


@dataclass
class MorenoExampleConf:
    """Moreno Section 5: x1' = -x1 + x2 (x2^2 - 1), x2' = -a x2 + u, y = x1."""

    _target_: str = "hgo.plants.circle_form.moreno_example_plant"
    a: float = 0.0
    x0: list[float] = field(default_factory=lambda: [0.0, 0.0])


@dataclass
class CircleFormConf:
    """Moreno (2): x' = A x + G psi(H x) + B u, y = C x, psi(s) = sum_k psi[k] s^k."""

    _target_: str = "hgo.plants.circle_form.circle_form_plant"
    A: list[list[float]] = field(default_factory=lambda: [[-1.0, 1.0], [0.0, 0.0]])
    G: list[float] = field(default_factory=lambda: [1.0, 0.0])
    C: list[float] = field(default_factory=lambda: [1.0, 0.0])
    H: list[float] = field(default_factory=lambda: [0.0, 1.0])
    B: list[float] = field(default_factory=lambda: [0.0, 1.0])
    psi: list[float] = field(default_factory=lambda: [0.0, -2.0, 0.0, 1.0])
    x0: list[float] = field(default_factory=lambda: [0.0, 0.0])


@dataclass
class CircleCriterionConf:
    """Moreno (3) with gains L = [l1, l2], N = k; x^(0) = x(0) - e0 (or xhat0)."""

    _target_: str = "hgo.observers.circle_criterion.circle_criterion_observer"
    L: list[float] = field(default_factory=lambda: [200.0, 120.0])
    N: float = 2.0
    e0: list[float] | None = field(default_factory=lambda: [70.0, -50.0])
    xhat0: list[float] | None = None


@dataclass
class ProfileInputConf:
    """u = r' + a r, r in {bad, pulse, pulse_return, sin} (notes section 9)."""

    _target_: str = "hgo.controllers.profile_input.profile_input"
    kind: str = "pulse"
    a: float = 0.0
    t_on: float = 5.0
    tau: float = 0.5
    level: float = 2.0
    amp: float = 2.0
    omega: float = 1.0
    t_back: float = 9.0
    ramp: str = "linear"


@dataclass
class MorenoCertificateConf:
    """Moreno (9)-(14) along the run; lambda_P in {half_min_eig, min_eig, sharp}."""

    _target_: str = "hgo.papers.moreno.postprocess.moreno_certificate"
    lambda_P: str = "half_min_eig"
    delta: float = 0.1
    regularisation: str = "margin"
    eps_fraction: float = 0.99
    K1t: float | None = None
    window: float | None = None
    norm_floor: float = 1.0e-6
    K1t_search: bool = False
    mu: float = 1.0e-7


@dataclass
class MorenoSectorConf:
    """Sector table: gain sets [k, l1, l2, a], eps_max(rho) points, (8) over gains."""

    _target_: str = "hgo.papers.moreno.sector_table.sector_table"
    gains: list[list[float]] = field(default_factory=lambda: [
        [2.0, 200.0, 120.0, 0.0], [1.0, 50.0, 10.0, 0.0], [5.0, 1000.0, 500.0, 0.0],
        [2.0, 200.0, 120.0, 0.5], [2.0, 200.0, 20.0, 0.5], [2.0, 200.0, 120.0, 1.0],
        [2.0, 200.0, 10.0, 0.1]])
    rho_gains: list[float] = field(default_factory=lambda: [2.0, 200.0, 120.0, 0.0])
    rhos: list[float] = field(default_factory=lambda: [-0.95, -0.9, -0.5, 0.0, 1.0, 2.0])
    over_gains_a: list[float] = field(default_factory=lambda: [0.0, 1.0])
    rho_lo: float = -50.0


# what hgo.core.config.register_configs stores: "<group>/<name>" -> schema, under schema/
SCHEMAS = {
    "plant/moreno_example": MorenoExampleConf,
    "plant/circle_form": CircleFormConf,
    "observer/circle_criterion": CircleCriterionConf,
    "controller/profile_input": ProfileInputConf,
    "postprocess/moreno_certificate": MorenoCertificateConf,
    "postprocess/moreno_sector": MorenoSectorConf,
}
