"""Figures of Moreno: Fig. 1 (u, x2, e1, e2 over the run), signature ``f(result, path)``."""

from __future__ import annotations

import math

import matplotlib.pyplot as plt
import numpy as np

from hgo.controllers.profile_input import profile_input
from hgo.core.registry import PaperFigure
from hgo.engine.simulate import Trajectory, simulate
from hgo.engine.system import System
from hgo.outputs.figures import legend_outside, panel_letters, save_figure

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


def fig1(result, path, overlay_bad: bool = True) -> None:
    """Moreno Fig. 1: u; x2 with the band |x2| <= 2/sqrt(3) shaded; e1, e2 (symlog,
    linthresh 1e-2 and 1e-1), the bad-input run dashed when ``overlay_bad``."""
    sysm, traj = result.experiment.system, result.trajectory
    t = traj.t
    e = _errors(sysm, traj)
    fig, axes = plt.subplots(4, 1, figsize=(10, 9), sharex=True)
    # the example of Section 5 is dimensionless: (–) on the state axes
    axes[0].plot(t, traj.u[:, 0], color="tab:blue", label="input $u$")
    axes[0].set_ylabel("$u$ (–)")
    legend_outside(axes[0])
    axes[1].plot(t, traj.z[:, 1], color="tab:blue", label="$x_2$")
    axes[1].axhspan(-BAND, BAND, color="tab:red", alpha=0.12,
                    label=r"$|x_2| \leq 2/\sqrt{3}$")
    axes[1].set_ylabel("$x_2$ (–)")
    legend_outside(axes[1])
    bad = bad_companion(result) if overlay_bad else None
    for k, (ax, thresh) in enumerate(zip(axes[2:], (1e-2, 1e-1), strict=True)):
        ax.plot(t, e[:, k], color="tab:blue", label="input of the run")
        if bad is not None:
            eb = _errors(sysm, bad)
            ax.plot(bad.t, eb[:, k], "k--", lw=1, label="bad input u = 0 (r = 0)")
        ax.set_yscale("symlog", linthresh=thresh)
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
                                  "bounds K1^a and eps_max of (7)-(8) by LMI and by the exact "
                                  "SPR test, side by side, for the gain sets of the notes."}),
]
