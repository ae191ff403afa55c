"""Figures of Sanfelice & Praly (2010), Section 3: Figs. 1-5 from one run each.

Each function takes a :class:`hgo.running.runner.RunResult` and a path and writes one PNG with
the quantities of the paper's figure on the same axes (time in s on the abscissa);
legends name the law (observer name and its p2), the copy, or the filter. The sweep of
Fig. 3 (three values of p2, three runs) is the sweep's ``compare.png``, drawn by
:func:`hgo.running.aggregate.compare_figure` from the recordings.
"""

from __future__ import annotations

from pathlib import Path

import matplotlib.pyplot as plt

from hgo.core.registry import PaperFigure
from hgo.outputs.figures import (
    PALETTE,
    hat,
    legend_below,
    panel_letters,
    plot_line,
    save_figure,
    split_rows,
    split_time,
)
from hgo.outputs.recording import Series

# the paper's colours (Fig. 1 blue/red, Fig. 3 blue/red/green, Figs. 4-5 green/black) in the
# colour-blind-safe palette; the dead-zone law is drawn first, wide and light, and law (6)
# dashed on top: where they coincide both stay visible
LAW_STYLES = {"dead_zone": {"color": PALETTE["vermillion"], "lw": 2.6, "alpha": 0.55},
              "sign_indefinite": {"color": PALETTE["blue"], "lw": 1.3, "ls": "--"}}
DRAW_ORDER = ("dead_zone", "sign_indefinite")
# the copies of Fig. 5: not the single observer's green nor the notch output's vermillion
COPY_COLOURS = [PALETTE[c] for c in ("orange", "sky", "purple", "blue", "yellow", "grey")]
PLANT = {"color": "k", "lw": 1.0, "ls": ":"}
TRANSIENT = 5.0  # s: the left part of the split time axis (the transients last ~2-4 s)


def _series(result) -> dict[str, Series]:
    return {s.entity: s for s in result.series}


def _label(obs) -> str:
    """The paper's name of an observer's law (and its p2); the config name otherwise."""
    from hgo.papers.sanfelice_praly.postprocess import law6_parameters

    par = law6_parameters(obs)
    if obs.f.__module__ == "hgo.observers.triangular":
        law = {0: "constant gain", 1: "law (6)", 2: "dead-zone law (4)"}[obs.p.law]
        return f"{law}, $p_2 = {obs.p.p2:g}$"
    if par is not None and par["kind"] == "collection":
        return f"average of {par['N']} copies (21), $p_2 = {par['p2']:g}$"
    return obs.name


def _drawing_order(observers) -> list:
    rank = {name: i for i, name in enumerate(DRAW_ORDER)}
    return sorted(observers, key=lambda o: rank.get(o.name, len(rank)))


def _estimates_and_gain(result, path, title: str) -> None:
    """x^1, x^2 (with the plant's x) and r of every observer, one row each, on a split
    time axis: the transient [0, 5 s] and the rest of the run, each with its own y-range
    (the late part shows what the noise does to the estimates and the gain)."""
    t = result.trajectory.t
    s = _series(result)
    system = result.experiment.system
    x = s["/plant/x"]
    n = x.values.shape[1]
    split = min(TRANSIENT, t[-1] / 4)
    fig, axes = split_rows(n + 1)
    observers = _drawing_order(system.observers)
    for row in range(n + 1):
        for col, window in enumerate(((0.0, split), (split, t[-1]))):
            ax = axes[row, col]
            if row < n:
                plot_line(ax, t, x.values[:, row], window=window, label="plant $x$",
                          **PLANT)
            for obs in observers:
                est = s.get(f"/observer/{obs.name}/xhat" if row < n else f"/observer/{obs.name}/r")
                k = row if row < n else 0
                if est is not None and k < est.values.shape[1]:
                    plot_line(ax, t, est.values[:, k], window=window, label=_label(obs),
                              **LAW_STYLES.get(obs.name, {}))
        split_time(axes[row, 0], axes[row, 1], split, t[-1])
        axes[row, 0].set_ylabel(f"{hat(f'x{row + 1}')} (–)" if row < n else "gain $r$ (–)")
    axes[0, 0].set_title(f"transient, $0 \\leq t \\leq {split:g}$ s")
    axes[0, 1].set_title(f"${split:g} \\leq t \\leq {t[-1]:g}$ s (own vertical scale)")
    for ax in axes[-1]:
        ax.set_xlabel("$t$ (s)")
    panel_letters(axes[:, 0])
    legend_below(fig, ncol=3)
    fig.suptitle(title)
    save_figure(fig, path)


