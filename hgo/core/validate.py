"""Checks of a composed config before any integration (:func:`hgo.running.runner.build` calls them).

* :func:`check_values`: every numeric value of the config is a number (no NaN), finite
  unless its key means "no limit" when infinite (``INF_ALLOWED``), and the top-level keys
  have their types (``seed`` a non-negative int, ``run_name`` a plain name, ``resume`` a
  bool, ``ensemble.size`` >= 0), and every ``_target_`` passes the allowlist
  (:mod:`hgo.core.targets`).
* :func:`check_cost`: the output rows, noise samples and integration steps of the run,
  estimated up front, stay under ``solver.max_output_rows`` / ``solver.max_steps`` and
  the machine's free memory; the message gives the estimate and the keys to change.

Component-specific ranges are checked by each builder; cross-component checks (observer
and controller against the plant) by :class:`hgo.engine.system.System`.
"""

from __future__ import annotations

import math
import os
import re
from collections.abc import Mapping

from omegaconf import DictConfig, OmegaConf

from hgo.core.errors import ConfigError
from hgo.core.targets import check_targets

#: Leaf keys where ``inf`` is meaningful ("no limit"): they may be infinite, never NaN.
INF_ALLOWED = {"u_max", "saturation", "state_bound", "h_max"}
_RUN_NAME = re.compile(r"^[A-Za-z0-9_.+=,-]+$")
BYTES_PER_VALUE = 8


def job_container(cfg: DictConfig) -> dict:
    """The resolved config without Hydra's node (interpolation errors name their key)."""
    job = OmegaConf.create({k: cfg._get_node(k) for k in cfg if k != "hydra"})
    return OmegaConf.to_container(job, resolve=True)


def _walk(node, prefix: str):
    if isinstance(node, Mapping):
        for k, v in node.items():
            yield from _walk(v, f"{prefix}.{k}" if prefix else str(k))
    elif isinstance(node, list):
        for i, v in enumerate(node):
            yield from _walk(v, f"{prefix}[{i}]")
    else:
        yield prefix, node


def _leaf(key: str) -> str:
    return re.sub(r"\[\d+\]", "", key).rsplit(".", 1)[-1]


def check_numbers(container: Mapping) -> None:
    """No NaN anywhere; no infinity except under ``INF_ALLOWED`` keys (+inf only)."""
    for key, value in _walk(container, ""):
        if isinstance(value, float) and not math.isfinite(value):
            if math.isnan(value):
                raise ConfigError(key, "must be a number, got nan")
            if not (_leaf(key) in INF_ALLOWED and value > 0):
                raise ConfigError(key, f"must be finite, got {value}",
                                  "+inf only for " + ", ".join(sorted(INF_ALLOWED)))


def _check_int(key: str, value, low: int = 0) -> None:
    if isinstance(value, bool) or not isinstance(value, int):
        raise ConfigError(key, f"must be an integer, got {value!r}", f"integers >= {low}")
    if not low <= value < 2 ** 63:
        raise ConfigError(key, f"must be >= {low}, got {value}", f"integers >= {low}")


def check_run_name(name) -> None:
    """``run_name`` is a folder name under ``outputs/``, never a path (``..``, ``a/b``)."""
    if not isinstance(name, str) or not _RUN_NAME.match(name) or set(name) == {"."}:
        raise ConfigError("run_name", f"must be a plain name, not a path, got {name!r}",
                          "letters, digits and _ . + = , - (not only dots)")


def check_top(container: Mapping) -> None:
    """``seed``, ``run_name`` and ``ensemble.size``/``ensemble.seed``."""
    _check_int("seed", container.get("seed", 0))
    check_run_name(container.get("run_name", "run"))
    if not isinstance(container.get("resume", False), bool):
        raise ConfigError("resume", f"must be true or false, got {container['resume']!r}")
    ens = container.get("ensemble") or {}
    _check_int("ensemble.size", ens.get("size", 0))
    _check_int("ensemble.seed", ens.get("seed", 0))


def _schemas() -> dict:
    from hgo.core.config import EnsembleConf, MetricsConf, RecordingConf, SolverConf

    return {"solver": SolverConf, "metrics": MetricsConf, "ensemble": EnsembleConf,
            "recording": RecordingConf}


