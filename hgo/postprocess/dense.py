"""Metrics from the integration, not from the output grid (issue 25, item 4).

A run made with ``SolverSettings.dense_steps`` carries its accepted steps with their
continuous extensions (:class:`hgo.engine.simulate.DenseRun`): every signal at any instant.
The functions here measure a scalar signal ``signal(traj) -> array`` (a function of the
run's signals sampled at some instants, e.g. ``lambda s: s.xh[:, 1] - s.z[:, 1]``) over a
window [a, b] from those steps only, so that the numbers do not move with ``dt_out``:

* :func:`integral`, :func:`mean`, :func:`rms`, :func:`std`: 3-point Gauss-Legendre on
  each step's part of the window (the rule the kernel's window metrics use,
  ``kernel_template._window_step``), pieces halved where the halves disagree (kinks);
  :class:`Cumulative` (the integral up to any instant) by the same rule, and on it
  :func:`window_mean_max` (the largest sliding-window mean) and :func:`max_rise`;
* :func:`first_below`, :func:`first_within`, :func:`settles_below`,
  :func:`fraction_above`: sign changes of ``signal - level`` (:func:`first_within`: of
  the signal too, whose zero crossing passes through the band) between the scan points
  (step ends and the Gauss nodes of every step), each crossing located by bisection on
  the continuous extension (to 1e-12 s, all crossings of a window at once);
* :func:`maximum`: the largest scan point, refined by a bounded search on the continuous
  extension between its neighbours.

A crossing in and out again between two scan points of one step is not seen (the scan
has 4 points per step; the steps are short where the signals move).

Long runs (issue 41, item 5): a :class:`Window` measures every metric asked of it in one
pass over its steps, :data:`CHUNK_STEPS` at a time; what a metric keeps between chunks
is a number, or one value or flag per step or scan point, so memory per output sample
does not grow with the horizon and the samples are taken once for all metrics of a
window. The numbers are those of the whole window at once, bit for bit (each step's
part is computed from its own samples; sums are taken over the whole window's per-step
values). The functions below each make a window of one metric; a post-processor with
many metrics of one long window asks them of one :class:`Window`
(:mod:`hgo.papers.dimassi.postprocess`).

:func:`steps_of` gives a trajectory's steps; a trajectory without them (an ensemble
member's record, RK4) gets :class:`GridRun`, its output samples joined by straight lines:
the same functions, measured on the grid.
"""

from __future__ import annotations

import math
import weakref
from collections.abc import Callable
from dataclasses import dataclass
from types import MethodType

import numpy as np

from hgo.core.scalar_min import bounded_minimum
from hgo.engine.simulate import DenseRun, Trajectory

Signal = Callable[[Trajectory], np.ndarray]
NODES, WEIGHTS = np.polynomial.legendre.leggauss(3)  # on [-1, 1]
NODES01, WEIGHTS01 = 0.5 * (NODES + 1.0), 0.5 * WEIGHTS  # on [0, 1]
XTOL = 1e-12  # seconds: the crossing instants' tolerance
# a piece's quadrature is accepted when its halves agree to QTOL times its length (signal
# units) or to QTOL of its integral: a signal that grows over a long run (a drifting state,
# a squared error) is resolved to the same relative accuracy, not to ever more halvings.
# An absolute tolerance alone made dhlm_example's RMS errors over t_end = 2000 s halve
# nearly every step (21.6 M samples against 0.32 M at 200 s: 68x for 10x the horizon).
QTOL = 1e-9
MAX_HALVINGS = 12
# steps a window is sampled at a time (Window): ~4 scan points and 6 half-step Gauss nodes
# a step, 17 signal columns each for dhlm_example: ~6 MB of samples a chunk
CHUNK_STEPS = 1 << 12


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


def release(run: DenseRun, a: float, b: float) -> None:
    """Drop what is kept for the window [a, b] (its step ends; for a window of one chunk, its
    scan points and samples): a post-processor done with a window frees them. Asked for
    again, they are computed again, the same."""
    cache = run.__dict__.get("_dense_samples", {})
    for kind in ("edges", "scan", "samples"):
        cache.pop((kind, a, b), None)


