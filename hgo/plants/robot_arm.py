"""Single-link robot arm in a vertical plane, Dimassi et al. (24)-(25).

    I q'' + (1/2) m g l sin q = u,   x = [q, q'],   y = q,
    x1' = x2,   x2' = -theta2 sin(y) + theta1 u,   theta1 = 1/I,  theta2 = m g l / (2 I),

with I the moment of inertia (kg m^2), m the mass (kg), g gravity (m/s^2), l the length
(m), u the torque (N m), q in rad. Paper values: I = 0.5, m = 1, g = 9.81, l = 1, so
theta = (2, 9.81); x(0) = (1, 1).

``outputs``: ``"y"`` (the paper: y = x1) or ``"Hx"`` (y = [x1, x2], the auxiliary outputs
z = Hx of Dimassi et al. Sec. IV with H = I: only for the diagnostic "ideal z_h" run of the
cascade observer, ``observer.*.hgo: ideal``; not in the paper).

Parameters (by name): I, m, g, l; constant n_out (the number of outputs).
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np

from hgo.core.components import Params, Plant

OUTPUTS = {"y": ["y"], "Hx": ["y", "x2"]}


def f(t, x, u, p, dx):
    """Dimassi et al. (24): I q'' = u - (1/2) m g l sin q."""
    dx[0] = x[1]
    dx[1] = (u[0] - 0.5 * p.m * p.g * p.l * math.sin(x[0])) / p.I


def h(t, x, p, y):
    """y = x1 (and x2 when ``outputs == "Hx"``)."""
    y[0] = x[0]
    if p.n_out > 1:
        y[1] = x[1]


def true_parameters(p) -> np.ndarray:
    """theta = [1/I, m g l / (2 I)] of Dimassi et al. (25) (regressor order A1: [u, -sin y])
    from the plant's parameters ``p`` (its ``p``, by name)."""
    return np.array([1.0 / p.I, p.m * p.g * p.l / (2.0 * p.I)])


def dimassi_psi(x, u, out):
    """psi(x, u) = [u, -sin x1] (1 x 2) of Dimassi et al. (25), regressor order A1, so that
    x2' = psi(x, u) theta with theta = (1/I, m g l/(2 I)): the robot arm's instance of the
    cascade observer's class (:mod:`hgo.observers.adaptive_cascade`)."""
    out[0, 0] = u[0]
    out[0, 1] = -math.sin(x[0])


def robot_arm_plant(x0: Sequence[float] = (1.0, 1.0), I: float = 0.5, m: float = 1.0,  # noqa: E741
                    g: float = 9.81, l: float = 1.0, outputs: str = "y") -> Plant:  # noqa: E741
    """The arm (24)-(25) with x(0) = x0 = [q(0), q'(0)] (paper: [1, 1])."""
    if len(x0) != 2 or not all(math.isfinite(v) for v in x0):
        raise ValueError(f"plant.x0 must be 2 finite numbers [q, q'], got {list(x0)}")
    for key, value in (("I", I), ("m", m), ("g", g), ("l", l)):
        if not (math.isfinite(value) and value > 0):
            raise ValueError(f"plant.{key} must be in (0, inf), got {value}")
    if outputs not in OUTPUTS:
        raise ValueError(f"plant.outputs must be one of {sorted(OUTPUTS)}, got '{outputs}'")
    names = OUTPUTS[outputs]
    # linearisation: eigenvalues +-sqrt(m g l / (2 I)) (i at the bottom): far from stiff
    return Plant(name="robot_arm", state_names=["x1", "x2"], output_names=names,
                 input_names=["u"], x0=np.asarray(x0, float),
                 p=Params({"n_out": len(names)}, I=I, m=m, g=g, l=l), f=f, h=h, output_state=0,
                 spectral_radius=math.sqrt(m * g * l / (2 * I)))
