"""Field-controlled DC motor, Ahrens & Khalil (38)-(39) (Khalil, Nonlinear Systems, 2002).

    dx1/dt = x2,
    dx2/dt = phi(x, u) = -a x2 + b x3 u,
    dx3/dt = psi(x, u) = -c x3 - d x2 u + e,
    y = [x1 (+ noise v, channel 0), x3 (w = theta_1 of (39))],

with x1 the rotor position (rad), x2 the angular velocity (rad/s), x3 the armature
current (A) and u the field current (A); the paper's values are a = b = 0.1, c = 2,
d = 0.2, e = 200. x1 is the high-gain observer's measured output; x3 is the extra
measured output w of (4). The engine adds ``noise.samples[k]`` to every channel, so a zero
noise column on channel 1 measures x3 exactly.

Initial current x3(0) (not given in the paper): 100 A by default, the equilibrium of
psi at rest (x2 = 0 gives psi = -2 x3 + 200 for every u), so the motor starts at
rest in steady state: x(0) = (0, 0, 100).

Parameters (by name): a, b, c, d, e.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from hgo.core.components import Params, Plant

#: Equilibrium armature current at rest, e / c = 200 / 2 (A).
X3_REST = 100.0


def f(t, x, u, p, dx):
    """Ahrens & Khalil (38): chain x1' = x2, x2' = phi(x, u), x3' = psi(x, u)."""
    dx[0] = x[1]
    dx[1] = -p.a * x[1] + p.b * x[2] * u[0]
    dx[2] = -p.c * x[2] - p.d * x[1] * u[0] + p.e


def h(t, x, p, y):
    """Ahrens & Khalil (39) before noise: y = x1 and the measured current x3."""
    y[0] = x[0]
    y[1] = x[2]


def dc_motor_plant(x0: Sequence[float] = (0.0, 0.0, X3_REST), a: float = 0.1, b: float = 0.1,
                   c: float = 2.0, d: float = 0.2, e: float = 200.0) -> Plant:
    """The motor (38)-(39) with initial state x0 = [x1(0), x2(0), x3(0)].

    The default x0 is the paper's x1(0) = x2(0) = 0 with x3(0) = 100 A (rest equilibrium).
    """
    if len(x0) != 3:
        raise ValueError(f"plant.x0 must have 3 entries [x1, x2, x3], got {list(x0)}")
    for key, value in (("a", a), ("b", b), ("c", c), ("d", d)):
        if not value > 0:
            raise ValueError(f"plant.{key} must be > 0, got {value}")
    # Jacobian at u = 0 has eigenvalues {0, -a, -c}: the plant is far from stiff next to
    # any high-gain observer (|u| = 10 adds only O(sqrt(b d) |u|) ~ 1.4).
    return Plant(name="dc_motor", state_names=["x1", "x2", "x3"], output_names=["y", "x3"],
                 input_names=["u"], x0=np.asarray(x0, float),
                 p=Params(a=a, b=b, c=c, d=d, e=e), f=f, h=h, output_state=0,
                 spectral_radius=max(a, c))