def _edges(run: DenseRun, a: float, b: float) -> np.ndarray:
    """``run.boundaries(a, b)``, once per run and window (every metric of a window asks)."""
    return _cached(run, ("edges", a, b), lambda: (run.boundaries(a, b),))[0]


def _gauss_nodes(lo: np.ndarray, width: np.ndarray) -> np.ndarray:
    """The Gauss nodes of the pieces [lo, lo + width] (3 a piece, in order)."""
    return (lo[:, None] + width[:, None] * NODES01[None, :]).ravel()


def _scan_points(run: DenseRun, a: float, b: float) -> np.ndarray:
    """The scan points of [a, b]: the step ends and each step's Gauss nodes, sorted (8 bytes
    each, 4 a step: kept on the run for a window of one chunk, whose samples are kept too).
    Each step's nodes lie inside it, so they are its end and nodes in turn (``np.union1d``
    where rounding makes two points meet: a step of a few ulp)."""
    def make():
        edges = _edges(run, a, b)
        nodes = _gauss_nodes(edges[:-1], np.diff(edges))
        ts = np.empty(edges.size + nodes.size)
        ts[::4], ts[1::4], ts[2::4], ts[3::4] = edges, nodes[::3], nodes[1::3], nodes[2::3]
        return (ts if np.all(ts[1:] > ts[:-1]) else np.union1d(edges, nodes),)

    if _edges(run, a, b).size - 1 <= CHUNK_STEPS:
        return _cached(run, ("scan", a, b), make)[0]
    return make()[0]


@dataclass
class _Chunk:
    """Steps ``p0 .. p0 + len(lo) - 1`` of a window (pieces [lo, lo + width]) and the
    signals at their scan points: ``s`` at the scan points ``j0 ..`` of the window, of which
    the first ``own`` are this chunk's (the next is the following chunk's first step end,
    sampled too in case a Gauss node rounds onto it); ``at``: the Gauss nodes' rows of
    ``s``; ``halves``: the signals at the Gauss nodes of both halves of every piece (for
    integrals; None when no request integrates)."""

    run: DenseRun
    p0: int
    lo: np.ndarray
    width: np.ndarray
    j0: int
    own: int
    s: Trajectory
    at: np.ndarray
    halves: tuple[Trajectory, Trajectory] | None