def check_known_keys(container: Mapping) -> None:
    """The nodes hgo reads itself (solver, metrics, ensemble, recording) hold only their
    schema's keys: Hydra's ``+``/``++`` skip the schema, so ``+solver.foo=1`` was accepted
    without a word (the other groups' keys are checked by their factories' signatures)."""
    from dataclasses import fields

    for group, schema in _schemas().items():
        node = container.get(group)
        if not isinstance(node, Mapping):
            continue
        allowed = [f.name for f in fields(schema)]
        for key in node:
            if key not in allowed:
                raise ConfigError(f"{group}.{key}", "is not a key of " + group,
                                  ", ".join(allowed))


#: Top-level keys hgo reads; a preset may add others only for its own interpolations
#: (``readings`` in apa_fig2: ``${readings.c3}``).
TOP_LEVEL = ("plant", "observer", "noise", "controller", "postprocess", "solver", "metrics",
             "ensemble", "recording", "figures", "run_name", "resume", "seed", "hydra")


def check_top_level_keys(cfg: DictConfig) -> None:
    """A top-level key that hgo does not read and no entry interpolates (``+foo=1``, a typo
    like ``+sed=3``) did nothing, silently."""
    extra = [k for k in cfg if k not in TOP_LEVEL]
    if not extra:
        return
    text = OmegaConf.to_yaml(OmegaConf.create(
        {k: cfg._get_node(k) for k in cfg if k != "hydra"}), resolve=False)
    for key in extra:
        if "${" + str(key) not in text and key != "experiment":
            raise ConfigError(str(key), "is not a key hgo reads, and nothing in the config "
                              "interpolates it", ", ".join(TOP_LEVEL[:-1]))


def check_package_header(container: Mapping) -> None:
    """An experiment preset without ``# @package _global_`` lands under ``experiment.``,
    where nothing reads it: its values were silently not applied."""
    node = container.get("experiment")
    if isinstance(node, Mapping):
        keys = ", ".join(list(node)[:6])
        raise ConfigError("experiment", f"the preset's values ({keys}) are not applied: its "
                          "file lacks the first line '# @package _global_' (Hydra put them "
                          "under 'experiment.')", "add '# @package _global_' as the first "
                          "line of the preset")


def task_overrides(cfg: DictConfig) -> list[str]:
    """The command line's overrides of the run (Hydra's node or HydraConfig), if known."""
    try:
        from hydra.core.hydra_config import HydraConfig

        if "hydra" in cfg:
            return list(cfg.hydra.overrides.task)
        if HydraConfig.initialized():
            return list(HydraConfig.get().overrides.task)
    except Exception:  # noqa: BLE001 - a config composed without Hydra's node
        pass
    return []


def check_empty_dict_overrides(cfg: DictConfig, container: Mapping) -> None:
    """``ensemble.vary={}`` / ``ensemble.grid={}`` merge nothing (Hydra merges mappings):
    the preset's vary was kept. Refused, pointing at ``=null``, which clears them. (Other
    mappings are left alone: ``figures={}`` is used by sweeps that keep their figures.)"""
    for override in task_overrides(cfg):
        key, _, value = override.lstrip("+~").partition("=")
        if key not in ("ensemble.vary", "ensemble.grid") or value.strip() not in ("{}", "{ }"):
            continue
        node = container
        for part in key.split("."):
            node = node.get(part) if isinstance(node, Mapping) else None
        if isinstance(node, Mapping) and node:
            raise ConfigError(key, f"'{key}={{}}' does not clear it: Hydra merges mappings, "
                              f"so it keeps {', '.join(list(node)[:4])}",
                              f"{key}=null to clear it")


def check_values(cfg: DictConfig) -> dict:
    """All value checks of the composed config; returns it resolved (without ``hydra``)."""
    container = job_container(cfg)
    check_package_header(container)
    check_top_level_keys(cfg)
    check_known_keys(container)
    check_empty_dict_overrides(cfg, container)
    check_numbers(container)
    check_top(container)
    check_targets(container)  # every _target_ allowed before anything is called
    return container


