"""Run a composed system: one trajectory on an output grid, or an ensemble of runs.

Integrator settings (:class:`SolverSettings`):

* ``method="rk4"``: classical RK4, equal substeps of at most ``h_max`` inside every
  segment between events (noise samples, break points, output instants). The step is
  also capped at ``stability_safety * 2.785 / rho``, where ``rho`` is the largest
  spectral radius the components declare (2.785 is RK4's stability limit on the negative
  real axis): the margin of a stiff high-gain observer is computed, not guessed.
* ``method="dopri5"``: Dormand–Prince 5(4) with error control (``rtol``, ``atol``) and
  steps clipped to the noise instants and the break points (the instants where a plant
  or controller declares a jump, :meth:`~hgo.engine.system.System.breaks`); outputs
  interpolated (dense output) at their exact instants k * dt_out.
* ``method="dop853"``: Hairer's DOP853 (8th order, 7th-order dense output), the same
  event handling; fewer steps than ``dopri5`` at tight tolerances (about half the right-
  hand-side evaluations of problem B at equal accuracy, ``benchmarks/``).

``split_observers=True`` integrates each observer with its own copy of the plant, under its
own error control (and its own RK4 step cap), when no observer feeds the input: a stiff
observer's short steps then do not cost the others, as the Andrieu, Praly & Astolfi notes
ask (spec section 12; ``apa_fig2`` 0.165 -> 0.055 s, ``benchmarks/apa_bench.py``). The
plant, y and u reported are the first observer's copy. Ensembles split too (adaptive
methods only).

Units: time in seconds of simulated time; states in the plant's own units.
"""

from __future__ import annotations

import math
import pickle
import re
import warnings
from dataclasses import dataclass, replace

import numpy as np

from hgo.core.errors import ConfigError
from hgo.engine.codegen import (
    damaged_cache_file,
    forget_kernel,
    load_kernel,
    remove_cache_entry,
)
from hgo.engine.composition import reads_estimate
from hgo.engine.interrupt import interruptible
from hgo.engine.system import System

RK4_STABILITY = 2.785  # |h*lambda| limit of classical RK4 on the negative real axis
METHODS = {"rk4": 0, "dopri5": 1, "dop853": 2}
CACHE_ERRORS = (pickle.UnpicklingError, EOFError)  # numba reading a damaged cache file
MAX_CACHE_REPAIRS = 64  # damaged cache files deleted (one per retry) before giving up
STATUS = {0: "ok", 1: "non-finite state", 2: "state left the bound", 3: "step size underflow",
          4: "non-finite step size or error norm (NaN/inf in the right-hand side or a "
             "parameter)",
          5: "step limit solver.max_steps reached", 6: "interrupted"}
INTERRUPTED = 6


