"""Figures of a run, one function per paper figure with signature ``f(result, path)``.

``result`` is :class:`hgo.running.runner.RunResult` (``.experiment.system``, ``.trajectory``,
``.series`` including post-processed series, ``.metrics``); the runner calls each entry of
the ``figures`` config mapping and writes ``<name>.<figures.format>`` in the run directory
(``png`` by default; ``pdf``, ``svg``) at ``figures.dpi``. Matplotlib runs on its
non-interactive Agg backend (no display needed).

One style for every paper (:data:`STYLE`): one colour-blind-safe palette (:data:`PALETTE`,
Okabe & Ito's eight colours), mathematical labels in mathtext (:func:`hat`,
:func:`math_label`), units on every axis, panel letters from :func:`panel_letters`, legends
placed where they hide no data (:func:`legend_below`).

Drawing costs the same for 1e3 or 1e7 samples: :func:`plot_line` draws a signal reduced
to the minimum and maximum of each pixel column of its axes (what the full line would
look like at that width), :func:`plot_band` draws a dense noisy signal as that min/max
band with the column means as its representative line. Only the drawing is reduced:
metrics are computed from the full-rate data before any figure. A transient and a long
horizon share a figure through a split time axis (:func:`split_time`).
"""

from __future__ import annotations

import re
from collections.abc import Iterator, Sequence
from contextlib import contextmanager
from pathlib import Path

import matplotlib
import numpy as np
from matplotlib import cycler  # (matplotlib re-exports it: no extra dependency)

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402

# Okabe & Ito (2008), "Color universal design": distinguishable with every common colour
# vision deficiency; the same names in every paper's figures
PALETTE = {"black": "#000000", "orange": "#E69F00", "sky": "#56B4E9", "green": "#009E73",
           "yellow": "#F0E442", "blue": "#0072B2", "vermillion": "#D55E00",
           "purple": "#CC79A7", "grey": "#7F7F7F"}
CYCLE = [PALETTE[c] for c in ("blue", "vermillion", "green", "orange", "purple", "sky")]
# runs of a sweep on one axes: a colour and a line style each (distinct in grey too)
RUN_STYLES = [{"color": PALETTE["blue"], "ls": "-"}, {"color": PALETTE["vermillion"], "ls": "--"},
              {"color": PALETTE["green"], "ls": "-."}, {"color": PALETTE["orange"], "ls": ":"},
              {"color": PALETTE["purple"], "ls": "-"}]

STYLE = {
    "axes.prop_cycle": cycler(color=CYCLE),
    "font.size": 10, "axes.titlesize": 10, "axes.labelsize": 10, "legend.fontsize": 8,
    "figure.titlesize": 11, "axes.grid": True, "grid.alpha": 0.3, "lines.linewidth": 1.2,
    "legend.loc": "best", "legend.framealpha": 0.85, "savefig.dpi": 110,
    "mathtext.fontset": "dejavusans",
    # figures made at the dpi they are saved at: savefig reuses the text measurements of
    # the layout (tight_layout) instead of measuring every label again (-0.06 s a figure)
    "figure.dpi": 110,
}
plt.rcParams.update(STYLE)


def _share_mathtext_parser() -> None:
    """One mathtext parser for the Agg renderers of a process and thread (the first
    renderer's). Matplotlib gives each renderer its own, and each figure has its own
    renderer; the parser's cache of parsed expressions is keyed by the parser, so every
    figure parsed its labels again (pyparsing: ~10 ms an expression). A parse is a
    function of the expression, dpi, font and hinting only, so a shared cache gives the
    same glyphs: dhlm_example's six figures draw in 2.4-3.2 s of CPU instead of 3.1-4.2 s.
    Per process and thread, as matplotlib keeps its FreeType fonts (a parse holds them):
    a forked figure process must not draw with its parent's fonts (FreeType fails)."""
    import os
    import threading

    from matplotlib.backends import backend_agg

    init = backend_agg.RendererAgg.__init__
    if getattr(init, "hgo_shared", False):
        return
    shared: dict = {}

    def __init__(self, *args, **kwargs) -> None:
        init(self, *args, **kwargs)
        self.mathtext_parser = shared.setdefault((os.getpid(), threading.get_ident()),
                                                 self.mathtext_parser)

    __init__.hgo_shared = True
    backend_agg.RendererAgg.__init__ = __init__