def free_memory() -> int:
    """Bytes of memory available now (physical pages free + reclaimable), or a large value."""
    try:
        with open("/proc/meminfo") as fh:
            info = dict(line.split(":", 1) for line in fh)
        return int(info["MemAvailable"].split()[0]) * 1024
    except (OSError, KeyError, ValueError):
        try:
            return os.sysconf("SC_AVPHYS_PAGES") * os.sysconf("SC_PAGE_SIZE")
        except (ValueError, OSError, AttributeError):
            return 2 ** 62


def check_cost(n_rows: int, n_columns: int, n_noise: int, n_steps: float,
               max_rows: int, max_steps: int, memory: int | None = None) -> None:
    """Reject a run whose estimated size exceeds a limit, before anything is allocated.

    ``n_rows`` output samples of ``n_columns`` values, ``n_noise`` held noise samples,
    ``n_steps`` integration steps (a lower estimate).
    """
    memory = free_memory() if memory is None else memory
    if n_rows > max_rows:
        raise ConfigError("solver.dt_out", f"the run records {n_rows:.3g} output rows "
                          f"(t_end / dt_out), over solver.max_output_rows = {max_rows:.3g}",
                          "raise solver.dt_out, lower solver.t_end or raise "
                          "solver.max_output_rows")
    if n_noise > max_rows:
        raise ConfigError("noise.period", f"the run draws {n_noise:.3g} noise samples "
                          f"(t_end / period), over solver.max_output_rows = {max_rows:.3g}",
                          "raise noise.period or lower solver.t_end")
    need = (n_rows * n_columns + n_noise) * BYTES_PER_VALUE
    if need > memory // 2:
        raise ConfigError("solver.dt_out", f"the run needs ~{need / 2 ** 30:.3g} GiB for "
                          f"{n_rows:.3g} output rows x {n_columns} columns and {n_noise:.3g} "
                          f"noise samples, over half the free memory "
                          f"({memory / 2 ** 30:.3g} GiB)",
                          "raise solver.dt_out or noise.period, or lower solver.t_end")
    if n_steps > max_steps:
        raise ConfigError("solver.max_steps", f"the run takes at least {n_steps:.3g} "
                          f"integration steps, over solver.max_steps = {max_steps:.3g}",
                          "raise solver.h_max (or noise.period, solver.dt_out for rk4), "
                          "lower solver.t_end, or raise solver.max_steps")


#: Memory of one ensemble member beside its noise and trajectory (its config node, System,
#: parameters, metric rows): 4-30 KB measured (sp_ensemble 4.1 KB, ak_tradeoff_grid
#: 9.4 KB, sp_fig3_grid 30 KB), so 4 KB is a lower estimate. Building a member took
#: ~0.6 ms (sp_ensemble, 2,000 members in 1.27 s, load ~6).
MEMBER_BYTES = 4096
MEMBER_BUILD_SECONDS = 6e-4


def check_ensemble_cost(n_members: int, member_bytes: int, member_steps: float,
                        max_steps: int, memory: int | None = None,
                        key: str = "ensemble.size") -> None:
    """Refuse an ensemble whose members, estimated before any is made, need more than half
    the free memory or more integration steps in all than ``solver.max_steps``."""
    memory = free_memory() if memory is None else memory
    need = n_members * (MEMBER_BYTES + member_bytes)
    steps = n_members * member_steps
    estimate = (f"the ensemble has {n_members:.4g} members (grid points x ensemble.size, "
                f"then the shard): at least ~{need / 2 ** 30:.3g} GiB, {steps:.3g} "
                f"integration steps and ~{n_members * MEMBER_BUILD_SECONDS:.3g} s to build "
                "the members")
    change = ("lower ensemble.size or shorten the lists of ensemble.grid, or split the "
              "members across jobs with ensemble.shard=i/N")
    if need > memory // 2:
        raise ConfigError(key, f"{estimate}, over half the free memory "
                          f"({memory / 2 ** 30:.3g} GiB)", change)
    if steps > max_steps:
        raise ConfigError(key, f"{estimate}, over solver.max_steps = "
                          f"{max_steps:.3g}", change + ", or raise solver.max_steps")
