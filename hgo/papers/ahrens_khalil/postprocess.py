"""Ahrens & Khalil (2008) Section 4 metrics: tracking error, switching log, ultimate bound.

``ak_metrics(transient, late_window)`` returns a post-processor whose ``apply`` adds

* the series ``/ak/tracking`` = [r', x2, e2] with the velocity tracking error
  e2 = x2 - r' of Figs. 1-3 (r' from the speed controller's reference; only when the
  controller is :mod:`hgo.controllers.dc_motor_speed`);
* metric rows (``observer`` = the observer that closes the loop, column ``closed_loop``):
  ``max_abs_e2_transient`` (max |e2| over [0, transient], claim 2),
  ``rms_e2_late`` and ``max_abs_e2_late`` (over the trailing window
  [t_end - late_window, t_end], claim 3);
* per observer with the switching discrete state of :mod:`hgo.observers.switched_hgo`:
  ``n_switches`` (the kernel's exact count, both directions), ``t_enter_first`` (first entry
  of y - x^1 into [-delta, delta]), ``t_switch_first`` / ``t_switch_last`` (gain changes;
  NaN if none), ``zone_time_at_first_switch`` (time spent in the zone when the first switch
  happened, >= T_d by rule 3);
* per observer: ``ultimate_bound_err`` = max over the late window of ||x - x^|| (Euclidean
  over the estimated states; the measured counterpart of the bound (25)) and
  ``rms_err_x2_late`` (RMS of x^2 - x2 there), both from the kernel's window metrics,
  taken at every integration step (the late window must be ``metrics.window``).

e2 metrics are on the output grid (the presets' dt_out = 5e-5 s, 16 samples per noise
hold: dividing it by 10 changes them by < 0.1 %, tests/test_ak_claims.py); the switch and
entry times are read from the observer's discrete state (exact step boundaries). A count
of switches is exact even when several happen between two output samples;
``t_switch_first`` is then the last of those.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from hgo.core.errors import ConfigError
from hgo.engine.simulate import Trajectory
from hgo.engine.system import System
from hgo.observers.switched_hgo import DISC_NAMES
from hgo.outputs.metrics import window_max_error, window_means
from hgo.outputs.recording import Series
from hgo.postprocess import PostOutput

TRACKING = "/ak/tracking"
_SWITCH_NAMES = tuple(DISC_NAMES)


def tracking_error(system: System, t: np.ndarray, x2: np.ndarray):
    """(r', e2 = x2 - r') for the speed controller, or None for any other controller."""
    ctrl = system.controller
    if ctrl is None or getattr(ctrl.u, "__module__", "") != "hgo.controllers.dc_motor_speed":
        return None
    from hgo.controllers.dc_motor_speed import velocity_reference

    rd, _ = velocity_reference(ctrl.p, t)
    return rd, x2 - rd


def switch_log(d: np.ndarray) -> dict[str, float]:
    """n_switches, first entry, first/last switch and zone time at the first switch.

    ``d``: the observer's discrete state on the output grid, columns ``DISC_NAMES``.
    """
    g, _, t_enter, _, n_sw, t_sw = range(6)
    out = {"n_switches": float(d[-1, n_sw]), "t_enter_first": math.nan,
           "t_switch_first": math.nan, "t_switch_last": math.nan,
           "zone_time_at_first_switch": math.nan}
    inside = np.flatnonzero(d[:, t_enter] >= 0)
    if inside.size:
        out["t_enter_first"] = float(d[inside[0], t_enter])
    switched = np.flatnonzero(d[:, n_sw] >= 1)
    if switched.size:
        k = switched[0]
        out["t_switch_first"] = float(d[k, t_sw])
        out["t_switch_last"] = float(d[-1, t_sw])
        if d[k, g] > 1.5 and d[k, t_enter] >= 0:  # on H2, still in the zone entered then
            out["zone_time_at_first_switch"] = float(d[k, t_sw] - d[k, t_enter])
    return out


@dataclass
class AKMetrics:
    transient: float = 0.5
    late_window: float = 1.0

    def __post_init__(self) -> None:
        for key in ("transient", "late_window"):
            if not getattr(self, key) > 0:
                raise ValueError(f"postprocess.ak_metrics.{key} must be in (0, inf) seconds, "
                                 f"got {getattr(self, key)}")

    def check(self, system: System, solver, key: str) -> None:
        """Both windows inside the run, before it starts (a longer one would be clipped);
        the late window is the kernel's metrics window (its error metrics come from it)."""
        if not math.isclose(self.late_window, solver.t_window, rel_tol=1e-12):
            raise ConfigError(f"{key}.late_window", f"{self.late_window} s differs from "
                              f"metrics.window = {solver.t_window} s, the window of the "
                              "kernel's error metrics", "metrics.window: "
                              "${" + key + ".late_window}")
        for name in ("transient", "late_window"):
            if getattr(self, name) > solver.t_end:
                raise ConfigError(f"{key}.{name}", f"{getattr(self, name)} s is longer than "
                                  f"the run (solver.t_end = {solver.t_end})",
                                  f"(0, {solver.t_end}]")

    def apply(self, system: System, traj: Trajectory) -> PostOutput:
        t = traj.t
        if self.late_window > t[-1] or self.transient > t[-1]:
            raise ValueError(f"postprocess.ak_metrics: windows (transient={self.transient}, "
                             f"late_window={self.late_window}) exceed t_end={t[-1]:g}")
        out = PostOutput()
        first = t <= self.transient + 1e-12
        late = t >= t[-1] - self.late_window - 1e-12
        plant = system.plant
        x = traj.z[:, : plant.nx]
        track = tracking_error(system, t, x[:, 1]) if plant.nx >= 2 else None
        loop = None
        if system.controller is not None:
            loop = system.observers[system.controlled_observer()].name
        if track is not None:
            rd, e2 = track
            out.series.append(Series(TRACKING, ["r_dot", "x2", "e2"],
                                     np.column_stack([rd, x[:, 1], e2])))
            for quantity, value in (
                    ("max_abs_e2_transient", np.max(np.abs(e2[first]))),
                    ("rms_e2_late", np.sqrt(np.mean(e2[late] ** 2))),
                    ("max_abs_e2_late", np.max(np.abs(e2[late])))):
                out.rows.append({"observer": loop, "quantity": quantity,
                                 "empirical": float(value), "closed_loop": loop})
        for obs, (da, db) in zip(system.observers, system.d_slices, strict=True):
            if tuple(obs.disc_names) == _SWITCH_NAMES:
                for quantity, value in switch_log(traj.d[:, da:db]).items():
                    out.rows.append({"observer": obs.name, "quantity": quantity,
                                     "empirical": value, "closed_loop": loop})
            # from the kernel's window metrics (every integration step, not the output
            # grid, whose instants fall on the noise jumps when dt_out = the noise hold)
            out.rows.append({"observer": obs.name, "quantity": "ultimate_bound_err",
                             "empirical": window_max_error(system, traj.acc)[obs.name],
                             "closed_loop": loop})
            if 1 in obs.estimated_states:
                x2 = system.plant.state_names[1]
                mean_sq = window_means(system, traj.acc)[(obs.name, f"mean_sq_error_{x2}")]
                out.rows.append({"observer": obs.name, "quantity": "rms_err_x2_late",
                                 "empirical": float(np.sqrt(mean_sq)), "closed_loop": loop})
        return out


