"""Helpers for ensembles: many parameter sets and initial states of one composed system.

:func:`hgo.engine.simulate.simulate_ensemble` takes one row of parameters and one initial
state (continuous and discrete) per member. :func:`stack_members` builds those rows from
systems built member by member (e.g. one observer per drawn p2), checking that every
member has the same layout (the same compiled kernel serves them all).
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

import numpy as np
from omegaconf import DictConfig, OmegaConf

from hgo.core.errors import as_floats
from hgo.engine.dry_call import check_user_code
from hgo.engine.system import System
from hgo.running.grid import check_grid, expand_grid, grid_size, shard_indices, shard_size


def _layout(system: System) -> tuple:
    """What the compiled kernel depends on: component functions (stiffness hooks and the
    observer the controller reads included), sizes, and the names, shapes and constants
    of named parameters (constants are literals of the kernel), not parameter values."""
    plant = system.plant
    funcs = (plant.f, plant.h) + tuple((o.f, o.update, o.estimate, o.stiffness)
                                       for o in system.observers)
    ctrl = None if system.controller is None else (system.controller.u,
                                                   system.controlled_observer())
    comps = [plant, *system.observers] + ([system.controller] if system.controller else [])
    names = tuple(None if c.params is None else c.params.layout() for c in comps)
    return (funcs, ctrl, tuple(system.z_slices), tuple(system.d_slices),
            tuple(system.p_slices), tuple(system.xh_slices), len(plant.output_names),
            len(plant.input_names), tuple(system.estimate_map().tolist()), names)


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
            raise ValueError(f"ensemble member {i} has a different layout (components, "
                             "state/parameter sizes or compile-time constants such as a "
                             "dimension or a law) than member 0; members may differ only "
                             "in parameter values and initial states")
    params = np.stack([s.params() for s in systems])
    z0 = np.stack([s.z0() for s in systems])
    d0 = np.stack([s.d0() for s in systems])
    return params, z0, d0


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


GROUPS = ("plant", "observer", "controller", "noise", "postprocess")
"""Config groups a member may differ in: everything one compiled call can vary per member
(the solver and the metrics window are shared by all)."""


def plain_value(value: Any) -> Any:
    if isinstance(value, np.ndarray):
        return value.tolist()
    return value.item() if isinstance(value, np.generic) else value


def _set(tree: dict, dotted: str, value: Any) -> dict:
    """``tree`` with ``dotted`` set to ``value``: the dicts along the path are copied, the
    rest is shared (members differ in a few keys; deep copies cost seconds at 10,000)."""
    *path, leaf = dotted.split(".")
    root = node = dict(tree)
    for part in path:
        if not isinstance(node.get(part), dict):
            raise ValueError(f"ensemble: '{dotted}' is not a key of the config")
        node[part] = node = dict(node[part])
    if leaf not in node:
        raise ValueError(f"ensemble: '{dotted}' is not a key of the config")
    node[leaf] = plain_value(value)
    return root


def check_member_keys(keys: list[str], where: str) -> None:
    """Varied keys must lie in :data:`GROUPS` (or be ``seed``): one ValueError naming the
    first that does not."""
    for key in keys:
        if key != "seed" and key.split(".")[0] not in GROUPS:
            raise ValueError(f"{where}.{key}: only keys under {', '.join(GROUPS)} or 'seed' "
                             "can differ between the members of one compiled call (solver "
                             "and metrics are shared); sweep it with -m instead")


@dataclass
class MemberPlan:
    """What each member sets: ``values[key][i]`` for member i, its noise ``seeds[i]`` and
    its ``index`` in the whole (unsharded) ensemble."""

    values: dict[str, list]
    seeds: list[int]
    index: np.ndarray


def _group(node) -> dict:
    return OmegaConf.to_container(node, resolve=True) if OmegaConf.is_config(node) \
        else dict(node or {})


def check_grid_seeds(grid: Mapping[str, Any]) -> None:
    """``ensemble.grid.seed`` holds integers >= 0 (0.5 and 1.5 were truncated to 0 and 1;
    -1 failed in numpy with "expected non-negative integer")."""
    for value in grid.get("seed") or []:
        if isinstance(value, bool) or not isinstance(value, int) or not 0 <= value < 2 ** 63:
            raise ValueError(f"ensemble.grid.seed: {value!r} is not a seed (allowed: "
                             f"integers >= 0), in {str(grid['seed'])[:80]}")


def member_count(cfg: DictConfig) -> int:
    """Number of members :func:`plan_members` would make (grid points x replicates, then
    the shard), computed without making them."""
    ens = cfg.ensemble
    grid = _group(ens.get("grid"))
    check_grid(grid)
    check_grid_seeds(grid)
    reps = max(int(ens.size), 1 if grid else 0)
    return shard_size(grid_size(grid) * reps, ens.get("shard"))


def plan_members(cfg: DictConfig) -> MemberPlan:
    """Members of ``cfg.ensemble``: grid points x replicates, then the shard.

    ``grid`` (dotted key -> list) gives G points (1 if empty); ``size`` gives R replicates
    per point (R = 1 when 0 and a grid is set). Replicate j draws ``vary`` (less the grid's
    keys: a key on the grid takes its grid values) with
    ``ensemble.seed`` (the same draw j at every grid point: common random numbers) and
    uses noise seed ``seed + j`` (``seed`` from the grid if it varies it, else the
    config's), so a grid of one replicate reproduces the jobs of the same sweep with
    ``-m``. Member index = g * R + j.
    """
    ens = cfg.ensemble
    grid, vary = _group(ens.get("grid")), _group(ens.get("vary"))
    check_member_keys(list(grid), "ensemble.grid")
    check_member_keys(list(vary), "ensemble.vary")
    vary = {k: v for k, v in vary.items() if k not in grid}  # a grid key is not drawn
    points = expand_grid(grid)
    n_points, reps = grid_size(grid), max(int(ens.size), 1 if grid else 0)
    draws = draw_members(vary, reps, int(ens.seed))
    index = shard_indices(n_points * reps, ens.get("shard"))
    g, j = index // reps, index % reps
    values = {k: [v[a] for a in g] for k, v in points.items()}
    values.update({k: [v[b] for b in j] for k, v in draws.items()})
    base = points.get("seed", [int(cfg.seed)] * n_points)
    seeds = [int(base[a]) + int(b) for a, b in zip(g, j, strict=True)]
    values.pop("seed", None)
    return MemberPlan(values, seeds, index)


def _interpolated_keys(cfg: DictConfig, keys: list[str]) -> list[str]:
    """Varied keys that other entries of the config interpolate (``${key}``)."""
    text = OmegaConf.to_yaml(cfg)
    return [k for k in keys if "${" + k + "}" in text]


def member_nodes(cfg: DictConfig, values: Mapping[str, Any]) -> list[Mapping]:
    """The component nodes (:data:`GROUPS`) of every member; ``values[key][i]`` is the
    value of member i (a list or an array, e.g. from :func:`draw_members`).

    Fast path: resolve the config once and set the members' values in plain copies of
    the paths to the varied keys (an unvaried group is the same object in every member,
    which :func:`build_members` builds once). If another entry interpolates a varied key
    (``M: [[${plant.nu1}, 0], ...]``), every member is re-resolved so the interpolation
    follows the member's value.
    """
    size = len(next(iter(values.values()))) if values else 0
    job = OmegaConf.create({k: cfg[k] for k in cfg if k != "hydra"})
    linked = _interpolated_keys(job, list(values))
    if linked:
        base = OmegaConf.to_container(job, resolve=False)
    else:
        base = {g: OmegaConf.to_container(job[g], resolve=True)
                if job.get(g) is not None else None for g in GROUPS}
    members = []
    for i in range(size):
        tree = base
        for key, column in values.items():
            tree = _set(tree, key, column[i])
        if linked:
            tree = OmegaConf.to_container(OmegaConf.create(tree), resolve=True)
        members.append({g: tree.get(g) for g in GROUPS})
    return members


def build_members(nodes: list[Mapping]) -> list[System]:
    """:func:`hgo.running.runner.build_system` of every member, each component built once per
    distinct node object (members share their unvaried groups, :func:`member_nodes`)."""
    from hgo.core.components import Controller, Observer, Plant
    from hgo.running.runner import _instantiate, plant_argument

    built: dict[tuple, Any] = {}

    def once(node, group: str, kind: type, **kwargs):
        # an observer built from the plant is built once per (node, plant) pair
        key = (id(node), *(id(v) for v in kwargs.values() if isinstance(v, Plant)))
        if key not in built:
            built[key] = (node, _instantiate(node, group, kind, **kwargs))
        return built[key][1]

    systems = []
    for n in nodes:
        if not n["observer"]:
            raise ValueError("observer: the config group is empty; choose an observer option")
        plant = once(n["plant"], "plant", Plant)
        observers = [once(node, f"observer.{name}", Observer, name=name,
                          **plant_argument(node, plant))
                     for name, node in n["observer"].items()]
        ctrl = n.get("controller")
        systems.append(System(plant, observers,
                              once(ctrl, "controller", Controller) if ctrl else None))
        check_user_code(systems[-1])  # (once per layout of functions and sizes)
    return systems