@dataclass(frozen=True)
class SolverSettings:
    """Integrator and output grid (times in seconds)."""

    t_end: float
    dt_out: float
    method: str = "dopri5"
    h_max: float = 0.01
    rtol: float = 1e-8
    atol: float = 1e-10
    state_bound: float = 1e6
    window: float = 0.0  # trailing window of the mean-error metrics; 0: last quarter
    stability_safety: float = 0.9
    max_steps: int = 10 ** 9  # a run stops (failed) after this many integration steps
    max_output_rows: int = 10 ** 8  # runs recording more output rows are refused up front
    split_observers: bool = False  # each observer with its own copy of the plant (module doc)
    # keep every accepted step with its continuous extension (adaptive methods): the run's
    # signals at any instant afterwards (Trajectory.dense); set for post-processors that
    # measure from the integration rather than the output grid
    dense_steps: bool = False

    def validate(self) -> None:
        """Every setting in its range (keys named as in the config: solver.*, metrics.*)."""
        if self.method not in METHODS:
            raise ConfigError("solver.method", f"'{self.method}' is not a method",
                              ", ".join(sorted(METHODS)))
        for key in ("t_end", "dt_out", "rtol", "atol"):
            value = getattr(self, key)
            if not (value > 0 and math.isfinite(value)):
                raise ConfigError(f"solver.{key}", f"must be > 0 and finite, got {value}")
        for key in ("h_max", "state_bound"):  # inf: no cap
            if not getattr(self, key) > 0:
                raise ConfigError(f"solver.{key}", f"must be > 0, got {getattr(self, key)}",
                                  "(0, inf]")
        if not 0 < self.stability_safety <= 1:
            raise ConfigError("solver.stability_safety", "the fraction of RK4's stability "
                              f"limit taken as step cap must be in (0, 1], got "
                              f"{self.stability_safety}", "(0, 1]")
        for key in ("max_steps", "max_output_rows"):
            value = getattr(self, key)
            if isinstance(value, bool) or not isinstance(value, (int, np.integer)) or value < 1:
                raise ConfigError(f"solver.{key}", f"must be an integer >= 1, got {value!r}")
        if not isinstance(self.split_observers, (bool, np.bool_)):
            raise ConfigError("solver.split_observers", "must be true or false, got "
                              f"{self.split_observers!r}")
        ratio = self.t_end / self.dt_out
        if ratio > self.max_output_rows:
            raise ConfigError("solver.dt_out", f"the run records {ratio + 1:.3g} output rows "
                              f"(t_end / dt_out + 1), over solver.max_output_rows = "
                              f"{self.max_output_rows:.3g}", "raise solver.dt_out, lower "
                              "solver.t_end or raise solver.max_output_rows")
        if abs(ratio - round(ratio)) > 1e-9 * max(1.0, ratio):
            raise ConfigError("solver.t_end", f"must be a multiple of solver.dt_out "
                              f"({self.dt_out}), got {self.t_end}")
        if not (0 <= self.window <= self.t_end and math.isfinite(self.window)):
            raise ConfigError("metrics.window", f"must be in [0, solver.t_end = {self.t_end}] "
                              f"(0: the last quarter), got {self.window}")

    def min_steps(self, spectral_radius: float, noise_period: float) -> float:
        """A lower estimate of the integration steps: the horizon over the step cap, plus
        one step per noise sample (and, for RK4, per output instant: both cut the steps)."""
        cap = self.effective_h_max(spectral_radius)
        steps = self.t_end / cap if math.isfinite(cap) else 0.0
        if math.isfinite(noise_period) and noise_period > 0:
            steps += self.t_end / noise_period
        if self.method == "rk4":
            steps += self.t_end / self.dt_out
        return steps

    @property
    def t_window(self) -> float:
        return self.window if self.window > 0 else self.t_end / 4

    def effective_h_max(self, spectral_radius: float) -> float:
        """Step cap: h_max, and for RK4 the stability limit of the stiffest component."""
        if self.method == "rk4" and spectral_radius > 0:
            return min(self.h_max, self.stability_safety * RK4_STABILITY / spectral_radius)
        return self.h_max


@dataclass
class Noise:
    """Sample-and-hold measurement noise: ``samples[k]`` holds on [k*dt, (k+1)*dt)."""

    samples: np.ndarray  # (n_samples, ny)
    dt: float  # math.inf for a constant (e.g. zero) signal


@dataclass
class Trajectory:
    """Signals on the output grid, up to the stop time (a failed run stops early)."""

    t: np.ndarray
    z: np.ndarray
    d: np.ndarray
    y: np.ndarray
    m: np.ndarray
    u: np.ndarray
    xh: np.ndarray
    status: int
    t_stop: float
    acc: np.ndarray  # window metrics (System.n_acc): integrals, max norms, window length
    dense: DenseRun | None = None  # the steps (SolverSettings.dense_steps, adaptive methods)
    reason: str = ""  # why it stopped, from an observer's ``explain`` (Observer), if any

    @property
    def ok(self) -> bool:
        return self.status == 0

    @property
    def message(self) -> str:
        return STATUS[self.status] + (f" ({self.reason})" if self.reason else "")


