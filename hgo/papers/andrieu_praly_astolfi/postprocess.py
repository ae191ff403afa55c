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

rows per observer (e = eta^2 - eta2, the Fig. 2 error; windows [a, b) on the output grid)
``bias_late``, ``std_late`` (mean, std of e on ``late``), ``rms_post`` (``post``),
``bias_w<k>``, ``std_w<k>`` (steady window k = 1..4), ``peak_e_x2`` (max |e_x2| on
``transient``), ``t1_<thr>`` (first time |e| < thr), ``ts_<thr>`` (settling: |e| < thr
from then until the end of ``transient``; NaN if never), ``L0``, ``L_end``, ``min_L``,
``max_L`` (bound: max(L(0), phi2 + (phi3/phi1) df2max) for the df2max and Omega1
observers, from (8) with Omega <= df2max: Omega1 <= df2max by the mean-value theorem; no
bound row for Omega2, whose sup the paper does not give), ``mean_Omega`` (over [0, T]),
``share_sat_high`` / ``share_sat_low`` (share of samples with x^2 above x2hi(y_s) / below
x2lo(y_s)), and the set-up constants ``eps1``, ``eps2``, ``df2max`` in force;
rows of ``plant``: ``min_eta1``, ``min_eta2`` (invariance of M_eta), ``mean_rate_true``,
``mean_rate_model``, ``max_rate_true``, ``t_max_rate_true`` (df2/dx2 along the solution).

Window means are sample means on the uniform output grid (NaN for a window beyond the
horizon); a test checks that dividing
``solver.dt_out`` by 10 changes them by < 1 %.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from hgo.engine.jit import kernel_helper
from hgo.engine.simulate import Trajectory
from hgo.engine.system import System
from hgo.observers import homogeneous_dynamic as hd
from hgo.outputs.recording import Series
from hgo.plants.contois import clip, df2_dx2, reaction_rate, x2_high, x2_low
from hgo.postprocess import PostOutput

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


def window(t: np.ndarray, ab: Sequence[float]) -> np.ndarray:
    """Mask of the samples in [a, b) (b = the horizon: [a, b])."""
    a, b = ab
    return (t >= a - 1e-9) & ((t < b - 1e-9) | (b >= t[-1] - 1e-9))


def _mean(x: np.ndarray) -> float:
    return float(x.mean()) if x.size else math.nan


def _std(x: np.ndarray) -> float:
    return float(x.std()) if x.size else math.nan


def first_below(t: np.ndarray, e: np.ndarray, thr: float) -> float:
    """First time |e| < thr (NaN if never)."""
    k = np.flatnonzero(np.abs(e) < thr)
    return float(t[k[0]]) if k.size else math.nan


def settling(t: np.ndarray, e: np.ndarray, thr: float, span: Sequence[float]) -> float:
    """The first time after which |e| < thr up to the end of ``span`` (NaN if not at its end)."""
    m = window(t, span)
    tt, ee = t[m], np.abs(e[m])
    above = np.flatnonzero(ee >= thr)
    if not above.size:
        return float(tt[0])
    return float(tt[above[-1] + 1]) if above[-1] + 1 < tt.size else math.nan


def is_apa_observer(obs) -> bool:
    """The observer (7)-(8) on the Contois model (the rates below are that model's)."""
    return obs.f is hd.f and obs.p.model is hd.contois_model


