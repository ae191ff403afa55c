"""A plant's own equations inside an observer (the Kalman filters): the plant's parameters
in the observer's record, its f and h, its Jacobians.

The observer's parameter record holds the plant's named parameters under their own names
(run-time values copied from the built plant, constants as they are, functions included)
next to the observer's own, which are all prefixed ``kf_`` so that none can shadow a
plant's. The plant's ``f(t, x, u, p, dx)`` and ``h(t, x, p, y)``, called with the
observer's record as ``p``, then read ``p.mu`` as in the plant; they are constants of
the record (``p.kf_f``, ``p.kf_h``), compiled into the observer's kernel functions
(:mod:`hgo.engine.codegen`: functions among a component's constants). A sweep or an
ensemble that varies a plant parameter builds the observer again from the new plant
(:func:`hgo.running.runner.plant_argument`), so the copy follows the plant.

Jacobians A = df/dx and C = dh/dx: the plant's ``jac_f(t, x, u, p, J)`` and
``jac_h(t, x, p, C)`` when it has them (a hand-written plant's, or a symbolic plant's
derivatives), otherwise central differences

    A[:, j] = (f(x + s_j e_j) - f(x - s_j e_j)) / (2 s_j),   s_j = FD_STEP * max(1, |x_j|),

with FD_STEP = eps^(1/3) ~ 6.1e-6 (eps the float64 machine epsilon): the step that
balances the truncation error (~ s^2 |f'''| / 6) and the rounding error (~ eps |f| / s),
both then ~ eps^(2/3) ~ 4e-11 relative (tests/test_kalman.py measures it on Van der Pol).
"""

from __future__ import annotations

import numpy as np

from hgo.core.components import Params, Plant
from hgo.engine.jit import record_helper

FD_STEP = float(np.finfo(float).eps ** (1.0 / 3.0))


def no_jac_f(t, x, u, p, J) -> None:  # noqa: ARG001 - the signature of jac_f
    """The plant has no jac_f (never called: ``p.kf_has_jac_f`` is False)."""
    return


def no_jac_h(t, x, p, C) -> None:  # noqa: ARG001 - the signature of jac_h
    """The plant has no jac_h (never called: ``p.kf_has_jac_h`` is False)."""
    return


@record_helper
def jacobian_f(t, x, u, p, J, xw, fp, fm):
    """J = df/dx at (t, x, u): the plant's jac_f, else central differences (module doc);
    xw, fp, fm: work vectors of n entries."""
    n = p.kf_nx
    for i in range(n):
        for j in range(n):
            J[i, j] = 0.0
    if p.kf_has_jac_f:
        p.kf_jac_f(t, x, u, p, J)
        return
    for j in range(n):
        xw[j] = x[j]
    for j in range(n):
        s = FD_STEP * max(1.0, abs(x[j]))
        xw[j] = x[j] + s
        p.kf_f(t, xw, u, p, fp)
        hi = xw[j]
        xw[j] = x[j] - s
        p.kf_f(t, xw, u, p, fm)
        width = hi - xw[j]  # (the step actually taken, after rounding x_j +- s)
        xw[j] = x[j]
        for i in range(n):
            J[i, j] = (fp[i] - fm[i]) / width


@record_helper
def jacobian_h(t, x, p, C, xw, yp, ym):
    """C = dh/dx at (t, x): the plant's jac_h, else central differences (module doc);
    xw: n entries, yp, ym: m entries of work space."""
    n, m = p.kf_nx, p.kf_ny
    for i in range(m):
        for j in range(n):
            C[i, j] = 0.0
    if p.kf_has_jac_h:
        p.kf_jac_h(t, x, p, C)
        return
    for j in range(n):
        xw[j] = x[j]
    for j in range(n):
        s = FD_STEP * max(1.0, abs(x[j]))
        xw[j] = x[j] + s
        p.kf_h(t, xw, p, yp)
        hi = xw[j]
        xw[j] = x[j] - s
        p.kf_h(t, xw, p, ym)
        width = hi - xw[j]
        xw[j] = x[j]
        for i in range(m):
            C[i, j] = (yp[i] - ym[i]) / width


def model_params(plant: Plant, key: str, work: int, constants: dict,
                 values: dict) -> Params:
    """The observer's parameters: the plant's (module doc) and the observer's own
    ``constants`` and ``values`` (names starting with ``kf_``), with ``work`` floats of
    scratch space after the plant's own (``p.kf_work``: where the observer's starts)."""
    spec = plant.params
    if spec is None:
        raise ValueError(f"{key}: plant {plant.name} has positional parameters (p[i]); the "
                         "Kalman filters call its f and h with named ones "
                         "(hgo.core.components.Params)")
    taken = sorted(k for k in [*spec.names, *spec.constants] if k.startswith("kf_"))
    if taken:
        raise ValueError(f"{key}: plant {plant.name} has parameters {taken} named like the "
                         "filter's own (kf_...); rename them")
    plant_scratch = int(spec.constants.get("scratch", 0))
    plant_constants = {k: v for k, v in spec.constants.items() if k != "scratch"}
    plant_values = {k: np.array(spec.get(plant.p, k), float) for k in spec.names}
    model = {"kf_f": plant.f, "kf_h": plant.h,
             "kf_jac_f": plant.jac_f or no_jac_f, "kf_jac_h": plant.jac_h or no_jac_h,
             "kf_has_jac_f": plant.jac_f is not None, "kf_has_jac_h": plant.jac_h is not None,
             "kf_nx": plant.nx, "kf_ny": len(plant.output_names),
             "kf_nu": len(plant.input_names), "kf_work": plant_scratch,
             "scratch": plant_scratch + work}
    return Params({**plant_constants, **model, **constants}, **plant_values, **values)