_share_mathtext_parser()

# symbols of config keys and signal names, as mathtext
_GREEK = {"eps": r"\varepsilon", "mu": r"\mu", "sigma": r"\sigma", "delta": r"\delta",
          "theta": r"\theta", "gamma": r"\gamma", "kappa": r"\kappa", "omega": r"\Omega",
          "eta": r"\eta", "alpha": r"\alpha", "nu": r"\nu", "phi": r"\varphi"}


def symbol(name: str) -> str:
    """``p2`` -> ``p_{2}``, ``eps1`` -> ``\\varepsilon_{1}``, ``x1`` -> ``x_{1}`` (mathtext
    body, no dollars); an unknown name is returned in roman."""
    m = re.fullmatch(r"([A-Za-z]+?)_?(\d*)", name)
    if not m:
        return rf"\mathrm{{{name}}}".replace("_", r"\_")
    base, index = m.groups()
    base = _GREEK.get(base, base if len(base) == 1 else rf"\mathrm{{{base}}}")
    return f"{base}_{{{index}}}" if index else base


def hat(name: str) -> str:
    """Estimate of a state: ``x1`` -> ``$\\hat{x}_{1}$``."""
    m = re.fullmatch(r"([A-Za-z]+?)_?(\d*)", name)
    if not m:
        return rf"$\hat{{{symbol(name)}}}$"
    base, index = m.groups()
    base = _GREEK.get(base, base)
    return rf"$\hat{{{base}}}_{{{index}}}$" if index else rf"$\hat{{{base}}}$"


def math_label(key: str, value: object) -> str:
    """A sweep label: ``observer.sign_indefinite.p2``, 3 -> ``$p_{2} = 3$``."""
    text = value if isinstance(value, str) else f"{value:g}"
    leaf = key.rsplit(".", 1)[-1]
    if isinstance(value, str) and not re.fullmatch(r"[-+.\deE]+", value):
        return f"{leaf} = {text}"
    return f"${symbol(leaf)} = {text}$"


def panel_letters(axes) -> None:
    """Mark each axes (in order) with a unique letter (a), (b), ... in its upper left."""
    for k, ax in enumerate(axes):
        ax.text(-0.02, 1.02, f"({chr(ord('a') + k)})", transform=ax.transAxes,
                ha="right", va="bottom", fontweight="bold")


def legend_outside(ax, below: bool = False) -> None:
    """The legend to the right of the axes (or below them), where it hides no data."""
    if below:
        ax.legend(loc="upper center", bbox_to_anchor=(0.5, -0.12), borderaxespad=0.0)
    else:
        ax.legend(loc="upper left", bbox_to_anchor=(1.01, 1.0), borderaxespad=0.0)


_ALSO: list[str] = []  # vector formats save_figure writes beside each figure


@contextmanager
def also_saved_as(vector: str | None) -> Iterator[None]:
    """Inside: :func:`save_figure` also writes ``<path stem>.<vector>`` (``pdf``,
    ``svg``; None: nothing more), the same figure as a vector file for a paper."""
    if vector:
        _ALSO.append(vector)
    try:
        yield
    finally:
        if vector:
            _ALSO.pop()


def save_figure(fig, path: str | Path) -> None:
    """Lay out ``fig``, write it to ``path`` (format from its suffix, dpi from
    ``savefig.dpi``), and as ``<stem>.pdf``/``.svg`` inside :func:`also_saved_as`, then
    close it. Each file is written as ``<path>.partial`` and renamed when complete
    (:func:`hgo.outputs.recording.atomic_output`)."""
    from hgo.outputs.recording import atomic_output

    fig.tight_layout()
    # a figure legend below the axes (legend_below) lies outside the canvas: grow it to
    # the figure's tight box, measured once here for every format (savefig's "tight" lays
    # the figure out once more per file to measure it: ~9 % of drawing a paper's figures
    # as png and pdf). The png is the same, byte for byte; a pdf's box, measured before by
    # the pdf renderer's text metrics, moves by < 1 pt inside its 0.1 in pad.
    extra = {"bbox_inches": fig.get_tightbbox().padded(0.1)} if fig.legends else {}
    path = Path(path)
    targets = [path] + [path.with_suffix(f".{v}") for v in dict.fromkeys(_ALSO)
                        if path.suffix != f".{v}"]
    try:
        for target in targets:
            with atomic_output(target) as partial:
                fig.savefig(partial, format=target.suffix.lstrip(".") or "png", **extra)
    finally:
        plt.close(fig)


