"""Figures of any run: each plant state with every observer's estimate, and how far from
singular the observers' dPhi/dx(x^) was (issue 42's presets; ``f(result, path)`` as every
figure of :mod:`hgo.outputs.figures`)."""

from __future__ import annotations

import numpy as np

from hgo.outputs.figures import RUN_STYLES, hat, legend_below, panel_letters, plot_line, \
    plt, save_figure, symbol


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
