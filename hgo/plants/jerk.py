"""Sprott's jerk system (Sprott, *Some simple chaotic jerk functions*, Am. J. Phys. 65(6),
1997; the quadratic jerk x''' = -A x'' + x'^2 - x) in observability normal form (n = 3):

    x1' = x2,   x2' = x3,   x3' = -A x3 + x2^2 - x1,   y = x1 (+ noise).

At A = 2.017 it is chaotic and, from x(0) = (-1, 0, 0), bounded: solve_ivp DOP853 (rtol
1e-10, atol 1e-12) over 2,000 s stays within |x1| <= 8.09, |x2| <= 3.13, |x3| <= 3.40, the
same bounds over [0, 100] s and [1000, 2000] s. Other starts escape: from (0, 0, 0.1) the
solution leaves to infinity at t = 42.5 s.
"""

from __future__ import annotations

from collections.abc import Sequence

from hgo.core.components import Plant
from hgo.plants.normal_form import normal_form_plant


def phi0(x, u, p):
    """x3' = -A x3 + x2^2 - x1 (also the observers' model: it reads p.A)."""
    return -p.A * x[2] + x[1] * x[1] - x[0]


def jerk_plant(A: float = 2.017, x0: Sequence[float] = (-1.0, 0.0, 0.0)) -> Plant:
    """The jerk system with damping ``A`` from ``x0`` (module doc: which starts stay bounded)."""
    return normal_form_plant("jerk", phi0, x0, A=float(A))