@dataclass
class StepRecord:
    """The accepted steps of one integration with their continuous extensions (rows as in
    kernel_template's step record) and what is needed to evaluate its signals."""

    system: System
    method: str
    P: np.ndarray
    rows: np.ndarray
    noisy: bool = True  # the run's kernel: with measurement noise, or the noiseless one

    def at(self, ts: np.ndarray) -> Trajectory:
        """Every signal at the instants ``ts`` (in [0, t_stop])."""
        ts = np.ascontiguousarray(ts, float)
        ny, nu = len(self.system.plant.output_names), len(self.system.plant.input_names)
        sysm = self.system
        t, *rec = _record_arrays(len(ts), (1, sysm.nz, sysm.nd, ny, ny, nu, sysm.nxh))
        if "_signals" not in self.__dict__:  # (loaded once: at() is called many times)
            self._signals = _kernel(sysm, self.method, self.noisy).function("dense_signals")
        self._signals(self.rows, len(self.rows), ts, self.P, *rec)
        return Trajectory(ts, *rec, 0, float(ts[-1]) if len(ts) else 0.0,
                          np.full(sysm.n_acc(), np.nan))

    def __getstate__(self) -> dict:
        # without the loaded kernel function (a closure of this process): a run sent to the
        # figure process loads it there (`hgo run experiment=apa_fig1` failed with "Can't
        # pickle local object 'compiled_first.<locals>.call'")
        return {k: v for k, v in self.__dict__.items() if k != "_signals"}


@dataclass
class DenseRun:
    """A run's signals at any instant: its step records (one per part of a split run,
    merged into the whole layout as the parts' output samples are)."""

    system: System
    records: list[StepRecord]
    parts: list | None = None  # the _Part of each record (split runs)

    def at(self, ts: np.ndarray) -> Trajectory:
        runs = [record.at(ts) for record in self.records]
        return runs[0] if self.parts is None else _merge(self.system, self.parts, runs)

    def part(self, k: int) -> DenseRun:
        """Of a split run, part ``k``'s steps in the part's own layout (the plant and
        observer ``k``; its columns are not copied into the whole layout at every instant
        asked for); an unsplit run as it is."""
        if self.parts is None:
            return self
        return DenseRun(self.records[k].system, [self.records[k]])

    def boundaries(self, a: float, b: float) -> np.ndarray:
        """The step ends of every part strictly inside (a, b), sorted, with a and b."""
        inner = [r.rows[:, 0][(r.rows[:, 0] > a) & (r.rows[:, 0] < b)] for r in self.records]
        return np.unique(np.concatenate([[a, b], *inner]))


def _kernel(system: System, method: str, noisy: bool = True):
    """The compiled kernel module, or the pure-Python one (numba missing)."""
    try:
        return load_kernel(system, compiled=True, method=method, noisy=noisy)
    except ImportError:  # numba missing
        return load_kernel(system, compiled=False, method=method, noisy=noisy)


def has_noise(samples: np.ndarray) -> bool:
    """Whether any measurement noise sample is non-zero (else the noiseless kernel runs:
    :func:`hgo.engine.codegen.composition_source`)."""
    return bool(np.any(samples))


def _call(system: System, method: str, fname: str, *args, noisy: bool = True):
    module = _kernel(system, method, noisy)
    try:
        return _call_repairing_cache(system, method, noisy, module, fname, args)
    except Exception as err:  # numba typing/lowering errors of user components
        if type(err).__module__.split(".")[0] != "numba":
            raise
        warnings.warn(f"hgo: numba could not compile {numba_failure(str(err))}; running on "
                      "the pure-Python path (slow).", RuntimeWarning, stacklevel=3)
        module = load_kernel(system, compiled=False, method=method, noisy=noisy)
        return interruptible(module.function(fname), args, args[-1])


