"""Helpers for ensembles: many parameter sets and initial states of one composed system.

:func:`hgo.engine.simulate.simulate_ensemble` takes one row of parameters and one initial
state (continuous and discrete) per member. :func:`stack_members` builds those rows from
systems built member by member (e.g. one observer per drawn p2), checking that every
member has the same layout (the same compiled kernel serves them all).
"""

from __future__ import annotations

import copy
from collections.abc import Mapping
from dataclasses import replace
from typing import Any

import numpy as np
from omegaconf import DictConfig, OmegaConf

from hgo.engine.system import System
from hgo.errors import as_floats


def _layout(system: System) -> tuple:
    """What the compiled kernel depends on: component functions (stiffness hooks and the
    observer the controller reads included) and sizes, not parameter values."""
    plant = system.plant
    funcs = (plant.f, plant.h) + tuple((o.f, o.update, o.estimate, o.stiffness)
                                       for o in system.observers)
    ctrl = None if system.controller is None else (system.controller.u,
                                                   system.controlled_observer())
    return (funcs, ctrl, tuple(system.z_slices), tuple(system.d_slices),
            tuple(system.p_slices), tuple(system.xh_slices), len(plant.output_names),
            len(plant.input_names), tuple(system.estimate_map().tolist()))


def stack_members(systems: list[System]) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(params (M, n_p), z0 (M, n_z), d0 (M, n_d)) of members that share one layout.

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
    d0 = np.stack([s.d0() for s in systems])
    return params, z0, d0


def stiffest_envelope(systems: list[System]) -> System:
    """Member 0 with each component's ``spectral_radius`` raised to its largest over members.

    One call of the ensemble kernel caps every member's RK4 steps with the constant spectral
    radii of the system it is given: member 0's alone would let a stiffer member (e.g. a
    larger drawn ``|nu1|``) step past RK4's stability limit. Only the step cap changes.
    """
    ref = systems[0]
    plant = replace(ref.plant, spectral_radius=max(s.plant.spectral_radius for s in systems))
    observers = [replace(o, spectral_radius=max(s.observers[k].spectral_radius for s in systems))
                 for k, o in enumerate(ref.observers)]
    return System(plant, observers, ref.controller)


# --- ensembles from a Hydra config (``ensemble.size > 0``) ------------------------------

def draw_members(vary: Mapping[str, Any], size: int, seed: int) -> dict[str, np.ndarray]:
    """Uniform draws per member: ``key: [low, high]`` gives (size,), ``key: [[l, h], ...]``
    gives (size, k) for a vector parameter (e.g. an initial state)."""
    rng = np.random.default_rng(seed)
    draws = {}
    for key, spec in vary.items():
        bounds = as_floats(f"ensemble.vary.{key}", spec)
        if bounds.shape == (2,):
            low, high = bounds
        elif bounds.ndim == 2 and bounds.shape[1] == 2:
            low, high = bounds[:, 0], bounds[:, 1]
        else:
            raise ValueError(f"ensemble.vary.{key}: expected [low, high] or a list of "
                             f"[low, high] pairs, got {spec}")
        if np.any(np.asarray(high) < np.asarray(low)):
            raise ValueError(f"ensemble.vary.{key}: high < low in {spec}")
        draws[key] = rng.uniform(low, high, size=(size, *np.shape(low)))
    return draws


def _set(tree: dict, dotted: str, value: Any) -> None:
    *path, leaf = dotted.split(".")
    node = tree
    for part in path:
        if not isinstance(node, dict) or part not in node:
            raise ValueError(f"ensemble.vary: '{dotted}' is not a key of the config")
        node = node[part]
    if leaf not in node:
        raise ValueError(f"ensemble.vary: '{dotted}' is not a key of the config")
    node[leaf] = value.tolist() if isinstance(value, np.ndarray) else float(value)


def _interpolated_keys(cfg: DictConfig, keys: list[str]) -> list[str]:
    """Varied keys that other entries of the config interpolate (``${key}``)."""
    text = OmegaConf.to_yaml(cfg)
    return [k for k in keys if "${" + k + "}" in text]


def member_nodes(cfg: DictConfig, draws: dict[str, np.ndarray]) -> list[Mapping]:
    """The component nodes (plant, observer, controller) of every member.

    Fast path: resolve the config once and set the drawn values in plain copies. If
    another entry interpolates a varied key (``M: [[${plant.nu1}, 0], ...]``), every
    member is re-resolved so the interpolation follows the drawn value.
    """
    groups = ("plant", "observer", "controller")
    size = len(next(iter(draws.values()))) if draws else 0
    job = OmegaConf.create({k: cfg[k] for k in cfg if k != "hydra"})
    linked = _interpolated_keys(job, list(draws))
    base = OmegaConf.to_container(job, resolve=not linked)
    members = []
    for i in range(size):
        tree = copy.deepcopy(base)
        for key, values in draws.items():
            _set(tree, key, values[i])
        if linked:
            tree = OmegaConf.to_container(OmegaConf.create(tree), resolve=True)
        members.append({g: tree.get(g) for g in groups})
    return members
