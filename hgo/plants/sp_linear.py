"""Sanfelice & Praly (18): the linear plant of the numerical example.

    dx1/dt = x2 + nu1*x1 + nu2,   dx2/dt = 0,   y = x1 (+ noise m).

nu1 is known to the observer, nu2 plays the unmodelled dynamics; x = [-nu2/nu1, 0] is an
equilibrium. In the form (3), F(x) = [nu1*x1 + nu2, 0], so Lemma 2.1 holds with
gamma = [nu2, 0] and L = [nu1, 0] against the model F^(x^) = [nu1*x^1, 0].
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from hgo.core.components import Params, Plant


def f(t, x, u, p, dx):
    """Sanfelice & Praly (18); parameters nu1, nu2."""
    dx[0] = x[1] + p.nu1 * x[0] + p.nu2
    dx[1] = 0.0


def h(t, x, p, y):
    """y = x1 before noise."""
    y[0] = x[0]


def sp_linear_plant(nu1: float = 0.01, nu2: float = 0.01,
                    x0: Sequence[float] = (-1.0, 0.0)) -> Plant:
    """The plant (18) with parameters nu1, nu2 and initial state x0 = [x1(0), x2(0)]."""
    if len(x0) != 2:
        raise ValueError(f"plant.x0 must have 2 entries [x1, x2], got {list(x0)}")
    return Plant(name="sp_linear", state_names=["x1", "x2"], output_names=["y"],
                 input_names=[], x0=np.asarray(x0, float), p=Params(nu1=nu1, nu2=nu2),
                 f=f, h=h, output_state=0, spectral_radius=abs(nu1))


def mismatch_constants(nu1: float, nu2: float) -> tuple[np.ndarray, np.ndarray]:
    """Lemma 2.1 constants (gamma, L) of (18) against the model [nu1*x^1, 0]."""
    return np.array([abs(nu2), 0.0]), np.array([abs(nu1), 0.0])