def _call_repairing_cache(system: System, method: str, noisy: bool, module, fname: str,
                          args: tuple):
    """Call the kernel; a damaged numba cache file (truncated, corrupted) is deleted, with
    one warning, and the kernel recompiled, until the call goes through."""
    warned = False
    for _ in range(MAX_CACHE_REPAIRS):
        try:
            return interruptible(module.function(fname), args, args[-1])
        except CACHE_ERRORS as err:
            damaged = damaged_cache_file(err)
            if damaged is None:
                raise
            if not warned:
                warnings.warn(f"hgo: a numba cache entry is damaged ({damaged.name}: "
                              f"{type(err).__name__}: {_reason(str(err))}); deleting it and "
                              "recompiling", RuntimeWarning, stacklevel=4)
                warned = True
            remove_cache_entry(damaged)
            forget_kernel(module)
            module = _kernel(system, method, noisy)
    return interruptible(module.function(fname), args, args[-1])


_ANSI = re.compile(r"\x1b\[[0-9;]*m")
_WHERE = re.compile(r'^File "(?P<file>[^"]+)", line (?P<line>\d+):')
_DEF = re.compile(r"^def (?P<name>\w+)\(")


def numba_failure(message: str) -> str:
    """Where numba's compile failed and why, in one line: ``my_phi0 (t.py, line 11):
    Untyped global name 'helper': ...``. The innermost failure of a numba error comes
    first: its first ``File "...", line N:`` names the source of the function that failed
    (its ``def`` is the next line) and the line before it is numba's error."""
    lines = [_ANSI.sub("", ln).strip() for ln in message.splitlines()]
    for k, line in enumerate(lines):
        where = _WHERE.match(line)
        if not where:
            continue
        reason = next((ln for ln in reversed(lines[:k]) if ln), "")
        name = next((m["name"] for ln in lines[k + 1:k + 4] if (m := _DEF.match(ln))), "?")
        return f"{name} ({where['file']}, line {where['line']}): {reason}"
    return f"this system ({_reason(_ANSI.sub('', message))})"


def _reason(message: str) -> str:
    """The informative line of a numba error (not its 'Failed in ...' preamble)."""
    for line in message.strip().splitlines():
        line = line.strip()
        if line and not line.startswith(("Failed in", "During:", "File ", "<source")):
            return line
    return message.strip().splitlines()[0] if message.strip() else "unknown error"


def rho_const(system: System, solver: SolverSettings) -> float:
    """The largest constant spectral radius (components without a ``stiffness`` hook) that
    caps RK4's substeps; 0 for the adaptive methods (their error control sets the step)."""
    if solver.method != "rk4":
        return 0.0
    return float(max([system.plant.spectral_radius]
                     + [o.spectral_radius for o in system.observers
                        if getattr(o, "stiffness", None) is None]))


def _common_args(system: System, solver: SolverSettings, noise: Noise) -> tuple:
    """noise_dt, t_end, dt_out, h_max, rtol, atol, stab, rho_const, bound, t_window.

    RK4 caps its substeps at min(h_max, stab / rho) with rho the largest of the constant
    spectral radii (components without a ``stiffness`` hook) and of the hooks' values now.
    """
    stab = solver.stability_safety * RK4_STABILITY if solver.method == "rk4" else 0.0
    return (float(noise.dt), float(solver.t_end), float(solver.dt_out), float(solver.h_max),
            float(solver.rtol), float(solver.atol), float(stab), rho_const(system, solver),
            float(solver.state_bound), float(solver.t_window))


def _control(solver: SolverSettings) -> np.ndarray:
    """The kernel's control vector: [stop request (set on Ctrl-C), step limit, steps
    recorded (out)]."""
    return np.array([0, solver.max_steps, 0], dtype=np.int64)


NO_STEPS = np.zeros((0, 0))  # an empty step record: the kernel keeps none


