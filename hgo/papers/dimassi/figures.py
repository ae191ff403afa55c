"""Figures of Dimassi et al. Sec. IV (Figs. 1-5) and an error panel, from one run.

Each function takes a :class:`hgo.running.runner.RunResult` and a path and writes one PNG (t in s on
every abscissa, implementation notes 9):

* :func:`fig1`: z_12 = x2 (solid) and its HGO estimate z^_12 (dashed: the saturated z_h12^s
  that the cascade uses, A13; dotted: the raw z_h12) on a split time axis: the peaking
  over the first 30 ms (re-simulated on a 10 us grid: the run's output grid is too coarse
  for a peak that lasts ~3 ms), then the rest of the run, each part at its own scale;
* :func:`fig2`, :func:`fig3`: x1, x^1 and x2, x^2, the first second on its own axis;
* :func:`fig4`, :func:`fig5`: theta_1 = 1/I, theta^_1 and theta_2 = m g l/(2 I), theta^_2;
* :func:`errors`: |e1|, |e2|, |theta~_i|/theta_i, V and R^2 on a log scale (not in the paper).
"""

from __future__ import annotations

import dataclasses

import matplotlib.pyplot as plt
import numpy as np

from hgo.core.registry import PaperFigure
from hgo.engine.simulate import no_noise, simulate
from hgo.observers import adaptive_cascade as ac
from hgo.outputs.figures import (
    PALETTE,
    legend_below,
    panel_letters,
    plot_line,
    save_figure,
    split_time,
)

INSET_HGO = 0.03  # s, Fig. 1: the peaking part of the split time axis
INSET_TRANSIENT = 1.0  # s, Figs. 2-5: the transient part of the split time axis
# the true quantity solid black, the estimate dashed in vermillion on top, the raw HGO
# output dotted blue: distinguishable where they coincide (most of the run)
STYLES = {"true": {"color": "k", "lw": 1.4}, "estimate": {"color": PALETTE["vermillion"],
          "lw": 1.3, "ls": "--"}, "raw": {"color": PALETTE["blue"], "lw": 1.2, "ls": ":"}}


def _cascade(result):
    """(index, observer) of the first cascade observer of the run."""
    for k, obs in enumerate(result.experiment.system.observers):
        if obs.f is ac.f:
            return k, obs
    raise ValueError("figure: the run has no adaptive_cascade observer")


def _series(result, entity: str) -> np.ndarray:
    for s in result.series:
        if s.entity == entity:
            return s.values
    raise ValueError(f"figure: no series {entity} (needs the dhlm_metrics post-processor)")


def _theta(result) -> np.ndarray:
    _, obs = _cascade(result)
    return _series(result, f"/observer/{obs.name}/theta_error")


def _with_inset(path, title, t, curves, ylabel, span=INSET_TRANSIENT, inset_t=None,
                inset_curves=None) -> None:
    """``curves`` ((values, style key, label)) on a split time axis: ``[0, span]`` (from
    ``inset_t``/``inset_curves`` when given: a finer grid) and ``[span, t_end]``, each
    part at the y-range of its own data: no zoom sits on the data, nothing is clipped."""
    fig, (early, late) = plt.subplots(1, 2, figsize=(10, 3.9),
                                      gridspec_kw={"width_ratios": [1, 3]})
    ti = t if inset_t is None else inset_t
    for values, style, label in (curves if inset_curves is None else inset_curves):
        plot_line(early, ti, values, window=(0.0, span), label=label, **STYLES[style])
    for values, style, label in curves:
        plot_line(late, t, values, window=(span, t[-1]), label=label, **STYLES[style])
    split_time(early, late, span, t[-1])
    early.set_title(f"transient, $0 \\leq t \\leq {span * 1e3:g}$ ms" if span < 0.1 else
                    f"transient, $0 \\leq t \\leq {span:g}$ s", fontsize=9)
    late.set_title(f"${span:g} \\leq t \\leq {t[-1]:g}$ s (own vertical scale)", fontsize=9)
    if span < 0.1:  # milliseconds on the transient's axis
        early.xaxis.set_major_formatter(lambda v, _: f"{v * 1e3:g}")
        early.set_xlabel("$t$ (ms)")
    else:
        early.set_xlabel("$t$ (s)")
    late.set_xlabel("$t$ (s)")
    early.set_ylabel(ylabel)
    legend_below(fig, [late], ncol=len(curves))
    fig.suptitle(title)
    save_figure(fig, path)


def fine_start(result, span: float = INSET_HGO, dt: float = 1e-5):
    """The same system re-simulated over [0, span] on a dt grid (same solver settings)."""
    exp = result.experiment
    solver = dataclasses.replace(exp.solver, t_end=span, dt_out=dt, window=0.0)
    return simulate(exp.system, solver, no_noise(len(exp.system.plant.output_names)))


