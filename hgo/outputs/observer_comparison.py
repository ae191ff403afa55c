"""Figures of observers compared on one plant and one measurement (experiment=vdp_kalman,
vdp_kalman_noise): the estimates over time, and each observer's steady-state error
against the noise level. Any plant, any observers: nothing here names one.

* :func:`estimates_figure` (a run's ``figures`` entry): for each plant state, the state
  and every observer's estimate of it, then the estimation errors, over the transient and
  the last seconds (a split time axis: each part with its own y-range).
* :func:`noise_report` (an ``ensemble.reports`` entry of a grid over ``noise.std``):
  ``noise_levels.csv`` (observer, noise std, RMS error of each state over the metrics
  window, sqrt of the run's ``mean_sq_error_<state>``) and ``noise_levels.png``: those
  RMS errors against the noise std (log-log, one line per observer, one panel per
  state), then the estimates and errors over time at the middle noise level.
"""

from __future__ import annotations

from pathlib import Path

import matplotlib.pyplot as plt
import numpy as np
import pandas as pd

from hgo.outputs.figures import (
    RUN_STYLES,
    hat,
    legend_below,
    plot_line,
    save_figure,
    split_rows,
    split_time,
    symbol,
)

NOISE_KEY = "noise.std"
TRANSIENT = 2.0  # s of the transient shown (at most a quarter of the run)
LAST = 2.0  # s of the end shown


def _estimates(axes, system, traj) -> None:
    """Rows 2i and 2i + 1 of ``axes`` (transient, end): x_i with every observer's estimate
    of it, then the estimation errors x^_i - x_i."""
    t, t_end = traj.t, float(traj.t[-1])
    split = min(TRANSIENT, t_end / 4)
    late = max(split, t_end - LAST)
    for i, name in enumerate(system.plant.state_names):
        rows = axes[2 * i], axes[2 * i + 1]
        for col, window in enumerate(((0.0, split), (late, t_end))):
            plot_line(rows[0][col], t, traj.z[:, i], color="k", lw=2.0, label="plant state",
                      window=window, band=False)
            for k, obs in enumerate(system.observers):
                if i not in obs.estimated_states:
                    continue
                xh = traj.xh[:, system.xh_slices[k][0] + obs.estimated_states.index(i)]
                style = {"lw": 1.1, "label": obs.name, "window": window,
                         **RUN_STYLES[k % len(RUN_STYLES)]}
                plot_line(rows[0][col], t, xh, band=False, **style)
                plot_line(rows[1][col], t, xh - traj.z[:, i], **style)
        for row in rows:
            split_time(row[0], row[1], split, t_end, late_start=late)
        rows[0][0].set_ylabel(f"${symbol(name)}$, {hat(name)}")
        rows[1][0].set_ylabel(f"{hat(name)} $- {symbol(name)}$")
    for ax in axes[-1]:
        ax.set_xlabel("$t$ (s)")


def estimates_figure(result, path) -> None:
    """Every state and its estimates over time (module doc)."""
    system = result.experiment.system
    fig, axes = split_rows(2 * system.plant.nx)
    _estimates(axes, system, result.trajectory)
    legend_below(fig, ncol=len(system.observers) + 1)
    fig.suptitle(f"{system.plant.name}: states and estimates, noise std "
                 f"{result.experiment.noise.std:g}")
    save_figure(fig, path)


def noise_table(metrics: pd.DataFrame, states: list[str]) -> pd.DataFrame:
    """(observer, noise_std, rms_<state>...) from the members' ``mean_sq_error_<state>``."""
    rows = metrics[metrics.member != "all"]
    wanted = {f"mean_sq_error_{s}": f"rms_{s}" for s in states}
    sel = rows[rows.quantity.isin(list(wanted))]
    table = sel.pivot_table(index=["observer", NOISE_KEY], columns="quantity",
                            values="empirical").rename(columns=wanted).reset_index()
    for col in wanted.values():
        table[col] = np.sqrt(table[col])
    return table.rename(columns={NOISE_KEY: "noise_std"})


def noise_report(result, out_dir: str | Path) -> pd.DataFrame:
    """Write noise_levels.csv and noise_levels.png (module doc); returns the table."""
    out = Path(out_dir)
    system = result.systems[0]
    states = system.plant.state_names
    table = noise_table(result.metrics, states)
    table.to_csv(out / "noise_levels.csv", index=False)
    levels = np.sort(table.noise_std.unique())
    n = len(states)
    fig = plt.figure(figsize=(11, 3.2 + 4.6 * n))
    grid = fig.add_gridspec(1 + 2 * n, 2 * n, height_ratios=[1.6] + [1.0] * (2 * n))
    for i, s in enumerate(states):
        ax = fig.add_subplot(grid[0, 2 * i:2 * i + 2])
        for k, obs in enumerate(system.observers):
            rows = table[table.observer == obs.name].sort_values("noise_std")
            ax.loglog(rows.noise_std, rows[f"rms_{s}"], marker="o", lw=1.2,
                      label=obs.name, **RUN_STYLES[k % len(RUN_STYLES)])
        ax.set_xlabel("noise std")
        ax.set_ylabel(f"RMS error of {hat(s)} (metrics window)")
        ax.grid(True, which="both", alpha=0.3)
    middle = float(levels[len(levels) // 2])
    if result.trajectories is not None:
        i = int(np.flatnonzero(np.asarray(result.draws[NOISE_KEY]) == middle)[0])
        axes = np.array([[fig.add_subplot(grid[1 + r, 0]),
                          fig.add_subplot(grid[1 + r, 1:])] for r in range(2 * n)])
        _estimates(axes, result.systems[i], result.trajectories[i])
        axes[0, 1].set_title(f"estimates at noise std {middle:g}")
    legend_below(fig, ncol=len(system.observers) + 1)
    fig.suptitle(f"{system.plant.name}: steady-state error against the noise level")
    save_figure(fig, out / "noise_levels.png")
    return table
