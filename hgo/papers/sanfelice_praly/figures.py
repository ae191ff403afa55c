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
from hgo.outputs.figures import hat, legend_outside, panel_letters, save_figure
from hgo.outputs.recording import Series

# the paper's colours: Fig. 1 blue/red, Fig. 3 blue/red/green, Figs. 4-5 green/black
LAW_COLOURS = {"sign_indefinite": "tab:blue", "dead_zone": "tab:red"}
COPY_COLOURS = ["tab:red", "tab:green", "tab:blue", "tab:orange", "tab:purple", "tab:brown"]


def _series(result) -> dict[str, Series]:
    return {s.entity: s for s in result.series}


def _label(obs) -> str:
    """Law and p2 of an observer, from its parameter vector when it is one of ours."""
    from hgo.papers.sanfelice_praly.postprocess import law6_parameters

    par = law6_parameters(obs)
    if obs.f.__module__ == "hgo.observers.triangular":
        law = {0: "constant gain", 1: "law (6)", 2: "dead-zone law (4)"}[obs.p.law]
        return f"{obs.name}: {law}, $p_2 = {obs.p.p2:g}$"
    if par is not None and par["kind"] == "collection":
        return f"{obs.name}: average of {par['N']} copies (21), $p_2 = {par['p2']:g}$"
    return obs.name


def _estimates_and_gain(result, path, title: str) -> None:
    """x^1, x^2 (with the plant's x) and r of every observer, one panel each."""
    t = result.trajectory.t
    s = _series(result)
    system = result.experiment.system
    x = s["/plant/x"]
    n = x.values.shape[1]
    fig, axes = plt.subplots(n + 1, 1, figsize=(10, 2.6 * (n + 1)), sharex=True)
    for k in range(n):
        ax = axes[k]
        ax.plot(t, x.values[:, k], "k--", lw=1, label=f"plant ${x.names[k][0]}_{k + 1}$")
        for obs in system.observers:
            est = s[f"/observer/{obs.name}/xhat"]
            if k < est.values.shape[1]:
                ax.plot(t, est.values[:, k], color=LAW_COLOURS.get(obs.name), lw=1.2,
                        label=_label(obs))
        ax.set_ylabel(f"{hat(f'x{k + 1}')} (–)")
        legend_outside(ax)
    ax = axes[n]
    for obs in system.observers:
        r = s.get(f"/observer/{obs.name}/r")
        if r is not None:
            ax.plot(t, r.values[:, 0], color=LAW_COLOURS.get(obs.name), label=_label(obs))
    ax.set_ylabel("gain $r$ (–)")
    ax.set_xlabel("$t$ (s)")
    legend_outside(ax)
    panel_letters(axes)
    fig.suptitle(title)
    save_figure(fig, path)


def fig1(result, path) -> None:
    """Fig. 1: x^ and r with law (6) (blue) and the dead-zone law (4) (red), no noise."""
    _estimates_and_gain(result, path, "Sanfelice & Praly Fig. 1: law (6) vs dead-zone law (4)")