def _check_noise(system: System, noises: list[Noise]) -> None:
    """The kernel indexes noise samples by the plant's outputs and one sample period:
    a wrong width or mixed periods must fail here, not read out of bounds."""
    ny = len(system.plant.output_names)
    for k, noise in enumerate(noises):
        if noise.samples.ndim != 2 or noise.samples.shape[1] != ny or not len(noise.samples):
            raise ValueError(f"noise {k}: samples must have shape (n >= 1, {ny}) for a plant "
                             f"with {ny} outputs, got {noise.samples.shape}")
        if noise.dt != noises[0].dt:
            raise ValueError(f"noise {k}: sample period {noise.dt} differs from member 0's "
                             f"{noises[0].dt}; an ensemble shares one period")


def simulate(system: System, solver: SolverSettings, noise: Noise,
             params: np.ndarray | None = None, z0: np.ndarray | None = None) -> Trajectory:
    """Integrate one run and record every signal on the grid ``k * solver.dt_out``."""
    solver.validate()
    _check_noise(system, [noise])
    z = (system.z0() if z0 is None else np.asarray(z0, float)).copy()
    if z.shape != (system.nz,):  # the kernel is generated for this state length
        raise ValueError(f"z0 must have shape ({system.nz},), got {z.shape}")
    P = system.params() if params is None else np.asarray(params, float)
    if solver.split_observers and len(system.observers) > 1:
        return _simulate_split(system, solver, noise, P, z)
    args = _common_args(system, solver, noise)
    n_out = int(round(solver.t_end / solver.dt_out)) + 1
    ny, nu = noise.samples.shape[1], len(system.plant.input_names)
    t, *rec = _record_arrays(n_out, (1, system.nz, system.nd, ny, ny, nu, system.nxh))
    breaks = system.breaks(P, solver.t_end)
    keep = solver.dense_steps and solver.method != "rk4"
    cap = _steps_guess(solver, noise) if keep else 0
    noisy = has_noise(noise.samples)
    while True:  # (once, unless the step record was too short: then again, long enough)
        steps, ctl = np.empty((cap, _step_width(system, solver.method) if keep else 0)), \
            _control(solver)
        acc = np.zeros(system.n_acc())
        d = system.d0()  # (the discrete state at the stop, for the observers' explain)
        status, n_rec, t_stop = _call(
            system, solver.method, "integrate", z.copy(), d, P,
            np.ascontiguousarray(noise.samples, float), args[0], breaks, *args[1:], t[:, 0],
            *rec, acc, steps, ctl, noisy=noisy)
        if ctl[2] <= cap:
            break
        cap = int(ctl[2])
    t = t[:n_rec, 0]  # k * dt_out, written by the kernel (~0.1 ms less than numpy after
    # the run, its caches cold: benchmarks/hand_bench.py)
    Z, D, Y, M, U, XH = (a[:n_rec] for a in rec)
    dense = DenseRun(system, [StepRecord(system, solver.method, P, steps[:ctl[2]], noisy)]) \
        if keep else None
    return Trajectory(t, Z, D, Y, M, U, XH, int(status), float(t_stop), acc, dense,
                      stop_reason(system, d) if status != 0 else "")


def stop_reason(system: System, d: np.ndarray) -> str:
    """What the observers with an ``explain`` hook read in the discrete state ``d`` at a
    run's stop ("" when none explains it)."""
    found = [o.explain(d[a:b]) for o, (a, b) in zip(system.observers, system.d_slices,
                                                    strict=True) if o.explain is not None]
    return "; ".join(r for r in found if r)


def _steps_guess(solver: SolverSettings, noise: Noise) -> int:
    """Room for the step record: one step per noise sample and 4096 more."""
    per_noise = solver.t_end / noise.dt if math.isfinite(noise.dt) else 0.0
    return int(per_noise) + 4096