def fig1(result, path) -> None:
    """Fig. 1: x^ and r with law (6) (blue) and the dead-zone law (4) (red), no noise."""
    _estimates_and_gain(result, path, "Sanfelice & Praly Fig. 1: law (6) and the dead-zone "
                        "law (4), no noise")


def fig2(result, path) -> None:
    """Fig. 2: as Fig. 1 with bounded measurement noise."""
    _estimates_and_gain(result, path, "Sanfelice & Praly Fig. 2: with bounded measurement "
                        "noise")


def fig3(result, path) -> None:
    """Fig. 3 for one run (one p2): x^1, x^2, r of law (6) on the zero plant solution.

    The three values of p2 together: the sweep's ``compare.png``
    (:func:`hgo.running.aggregate.compare_figure`, titled :data:`FIG3_TITLE`).
    """
    _estimates_and_gain(result, path, "Sanfelice & Praly Fig. 3: oscillation of law (6)")


def fig4(result, path) -> None:
    """Fig. 4: (a) x^1 vs x^2 and filtered; (b) x^1, x^1f; (c) x^2, x^2f (green/black)."""
    t = result.trajectory.t
    s = _series(result)
    obs = result.experiment.system.observers[0]
    xh = s[f"/observer/{obs.name}/xhat"].values
    xf = s[f"/observer/{obs.name}/xhat_f"].values
    fig = plt.figure(figsize=(13, 6.5))
    ax = fig.add_subplot(1, 2, 1)
    ax.plot(xh[:, 0], xh[:, 1], color=PALETTE["green"], lw=0.8,
            label=rf"$\hat{{x}}$, {_label(obs)}")
    ax.plot(xf[:, 0], xf[:, 1], color="k", lw=0.8, label=r"$\hat{x}_f$ (notch filter $T(s)$)")
    ax.set_xlabel(f"{hat('x1')} (–)")
    ax.set_ylabel(f"{hat('x2')} (–)")
    ax.set_title(r"phase plane of $\hat{x}$")
    panels = [ax]
    for k, pos in ((0, 2), (1, 4)):
        ax = fig.add_subplot(2, 2, pos)
        plot_line(ax, t, xh[:, k], color=PALETTE["green"], lw=1)
        plot_line(ax, t, xf[:, k], color="k", lw=1)
        ax.set_ylabel(f"{hat(f'x{k + 1}')}, $\\hat{{x}}_{{{k + 1}f}}$ (–)")
        panels.append(ax)
    ax.set_xlabel("$t$ (s)")
    panel_letters(panels)
    legend_below(fig, panels[:1], ncol=2)
    fig.suptitle("Sanfelice & Praly Fig. 4: notch filter on the estimates")
    save_figure(fig, path)


