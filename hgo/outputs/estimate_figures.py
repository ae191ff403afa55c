"""Figures of any run: each plant state with every observer's estimate, and how far from
singular the observers' dPhi/dx(x^) was (issue 42's presets; ``f(result, path)`` as every
figure of :mod:`hgo.outputs.figures`)."""

from __future__ import annotations

import numpy as np

from hgo.outputs.figures import (
    RUN_STYLES,
    hat,
    legend_below,
    panel_letters,
    plot_line,
    plt,
    save_figure,
    symbol,
)


def states_and_estimates(result, path) -> None:
    """One panel per plant state x_i (black) with each observer's x^_i, then a panel of
    |det dPhi/dx(x^)| (log axis) for the observers that record it."""
    system, traj = result.experiment.system, result.trajectory
    plant, t = system.plant, traj.t
    dets = [(obs, a + obs.disc_names.index("det_dPhi"))
            for obs, (a, _) in zip(system.observers, system.d_slices, strict=True)
            if "det_dPhi" in obs.disc_names]
    rows = plant.nx + bool(dets)
    fig, axes = plt.subplots(rows, 1, figsize=(8, 1.9 * rows + 0.8), sharex=True,
                             squeeze=False)
    axes = axes[:, 0]
    for i, name in enumerate(plant.state_names):
        ax = axes[i]
        plot_line(ax, t, traj.z[:, i], color="k", lw=1.6, label="plant", band=False)
        for k, (obs, (xa, _)) in enumerate(zip(system.observers, system.xh_slices,
                                                strict=True)):
            if i in obs.estimated_states:
                col = xa + list(obs.estimated_states).index(i)
                plot_line(ax, t, traj.xh[:, col], lw=1.0, label=obs.name,
                          **RUN_STYLES[k % len(RUN_STYLES)])
        ax.set_ylabel(f"${symbol(name)}$, {hat(name)}")
    if dets:
        ax = axes[-1]
        for k, (obs, col) in enumerate(dets):
            plot_line(ax, t, np.abs(traj.d[:, col]), lw=1.0, label=obs.name,
                      **RUN_STYLES[k % len(RUN_STYLES)])
        ax.set_yscale("log")
        ax.set_ylabel(r"$|\det\,\partial\Phi/\partial x(\hat x)|$")
    axes[-1].set_xlabel("$t$ (s)")
    panel_letters(axes)
    fig.tight_layout(rect=(0, 0.06, 1, 1))
    legend_below(fig, list(axes))
    save_figure(fig, path)


def tradeoff_table(metrics, gain_key: str, noise_key: str):
    """(observer, eps, noise, rms_error) of an ensemble's members: rms_error =
    sqrt(sum_i mean_sq_error_<x_i>) over the metrics window, one row per member and
    observer."""
    rows = metrics[(metrics.member != "all") & metrics.quantity.str.startswith("mean_sq_error_")]
    table = rows.groupby(["observer", gain_key, noise_key], as_index=False).empirical.sum()
    table["rms_error"] = np.sqrt(table.pop("empirical"))
    return table.rename(columns={gain_key: "eps", noise_key: "noise"})


def tradeoff_report(result, out_dir) -> None:
    """The trade-off of a grid over an observer's ``eps`` and ``noise.std``: tradeoff.csv
    and tradeoff.png (the window's RMS estimation error against eps, log-log, one line per
    observer and noise level): model error shrinks with eps, noise amplification grows."""
    from pathlib import Path

    gain_key = next(k for k in result.draws if k.endswith(".eps"))
    table = tradeoff_table(result.metrics, gain_key, "noise.std")
    table.to_csv(Path(out_dir) / "tradeoff.csv", index=False)
    tradeoff_figure(table, Path(out_dir) / "tradeoff.png")


def tradeoff_figure(table, path) -> None:
    """RMS error against eps (log-log) of :func:`tradeoff_table`'s rows."""
    fig, ax = plt.subplots(figsize=(7, 4.2))
    lines = table.groupby(["observer", "noise"])
    for k, ((obs, noise), part) in enumerate(lines):
        part = part.sort_values("eps")
        ax.loglog(part.eps, part.rms_error, marker="o", ms=3, label=f"{obs}, noise std {noise:g}",
                  **RUN_STYLES[k % len(RUN_STYLES)])
    ax.set_xlabel(r"$\varepsilon$ (s)")
    ax.set_ylabel(r"RMS of $\|\hat x - x\|$ over the window")
    fig.tight_layout(rect=(0, 0.12, 1, 1))
    legend_below(fig, [ax], ncol=2)
    save_figure(fig, path)
