"""Andrieu, Praly & Astolfi (2007) Section 3.1 signals and metrics (Figs. 1-2, notes §8, §11).

``apa_metrics(...)`` returns a post-processor whose ``apply`` adds, for the Contois plant
(:mod:`hgo.plants.contois`) and every observer of :mod:`hgo.observers.homogeneous_dynamic`:

series
* ``/observer/<name>/Omega``: the bound Omega driving L, along the observer's own
  (u, y_s, x^2s) (Fig. 1, reading C12; constant df2max for the df2max observer);
* ``/observer/<name>/e_x2``: x^2 - x2_true, x2_true = eta1 eta2/(hbar eta1 + eta2) with the
  plant's hbar (the true reaction rate, reading C18; unsaturated x^2: peaking shows here);
* ``/apa/rate``: df2/dx2 along the true solution, with the plant's hbar (x = F_1(eta))
  and with the observers' hbar_o (x = F_hbar_o(eta)) (reading C11: both).

rows per observer (e = eta^2 - eta2, the Fig. 2 error; windows [a, b] of the integration)
``bias_late``, ``std_late`` (mean, std of e on ``late``), ``rms_post`` (``post``),
``bias_w<k>``, ``std_w<k>`` (steady window k = 1..4), ``peak_e_x2`` (max |e_x2| on
``transient``), ``t1_<thr>`` (first time |e| < thr, a zero crossing of e between scan
points included), ``ts_<thr>`` (settling: |e| < thr
from then until the end of ``transient``; NaN, "never", if |e| >= thr at its end),
``L0``, ``L_end``, ``min_L``,
``max_L`` (bound: max(L(0), phi2 + (phi3/phi1) df2max) for the Omega1 observer, from (8)
with Omega1 <= df2max (the mean-value theorem); none for the df2max observer, whose L is
that equilibrium itself (an identity, not a test), nor for Omega2, whose sup the paper does
not give), ``mean_Omega`` (over [0, T]),
``share_sat_high`` / ``share_sat_low`` (share of [0, T] with x^2 above x2hi(y_s) / below
x2lo(y_s)), and the set-up constants ``eps1``, ``eps2``, ``df2max`` in force;
rows of ``plant``: ``min_eta1``, ``min_eta2`` (invariance of M_eta), ``mean_rate_true``,
``mean_rate_model``, ``max_rate_true``, ``t_max_rate_true`` (df2/dx2 along the solution),
``mean_abs_rate_true``, ``mean_abs_rate_model`` (time means of |df2/dx2|).

Every row is measured from the integration's steps and their continuous extension, not
from the output grid (:mod:`hgo.postprocess.dense`: time means by Gauss-Legendre on each
step, crossings by root finding, maxima refined between the steps; NaN for a window
beyond the horizon): a test checks they do not move with ``solver.dt_out``. The series
are the output samples.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from hgo.engine.jit import kernel_helper
from hgo.engine.simulate import DenseRun, Trajectory
from hgo.engine.system import System
from hgo.observers import homogeneous_dynamic as hd
from hgo.outputs.recording import Series
from hgo.plants.contois import clip, df2_dx2, reaction_rate, x2_high, x2_low
from hgo.postprocess import PostOutput, dense
from hgo.postprocess.dense import steps_of

RATE = "/apa/rate"


def omega_series(p, u, y, xh2, out) -> None:
    """Omega of an observer with (Contois) parameters p along (u, y, x^2) samples (its f's
    Omega), into ``out``."""
    _omega_series(p.kind, p.q, p.hbar, p.eps1, p.eps2, p.df2max, u, y, xh2, out)


@kernel_helper
def _omega_series(kind, q, hbar, eps1, eps2, dfmax, u, y, xh2, out):
    for k in range(out.shape[0]):
        ys = clip(y[k], eps1, 1.0 - eps2)
        out[k] = hd.omega_now(kind, u[k], ys, xh2[k], q, hbar, eps2, dfmax)


@kernel_helper
def rate_series(eta1, eta2, u, hbar, out):
    """df2/dx2 at x = F_hbar(eta) along samples."""
    for k in range(out.shape[0]):
        out[k] = df2_dx2(eta1[k], reaction_rate(eta1[k], eta2[k], hbar), u[k], hbar)


def is_apa_observer(obs) -> bool:
    """The observer (7)-(8) on the Contois model (the rates below are that model's)."""
    return obs.f is hd.f and obs.p.model is hd.contois_model


def _span(ab: Sequence[float], t_stop: float) -> tuple[float, float] | None:
    """The window [a, b] cut at the run's end; None (NaN metrics) if it starts after it."""
    a, b = float(ab[0]), min(float(ab[1]), t_stop)
    return (a, b) if a < b else None


def _rates(s: Trajectory, hbar: float) -> np.ndarray:
    """df2/dx2 at x = F_hbar(eta) along the samples of ``s``."""
    out = np.empty(len(s.t))
    rate_series(np.ascontiguousarray(s.z[:, 0]), np.ascontiguousarray(s.z[:, 1]),
                np.ascontiguousarray(s.u[:, 0]), hbar, out)
    return out


def _own_steps(run, k: int, za: int, xa: int, held: dict) -> tuple[object, int, int]:
    """The steps observer ``k`` is measured on (of a split run, its part's own layout:
    :meth:`DenseRun.part`) and the first columns of its z and x^ there (``za``, ``xa``:
    in the whole layout). ``held``: the part runs made so far, one per part, so that the
    plant rows reuse the samples that measuring observer 0 took."""
    if not isinstance(run, DenseRun) or run.parts is None:
        return run, za, xa
    if k not in held:
        held[k] = run.part(k)
    part = held[k].system  # the plant and observer k alone
    return held[k], part.z_slices[1][0], part.xh_slices[0][0]


@dataclass(frozen=True)
class _ObserverSignals:
    """The signals of one observer (z columns from ``za``, estimate from ``xa``) as
    functions of sampled signals (:mod:`hgo.postprocess.dense`)."""

    p: np.ndarray
    za: int
    xa: int
    hbar: float  # the plant's

    def e(self, s: Trajectory) -> np.ndarray:  # eta^2 - eta2, the Fig. 2 error
        return s.xh[:, self.xa + 1] - s.z[:, 1]

    def abs_e(self, s: Trajectory) -> np.ndarray:
        return np.abs(self.e(s))

    def e_x2(self, s: Trajectory) -> np.ndarray:  # x^2 - x2_true (reading C18)
        eta1, eta2 = s.z[:, 0], s.z[:, 1]
        return s.z[:, self.za + 1] - eta1 * eta2 / (self.hbar * eta1 + eta2)

    def L(self, s: Trajectory) -> np.ndarray:
        return s.z[:, self.za + 2]

    def omega(self, s: Trajectory) -> np.ndarray:
        out = np.empty(len(s.t))
        omega_series(self.p, np.ascontiguousarray(s.u[:, 0]), np.ascontiguousarray(s.y[:, 0]),
                     np.ascontiguousarray(s.z[:, self.za + 1]), out)
        return out

    def _ys(self, s: Trajectory) -> np.ndarray:
        return np.clip(s.y[:, 0], self.p.eps1, 1.0 - self.p.eps2)

    def above_high(self, s: Trajectory) -> np.ndarray:  # > 0: x^2 above x2hi(y_s)
        return s.z[:, self.za + 1] - x2_high(self._ys(s), self.p.hbar)

    def below_low(self, s: Trajectory) -> np.ndarray:  # > 0: x^2 below x2lo(y_s)
        return x2_low(self._ys(s), self.p.eps2, self.p.hbar) - s.z[:, self.za + 1]


@dataclass
class APAMetrics:
    late: Sequence[float] = (40.0, 50.0)
    post: Sequence[float] = (10.0, 50.0)
    transient: Sequence[float] = (0.0, 10.0)
    steady: Sequence[Sequence[float]] = ((3.0, 10.0), (13.0, 20.0), (23.0, 35.0),
                                         (38.0, 50.0))
    thresholds: Sequence[float] = (0.1, 0.01)
    needs_steps = True  # metrics from the integration's steps (hgo.postprocess.dense)

    def check(self, system: System, solver, key: str) -> None:  # noqa: ARG002
        """Every window inside the run, before it (``post=[0, 100]`` of a 50 s run was
        measured over [0, 50] without a word)."""
        spans = {"late": self.late, "post": self.post, "transient": self.transient,
                 **{f"steady[{k}]": w for k, w in enumerate(self.steady)}}
        for name, (_, b) in spans.items():
            if b > solver.t_end + 1e-9:
                raise ValueError(f"{key}.{name} = {list(spans[name])} ends after "
                                 f"solver.t_end = {solver.t_end:g}")

    def apply(self, system: System, traj: Trajectory) -> PostOutput:
        run = steps_of(traj)
        hbar = system.plant.p.hbar
        out = PostOutput()
        rates = {"true": _rates(traj, hbar)}
        hbar_o = None
        rows = []
        parts = {}
        for k, (obs, (za, _), (xa, _)) in enumerate(zip(system.observers, system.z_slices[1:],
                                                        system.xh_slices, strict=True)):
            if not is_apa_observer(obs):
                continue
            if hbar_o is None:  # the observers' hbar_o (the first one's)
                hbar_o = obs.p.hbar
                rates["model"] = _rates(traj, hbar_o)
            sig = _ObserverSignals(obs.p, za, xa, hbar)
            omega = sig.omega(traj)
            out.series += [Series(f"/observer/{obs.name}/Omega", ["Omega"], omega[:, None]),
                           Series(f"/observer/{obs.name}/e_x2", ["e_x2"],
                                  sig.e_x2(traj)[:, None])]
            mine, za_own, xa_own = _own_steps(run, k, za, xa, parts)
            rows += self._observer_rows(obs, _ObserverSignals(obs.p, za_own, xa_own, hbar),
                                        mine, traj.t_stop)
        rate_names = [f"df2dx2_{k}" for k in rates]
        out.series.append(Series(RATE, rate_names, np.column_stack(list(rates.values()))))
        plant_run = _own_steps(run, 0, 0, 0, parts)[0]  # (part 0's plant)
        rows += self._plant_rows(plant_run, traj.t_stop, hbar, hbar_o)
        out.rows = rows
        return out

    def _window_rows(self, sig: _ObserverSignals, run, t_stop: float) -> dict:
        """Means, std and rms of e over the windows (Gauss on the steps; NaN beyond the
        horizon)."""
        vals = {}
        named = [("late", self.late), ("post", self.post),
                 *((f"w{k}", ab) for k, ab in enumerate(self.steady, start=1))]
        for name, ab in named:
            span = _span(ab, t_stop)
            if name == "post":
                vals["rms_post"] = dense.rms(run, sig.e, *span) if span else math.nan
                continue
            vals[f"bias_{name}"] = dense.mean(run, sig.e, *span) if span else math.nan
            vals[f"std_{name}"] = dense.std(run, sig.e, *span) if span else math.nan
        return vals

    def _observer_rows(self, obs, sig: _ObserverSignals, run, t_stop: float) -> list[dict]:
        """The rows of one observer, every one measured on the steps (the metrics of the
        run and of the transient each asked of one window, measured in one pass)."""
        p = obs.p
        whole = dense.Window(run, 0.0, t_stop)
        transient = dense.Window(run, *_span(self.transient, t_stop))
        vals = self._window_rows(sig, run, t_stop)
        vals["peak_e_x2"] = transient.maximum(lambda s: np.abs(sig.e_x2(s))).then(
            lambda m: m[0])
        for thr in self.thresholds:
            vals[f"t1_{thr:g}"] = whole.first_within(sig.e, thr)
        vals[f"ts_{min(self.thresholds):g}"] = transient.settles_below(
            sig.abs_e, min(self.thresholds))
        L_ends = sig.L(run.at(np.array([0.0, t_stop])))
        vals.update(L0=L_ends[0], L_end=L_ends[1],
                    min_L=whole.minimum(sig.L).then(lambda m: m[0]),
                    max_L=whole.maximum(sig.L).then(lambda m: m[0]),
                    mean_Omega=whole.mean(sig.omega),
                    share_sat_high=whole.fraction_above(sig.above_high, 0.0),
                    share_sat_low=whole.fraction_above(sig.below_low, 0.0))
        vals.update(eps1=p.eps1, eps2=p.eps2, df2max=p.df2max)
        rows = [{"observer": obs.name, "quantity": q, "empirical": float(_measured(v))}
                for q, v in vals.items()]
        if p.kind == 1:  # Omega1 <= df2max: L <= max(L(0), equilibrium at df2max); of the
            # df2max observer (Omega = df2max) L stays at that equilibrium: no test
            bound = max(L_ends[0], p.phi2 + p.phi3 / p.phi1 * p.df2max)
            rows[[r["quantity"] for r in rows].index("max_L")]["bound"] = bound
        return rows

    @staticmethod
    def _plant_rows(run, t_stop: float, hbar: float, hbar_o: float | None) -> list[dict]:
        whole = dense.Window(run, 0.0, t_stop)  # every row in one pass
        max_rate = whole.maximum(lambda s: _rates(s, hbar))
        vals = {"min_eta1": whole.minimum(lambda s: s.z[:, 0]).then(lambda m: m[0]),
                "min_eta2": whole.minimum(lambda s: s.z[:, 1]).then(lambda m: m[0]),
                "mean_rate_true": whole.mean(lambda s: _rates(s, hbar)),
                "max_rate_true": max_rate.then(lambda m: m[0]),
                "t_max_rate_true": max_rate.then(lambda m: m[1])}
        vals["mean_abs_rate_true"] = whole.mean(lambda s: np.abs(_rates(s, hbar)))
        if hbar_o is not None:
            vals["mean_rate_model"] = whole.mean(lambda s: _rates(s, hbar_o))
            vals["mean_abs_rate_model"] = whole.mean(lambda s: np.abs(_rates(s, hbar_o)))
        return [{"observer": "plant", "quantity": q, "empirical": float(_measured(v))}
                for q, v in vals.items()]


def _measured(v):
    """A row's value: measured (:class:`dense.Pending`) or a number."""
    return v.value if isinstance(v, dense.Pending) else v


def apa_metrics(late: Sequence[float] = (40.0, 50.0), post: Sequence[float] = (10.0, 50.0),
                transient: Sequence[float] = (0.0, 10.0),
                steady: Sequence[Sequence[float]] = ((3.0, 10.0), (13.0, 20.0), (23.0, 35.0),
                                                     (38.0, 50.0)),
                thresholds: Sequence[float] = (0.1, 0.01)) -> APAMetrics:
    """The post-processor; windows [a, b) in the paper's normalised time."""
    spans = {"late": late, "post": post, "transient": transient,
             **{f"steady[{k}]": w for k, w in enumerate(steady)}}
    for key, ab in spans.items():
        if len(ab) != 2 or not 0 <= ab[0] < ab[1]:
            raise ValueError(f"postprocess.apa.{key} must be [a, b] with 0 <= a < b, got "
                             f"{list(ab)}")
    if not thresholds or any(not v > 0 for v in thresholds):
        raise ValueError(f"postprocess.apa.thresholds must be > 0, got {list(thresholds)}")
    return APAMetrics(tuple(late), tuple(post), tuple(transient),
                      tuple(tuple(w) for w in steady), tuple(thresholds))
