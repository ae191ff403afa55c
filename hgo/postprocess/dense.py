"""Metrics from the integration, not from the output grid (issue 25, item 4).

A run made with ``SolverSettings.dense_steps`` carries its accepted steps with their
continuous extensions (:class:`hgo.engine.simulate.DenseRun`): every signal at any instant.
The functions here measure a scalar signal ``signal(traj) -> array`` (a function of the
run's signals sampled at some instants, e.g. ``lambda s: s.xh[:, 1] - s.z[:, 1]``) over a
window [a, b] from those steps only, so that the numbers do not move with ``dt_out``:

* :func:`integral`, :func:`mean`, :func:`rms`, :func:`std`: 3-point Gauss-Legendre on
  each step's part of the window (the rule the kernel's window metrics use,
  ``kernel_template._window_step``), pieces halved where the halves disagree (kinks);
* :func:`first_below`, :func:`settles_below`, :func:`fraction_above`: sign changes of
  ``signal - level`` between the scan points (step ends and the Gauss nodes of every
  step), each crossing located by bisection on the continuous extension (to 1e-12 s, all
  crossings of a window at once);
* :func:`maximum`: the largest scan point, refined by a bounded search on the continuous
  extension between its neighbours.

A crossing in and out again between two scan points of one step is not seen (the scan
has 4 points per step; the steps are short where the signals move).

:func:`steps_of` gives a trajectory's steps; a trajectory without them (an ensemble
member's record, RK4) gets :class:`GridRun`, its output samples joined by straight lines:
the same functions, measured on the grid.
"""

from __future__ import annotations

import math
from collections.abc import Callable

import numpy as np
from scipy.optimize import minimize_scalar

from hgo.engine.simulate import DenseRun, Trajectory

Signal = Callable[[Trajectory], np.ndarray]
NODES, WEIGHTS = np.polynomial.legendre.leggauss(3)  # on [-1, 1]
NODES01, WEIGHTS01 = 0.5 * (NODES + 1.0), 0.5 * WEIGHTS  # on [0, 1]
XTOL = 1e-12  # seconds: the crossing instants' tolerance
QTOL = 1e-9  # signal units: a piece's quadrature is accepted when its halves agree to QTOL
MAX_HALVINGS = 12


class GridRun:
    """A trajectory's output samples as a :class:`DenseRun`-like object: the signals
    interpolated linearly between the samples, the samples as the step ends."""

    FIELDS = ("z", "d", "y", "m", "u", "xh")

    def __init__(self, traj: Trajectory) -> None:
        self.traj = traj

    def at(self, ts: np.ndarray) -> Trajectory:
        tr = self.traj
        cols = {f: np.column_stack([np.interp(ts, tr.t, c) for c in getattr(tr, f).T])
                if getattr(tr, f).shape[1] else np.zeros((len(ts), 0)) for f in self.FIELDS}
        return Trajectory(np.asarray(ts, float), **cols, status=0,
                          t_stop=float(ts[-1]) if len(ts) else 0.0, acc=tr.acc)

    def boundaries(self, a: float, b: float) -> np.ndarray:
        t = self.traj.t
        return np.unique(np.concatenate([[a, b], t[(t > a) & (t < b)]]))


def steps_of(traj: Trajectory) -> DenseRun | GridRun:
    """The run's steps (``traj.dense``), or its output grid when it kept none."""
    return traj.dense if traj.dense is not None else GridRun(traj)


def _values(run: DenseRun, signal: Signal, ts: np.ndarray) -> np.ndarray:
    return np.asarray(signal(run.at(np.atleast_1d(np.asarray(ts, float)))), float)


def _at(run: DenseRun, signal: Signal, t: float) -> float:
    return float(_values(run, signal, np.array([t]))[0])


def _cached(run, key: tuple, make: Callable[[], tuple]) -> tuple:
    """``make()`` once per run and key (the signals sampled at a window's points serve
    every metric of that window)."""
    cache = run.__dict__.setdefault("_dense_samples", {})
    if key not in cache:
        cache[key] = make()
    return cache[key]