class Window:
    """Metrics of ``signal``s over the window [a, b] of a run, measured in one pass over its
    steps, :data:`CHUNK_STEPS` at a time: every metric asked for (:meth:`maximum`,
    :meth:`integral`, ...) returns a :class:`Pending`; the first value read measures every
    metric asked for until then, sampling each chunk's scan points (and, for integrals, its
    half-step Gauss nodes) once for all of them. What a metric keeps between chunks is a
    number, or one flag or value per step (integrals, shares): the samples of a long
    window are never all held at once (a 2000 s DHLM run: 2.1 M scan points, 0.29 GB of
    samples a window). A window of one chunk keeps its samples on the run, for the next
    :class:`Window` of it (the functions below make one per metric)."""

    def __init__(self, run: DenseRun, a: float, b: float) -> None:
        self.run, self.a, self.b = run, float(a), float(b)
        self.todo: list[_Request] = []

    def _ask(self, request: _Request) -> Pending:
        self.todo.append(request)
        return Pending(self, request)

    def maximum(self, signal: Signal) -> Pending:
        """(max over [a, b] of signal, the instant): the largest scan point, refined on the
        continuous extension between its neighbours."""
        return self._ask(_Maximum(signal))

    def minimum(self, signal: Signal) -> Pending:
        """(min over [a, b] of signal, the instant), as :meth:`maximum`."""
        return self.maximum(lambda s: -signal(s)).then(lambda m: (-m[0], m[1]))

    def integral(self, signal: Signal) -> Pending:
        """int_a^b signal dt (:func:`integral`)."""
        return self._ask(_Integral(signal))

    def mean(self, signal: Signal) -> Pending:
        """(1 / (b - a)) int_a^b signal dt."""
        return self.integral(signal).then(lambda v: v / (self.b - self.a))

    def rms(self, signal: Signal) -> Pending:
        """sqrt of the mean of signal^2 over [a, b]."""
        return self.mean(lambda s: signal(s) ** 2).then(math.sqrt)

    def settles_below(self, signal: Signal, level: float) -> Pending:
        """:func:`settles_below`."""
        return self._ask(_SettlesBelow(signal, level))

    def first_below(self, signal: Signal, level: float) -> Pending:
        """:func:`first_below`."""
        return self._ask(_FirstBelow(signal, level))

    def fraction_above(self, signal: Signal, level: float) -> Pending:
        """:func:`fraction_above`."""
        return self._ask(_FractionAbove(signal, level))

    def first_within(self, signal: Signal, level: float) -> Pending:
        """:func:`first_within` (one number kept per scan point)."""
        return self.values(signal).then(
            lambda tv: _first_within(self.run, signal, level, *tv))

    def values(self, signal: Signal) -> Pending:
        """(the scan points, signal at each): one number kept per scan point."""
        return self._ask(_Values(signal))

    def size(self) -> int:
        """The window's scan points, at most (4 a step, and b)."""
        return 4 * (_edges(self.run, self.a, self.b).size - 1) + 1

    def measure(self) -> None:
        """Measure every metric asked for and not yet measured, in one pass."""
        todo, self.todo = self.todo, []
        if not todo:
            return
        ts = _scan_points(self.run, self.a, self.b)
        steps = _edges(self.run, self.a, self.b).size - 1
        for request in todo:
            request.start(ts, steps)
        halves = any(r.integrates for r in todo)
        for chunk in self._chunks(ts, halves):
            for request in todo:
                request.update(chunk)
        for request in todo:
            request.finish(self.run, ts)
        if steps > CHUNK_STEPS:  # (a window of one chunk keeps its samples for the next)
            release(self.run, self.a, self.b)

    def _chunks(self, ts: np.ndarray, halves: bool):
        edges = _edges(self.run, self.a, self.b)
        pieces = edges.size - 1
        for p0 in range(0, max(pieces, 1), CHUNK_STEPS):  # (a window of no step: its point)
            p1 = min(p0 + CHUNK_STEPS, pieces)
            j0 = int(np.searchsorted(ts, edges[p0]))
            j1 = int(np.searchsorted(ts, edges[p1])) if p1 < pieces else ts.size
            lo, width = edges[p0:p1], np.diff(edges[p0:p1 + 1])
            s, halved = self._samples(ts[j0:min(j1 + 1, ts.size)], lo, width, halves,
                                      single=pieces <= CHUNK_STEPS)
            at = np.searchsorted(ts[j0:j1 + 1], _gauss_nodes(lo, width))
            yield _Chunk(self.run, p0, lo, width, j0, j1 - j0, s, at, halved)

    def _samples(self, ts: np.ndarray, lo: np.ndarray, width: np.ndarray, halves: bool,
                 single: bool) -> tuple[Trajectory, tuple | None]:
        """The signals at the chunk's scan points and (``halves``) at the Gauss nodes of
        both halves of its pieces; a window of one chunk (``single``) keeps them."""
        def sample(kept: tuple | None) -> tuple:
            s = kept[0] if kept else self.run.at(ts)
            half = 0.5 * width
            halved = (kept[1] if kept and kept[1] is not None else
                      tuple(self.run.at(_gauss_nodes(start, half)) for start in (lo, lo + half))
                      if halves else None)
            return s, halved

        if not single:
            return sample(None)
        cache = self.run.__dict__.setdefault("_dense_samples", {})
        key = ("samples", self.a, self.b)
        kept = cache.get(key)
        if kept is None or (halves and kept[1] is None):
            cache[key] = kept = sample(kept)
        return kept


class Pending:
    """A metric of a :class:`Window`: ``value`` measures the window (with every metric asked
    for until then) the first time it is read; ``then(fn)``: ``fn(value)``, pending too."""

    def __init__(self, window: Window, request: _Request,
                 fn: Callable[[object], object] | None = None) -> None:
        self.window, self.request, self.fn = window, request, fn

    @property
    def value(self):
        if not self.request.done:
            self.window.measure()
        return self.request.result if self.fn is None else self.fn(self.request.result)

    def then(self, fn: Callable[[object], object]) -> Pending:
        inner = self.fn
        return Pending(self.window, self.request,
                       fn if inner is None else (lambda v: fn(inner(v))))


