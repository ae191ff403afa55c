"""Open-loop input u(t) = a + b sin(omega t), ignoring every estimate.

Used by the DC motor benchmark problem A (u = 1 + 0.5 sin t): the observers then only
estimate, they do not close a loop. Parameters (by name): a, b, omega.
"""

from __future__ import annotations

import math

from hgo.core.components import Controller, Params


def u(t, xhat, y, p, u_out):
    """u = a + b sin(omega t) on every input channel."""
    val = p.a + p.b * math.sin(p.omega * t)
    for i in range(u_out.shape[0]):
        u_out[i] = val


def open_loop_controller(a: float = 1.0, b: float = 0.5, omega: float = 1.0,
                         name: str = "open_loop") -> Controller:
    """u(t) = a + b sin(omega t); the defaults are problem A's u = 1 + 0.5 sin t."""
    for key, value in (("a", a), ("b", b), ("omega", omega)):
        if not math.isfinite(value):
            raise ValueError(f"controller.{key} must be finite, got {value}")
    return Controller(name=name, p=Params(a=a, b=b, omega=omega), u=u, observer=None)