def _gauss(run: DenseRun, a: float, b: float) -> tuple[np.ndarray, np.ndarray, Trajectory]:
    """The Gauss nodes of every step's part of [a, b], their weights (sum: b - a) and the
    signals there."""
    def make():
        edges = run.boundaries(a, b)
        lo, width = edges[:-1], np.diff(edges)
        ts = (lo[:, None] + width[:, None] * NODES01[None, :]).ravel()
        return ts, (width[:, None] * WEIGHTS01[None, :]).ravel(), run.at(ts)

    return _cached(run, ("gauss", a, b), make)


def _halves(run: DenseRun, a: float, b: float) -> tuple[Trajectory, Trajectory]:
    """The signals at the Gauss nodes of both halves of every step's part of [a, b]: the
    first refinement of :func:`integral`, shared by every signal of the window."""
    def make():
        edges = run.boundaries(a, b)
        lo, half = edges[:-1], 0.5 * np.diff(edges)
        return tuple(run.at((start[:, None] + half[:, None] * NODES01[None, :]).ravel())
                     for start in (lo, lo + half))

    return _cached(run, ("halves", a, b), make)


def _scan(run: DenseRun, a: float, b: float) -> tuple[np.ndarray, Trajectory]:
    """The scan points of [a, b] (the step ends and each step's Gauss nodes, sorted) and
    the signals there."""
    def make():
        ts = np.union1d(run.boundaries(a, b), _gauss(run, a, b)[0])
        return ts, run.at(ts)

    return _cached(run, ("scan", a, b), make)


def _roots(run: DenseRun, signal: Signal, level: float, lo: np.ndarray,
           hi: np.ndarray) -> np.ndarray:
    """The crossings of ``level`` in the brackets [lo, hi] (signal - level changes sign
    across each), all at once: bisection on the continuous extension to XTOL."""
    lo, hi = np.array(lo, float), np.array(hi, float)
    g_lo = _values(run, signal, lo) - level
    while lo.size and np.max(hi - lo) > XTOL:
        mid = 0.5 * (lo + hi)
        g_mid = _values(run, signal, mid) - level
        left = np.sign(g_mid) == np.sign(g_lo)
        lo, g_lo = np.where(left, mid, lo), np.where(left, g_mid, g_lo)
        hi = np.where(left, hi, mid)
        if np.all(hi - lo <= XTOL):
            break
    return 0.5 * (lo + hi)


def _gauss_pieces(run: DenseRun, signal: Signal, lo: np.ndarray,
                  width: np.ndarray) -> np.ndarray:
    """3-point Gauss-Legendre integral of ``signal`` on each piece [lo, lo + width]."""
    ts = (lo[:, None] + width[:, None] * NODES01[None, :]).ravel()
    v = _values(run, signal, ts).reshape(lo.size, 3)
    return width * (v @ WEIGHTS01)


def integral(run: DenseRun, signal: Signal, a: float, b: float) -> float:
    """int_a^b signal dt: 3-point Gauss-Legendre on each step's part of [a, b], each piece
    halved until the halves agree with the whole to QTOL (signal units) times its length,
    at most MAX_HALVINGS times: the signals have kinks inside steps (saturations of an
    estimate), where one Gauss rule per step is off by O(h^2) of the slope's jump."""
    _, wts, s = _gauss(run, a, b)
    edges = run.boundaries(a, b)
    lo, width = edges[:-1], np.diff(edges)
    whole = (np.asarray(signal(s), float).reshape(lo.size, 3) @ WEIGHTS01) * width
    total = 0.0
    for level in range(MAX_HALVINGS):
        half = 0.5 * width
        if level == 0:  # every step's halves: sampled once for all signals of the window
            left, right = ((np.asarray(signal(h), float).reshape(lo.size, 3) @ WEIGHTS01)
                           * half for h in _halves(run, a, b))
        else:
            left = _gauss_pieces(run, signal, lo, half)
            right = _gauss_pieces(run, signal, lo + half, half)
        split = left + right
        done = np.abs(split - whole) <= QTOL * width
        total += float(np.sum(split[done]))
        if done.all():
            return total
        keep = ~done
        lo = np.concatenate([lo[keep], lo[keep] + half[keep]])
        width = np.concatenate([half[keep], half[keep]])
        whole = np.concatenate([left[keep], right[keep]])
    return total + float(np.sum(whole))