class _Request:
    """One metric of a window: ``start(ts, steps)`` (the window's scan points and number of
    steps), ``update(chunk)`` per chunk in order, ``finish(run, ts)`` sets ``result``."""

    integrates = False

    def __init__(self, signal: Signal) -> None:
        self.signal, self.done, self.result = signal, False, None

    def start(self, ts: np.ndarray, steps: int) -> None:
        pass

    def values(self, chunk: _Chunk) -> np.ndarray:
        """The signal at the chunk's own scan points."""
        return np.asarray(self.signal(chunk.s), float)[:chunk.own]

    def update(self, chunk: _Chunk) -> None:
        raise NotImplementedError

    def finish(self, run: DenseRun, ts: np.ndarray) -> None:
        self.result, self.done = self.outcome(run, ts), True

    def outcome(self, run: DenseRun, ts: np.ndarray):
        raise NotImplementedError


class _Maximum(_Request):
    """The first largest scan point (NaN first, as ``np.argmax``), refined."""

    def start(self, ts: np.ndarray, steps: int) -> None:
        self.k, self.best = -1, -math.inf

    def update(self, chunk: _Chunk) -> None:
        v = self.values(chunk)
        if not v.size:
            return
        k = int(np.argmax(v))
        if self.k < 0 or v[k] > self.best or (math.isnan(v[k]) and not math.isnan(self.best)):
            self.k, self.best = chunk.j0 + k, float(v[k])

    def outcome(self, run: DenseRun, ts: np.ndarray) -> tuple[float, float]:
        k, best, signal = self.k, self.best, self.signal
        lo, hi = ts[max(k - 1, 0)], ts[min(k + 1, ts.size - 1)]
        best_t = float(ts[k])
        if hi > lo:
            t, neg = bounded_minimum(lambda t: -_at(run, signal, t), lo, hi, xatol=XTOL)
            if -neg > best:
                best_t, best = float(t), float(-neg)
        return best, best_t


class _Integral(_Request):
    """:func:`integral`'s rule on every step's part of the window, kept per step and summed
    at the end (the same sum, in the same order, as over the whole window at once)."""

    integrates = True

    def start(self, ts: np.ndarray, steps: int) -> None:
        self.pieces = np.zeros(steps)

    def update(self, chunk: _Chunk) -> None:
        gauss = np.asarray(self.signal(chunk.s), float)[chunk.at]
        whole = (gauss.reshape(chunk.lo.size, 3) @ WEIGHTS01) * chunk.width
        self.pieces[chunk.p0:chunk.p0 + chunk.lo.size] = _refine(
            chunk.run, self.signal, chunk.lo, chunk.width, whole, chunk.halves)

    def outcome(self, run: DenseRun, ts: np.ndarray) -> float:
        pieces, self.pieces = self.pieces, None
        return float(np.sum(pieces))


class _SettlesBelow(_Request):
    """The last scan point at or above ``level``."""

    def __init__(self, signal: Signal, level: float) -> None:
        super().__init__(signal)
        self.level, self.last = level, -1

    def update(self, chunk: _Chunk) -> None:
        above = np.flatnonzero(self.values(chunk) >= self.level)
        if above.size:
            self.last = chunk.j0 + int(above[-1])

    def outcome(self, run: DenseRun, ts: np.ndarray) -> float:
        k = self.last
        if k < 0:
            return float(ts[0])
        if k == ts.size - 1:
            return math.nan
        return float(_roots(run, self.signal, self.level, ts[k:k + 1], ts[k + 1:k + 2])[0])


class _FirstBelow(_Request):
    """The first scan point below ``level``."""

    def __init__(self, signal: Signal, level: float) -> None:
        super().__init__(signal)
        self.level, self.first = level, -1

    def update(self, chunk: _Chunk) -> None:
        if self.first >= 0:
            return
        below = np.flatnonzero(self.values(chunk) < self.level)
        if below.size:
            self.first = chunk.j0 + int(below[0])

    def outcome(self, run: DenseRun, ts: np.ndarray) -> float:
        k = self.first
        if k < 0:
            return math.nan
        if k == 0:
            return float(ts[0])
        return float(_roots(run, self.signal, self.level, ts[k - 1:k], ts[k:k + 1])[0])


