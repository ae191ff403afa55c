"""Van der Pol oscillator (mu named), observed by hgo's standard high-gain observer:

    x1' = x2,   x2' = mu (1 - x1^2) x2 - x1,   y = x1 (+ noise).
"""

import numpy as np

from hgo.core.components import Params, Plant


def f(t, x, u, p, dx):
    dx[0] = x[1]
    dx[1] = p.mu * (1.0 - x[0] ** 2) * x[1] - x[0]


def h(t, x, p, y):
    y[0] = x[0]


def phi0(x, u, p):
    """The observer's model of x2' (here the plant's own; p.mu is the observer's mu)."""
    return p.mu * (1.0 - x[0] ** 2) * x[1] - x[0]


def make_vdp(mu: float = 1.0, x0: tuple = (2.0, 0.0)) -> Plant:
    return Plant(name="vdp", state_names=["x1", "x2"], output_names=["y"], input_names=[],
                 x0=np.asarray(x0, float), p=Params(mu=mu), f=f, h=h)
