"""Plants in observability normal form (issue 24, item 4):

    x1' = x2,  ...,  x(n-1)' = xn,  xn' = phi0(x, u, p),   y = x1 (+ noise),

``phi0`` a function of the state, the inputs and the plant's named parameters (``p.mu``),
the same function the observers of :mod:`hgo.observers.normal_form` take as their model.
Instances: :mod:`hgo.plants.van_der_pol`, :mod:`hgo.plants.jerk`.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence

import numpy as np

from hgo.core.components import Params, Plant


def f(t, x, u, p, dx):
    """The chain of integrators closed by phi0."""
    for i in range(p.n - 1):
        dx[i] = x[i + 1]
    dx[p.n - 1] = p.phi0(x, u, p)


def h(t, x, p, y):
    """y = x1 (before noise)."""
    y[0] = x[0]


def normal_form_plant(name: str, phi0: Callable, x0: Sequence[float],
                      inputs: Sequence[str] = (), spectral_radius: float = 0.0,
                      **values: float) -> Plant:
    r"""A plant in observability normal form, of order $n$ = ``len(x0)``:

    $$\dot x_i = x_{i+1}\ (i < n), \qquad \dot x_n = \varphi_0(x, u, p), \qquad y = x_1 .$$

    Args:
        name: the plant's name.
        phi0: ``phi0(x, u, p) -> float`` (numba-compilable; reads ``p.<name>`` of
            ``values``); the same function the observers of
            :mod:`hgo.observers.normal_form` take as their model.
        x0: $x(0)$, $n \ge 2$ finite numbers; states ``x1`` ... ``x<n>``.
        inputs: the names of the inputs $u$ (default none).
        spectral_radius: a bound on $|\lambda(\partial f/\partial x)|$ (1/s) for RK4.
        **values: the named run-time parameters ``phi0`` reads (``mu=1.0``).

    Example:
        ```python
        import numba
        from hgo.plants.normal_form import normal_form_plant

        @numba.njit
        def duffing(x, u, p):  # x2' = -d x2 - a x1 - b x1^3 + u
            return -p.d * x[1] - p.a * x[0] - p.b * x[0] ** 3 + u[0]

        plant = normal_form_plant("duffing", duffing, x0=[1.0, 0.0], inputs=["u"],
                                  d=0.2, a=1.0, b=1.0)
        print(plant.state_names, plant.p.b)  # ['x1', 'x2'] 1.0
        ```
    """
    x0 = np.asarray(x0, float).reshape(-1)
    n = x0.size
    if n < 2 or not np.all(np.isfinite(x0)):
        raise ValueError(f"plant.x0 must have n >= 2 finite entries, got {x0.tolist()}")
    return Plant(name=name, state_names=[f"x{i + 1}" for i in range(n)], output_names=["y"],
                 input_names=list(inputs), x0=x0,
                 p=Params({"n": n, "phi0": phi0}, **values), f=f, h=h, output_state=0,
                 spectral_radius=spectral_radius)
