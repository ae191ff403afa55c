"""Checks of a composed config before any integration (:func:`hgo.running.runner.build` calls them).

* :func:`check_values`: every numeric value of the config is a number (no NaN), finite
  unless its key means "no limit" when infinite (``INF_ALLOWED``), and the top-level keys
  have their types (``seed`` a non-negative int, ``run_name`` a plain name, ``resume`` a
  bool, ``ensemble.size`` >= 0).
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


def check_top(container: Mapping) -> None:
    """``seed``, ``run_name`` and ``ensemble.size``/``ensemble.seed``."""
    _check_int("seed", container.get("seed", 0))
    name = container.get("run_name", "run")
    if not isinstance(name, str) or not _RUN_NAME.match(name):
        raise ConfigError("run_name", f"must be a plain name, got {name!r}",
                          "letters, digits and _ . + = , -")
    if not isinstance(container.get("resume", False), bool):
        raise ConfigError("resume", f"must be true or false, got {container['resume']!r}")
    ens = container.get("ensemble") or {}
    _check_int("ensemble.size", ens.get("size", 0))
    _check_int("ensemble.seed", ens.get("seed", 0))


def check_values(cfg: DictConfig) -> dict:
    """All value checks of the composed config; returns it resolved (without ``hydra``)."""
    container = job_container(cfg)
    check_numbers(container)
    check_top(container)
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
