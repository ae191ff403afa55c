"""Figures of Moreno: Fig. 1 (u, x2, e1, e2 over the run), signature ``f(result, path)``."""

from __future__ import annotations

import math

import matplotlib.pyplot as plt
import numpy as np

from hgo.controllers.profile_input import profile_input
from hgo.core.registry import PaperFigure
from hgo.engine.simulate import Trajectory, simulate
from hgo.engine.system import System
from hgo.outputs.figures import PALETTE, legend_outside, panel_letters, plot_line, save_figure

BAND = 2 / math.sqrt(3)  # |sigma| <= 2/sqrt(3): phi can leave (-1, inf]


def bad_companion(result) -> Trajectory:
    """The run of ``result`` with the input replaced by the bad one (u = r' + a r, r = 0):
    same plant, observers, solver and noise."""
    exp = result.experiment
    sysm = exp.system
    a = sysm.controller.p.a if sysm.controller is not None else 0.0
    bad = System(sysm.plant, sysm.observers, profile_input("bad", a=a))
    ny = len(sysm.plant.output_names)
    return simulate(bad, exp.solver, exp.noise.sample(exp.solver.t_end, ny, exp.seed))


def _errors(system: System, traj: Trajectory) -> np.ndarray:
    """e = x - x^ of the first observer (the paper's sign)."""
    xa, xb = system.xh_slices[0]
    return traj.z[:, :system.plant.nx] - traj.xh[:, xa:xb]


def _power_label(v: float) -> str:
    if v == 0:
        return "$0$"
    return f"${'-' if v < 0 else ''}10^{{{int(round(np.log10(abs(v))))}}}$"


def symlog_ticks(ax, values: np.ndarray, linthresh: float, most: int = 7) -> None:
    """At most ``most`` labelled ticks on a symlog axis: 0 and the powers of ten from
    ``linthresh`` up to the data's extent on each side that has data, every second or
    third decade when there are more (matplotlib's default labels every decade)."""
    top = max(float(np.max(np.abs(values))), linthresh)
    decades = np.arange(np.floor(np.log10(linthresh)), np.ceil(np.log10(top)) + 1)
    sides = [sign for sign, present in ((-1, np.min(values) < -linthresh),
                                        (1, np.max(values) > linthresh)) if present]
    step = 1
    while 1 + len(sides) * len(decades[::step]) > most:
        step += 1
    powers = 10.0 ** decades[::-1][::step]
    ticks = sorted([0.0] + [sign * v for sign in sides for v in powers])
    ax.set_yticks(ticks, [_power_label(v) for v in ticks])
    ax.yaxis.set_minor_locator(plt.NullLocator())


def fig1(result, path, overlay_bad: bool = True) -> None:
    """Moreno Fig. 1: u; x2 with the band |x2| <= 2/sqrt(3) shaded; e1, e2 (symlog,
    linthresh 1e-2 and 1e-1), the bad-input run dashed when ``overlay_bad``."""
    sysm, traj = result.experiment.system, result.trajectory
    t = traj.t
    e = _errors(sysm, traj)
    fig, axes = plt.subplots(4, 1, figsize=(10, 9), sharex=True)
    # the example of Section 5 is dimensionless: (–) on the state axes
    plot_line(axes[0], t, traj.u[:, 0], color=PALETTE["blue"], label="input $u$")
    axes[0].set_ylabel("$u$ (–)")
    legend_outside(axes[0])
    plot_line(axes[1], t, traj.z[:, 1], color=PALETTE["blue"], label="$x_2$")
    axes[1].axhspan(-BAND, BAND, color=PALETTE["vermillion"], alpha=0.12,
                    label=r"$|x_2| \leq 2/\sqrt{3}$")
    axes[1].set_ylabel("$x_2$ (–)")
    legend_outside(axes[1])
    bad = bad_companion(result) if overlay_bad else None
    for k, (ax, thresh) in enumerate(zip(axes[2:], (1e-2, 1e-1), strict=True)):
        plot_line(ax, t, e[:, k], color=PALETTE["blue"], label="with the input $u$ of (a)")
        shown = [e[:, k]]
        if bad is not None:
            eb = _errors(sysm, bad)
            plot_line(ax, bad.t, eb[:, k], color="k", ls="--", lw=1,
                      label=r"with the bad input $u = 0$ ($r = 0$)")
            shown.append(eb[:, k])
        ax.set_yscale("symlog", linthresh=thresh)
        symlog_ticks(ax, np.concatenate(shown), thresh)
        ax.set_ylabel(rf"$e_{k + 1} = x_{k + 1} - \hat{{x}}_{k + 1}$ (–)")
        legend_outside(ax)
    axes[-1].set_xlabel("$t$ (s)")
    panel_letters(axes)
    obs = sysm.observers[0]
    title = (f"Moreno Fig. 1: $a = {-sysm.plant.A[1, 1]:g}$, $k = {obs.N:g}$, "
             f"$l_1 = {obs.L[0]:g}$, $l_2 = {obs.L[1]:g}$, "
             f"$e_0 = ({e[0, 0]:g}, {e[0, 1]:g})$")
    fig.suptitle(title)
    save_figure(fig, path)


# --- what ``hgo reproduce`` runs ------------------------------------------------------------

PAPER_FIGURES = [
    PaperFigure("moreno_fig1", {"fig1": "Simulation results for the example with the following "
                                "parameters: a = 0, k = 2, l1 = 200, l2 = 120, x0 = 0, "
                                "e0 = (70, -50). Shown are the input applied u, the state "
                                "variable x2, and the estimation errors e1, e2."}),
    PaperFigure("moreno_sector", {"sector_table": "(Not a figure of the paper.) The sector "
                                  "bounds K₁ᵃ and ε_max of (7)-(8) by LMI and by the exact "
                                  "SPR test, side by side, for the gain sets of the notes."}),
]
