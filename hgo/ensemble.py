"""Helpers for ensembles: many parameter sets and initial states of one composed system.

:func:`hgo.engine.simulate.simulate_ensemble` takes one row of parameters and one initial
state per member. :func:`stack_members` builds those rows from systems built member by
member (e.g. one observer per drawn p2), checking that every member has the same
layout (the same compiled kernel serves them all).
"""

from __future__ import annotations

import numpy as np

from hgo.engine.system import System


def _layout(system: System) -> tuple:
    plant = system.plant
    funcs = (plant.f, plant.h) + tuple((o.f, o.update, o.estimate) for o in system.observers)
    ctrl = None if system.controller is None else system.controller.u
    return (funcs, ctrl, tuple(system.z_slices), tuple(system.d_slices),
            tuple(system.p_slices), tuple(system.xh_slices), len(plant.output_names),
            len(plant.input_names), tuple(system.estimate_map().tolist()))


def stack_members(systems: list[System]) -> tuple[np.ndarray, np.ndarray]:
    """(params (M, n_p), z0 (M, n_z)) of members that share one layout.

    Raises ValueError naming the first member whose components or sizes differ from
    member 0's.
    """
    if not systems:
        raise ValueError("ensemble: at least one member is required")
    ref = _layout(systems[0])
    for i, s in enumerate(systems[1:], start=1):
        if _layout(s) != ref:
            raise ValueError(f"ensemble member {i} has a different layout (components or "
                             "state/parameter sizes) than member 0; members may differ "
                             "only in parameter values and initial states")
    params = np.stack([s.params() for s in systems])
    z0 = np.stack([s.z0() for s in systems])
    return params, z0