def fig1(result, path) -> None:
    """Fig. 1: z_12 = x2 and its estimate z^_12 by the HGO (6) (saturated, raw dotted)."""
    t = result.trajectory.t
    k, obs = _cascade(result)
    x2 = result.trajectory.z[:, 1]
    sat = _series(result, f"/observer/{obs.name}/hgo/saturated")[:, 1]
    raw = _series(result, f"/observer/{obs.name}/hgo/raw")[:, 1]
    fine = fine_start(result)
    za = result.experiment.system.z_slices[k + 1][0]
    s_level = ac.unpack(obs.p)["S"][1]
    f_raw = fine.z[:, za + 1]
    curves = [(x2, "true", "$z_{12} = x_2$"),
              (sat, "estimate", r"$\hat z_{12}$ (saturated at $S$, used by (5), (7))"),
              (raw, "raw", r"$\hat z_{12}$ raw")]
    inset = [(fine.z[:, 1], "true", ""), (np.clip(f_raw, -s_level, s_level), "estimate", ""),
             (f_raw, "raw", "")]
    _with_inset(path, rf"Dimassi et al. Fig. 1 - HGO (6), $\varepsilon = "
                f"{ac.unpack(obs.p)['eps']:g}$, $S = {s_level:g}$ (peaking on a "
                r"10 $\mu$s grid)",
                t, curves, r"$z_{12}$, $\hat z_{12}$ (rad/s)", INSET_HGO, fine.t, inset)


def fig2(result, path) -> None:
    """Fig. 2: x1 and its estimate x^1 by (5), (7)."""
    t, z = result.trajectory.t, result.trajectory.z
    xh = result.trajectory.xh
    _with_inset(path, r"Dimassi et al. Fig. 2 - $x_1$ and $\hat x_1$ by (5), (7)", t,
                [(z[:, 0], "true", "$x_1$"), (xh[:, 0], "estimate", r"$\hat x_1$")],
                r"$x_1$, $\hat x_1$ (rad)")


def fig3(result, path) -> None:
    """Fig. 3: x2 and its estimate x^2 by (5), (7)."""
    t, z = result.trajectory.t, result.trajectory.z
    xh = result.trajectory.xh
    _with_inset(path, r"Dimassi et al. Fig. 3 - $x_2$ and $\hat x_2$ by (5), (7)", t,
                [(z[:, 1], "true", "$x_2$"), (xh[:, 1], "estimate", r"$\hat x_2$")],
                r"$x_2$, $\hat x_2$ (rad/s)")


def _theta_fig(result, path, i: int, unit: str) -> None:
    t = result.trajectory.t
    theta = np.full_like(t, _true(result)[i])
    th = theta + _theta(result)[:, i]
    sym, est = rf"$\theta_{i + 1}$", rf"$\hat\theta_{i + 1}$"
    _with_inset(path, f"Dimassi et al. Fig. {4 + i} - {sym} and its estimate", t,
                [(theta, "true", f"{sym} = {theta[0]:g}"), (th, "estimate", est)],
                f"{sym}, {est} ({unit})")


def fig4(result, path) -> None:
    """Fig. 4: theta_1 = 1/I and theta^_1."""
    _theta_fig(result, path, 0, r"kg$^{-1}$ m$^{-2}$")


def fig5(result, path) -> None:
    """Fig. 5: theta_2 = m g l / (2 I) and theta^_2."""
    _theta_fig(result, path, 1, r"s$^{-2}$")


def errors(result, path) -> None:
    """|e1|, |e2|, |theta~_i|/theta_i, V (18) and R^2 (23) on a log scale."""
    t = result.trajectory.t
    _, obs = _cascade(result)
    e = result.trajectory.xh - result.trajectory.z[:, :2]
    th = np.abs(_theta(result))
    theta = np.abs(_true(result))
    fig, (a1, a2) = plt.subplots(2, 1, figsize=(10, 6), sharex=True)
    plot_line(a1, t, np.abs(e[:, 0]), label="$|e_1|$ (rad)")
    plot_line(a1, t, np.abs(e[:, 1]), label="$|e_2|$ (rad/s)")
    for i in range(th.shape[1]):
        plot_line(a1, t, th[:, i] / theta[i],
                    label=rf"$|\tilde\theta_{i + 1}|/\theta_{i + 1}$ (–)")
    a1.set_ylabel("errors")
    a1.set_yscale("log")
    a1.legend(loc="upper right", ncol=2)
    lyap = _series(result, f"/observer/{obs.name}/lyapunov")
    plot_line(a2, t, lyap[:, 0], label="$V$ (18)")
    plot_line(a2, t, lyap[:, 1], "k--", label="$R^2$ (23)")
    a2.set_yscale("log")
    a2.set_ylabel("$V$, $R^2$ (–)")
    a2.set_xlabel("$t$ (s)")
    a2.legend(loc="upper right")
    panel_letters((a1, a2))
    a1.set_title(r"Dimassi et al. - errors, $V$ and the $D_R$ level (not a paper figure)")
    save_figure(fig, path)


def _true(result) -> np.ndarray:
    """theta from th^ and th^ - theta at t = 0."""
    k, obs = _cascade(result)
    za = result.experiment.system.z_slices[k + 1][0]
    blk = ac.unpack(obs.p)
    a = za + int(blk["N"]) + int(blk["n"])
    return result.trajectory.z[0, a:a + int(blk["q"])] - _theta(result)[0]


# --- what ``hgo reproduce`` runs ------------------------------------------------------------

PAPER_FIGURES = [
    PaperFigure("dhlm_example", {
        "fig1": "Evolution of the auxiliary output z12 and its estimate ẑ12 by the high gain "
                "observer (6).",
        "fig2": "Evolution of the state x1 and its estimate x̂1 by the adaptive observer (5) "
                "and adaptation law (7).",
        "fig3": "Evolution of the state x2 and its estimate x̂2 by the adaptive observer (5) "
                "and adaptation law (7).",
        "fig4": "The unknown parameter θ1 and its estimate θ̂1.",
        "fig5": "The unknown parameter θ2 and its estimate θ̂2.",
    }),
]
