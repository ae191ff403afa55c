"""Figures of Andrieu, Praly & Astolfi (2007), Section 3.1, from one run of the paper's scenario.

* :func:`fig1` "Approximations of the local incremental rates in the 3 cases": df2max (a
  constant line), Omega1 along the Omega1 observer, Omega2 along the Omega2 observer and
  |df2/dx2| along the true solution on a log axis (top); the signed df2/dx2 along the
  solution (plant's hbar and the observers' hbar_o, reading C11) on a linear axis
  (bottom: a log axis cannot show negative values).
* :func:`fig2` "Estimation of eta2 with the 3 observers": three stacked panels, df2max
  (top), Omega1 (middle), Omega2 (bottom), each with eta2 and eta^2 against time.

Time is the paper's normalised time.
"""

from __future__ import annotations

import matplotlib.pyplot as plt
import numpy as np

from hgo.core.registry import PaperFigure
from hgo.outputs.figures import (
    PALETTE,
    legend_below,
    panel_letters,
    plot_band,
    plot_line,
    save_figure,
)
from hgo.papers.andrieu_praly_astolfi.postprocess import RATE

ORDER = ("df2max", "omega1", "omega2")
COLOURS = {"df2max": PALETTE["vermillion"], "omega1": PALETTE["blue"],
           "omega2": PALETTE["green"]}
LABELS = {"df2max": r"$df_{2\max}$ (constant gain)", "omega1": r"$\Omega_1$ (updated gain)",
          "omega2": r"$\Omega_2$ (updated gain + homogeneous)"}
# the model is normalised (Section 3): time and concentrations are dimensionless
T_LABEL = "$t$ (–, normalised time)"


def _series(result) -> dict:
    return {s.entity: s for s in result.series}


def _observers(result) -> list[str]:
    names = [o.name for o in result.experiment.system.observers]
    return [n for n in ORDER if n in names] + [n for n in names if n not in ORDER]


def _log_floor(omegas: list[np.ndarray], true: np.ndarray) -> float:
    """Bottom of the log axis of Fig. 1, set by the data of interest: under the 1st
    percentile of the Omegas and the 10th of |df2/dx2| (whose dips to 0 where it changes
    sign would otherwise pull the axis down to 1e-4)."""
    lows = [float(np.percentile(c[c > 0], 1)) for c in omegas if np.any(c > 0)]
    lows.append(float(np.percentile(true[true > 0], 10)))
    return 10 ** np.floor(np.log10(min(lows)))  # the decade below


def fig1(result, path) -> None:
    """Rates along the run: Omega of each observer and df2/dx2 along the solution."""
    t = result.trajectory.t
    s = _series(result)
    rate = s[RATE]
    fig, (ax, ax2) = plt.subplots(2, 1, figsize=(10, 7), sharex=True,
                                  gridspec_kw={"height_ratios": [2, 1]})
    rates = []
    for name in _observers(result):
        om = s[f"/observer/{name}/Omega"].values[:, 0]
        rates.append(om)
        plot_line(ax, t, om, color=COLOURS.get(name), lw=0.9,
                  label=LABELS.get(name, name))
    true = np.abs(rate.values[:, rate.names.index("df2dx2_true")])
    plot_line(ax, t, true, color="k", lw=1.2,
              label=r"$|\partial f_2/\partial x_2|$ along the solution ($\bar h$ true)")
    ax.set_yscale("log")
    ax.set_ylim(bottom=_log_floor(rates, true))
    ax.set_ylabel("local incremental rate (–)")
    ax.grid(alpha=0.3, which="both")
    ax.set_title(r"dips of $|\partial f_2/\partial x_2|$ below the axis: its sign changes "
                 "(see (b))", fontsize=9)
    for k, name in enumerate(rate.names):
        hbar = name.replace("df2dx2_", "")
        plot_line(ax2, t, rate.values[:, k], color="k" if k == 0 else PALETTE["grey"],
                  lw=1.0, ls="-" if k == 0 else "--",
                  label=rf"$\partial f_2/\partial x_2$ (signed), $\bar h$ {hbar}")
    ax2.axhline(0.0, color="k", lw=0.5)
    ax2.set_ylabel(r"$\partial f_2/\partial x_2$ (–)")
    ax2.set_xlabel(T_LABEL)
    panel_letters((ax, ax2))
    legend_below(fig, ncol=2)
    fig.suptitle("Andrieu, Praly & Astolfi Fig. 1: approximations of the local incremental "
                 "rates in the 3 cases")
    save_figure(fig, path)


def fig2(result, path) -> None:
    """eta2 and eta^2 of each observer, one panel each (df2max, Omega1, Omega2). The
    estimates chatter (the constant-gain one within 1 ms): each is drawn as the min/max
    band of its pixel columns and their mean, under eta2."""
    t = result.trajectory.t
    s = _series(result)
    eta2 = s["/plant/x"].values[:, 1]
    names = _observers(result)
    fig, axes = plt.subplots(len(names), 1, figsize=(10, 2.5 * len(names) + 0.6),
                             sharex=True, squeeze=False)
    for ax, name in zip(axes[:, 0], names, strict=True):
        est = s[f"/observer/{name}/xhat"].values[:, 1]
        plot_band(ax, t, est, color=COLOURS.get(name), lw=1.0,
                  label=rf"$\hat\eta_2$, {LABELS.get(name, name)}")
        plot_line(ax, t, eta2, color="k", lw=1.3, label=r"$\eta_2$")
        ax.set_ylabel(r"$\eta_2$, $\hat\eta_2$ (–)")
        ax.set_ylim(-0.05, 1.05)
        ax.set_title(LABELS.get(name, name), fontsize=9)
    panel_letters(axes[:, 0])
    legend_below(fig, ncol=2)
    fig.suptitle(r"Andrieu, Praly & Astolfi Fig. 2: estimation of $\eta_2$ with the 3 "
                 "observers")
    axes[-1, 0].set_xlabel(T_LABEL)
    save_figure(fig, path)


# --- what ``hgo reproduce`` runs ------------------------------------------------------------

PAPER_FIGURES = [
    # apa_fig1 is apa_fig2 renamed (same run): each figure credited to its own preset
    PaperFigure("apa_fig1", {
        "fig1": "Approximations of the local incremental rates in the 3 cases.",
    }),
    PaperFigure("apa_fig2", {
        "fig2": "Estimation of η2 with the 3 observers (constant gain from df2max, top; "
                "adapted gain from Ω1, middle; updated gain from Ω2 with homogeneity "
                "p = 0.9, bottom).",
    }),
]
