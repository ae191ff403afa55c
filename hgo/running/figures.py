"""A run's figures: the ``figures`` mapping of its config (name -> ``_target_``), checked
before the run and drawn from its :class:`hgo.running.runner.RunResult` (in the run's
process, or in the figure process of :mod:`hgo.running.figure_worker`)."""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING

from hydra.utils import instantiate
from omegaconf import DictConfig

if TYPE_CHECKING:
    from hgo.running.results import RunResult

FIGURE_SETTINGS = ("format", "dpi")  # keys of the ``figures`` node that are not figures
FORMATS = ("png", "pdf", "svg")  # of ``figures.format``


def figure_settings(cfg: DictConfig) -> tuple[str, float]:
    """``figures.format`` and ``figures.dpi``, checked (before any integration)."""
    node = cfg.get("figures") or {}
    fmt, dpi = node.get("format", "png"), node.get("dpi", 110)
    if fmt not in FORMATS:
        raise ValueError(f"figures.format: '{fmt}' not in {list(FORMATS)}")
    if not (isinstance(dpi, int | float) and 10 <= dpi <= 1200):
        raise ValueError(f"figures.dpi must be a number in [10, 1200], got {dpi}")
    return fmt, float(dpi)


def figure_nodes(cfg: DictConfig) -> dict:
    """The figures of the ``figures`` mapping (name -> ``_target_`` node); a preset drops
    an inherited figure with ``figures.<name>: null``."""
    return {name: node for name, node in (cfg.get("figures") or {}).items()
            if node is not None and name not in FIGURE_SETTINGS}


def draw_figures(cfg: DictConfig, result: RunResult) -> list[Path]:
    """Figures of the ``figures`` mapping (name -> ``_target_`` taking the result and a
    path), written as ``<name>.<figures.format>`` at ``figures.dpi``."""
    import matplotlib.pyplot as plt

    import hgo.outputs.figures  # noqa: F401  (hgo's style and the Agg backend)

    fmt, dpi = figure_settings(cfg)
    paths = []
    for name, node in figure_nodes(cfg).items():
        path = result.out_dir / f"{name}.{fmt}"
        with plt.rc_context({"savefig.dpi": dpi, "figure.dpi": dpi}):  # (see figures.STYLE)
            instantiate(node, _partial_=True)(result, path)
        paths.append(path)
    return paths