@dataclass
class APAMetrics:
    late: Sequence[float] = (40.0, 50.0)
    post: Sequence[float] = (10.0, 50.0)
    transient: Sequence[float] = (0.0, 10.0)
    steady: Sequence[Sequence[float]] = ((3.0, 10.0), (13.0, 20.0), (23.0, 35.0),
                                         (38.0, 50.0))
    thresholds: Sequence[float] = (0.1, 0.01)

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
        t, u, y = traj.t, np.ascontiguousarray(traj.u[:, 0]), np.ascontiguousarray(traj.y[:, 0])
        eta1, eta2 = (np.ascontiguousarray(traj.z[:, i]) for i in (0, 1))
        hbar = float(system.plant.p[0])
        x2_true = eta1 * eta2 / (hbar * eta1 + eta2)
        out = PostOutput()
        rates = {"true": np.empty_like(t)}
        rate_series(eta1, eta2, u, hbar, rates["true"])
        rows = []
        for obs, (za, _), (xa, _) in zip(system.observers, system.z_slices[1:],
                                         system.xh_slices, strict=True):
            if not is_apa_observer(obs):
                continue
            if "model" not in rates:  # the observers' hbar_o (the first one's)
                rates["model"] = np.empty_like(t)
                rate_series(eta1, eta2, u, obs.p.hbar, rates["model"])
            series, obs_rows = self._observer(obs, t, u, y, traj.z[:, za:za + 3],
                                              traj.xh[:, xa + 1] - eta2, x2_true)
            out.series += series
            rows += obs_rows
        rate_names = [f"df2dx2_{k}" for k in rates]
        out.series.append(Series(RATE, rate_names, np.column_stack(list(rates.values()))))
        rows += self._plant_rows(t, eta1, eta2, rates)
        out.rows = rows
        return out

    def _observer(self, obs, t, u, y, z, e, x2_true) -> tuple[list[Series], list[dict]]:
        """Series and rows of one observer (z = its [x^1, x^2, L] columns)."""
        p = obs.p
        xh2, L = np.ascontiguousarray(z[:, 1]), z[:, 2]
        omega = np.empty_like(t)
        omega_series(p, u, y, xh2, omega)
        e_x2 = xh2 - x2_true
        name = obs.name
        vals = {"bias_late": _mean(e[window(t, self.late)]),
                "std_late": _std(e[window(t, self.late)]),
                "rms_post": math.sqrt(_mean(e[window(t, self.post)] ** 2))}
        for k, ab in enumerate(self.steady, start=1):
            vals[f"bias_w{k}"] = _mean(e[window(t, ab)])
            vals[f"std_w{k}"] = _std(e[window(t, ab)])
        vals["peak_e_x2"] = np.abs(e_x2[window(t, self.transient)]).max()
        for thr in self.thresholds:
            vals[f"t1_{thr:g}"] = first_below(t, e, thr)
        vals[f"ts_{min(self.thresholds):g}"] = settling(t, e, min(self.thresholds),
                                                       self.transient)
        vals.update(L0=L[0], L_end=L[-1], min_L=L.min(), max_L=L.max(),
                    mean_Omega=omega.mean())
        hbar, eps1, eps2 = p.hbar, p.eps1, p.eps2
        ys = np.clip(y, eps1, 1.0 - eps2)
        vals["share_sat_high"] = np.mean(xh2 > x2_high(ys, hbar))  # (array arguments)
        vals["share_sat_low"] = np.mean(xh2 < x2_low(ys, eps2, hbar))
        vals.update(eps1=eps1, eps2=eps2, df2max=p.df2max)
        rows = [{"observer": name, "quantity": q, "empirical": float(v)} for q, v in vals.items()]
        if p.kind in (0, 1):  # Omega <= df2max: L <= max(L(0), equilibrium at df2max)
            bound = max(L[0], p.phi2 + p.phi3 / p.phi1 * p.df2max)
            rows[[r["quantity"] for r in rows].index("max_L")]["bound"] = bound
        series = [Series(f"/observer/{name}/Omega", ["Omega"], omega[:, None]),
                  Series(f"/observer/{name}/e_x2", ["e_x2"], e_x2[:, None])]
        return series, rows

    @staticmethod
    def _plant_rows(t, eta1, eta2, rates) -> list[dict]:
        k = int(np.argmax(rates["true"]))
        vals = {"min_eta1": eta1.min(), "min_eta2": eta2.min(),
                "mean_rate_true": rates["true"].mean(), "max_rate_true": rates["true"][k],
                "t_max_rate_true": t[k]}
        if "model" in rates:
            vals["mean_rate_model"] = rates["model"].mean()
        return [{"observer": "plant", "quantity": q, "empirical": float(v)}
                for q, v in vals.items()]


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