def save_png_and_pdf(fig, base: str | Path) -> list[Path]:
    """:func:`save_figure` to ``<base>.png`` and ``<base>.pdf`` (``base`` without suffix);
    the two paths."""
    base = Path(base)
    png = base.with_name(f"{base.name}.png")
    with also_saved_as("pdf"):
        save_figure(fig, png)
    return [png, png.with_suffix(".pdf")]


def legend_below(fig, axes: Sequence | None = None, ncol: int | None = None) -> None:
    """One legend for the whole figure, centred below it (no white gap beside the axes):
    the distinct labels of ``axes`` (default: all), in drawing order."""
    handles: dict[str, object] = {}
    for ax in axes if axes is not None else fig.axes:
        for h, label in zip(*ax.get_legend_handles_labels(), strict=True):
            handles.setdefault(label, h)
    if getattr(fig, "hgo_band", False):
        from matplotlib.patches import Patch

        handles["shaded: min–max of each pixel column, line: its mean"] = Patch(
            color=PALETTE["grey"], alpha=0.35)
    if handles:
        fig.legend(list(handles.values()), list(handles), loc="upper center",
                   bbox_to_anchor=(0.5, 0.02), ncol=ncol or min(3, len(handles)),
                   frameon=False)


def pixel_columns(ax) -> int:
    """The width of ``ax`` in pixels at the figure's dpi (at least 100)."""
    fig = ax.figure
    return max(100, int(ax.get_position().width * fig.get_figwidth() * fig.dpi))


def _window(t: np.ndarray, y: np.ndarray, window: tuple[float, float] | None):
    t, y = np.asarray(t, float), np.asarray(y, float)
    if window is None:
        return t, y
    a, b = np.searchsorted(t, window[0], "left"), np.searchsorted(t, window[1], "right")
    return t[max(a - 1, 0):b + 1], y[max(a - 1, 0):b + 1]  # one sample beyond each edge


def _columns(t: np.ndarray, y: np.ndarray, columns: int):
    """(edges, t_first, t_last, min, max) of ``y`` per column of consecutive samples.

    numpy's reductions, not the compiled :func:`hgo.outputs.decimate.bucket_min_max`: a
    figure process gets at most ~60,000 samples a signal
    (:func:`hgo.running.figure_worker.drawing_view`), ~0.3 ms here, and would otherwise
    load numba's registries for it (0.6-1 s of its start-up on a 2-core VM)."""
    from hgo.outputs.decimate import bucket_edges

    y = y.reshape(len(y), -1)[:, 0]
    edges = bucket_edges(len(t), 2 * columns)
    starts = edges[:-1]
    return (edges, t[starts], t[edges[1:] - 1], np.minimum.reduceat(y, starts),
            np.maximum.reduceat(y, starts))


def drawn(t, y, columns: int, window: tuple[float, float] | None = None):
    """``(t, y)`` inside ``window`` as drawn on ``columns`` pixels: unchanged up to
    4 samples a pixel, else each pixel column's minimum and maximum (every peak stays)."""
    t, y = _window(t, y, window)
    if len(t) <= 4 * columns:
        return t, y
    edges, t0, t1, lo, hi = _columns(t, y, columns)
    # a falling column is drawn from its maximum to its minimum: a smooth curve stays
    # smooth (min first everywhere would zigzag back on every falling slope)
    falling = y[edges[:-1]] > y[edges[1:] - 1]
    t_out, y_out = np.empty(2 * len(t0)), np.empty(2 * len(t0))
    t_out[0::2], t_out[1::2] = t0, t1
    y_out[0::2], y_out[1::2] = np.where(falling, hi, lo), np.where(falling, lo, hi)
    return t_out, y_out