def mean(run: DenseRun, signal: Signal, a: float, b: float) -> float:
    """(1 / (b - a)) int_a^b signal dt (:func:`integral`)."""
    return integral(run, signal, a, b) / (b - a)


def rms(run: DenseRun, signal: Signal, a: float, b: float) -> float:
    """sqrt of the mean of signal^2 over [a, b]."""
    return math.sqrt(mean(run, lambda s: signal(s) ** 2, a, b))


def std(run: DenseRun, signal: Signal, a: float, b: float) -> float:
    """The standard deviation over [a, b] in time: sqrt(mean((s - mean s)^2))."""
    m = mean(run, signal, a, b)
    return math.sqrt(max(mean(run, lambda x: (signal(x) - m) ** 2, a, b), 0.0))


def first_below(run: DenseRun, signal: Signal, level: float, a: float, b: float) -> float:
    """The first t in [a, b] with signal(t) < level; NaN if none."""
    ts, s = _scan(run, a, b)
    below = np.flatnonzero(np.asarray(signal(s)) < level)
    if not below.size:
        return math.nan
    k = int(below[0])
    if k == 0:
        return float(ts[0])
    return float(_roots(run, signal, level, ts[k - 1:k], ts[k:k + 1])[0])


def settles_below(run: DenseRun, signal: Signal, level: float, a: float, b: float) -> float:
    """The first t in [a, b] after which signal < level up to b: the last up-crossing;
    NaN ("never") if the signal is >= level at b (it leaves the band before the end)."""
    ts, s = _scan(run, a, b)
    above = np.flatnonzero(np.asarray(signal(s)) >= level)
    if not above.size:
        return float(ts[0])
    k = int(above[-1])
    if k == ts.size - 1:
        return math.nan
    return float(_roots(run, signal, level, ts[k:k + 1], ts[k + 1:k + 2])[0])


def fraction_above(run: DenseRun, signal: Signal, level: float, a: float, b: float) -> float:
    """The share of [a, b] where signal > level (crossings located on the steps)."""
    ts, s = _scan(run, a, b)
    up = np.asarray(signal(s), float) > level
    dt = np.diff(ts)
    total = float(dt[up[:-1] & up[1:]].sum())
    change = np.flatnonzero(up[:-1] != up[1:])  # one crossing in each such interval
    roots = _roots(run, signal, level, ts[change], ts[change + 1])
    rising = up[change + 1]
    total += float(np.sum(np.where(rising, ts[change + 1] - roots, roots - ts[change])))
    return total / (b - a)


def maximum(run: DenseRun, signal: Signal, a: float, b: float) -> tuple[float, float]:
    """(max over [a, b] of signal, the instant): the largest scan point refined on the
    continuous extension between its neighbours."""
    ts, s = _scan(run, a, b)
    v = np.asarray(signal(s), float)
    k = int(np.argmax(v))
    lo, hi = ts[max(k - 1, 0)], ts[min(k + 1, ts.size - 1)]
    best_t, best = float(ts[k]), float(v[k])
    if hi > lo:
        res = minimize_scalar(lambda t: -_at(run, signal, t), bounds=(lo, hi),
                              method="bounded", options={"xatol": XTOL})
        if -res.fun > best:
            best_t, best = float(res.x), float(-res.fun)
    return best, best_t


def minimum(run: DenseRun, signal: Signal, a: float, b: float) -> tuple[float, float]:
    """(min over [a, b] of signal, the instant), as :func:`maximum`."""
    value, t = maximum(run, lambda s: -signal(s), a, b)
    return -value, t