def _step_width(system: System, method: str) -> int:
    """Length of a step-record row: t, h, z, the continuous extension, d, m."""
    n_f = {"dopri5": 4, "dop853": 7}[method]  # (tableau: N_F of each method)
    return 2 + system.nz * (1 + n_f) + system.nd + len(system.plant.output_names)


def _record_arrays(n_out: int, widths: tuple[int, ...]) -> list[np.ndarray]:
    """(n_out, width) arrays, C-contiguous views of one uninitialised allocation.

    Not zeroed: the kernel writes every row up to its stop, and only those rows are
    returned. One block rather than one array per signal: glibc serves a freed block of
    this size again from its heap (its mmap threshold rises to the largest block freed),
    so the next run of a sweep writes into memory already mapped. Separate arrays of
    0.3-1.3 MB each went back to the kernel at every free and were mapped again page by
    page: ~770 page faults, ~1.2 ms of a 40 s Moreno run with a 1 ms grid (benchmarks/).
    """
    block = np.empty(n_out * sum(widths))
    arrays, start = [], 0
    for k in widths:  # (Python ints, not np.cumsum: ~20 us less a call of StepRecord.at)
        arrays.append(block[start:start + n_out * k].reshape(n_out, k))
        start += n_out * k
    return arrays


@dataclass(frozen=True)
class _Part:
    """One observer with its own copy of the plant (``split_observers``): its system and
    the indices of its entries in the whole system's z, d, P, xh and metric vectors."""

    system: System
    z: np.ndarray
    d: np.ndarray
    p: np.ndarray
    xh: np.ndarray
    acc: np.ndarray


def check_split(system: System, solver: SolverSettings) -> None:
    """``split_observers`` (with several observers) is refused when the input depends on
    an estimate: the observer feeding the controller drives the plant, so the parts would
    not be independent."""
    ctrl = system.controller
    if not (solver.split_observers and len(system.observers) > 1):
        return
    if reads_estimate(system) or (ctrl is not None and ctrl.reads_estimate):
        raise ConfigError("solver.split_observers", "the controller reads an observer's "
                          "estimate, so the observers are coupled through the input", "false")


def _parts(system: System, solver: SolverSettings) -> list[_Part]:
    """One part per observer (:func:`check_split` first)."""
    check_split(system, solver)
    ctrl = system.controller
    # (an open-loop controller reads no estimate: it may name any observer's)
    ctrl = None if ctrl is None else replace(ctrl, observer=None)
    ctrl_p = [] if ctrl is None else [np.arange(*system.p_slices[-1])]
    n_xh, n_obs = system.nxh, len(system.observers)
    parts = []
    for k, obs in enumerate(system.observers):
        xh = np.arange(*system.xh_slices[k])
        parts.append(_Part(
            System(system.plant, [obs], ctrl),
            z=np.r_[np.arange(*system.z_slices[0]), np.arange(*system.z_slices[k + 1])],
            d=np.arange(*system.d_slices[k]),
            p=np.concatenate([np.arange(*system.p_slices[0]),
                              np.arange(*system.p_slices[k + 1]), *ctrl_p]),
            xh=xh,
            # the metric vector: xh integrals, output-error integral, max norm, window
            acc=np.r_[xh, n_xh + k, n_xh + n_obs + k, n_xh + 2 * n_obs]))
    return parts


def _simulate_split(system: System, solver: SolverSettings, noise: Noise, P: np.ndarray,
                    z: np.ndarray) -> Trajectory:
    """Each part integrated on its own (its own RK4 step cap too), then put back in the
    layout of ``system`` (:func:`_merge`); an interruption skips the parts after it."""
    whole = replace(solver, split_observers=False)
    runs = []
    parts = _parts(system, solver)
    for part in parts:
        runs.append(simulate(part.system, whole, noise, P[part.p], z[part.z]))
        if runs[-1].status == INTERRUPTED:
            break
    return _merge(system, parts, runs)