def noisy(lo: np.ndarray, hi: np.ndarray) -> bool:
    """Whether a signal whose pixel columns span ``lo``..``hi`` is dense noise: the median
    column spans more than 15 % of the whole range (a smooth curve spans ~1 pixel)."""
    total = float(np.max(hi) - np.min(lo))
    return total > 0 and float(np.median(hi - lo)) > 0.15 * total


def plot_line(ax, t, y, *args, window: tuple[float, float] | None = None,
              band: bool | None = None, **kwargs):
    """``ax.plot(t, y, ...)`` of the samples inside ``window``, reduced to the pixel width
    of ``ax`` (:func:`drawn`). A dense noisy signal (``band=None``: :func:`noisy`; True:
    always) is drawn as :func:`plot_band` instead: a line of it would fill a block."""
    columns = pixel_columns(ax)
    td, yd = drawn(t, y, columns, window)
    if band is None:
        first, second = yd[0::2], yd[1::2]
        band = len(td) == 2 * columns and noisy(np.minimum(first, second),
                                                np.maximum(first, second))
    if band and not args:
        return plot_band(ax, t, y, window=window, **kwargs)
    return ax.plot(td, yd, *args, **kwargs)


def plot_band(ax, t, y, *, color: str, label: str | None = None,
              window: tuple[float, float] | None = None, lw: float = 1.2,
              alpha: float = 0.28, **kwargs):
    """A dense noisy signal: the min/max band of each pixel column (light) and the
    column means (a line in ``color``, ``kwargs`` its style) as its representative curve;
    a plain line where there are fewer than 3 samples a pixel."""
    t, y = _window(t, y, window)
    columns = pixel_columns(ax) // 2  # 2 px a column: the mean line stays smooth
    line = {k: v for k, v in kwargs.items() if k != "alpha"}
    if len(t) <= 3 * columns:
        return ax.plot(t, y, color=color, lw=lw, label=label, **line)
    edges, t0, t1, lo, hi = _columns(t, y, columns)
    mean = np.add.reduceat(y, edges[:-1]) / np.diff(edges)
    mid = 0.5 * (t0 + t1)
    ax.fill_between(mid, lo, hi, color=color, alpha=alpha, lw=0, label="_nolegend_")
    ax.figure.hgo_band = True  # legend_below explains the shading
    return ax.plot(mid, mean, color=color, lw=min(lw, 1.5), label=label, **line)


def split_rows(n_rows: int, height: float = 2.3):
    """A figure of ``n_rows`` rows of (transient, rest) axes pairs for :func:`split_time`,
    the transient a quarter of the width."""
    return plt.subplots(n_rows, 2, figsize=(11, height * n_rows + 0.6), squeeze=False,
                        gridspec_kw={"width_ratios": [1, 3]})


def split_time(ax_early, ax_late, split: float, t_end: float, t_start: float = 0.0,
               late_start: float | None = None) -> None:
    """A broken time axis over two axes side by side: ``[t_start, split]`` (the
    transient) and ``[late_start or split, t_end]``, each with its own y-range (the
    data it shows), break marks between them."""
    ax_early.set_xlim(t_start, split)
    ax_late.set_xlim(split if late_start is None else late_start, t_end)
    # the late part at its own scale, but a converged (flat) signal stays a flat line: a
    # range at least 1e-3 of the transient's, without an offset above the axis
    (lo, hi), early = ax_late.dataLim.intervaly, ax_early.dataLim.intervaly
    least = 1e-3 * (early[1] - early[0])
    if np.isfinite([lo, hi]).all() and hi - lo < least:
        mid = 0.5 * (lo + hi)
        ax_late.set_ylim(mid - 0.55 * least, mid + 0.55 * least)
    for ax in (ax_early, ax_late):
        ax.ticklabel_format(axis="y", useOffset=False)
    ax_early.spines["right"].set_visible(False)
    ax_late.spines["left"].set_visible(False)
    ax_late.yaxis.tick_right()
    mark = {"marker": [(-1, -1.5), (1, 1.5)], "markersize": 8, "linestyle": "none",
            "color": "k", "mec": "k", "mew": 1, "clip_on": False}
    ax_early.plot([1, 1], [0, 1], transform=ax_early.transAxes, **mark)
    ax_late.plot([0, 0], [0, 1], transform=ax_late.transAxes, **mark)