def fig5(result, path, zoom: float = 10.0) -> None:
    """Fig. 5: (a) y^_i and <y^>; (b) x^_{i,2} and <x^2> (last ``zoom`` s); (c) single
    observer (green) against the average (black), with the single observer's notch output.
    """
    from hgo.observers.collection import collection_params

    t = result.trajectory.t
    s = _series(result)
    system = result.experiment.system
    coll = next(o for o in system.observers if o.f.__module__ == "hgo.observers.collection")
    single = [o for o in system.observers if o is not coll]
    N = collection_params(coll)["N"]
    last = (t[-1] - zoom, t[-1])
    avg = s[f"/observer/{coll.name}/xhat"].values
    fig, axes = plt.subplots(2, 2, figsize=(13, 7))
    for k, ax in enumerate(axes[0]):
        for i in range(N):
            v = s[f"/observer/{coll.name}/copy{i + 1}/xhat"].values[:, k]
            plot_line(ax, t, v, window=last, color=COPY_COLOURS[i % len(COPY_COLOURS)], lw=1,
                      label=rf"copy {i + 1}, $\hat{{x}}_{{{i + 1}}}$")
        plot_line(ax, t, avg[:, k], "k", window=last, lw=2,
                  label=rf"average $\langle\hat{{x}}\rangle$ of the {N} copies (21)")
        what = r"outputs $\hat{y}_i = \hat{x}_{i,1}$" if k == 0 else r"components $\hat{x}_{i,2}$"
        ax.set_title(f"{what}, last {zoom:g} s")
        ax.set_xlim(*last)
        ax.set_ylabel(rf"$\hat{{x}}_{{i,{k + 1}}}$ (–)")
    for k, ax in enumerate(axes[1]):
        # the single observer thin, the average under the notch output, which is drawn
        # last and dashed: where the two coincide both stay visible
        for obs in single:
            plot_line(ax, t, s[f"/observer/{obs.name}/xhat"].values[:, k],
                      color=PALETTE["green"], lw=0.8, label=f"single observer, {_label(obs)}")
        plot_line(ax, t, avg[:, k], color="k", lw=2.2, alpha=0.6,
                  label=rf"average $\langle\hat{{x}}\rangle$ of the {N} copies (21)")
        for obs in single:
            f = s.get(f"/observer/{obs.name}/xhat_f")
            if f is not None:
                plot_line(ax, t, f.values[:, k], color=PALETTE["vermillion"], lw=1.2, ls="--",
                          label=r"single observer through the notch filter $T(s)$")
        ax.set_title(f"{hat(f'x{k + 1}')}: single observer and average")
        ax.set_ylabel(f"{hat(f'x{k + 1}')} (–)")
        ax.set_xlim(0, t[-1])
    for ax in axes.ravel():
        ax.set_xlabel("$t$ (s)")
    panel_letters(axes.ravel())
    legend_below(fig, ncol=2)
    fig.suptitle("Sanfelice & Praly Fig. 5: collection (21) and its average")
    save_figure(fig, path)


# --- what ``hgo reproduce`` runs ------------------------------------------------------------


FIG3_TITLE = (r"Sanfelice & Praly Fig. 3: law (6), $p_1 = 4/3$, $\nu_1 = 3$, "
              "zero plant solution")


def _aggregate(sweep: Path) -> None:
    """The sweep's tables and its comparison figure, which is the paper's Fig. 3."""
    from hgo.running.aggregate import aggregate

    png = aggregate(sweep, title=FIG3_TITLE).get("png")
    for drawn in ([] if png is None else sweep.glob(f"{png.stem}.*")):  # and its PDF/SVG
        drawn.replace(sweep / f"fig3{drawn.suffix}")


_SOLUTION = ("Components of the solution to (18)-(19) corresponding to the zero solution of "
             "the plant")
PAPER_FIGURES = [
    PaperFigure("sp_fig1", {"fig1": "Components of the solution to (18)-(19) corresponding to "
                            "the zero equilibrium solution of the plant (blue) and with "
                            "constant, sufficiently large gain (red)."}),
    PaperFigure("sp_fig2", {"fig2": f"{_SOLUTION} (blue)."}),
    PaperFigure("sp_fig3", {"fig3": f"{_SOLUTION}, for parameters p1 = 4/3 and p2 = 3 "
                            "(blue), 2 (red), 1.5 (green)."},
                sweep={"observer.sign_indefinite.p2": (3, 2, 1.5)}, combine=_aggregate),
    PaperFigure("sp_fig4", {"fig4": f"{_SOLUTION}, for parameters p1 = 4/3 and p2 = 1.5, "
                            "without filter (green) and with filter (black)."}),
    PaperFigure("sp_fig5", {"fig5": "Components of the solution to (18)-(19) shown in Figure 4 "
                            "and to (18),(21) corresponding to the zero solution of the "
                            "plant, for p1 = 4/3 and p2 = 1.5."}),
]