def _merge(system: System, parts: list[_Part], runs: list[Trajectory]) -> Trajectory:
    """The parts' runs in the layout of ``system``: the plant, y, m and u of the first
    part; the run stops where its earliest part stopped, with the first failing part's
    status; the columns of parts not run (after an interruption) are NaN, and the run is
    interrupted even where the parts it ran all ended well (an ensemble member that had
    finished the part during which another member was interrupted)."""
    n = min(len(run.t) for run in runs)
    first = runs[0]
    complete = len(runs) == len(parts)
    out = Trajectory(first.t[:n], np.full((n, system.nz), np.nan),
                     np.full((n, system.nd), np.nan), first.y[:n], first.m[:n], first.u[:n],
                     np.full((n, system.nxh), np.nan),
                     next((run.status for run in runs if run.status != 0),
                          0 if complete else INTERRUPTED),
                     min(run.t_stop for run in runs), np.full(system.n_acc(), np.nan))
    if all(run.dense is not None for run in runs):
        out.dense = DenseRun(system, [r for run in runs for r in run.dense.records],
                             parts[:len(runs)])
    nx = system.plant.nx
    out.z[:, :nx] = first.z[:n, :nx]
    for part, run in zip(parts, runs, strict=False):
        out.z[:, part.z[nx:]] = run.z[:n, nx:]
        out.d[:, part.d] = run.d[:n]
        out.xh[:, part.xh] = run.xh[:n]
        out.acc[part.acc] = run.acc
    return out


def simulate_ensemble(system: System, solver: SolverSettings, noise: list[Noise] | Noise,
                      params: np.ndarray, z0: np.ndarray,
                      d0: np.ndarray | None = None, rho: np.ndarray | None = None,
                      record: bool = False) -> dict:
    """Integrate many runs in parallel (numba ``prange``) in one compiled call.

    ``params`` (M, n_p), ``z0`` (M, n_z) and ``d0`` (M, n_d; default: ``system.d0()`` for
    all) give one row per member (:func:`hgo.running.ensemble.stack_members` builds all three);
    ``noise`` is one :class:`Noise` per member (same ``dt``) or one shared by all.
    ``system`` gives the kernel. ``rho`` (M,): each member's constant spectral radius that
    caps its RK4 steps (:func:`rho_const` of the member's own system, so a member takes
    the steps of its single run); default: ``system``'s for all.
    Returns ``acc`` (M, n_acc) window integrals, ``status`` (M,) and ``t_stop`` (M,); with
    ``record=True`` also ``trajectories``: one :class:`Trajectory` per member (memory:
    M x n_out x all signals). ``solver.split_observers``: one ensemble per observer, merged
    per member as a single run's parts are (adaptive methods only).
    """
    solver.validate()
    params = np.ascontiguousarray(params, float)
    z0 = np.ascontiguousarray(z0, float)
    n = params.shape[0]
    if z0.shape != (n, system.nz):
        raise ValueError(f"z0 must have shape ({n}, {system.nz}), got {z0.shape}")
    members = noise if isinstance(noise, list) else [noise] * n
    if len(members) != n:
        raise ValueError(f"noise: {len(members)} members' noise for {n} parameter rows")
    _check_noise(system, members)
    samples = np.ascontiguousarray(np.stack([m.samples for m in members]), float)
    d0 = np.tile(system.d0(), (n, 1)) if d0 is None else np.ascontiguousarray(d0, float)
    if d0.shape != (n, system.nd):
        raise ValueError(f"d0 must have shape ({n}, {system.nd}), got {d0.shape}")
    if solver.split_observers and len(system.observers) > 1:
        return _ensemble_split(system, solver, members, params, z0, d0, record)
    args = list(_common_args(system, solver, members[0]))
    rho = np.full(n, args[7]) if rho is None else np.ascontiguousarray(rho, float)
    if rho.shape != (n,):
        raise ValueError(f"rho must have shape ({n},), got {rho.shape}")
    args[7] = rho
    acc = np.zeros((n, system.n_acc()))
    status = np.zeros(n, dtype=np.int64)
    t_stop = np.zeros(n)
    n_rec = np.zeros(n, dtype=np.int64)
    n_out = int(round(solver.t_end / solver.dt_out)) + 1 if record else 0
    ny, nu = samples.shape[2], len(system.plant.input_names)
    recs = [np.zeros((n, n_out, k)) for k in (system.nz, system.nd, ny, ny, nu, system.nxh)]
    _call(system, solver.method, "integrate_ensemble", z0, d0, params, samples, args[0],
          member_breaks(system, params, solver.t_end), *args[1:], acc, status, t_stop, n_rec,
          *recs, NO_STEPS, _control(solver), noisy=has_noise(samples))
    out = {"acc": acc, "status": status, "t_stop": t_stop}
    if record:
        t = np.arange(n_out) * solver.dt_out
        out["trajectories"] = [
            Trajectory(t[:k], *(r[i, :k] for r in recs), int(status[i]), float(t_stop[i]),
                       acc[i]) for i, k in enumerate(n_rec)]
    return out


