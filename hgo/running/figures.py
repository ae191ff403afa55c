"""A run's figures: the ``figures`` mapping of its config (name -> ``_target_``), checked
before the run and drawn from its :class:`hgo.running.runner.RunResult` (in the run's
process, or in the figure process of :mod:`hgo.running.figure_worker`)."""

from __future__ import annotations

import ast
import dataclasses
import importlib.util
from collections.abc import Mapping
from pathlib import Path
from typing import TYPE_CHECKING

from omegaconf import DictConfig

from hgo.core import targets
from hgo.core.errors import ConfigError

if TYPE_CHECKING:
    from hgo.running.results import RunResult

FIGURE_SETTINGS = ("format", "dpi", "vector")  # keys of ``figures`` that are not figures
FORMATS = ("png", "pdf", "svg")  # of ``figures.format``
VECTOR_FORMATS = ("pdf", "svg")  # of ``figures.vector``


def figure_settings(cfg: DictConfig) -> tuple[str, float]:
    """``figures.format`` and ``figures.dpi``, checked with ``figures.vector`` (before
    any integration)."""
    node = cfg.get("figures") or {}
    fmt, dpi = node.get("format", "png"), node.get("dpi", 110)
    if fmt not in FORMATS:
        raise ValueError(f"figures.format: '{fmt}' not in {list(FORMATS)}")
    vector = node.get("vector")
    if vector is not None and vector not in VECTOR_FORMATS:
        raise ValueError(f"figures.vector: '{vector}' not in {list(VECTOR_FORMATS)} or null")
    if not (isinstance(dpi, int | float) and 10 <= dpi <= 1200):
        raise ValueError(f"figures.dpi must be a number in [10, 1200], got {dpi}")
    return fmt, float(dpi)


def figure_nodes(cfg: DictConfig) -> dict:
    """The figures of the ``figures`` mapping (name -> ``_target_`` node); a preset drops
    an inherited figure with ``figures.<name>: null``."""
    return {name: node for name, node in (cfg.get("figures") or {}).items()
            if node is not None and name not in FIGURE_SETTINGS}


def _static_parameters(target: str) -> tuple[list[str], bool] | None:
    """Parameter names of the module-level function ``target`` names and whether it takes
    ``**kwargs``, read from its source without importing the module (a paper's figures
    import matplotlib, which a run's process does not load); None when not found so."""
    module, _, name = str(target).rpartition(".")
    try:
        spec = importlib.util.find_spec(module)
        source = Path(spec.origin).read_text() if spec and spec.origin else None
    except (ImportError, ValueError, OSError):
        return None
    if not source or not str(spec.origin).endswith(".py"):
        return None
    for node in ast.parse(source).body:
        if isinstance(node, ast.FunctionDef) and node.name == name:
            a = node.args
            return ([x.arg for x in (*a.posonlyargs, *a.args, *a.kwonlyargs)],
                    a.kwarg is not None)
    return None


def check_figures(cfg: DictConfig) -> None:
    """Every figure is a ``_target_`` node whose keys its function takes (after the result
    and the path), checked before the run: a bad keyword failed only after the whole run,
    ``+figures.foo=1`` was accepted."""
    for name, node in figure_nodes(cfg).items():
        if not isinstance(node, Mapping) or "_target_" not in node:
            raise ConfigError(f"figures.{name}", "must be a figure node with a _target_ "
                              f"(or null to drop it), got {str(node)[:60]!r}")
        targets.check_text(node["_target_"], f"figures.{name}._target_")  # (imports nothing)
        found = _static_parameters(node["_target_"])
        if found is None:
            continue
        params, any_keyword = found
        for key in node:
            if not str(key).startswith("_") and key not in params[2:] and not any_keyword:
                raise ConfigError(f"figures.{name}.{key}", "is not a parameter of "
                                  f"{node['_target_']}", ", ".join(params[2:]) or "none")


def draw_figures(cfg: DictConfig, result: RunResult,
                 names: list[str] | None = None) -> list[Path]:
    """Figures of the ``figures`` mapping (name -> ``_target_`` taking the result and a
    path; ``names``: only those), written as ``<name>.<figures.format>`` at ``figures.dpi``
    (and also as ``<name>.<figures.vector>`` when set)."""
    nodes = {name: node for name, node in figure_nodes(cfg).items()
             if names is None or name in names}
    if not nodes:  # (a run without figures does not import matplotlib: ~0.5 s)
        return []
    import matplotlib.pyplot as plt

    from hgo.outputs.figures import also_saved_as  # (and hgo's style, the Agg backend)
    from hgo.outputs.recording import materialized

    fmt, dpi = figure_settings(cfg)
    vector = (cfg.get("figures") or {}).get("vector")
    # figure functions get arrays (a run's derived series are computed when read)
    result = dataclasses.replace(result, series=materialized(result.series))
    paths = []
    for name, node in nodes.items():
        path = result.out_dir / f"{name}.{fmt}"
        with plt.rc_context({"savefig.dpi": dpi, "figure.dpi": dpi}), also_saved_as(vector):
            figure = targets.instantiate(node, f"figures.{name}", _partial_=True)
            figure(result, path)  # (rc: see figures.STYLE)
        paths.append(path)
    return paths