def ak_metrics(transient: float = 0.5, late_window: float = 1.0) -> AKMetrics:
    """Factory of the ``postprocess`` group
    (``_target_: hgo.papers.ahrens_khalil.postprocess.ak_metrics``)."""
    return AKMetrics(float(transient), float(late_window))


# --- noise trade-off (25) over a sweep ------------------------------------------------------


def grid_minimiser(eps: np.ndarray, bound: np.ndarray) -> float:
    """Model-free eps*: parabola through log(bound) vs log(eps) at the grid argmin and its
    two neighbours; NaN when the minimum sits on the edge of the grid (not bracketed)."""
    order = np.argsort(eps)
    eps, bound = np.asarray(eps, float)[order], np.asarray(bound, float)[order]
    k = int(np.argmin(bound))
    if k == 0 or k == eps.size - 1:
        return math.nan
    c = np.polyfit(np.log(eps[k - 1:k + 2]), np.log(bound[k - 1:k + 2]), 2)
    return float(math.exp(-c[1] / (2 * c[0]))) if c[0] > 0 else float(eps[k])


@dataclass
class TradeoffAnalysis:
    """Fits of Ahrens & Khalil (25) to measured ultimate bounds.

    ``global_fit``: one (c1, c2) for all points; ``per_mu``: rows (mu, n, c1, c2,
    rms_residual, eps_star_fit = ((r-1) mu c2/c1)^(1/r) of that mu's own fit,
    eps_star_grid = :func:`grid_minimiser`); ``power_fit`` / ``power_grid``: eps* = C mu^q
    (OLS on log-log, with the standard error of q) for the two eps* estimates. The power
    law is fitted to per-mu fits, not to the global one (whose minimiser is mu^(1/r) by
    construction).
    """

    r: int
    global_fit: object
    per_mu: list[dict]
    power_fit: object
    power_grid: object


def analyse_tradeoff(eps, mu, bound, r: int) -> TradeoffAnalysis:
    from hgo.papers.ahrens_khalil.design import fit_power_law, fit_ultimate_bound, optimal_eps

    eps, mu, bound = (np.asarray(v, float).ravel() for v in (eps, mu, bound))
    ok = np.isfinite(bound) & (bound > 0)
    eps, mu, bound = eps[ok], mu[ok], bound[ok]
    global_fit = fit_ultimate_bound(eps, mu, bound, r)
    per_mu = []
    for m in np.unique(mu):
        sel = mu == m
        row = {"mu": float(m), "n": int(sel.sum()), "c1": math.nan, "c2": math.nan,
               "rms_residual": math.nan, "eps_star_fit": math.nan,
               "eps_star_grid": grid_minimiser(eps[sel], bound[sel])}
        if sel.sum() >= 3 and np.unique(eps[sel]).size >= 2:
            fit = fit_ultimate_bound(eps[sel], mu[sel], bound[sel], r)
            row.update(c1=fit.c1, c2=fit.c2, rms_residual=fit.rms_residual)
            if fit.c1 > 0 and fit.c2 > 0:
                row["eps_star_fit"] = float(optimal_eps(m, fit.c1, fit.c2, r))
        per_mu.append(row)

    def power(key):
        pts = [(p["mu"], p[key]) for p in per_mu if math.isfinite(p[key])]
        if len(pts) < 3:
            return None
        return fit_power_law(*zip(*pts, strict=True))

    return TradeoffAnalysis(r, global_fit, per_mu, power("eps_star_fit"),
                            power("eps_star_grid"))
