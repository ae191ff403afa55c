"""Open-loop input u(t) = a + b sin(omega t), ignoring every estimate.

Used by the DC motor benchmark problem A (u = 1 + 0.5 sin t): the observers then only
estimate, they do not close a loop. Parameters p = [a, b, omega].
"""

from __future__ import annotations

import math

import numpy as np

from hgo.core.components import Controller

#: Names of the entries of the parameter vector p.
PARAM_NAMES = ["a", "b", "omega"]


def u(t, xhat, y, p, u_out):
    """u = a + b sin(omega t) on every input channel."""
    val = p[0] + p[1] * math.sin(p[2] * t)
    for i in range(u_out.shape[0]):
        u_out[i] = val


def open_loop_controller(a: float = 1.0, b: float = 0.5, omega: float = 1.0,
                         name: str = "open_loop") -> Controller:
    """u(t) = a + b sin(omega t); the defaults are problem A's u = 1 + 0.5 sin t."""
    for key, value in (("a", a), ("b", b), ("omega", omega)):
        if not math.isfinite(value):
            raise ValueError(f"controller.{key} must be finite, got {value}")
    return Controller(name=name, p=np.array([a, b, omega], float), u=u, observer=None)