def member_breaks(system: System, params: np.ndarray, t_end: float) -> np.ndarray:
    """Each member's break points (:meth:`System.breaks` of its parameter row), one row per
    member padded with inf (the kernel ignores break points beyond t_end)."""
    rows = [system.breaks(p, t_end) for p in params]
    out = np.full((len(rows), max([len(r) for r in rows], default=0)), np.inf)
    for i, row in enumerate(rows):
        out[i, :len(row)] = row
    return out


def _ensemble_split(system: System, solver: SolverSettings, members: list[Noise],
                    params: np.ndarray, z0: np.ndarray, d0: np.ndarray, record: bool) -> dict:
    """``split_observers`` in an ensemble: each part an ensemble of its own, the members'
    parts merged as :func:`_merge` does. RK4 is refused: the members' step caps (``rho``)
    are their whole systems', while a split single run caps each part by its own."""
    if solver.method == "rk4":
        raise ConfigError("solver.split_observers", "an RK4 ensemble caps each member's "
                          "steps by its whole system's stiffness; split ensembles run with "
                          "the adaptive methods", "false, or solver.method dopri5/dop853")
    whole = replace(solver, split_observers=False)
    parts, outs = _parts(system, solver), []
    for part in parts:
        outs.append(simulate_ensemble(part.system, whole, members, params[:, part.p],
                                      z0[:, part.z], d0[:, part.d], record=record))
        if np.any(outs[-1]["status"] == INTERRUPTED):
            break
    acc = np.full((len(params), system.n_acc()), np.nan)
    status = np.zeros(len(params), dtype=np.int64)
    for part, out in zip(parts, outs, strict=False):
        acc[:, part.acc] = out["acc"]
        status = np.where(status != 0, status, out["status"])
    if len(outs) < len(parts):  # the later parts ran for no member: none is complete
        status = np.where(status != 0, status, INTERRUPTED)
    merged = {"acc": acc, "status": status,
              "t_stop": np.min([out["t_stop"] for out in outs], axis=0)}
    if record:
        merged["trajectories"] = [_merge(system, parts, [out["trajectories"][i] for out in outs])
                                  for i in range(len(params))]
    return merged


def not_run(system: System) -> Trajectory:
    """The run of a member that never started (an ensemble stopped by Ctrl-C before its
    chunk): no samples, interrupted at t = 0, its metrics NaN."""
    ny, nu = len(system.plant.output_names), len(system.plant.input_names)
    t, *rec = _record_arrays(0, (1, system.nz, system.nd, ny, ny, nu, system.nxh))
    return Trajectory(t[:, 0], *rec, INTERRUPTED, 0.0, np.full(system.n_acc(), np.nan))


def no_noise(ny: int) -> Noise:
    """A zero measurement noise on ``ny`` channels."""
    return Noise(np.zeros((1, ny)), math.inf)