def fig2(result, path) -> None:
    """Fig. 2: as Fig. 1 with bounded measurement noise."""
    _estimates_and_gain(result, path, "Sanfelice & Praly Fig. 2: with measurement noise")


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
    fig = plt.figure(figsize=(13, 7.5))
    ax = fig.add_subplot(1, 2, 1)
    ax.plot(xh[:, 0], xh[:, 1], color="tab:green", lw=0.8, label=rf"$\hat{{x}}$ ({_label(obs)})")
    ax.plot(xf[:, 0], xf[:, 1], color="k", lw=0.8, label=r"$\hat{x}_f$ (notch filter $T(s)$)")
    ax.set_xlabel(f"{hat('x1')} (–)")
    ax.set_ylabel(f"{hat('x2')} (–)")
    ax.set_title(r"phase plane of $\hat{x}$")
    legend_outside(ax, below=True)
    panels = [ax]
    for k, pos in ((0, 2), (1, 4)):
        ax = fig.add_subplot(2, 2, pos)
        ax.plot(t, xh[:, k], color="tab:green", lw=1, label=hat(f"x{k + 1}"))
        ax.plot(t, xf[:, k], color="k", lw=1, label=rf"$\hat{{x}}_{{{k + 1}f}}$ (notch)")
        ax.set_ylabel(f"{hat(f'x{k + 1}')} (–)")
        legend_outside(ax)
        panels.append(ax)
    ax.set_xlabel("$t$ (s)")
    panel_letters(panels)
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
    zm = t >= t[-1] - zoom
    avg = s[f"/observer/{coll.name}/xhat"].values
    fig, axes = plt.subplots(2, 2, figsize=(15, 7.5))
    for k, ax in enumerate(axes[0]):
        for i in range(N):
            v = s[f"/observer/{coll.name}/copy{i + 1}/xhat"].values[:, k]
            ax.plot(t[zm], v[zm], color=COPY_COLOURS[i % len(COPY_COLOURS)], lw=1,
                    label=rf"copy {i + 1}: $\hat{{x}}_{{{i + 1},{k + 1}}}$")
        ax.plot(t[zm], avg[zm, k], "k", lw=2,
                label=rf"$\langle\hat{{x}}_{k + 1}\rangle$ (average)")
        what = r"outputs $\hat{y}_i$" if k == 0 else r"components $\hat{x}_{i,2}$"
        ax.set_title(f"{what}, last {zoom:g} s")
        ax.set_ylabel(f"{hat(f'x{k + 1}')} (–)")
        legend_outside(ax)
    for k, ax in enumerate(axes[1]):
        for obs in single:
            ax.plot(t, s[f"/observer/{obs.name}/xhat"].values[:, k], color="tab:green", lw=1,
                    label=f"{hat(f'x{k + 1}')} ({_label(obs)})")
            f = s.get(f"/observer/{obs.name}/xhat_f")
            if f is not None:
                ax.plot(t, f.values[:, k], color="tab:gray", lw=1,
                        label=rf"$\hat{{x}}_{{{k + 1}f}}$ (notch on {obs.name})")
        ax.plot(t, avg[:, k], "k", lw=1.2,
                label=rf"$\langle\hat{{x}}_{k + 1}\rangle$ ({N} copies)")
        ax.set_title(f"{hat(f'x{k + 1}')}: single observer vs average")
        ax.set_ylabel(f"{hat(f'x{k + 1}')} (–)")
        legend_outside(ax)
    for ax in axes.ravel():
        ax.set_xlabel("$t$ (s)")
    panel_letters(axes.ravel())
    fig.suptitle("Sanfelice & Praly Fig. 5: collection (21) and its average")
    save_figure(fig, path)


# --- what ``hgo reproduce`` runs ------------------------------------------------------------


FIG3_TITLE = (r"Sanfelice & Praly Fig. 3: law (6), $p_1 = 4/3$, $\nu_1 = 3$, "
              "zero plant solution")


def _aggregate(sweep: Path) -> None:
    from hgo.running.aggregate import aggregate

    aggregate(sweep, title=FIG3_TITLE)


_SOLUTION = ("Components of the solution to (18)-(19) corresponding to the zero solution of "
             "the plant")
PAPER_FIGURES = [
    PaperFigure("sp_fig1", {"fig1": "Components of the solution to (18)-(19) corresponding to "
                            "the zero equilibrium solution of the plant (blue) and with "
                            "constant, sufficiently large gain (red)."}),
    PaperFigure("sp_fig2", {"fig2": f"{_SOLUTION} (blue)."}),
    PaperFigure("sp_fig3", {"compare": f"{_SOLUTION}, for parameters p1 = 4/3 and p2 = 3 "
                            "(blue), 2 (red), 1.5 (green)."},
                sweep={"observer.sign_indefinite.p2": (3, 2, 1.5)}, combine=_aggregate),
    PaperFigure("sp_fig4", {"fig4": f"{_SOLUTION}, for parameters p1 = 4/3 and p2 = 1.5, "
                            "without filter (green) and with filter (black)."}),
    PaperFigure("sp_fig5", {"fig5": "Components of the solution to (18)-(19) shown in Figure 4 "
                            "and to (18),(21) corresponding to the zero solution of the "
                            "plant, for p1 = 4/3 and p2 = 1.5."}),
]