class _FractionAbove(_Request):
    """Whether the signal is above ``level`` at each scan point (one byte a point)."""

    def __init__(self, signal: Signal, level: float) -> None:
        super().__init__(signal)
        self.level = level

    def start(self, ts: np.ndarray, steps: int) -> None:
        self.up = np.zeros(ts.size, bool)

    def update(self, chunk: _Chunk) -> None:
        self.up[chunk.j0:chunk.j0 + chunk.own] = self.values(chunk) > self.level

    def outcome(self, run: DenseRun, ts: np.ndarray) -> float:
        (up, self.up), dt = (self.up, None), np.diff(ts)
        total = float(dt[up[:-1] & up[1:]].sum())
        change = np.flatnonzero(up[:-1] != up[1:])  # one crossing in each such interval
        roots = _roots(run, self.signal, self.level, ts[change], ts[change + 1])
        rising = up[change + 1]
        total += float(np.sum(np.where(rising, ts[change + 1] - roots, roots - ts[change])))
        return total / (float(ts[-1]) - float(ts[0]))  # (b - a)


class _Values(_Request):
    """The signal at every scan point (8 bytes a point)."""

    def start(self, ts: np.ndarray, steps: int) -> None:
        self.v = np.empty(ts.size)

    def update(self, chunk: _Chunk) -> None:
        self.v[chunk.j0:chunk.j0 + chunk.own] = self.values(chunk)

    def outcome(self, run: DenseRun, ts: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        return ts, self.v


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


def _refine(run: DenseRun, signal: Signal, lo: np.ndarray, width: np.ndarray,
            whole: np.ndarray, halves: tuple[Trajectory, Trajectory] | None = None
            ) -> np.ndarray:
    """The integral of ``signal`` on each piece [lo, lo + width] whose one-rule value is
    ``whole``: each piece halved until its halves agree with it to QTOL (signal units)
    times its length or to QTOL of its integral, at most MAX_HALVINGS times (``halves``:
    the signals at the Gauss nodes of the first halves, already sampled)."""
    out = np.zeros(lo.size)
    owner = np.arange(lo.size)  # the piece each sub-piece belongs to
    for level in range(MAX_HALVINGS):
        if not lo.size:
            return out
        half = 0.5 * width
        if level == 0 and halves is not None:
            left, right = ((np.asarray(signal(h), float).reshape(lo.size, 3) @ WEIGHTS01)
                           * half for h in halves)
        else:
            left = _gauss_pieces(run, signal, lo, half)
            right = _gauss_pieces(run, signal, lo + half, half)
        split = left + right
        done = np.abs(split - whole) <= QTOL * np.maximum(width, np.abs(split))
        np.add.at(out, owner[done], split[done])
        keep = ~done
        lo = np.concatenate([lo[keep], lo[keep] + half[keep]])
        width = np.concatenate([half[keep], half[keep]])
        whole = np.concatenate([left[keep], right[keep]])
        owner = np.concatenate([owner[keep], owner[keep]])
    np.add.at(out, owner, whole)
    return out


def integral(run: DenseRun, signal: Signal, a: float, b: float) -> float:
    """int_a^b signal dt: 3-point Gauss-Legendre on each step's part of [a, b], each piece
    halved until the halves agree with the whole to QTOL (signal units) times its length
    or to QTOL of its integral, at most MAX_HALVINGS times: the signals have kinks inside
    steps (saturations of an estimate), where one Gauss rule per step is off by O(h^2) of
    the slope's jump.

    A signal that is a bound method (the same method of the same object) is integrated
    once per run and window: :func:`std` integrates the signal whose :func:`mean` a caller
    has just taken."""
    if isinstance(signal, MethodType):
        return _cached(run, ("integral", signal, a, b),
                       lambda: (Window(run, a, b).integral(signal).value,))[0]
    return Window(run, a, b).integral(signal).value


class Cumulative:
    """I(t) = int_a^t signal for any t in [a, b], from the steps: :func:`integral`'s rule on
    every step's part of [a, b] (summed into I at the step ends), plus the same rule on
    [last step end, t] (a piece of one step: the extension is smooth there but for kinks,
    which the halving resolves). Each value is the integral to about QTOL (b - a), for any
    t, whatever the output grid."""

    def __init__(self, run: DenseRun, signal: Signal, a: float, b: float) -> None:
        self.run, self.signal, self.a, self.b = run, signal, float(a), float(b)
        self.edges = run.boundaries(a, b)
        lo, width = self.edges[:-1], np.diff(self.edges)
        pieces = _refine(run, signal, lo, width, _gauss_pieces(run, signal, lo, width))
        self.at_edges = np.concatenate([[0.0], np.cumsum(pieces)])

    def __call__(self, ts: np.ndarray) -> np.ndarray:
        ts = np.clip(np.atleast_1d(np.asarray(ts, float)), self.a, self.b)
        k = np.clip(np.searchsorted(self.edges, ts, side="right") - 1, 0,
                    self.edges.size - 2)
        lo, width = self.edges[k], ts - self.edges[k]
        part = _refine(self.run, self.signal, lo, width,
                       _gauss_pieces(self.run, self.signal, lo, width))
        return self.at_edges[k] + part


class Remembering:
    """A run whose ``at`` remembers the samples at each array of instants it was asked for:
    for measuring many signals of one run on the same points one after the other (each
    new :class:`Cumulative` samples the same Gauss nodes). With ``of``, ``at`` gives (and
    remembers) ``of(samples)`` instead: a quantity every one of those signals is made from,
    computed once per array of instants; the signals are then functions of it."""

    def __init__(self, run: DenseRun, of: Callable[[Trajectory], object] | None = None
                 ) -> None:
        self.run, self.of, self._seen = run, of, {}

    def at(self, ts: np.ndarray):
        ts = np.ascontiguousarray(ts, float)
        key = ts.tobytes()
        if key not in self._seen:
            samples = self.run.at(ts)
            self._seen[key] = samples if self.of is None else self.of(samples)
        return self._seen[key]

    def boundaries(self, a: float, b: float) -> np.ndarray:
        return self.run.boundaries(a, b)


class LastValue:
    """``fn(samples)`` remembered for the last samples of more than one instant it was
    called with (by identity): for a quantity with several columns whose maxima are
    measured one column after the other on the same scan or chunk of it (each column's
    signal computes the whole quantity; :func:`maximum`'s refinement between, at single
    instants, is computed afresh and does not replace the scan's value). The samples are
    referred to weakly (a window's last chunk is not kept alive by it)."""

    def __init__(self, fn: Callable[[Trajectory], np.ndarray]) -> None:
        self.fn, self.samples, self.value = fn, lambda: None, None

    def __call__(self, samples: Trajectory) -> np.ndarray:
        if samples is self.samples():
            return self.value
        value = self.fn(samples)
        if len(samples.t) > 1:
            self.samples, self.value = weakref.ref(samples), value
        return value


class _Pair:
    """The run seen at (t, t + shift) at once: ``at(ts)`` gives both samples."""

    def __init__(self, run: DenseRun, shift: float) -> None:
        self.run, self.shift = run, shift

    def at(self, ts: np.ndarray) -> tuple[Trajectory, Trajectory]:
        return self.run.at(ts), self.run.at(ts + self.shift)


def window_mean_max(cum: Cumulative, window: float, a: float, b: float
                    ) -> tuple[float, float]:
    """(max over s in [a, b] of m(s) = (I(s + window) - I(s)) / window, its s), I = ``cum``
    (b + window <= cum.b). m' = (signal(s + window) - signal(s)) / window: between the
    points where s or s + window is a step end, both ends move inside one step each, so
    m is as smooth as the extension. m is evaluated (exactly, :class:`Cumulative`) at
    those points and at the Gauss nodes between them, and at every interior maximum:
    each sign change of m' from + to - located by bisection to XTOL. A maximum is
    missed only where m' goes + - + - between two scan points (as for crossings)."""
    ends = cum.edges
    inner = np.concatenate([ends, ends - window])
    cand = np.unique(np.concatenate([[a, b], inner[(inner > a) & (inner < b)]]))
    lo, width = cand[:-1], np.diff(cand)
    scan = np.union1d(cand, (lo[:, None] + width[:, None] * NODES01[None, :]).ravel())
    pair = _Pair(cum.run, window)

    def slope(p: tuple[Trajectory, Trajectory]) -> np.ndarray:
        return np.asarray(cum.signal(p[1]), float) - np.asarray(cum.signal(p[0]), float)

    g = _values(pair, slope, scan)
    k = np.flatnonzero((g[:-1] > 0) & (g[1:] <= 0))
    roots = _roots(pair, slope, 0.0, scan[k], scan[k + 1])
    points = np.concatenate([scan, roots])
    # the scan's means apart from the roots': on a Remembering run the scan's instants are
    # sampled once for every signal (each instant's I is computed alone, the same either way)
    means = np.concatenate([(cum(p + window) - cum(p)) / window for p in (scan, roots)
                            if p.size])
    best = int(np.argmax(means))
    return float(means[best]), float(points[best])


def max_rise(cum: Cumulative, level: float, a: float, b: float) -> float:
    """max over a <= s <= t <= b of int_s^t (signal - level) = I(t) - I(s) - level (t - s),
    I = ``cum``: J = I - level t is monotone between the crossings of ``level`` by the
    signal, so its largest rise is that of its values at the scan points of [a, b] and
    those crossings (located by bisection to XTOL), evaluated exactly."""
    ts, v = Window(cum.run, a, b).values(cum.signal).value
    v = v - level
    k = np.flatnonzero(np.sign(v[:-1]) != np.sign(v[1:]))
    points = np.sort(np.concatenate([ts, _roots(cum.run, cum.signal, level, ts[k],
                                                ts[k + 1])]))
    J = cum(points) - level * points
    return float(np.max(J - np.minimum.accumulate(J)))


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
    return Window(run, a, b).first_below(signal, level).value


def first_within(run: DenseRun, signal: Signal, level: float, a: float, b: float) -> float:
    """The first t in [a, b] with |signal(t)| < level; NaN if none. Between two scan points
    the signal enters the band where it ends inside it or changes sign (a continuous
    signal passes through 0, so through the band, even with both ends outside: a fast
    zero crossing between scan points); the entry is the crossing of the band edge on the
    side it came from, located by bisection on the continuous extension (to XTOL). A
    bracket whose bisection ends on a jump over the band (|signal - edge| > level there:
    the signal is discontinuous) is no entry."""
    return Window(run, a, b).first_within(signal, level).value


def _first_within(run: DenseRun, signal: Signal, level: float, ts: np.ndarray,
                  v: np.ndarray) -> float:
    """:func:`first_within` from the signal ``v`` at the scan points ``ts``."""
    inside = np.abs(v) < level
    if inside[0]:
        return float(ts[0])
    for k in np.flatnonzero(inside[1:] | (np.sign(v[:-1]) * np.sign(v[1:]) < 0)):
        edge = math.copysign(level, v[k])  # |v[k]| >= level: this edge is crossed first
        t = float(_roots(run, signal, edge, ts[k:k + 1], ts[k + 1:k + 2])[0])
        if inside[k + 1] or abs(_at(run, signal, t) - edge) <= level:
            return t
    return math.nan


def settles_below(run: DenseRun, signal: Signal, level: float, a: float, b: float) -> float:
    """The first t in [a, b] after which signal < level up to b: the last up-crossing;
    NaN ("never") if the signal is >= level at b (it leaves the band before the end)."""
    return Window(run, a, b).settles_below(signal, level).value


def fraction_above(run: DenseRun, signal: Signal, level: float, a: float, b: float) -> float:
    """The share of [a, b] where signal > level (crossings located on the steps)."""
    return Window(run, a, b).fraction_above(signal, level).value


def maximum(run: DenseRun, signal: Signal, a: float, b: float) -> tuple[float, float]:
    """(max over [a, b] of signal, the instant): the largest scan point refined on the
    continuous extension between its neighbours."""
    return Window(run, a, b).maximum(signal).value


def minimum(run: DenseRun, signal: Signal, a: float, b: float) -> tuple[float, float]:
    """(min over [a, b] of signal, the instant), as :func:`maximum`."""
    return Window(run, a, b).minimum(signal).value
