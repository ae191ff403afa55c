"""Van der Pol oscillator in observability normal form (n = 2):

    x1' = x2,   x2' = mu (1 - x1^2) x2 - x1,   y = x1 (+ noise).

For mu > 0 every solution but the origin tends to one limit cycle (|x1| <= ~2.0 on it).
"""

from __future__ import annotations

from collections.abc import Sequence

from hgo.core.components import Plant
from hgo.plants.normal_form import normal_form_plant


def phi0(x, u, p):
    """x2' = mu (1 - x1^2) x2 - x1 (also the observers' model: it reads p.mu)."""
    return p.mu * (1.0 - x[0] * x[0]) * x[1] - x[0]


def van_der_pol_plant(mu: float = 1.0, x0: Sequence[float] = (2.0, 0.0)) -> Plant:
    """The oscillator with damping parameter ``mu`` from ``x0``."""
    return normal_form_plant("van_der_pol", phi0, x0, mu=float(mu))
