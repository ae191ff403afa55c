"""From a composed Hydra config to a run directory: recording, metrics, config.

    build(cfg)  -> Experiment (system, solver settings, noise model, post-processors):
                   every parameter is checked here, before any integration
                   (:mod:`hgo.core.validate`, the builders, :class:`System`).
    run(cfg, out_dir) -> RunResult: simulate, write ``recording.rrd`` and ``metrics.csv``;
                   a run that stops early (non-finite state, state bound) keeps everything
                   up to its stop time and is marked failed in ``metrics.csv``.
"""

from __future__ import annotations

import functools
import inspect
import logging
import math
import re
import time
import uuid
from collections.abc import Callable, Iterator, Mapping
from contextlib import contextmanager
from dataclasses import dataclass, replace
from datetime import datetime
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np
import pandas as pd
from hydra.errors import InstantiationException
from omegaconf import DictConfig, OmegaConf

from hgo.core import targets
from hgo.core.components import Controller, Observer, Plant
from hgo.core.errors import ConfigError, UserCodeError
from hgo.core.validate import check_cost as _check_sizes
from hgo.core.validate import check_values
from hgo.engine.dry_call import check_user_code
from hgo.engine.interrupt import LAST_WORDS
from hgo.engine.jit import run_seconds
from hgo.engine.simulate import INTERRUPTED, SolverSettings, Trajectory, check_split, simulate
from hgo.engine.system import System
from hgo.noise import NoiseModel
from hgo.outputs.console import compact_table
from hgo.outputs.decimate import check_recording, recording_mode, write_run_recording
from hgo.outputs.metrics import metrics_table, status_word
from hgo.outputs.recording import Difference, Series, atomic_output
from hgo.outputs.runs import write_run_json
from hgo.postprocess import PostOutput
from hgo.running.figures import check_figures, draw_figures, figure_settings
from hgo.running.progress import compile_progress
from hgo.running.results import Experiment, RunResult
from hgo.running.viewer_layout import blueprint, recording_name, styled

if TYPE_CHECKING:
    from hgo.running.figure_worker import FigureWorker

log = logging.getLogger(__name__)


class SimulationFailed(RuntimeError):
    """A run stopped early; its outputs up to the stop time are written (``result``: the
    :class:`RunResult` of what was computed)."""


class RunInterrupted(KeyboardInterrupt):
    """Ctrl-C (SIGINT) stopped a run; its outputs up to then are written."""


def _has_nested_target(value) -> bool:
    if isinstance(value, dict):
        return "_target_" in value or _any_nested_target(value.values())
    return isinstance(value, list) and _any_nested_target(value)


def _any_nested_target(values) -> bool:
    # containers only recursed into: an ensemble checks every member's node (10,000 of
    # them in a grid), mostly lists of numbers
    return any(_has_nested_target(v) for v in values if isinstance(v, dict | list))


def _construct(node, group: str, **kwargs):
    """``instantiate``, with a fast path for a plain, resolved dict of plain values: Hydra's
    instantiate costs ~10 ms a call (a claim's run builds five components, an ensemble one
    per member). A config node is resolved into plain values first, so a factory gets
    lists, dicts and numbers, in a single run as in an ensemble's members (a node with a
    long list too: instantiate cost ~0.4 ms a list element, 8.3 s for a 20,000-element
    ``plant.x0``, against 0.3 s to convert it). Nested ``_target_`` nodes and Hydra's
    other ``_keys_`` go through instantiate. Every ``_target_`` passes the allowlist
    (:mod:`hgo.core.targets`) before anything is called."""
    if OmegaConf.is_dict(node):
        node = OmegaConf.to_container(node, resolve=True)
    if isinstance(node, dict) and kwargs:  # what hgo passes (the built plant) replaces the
        node = {k: v for k, v in node.items() if k not in kwargs}  # node's (not built)
    if isinstance(node, dict) and not _has_nested_target(
            {k: v for k, v in node.items() if k != "_target_"}) and not any(
            k.startswith("_") and k != "_target_" for k in node):
        factory = targets.locate(node["_target_"], f"{group}._target_")
        try:
            return factory(**{k: v for k, v in node.items() if k != "_target_"}, **kwargs)
        except Exception as err:
            raise InstantiationException(f"Error in call to target '{node['_target_']}'") \
                from err
    return targets.instantiate(node, group, **kwargs)


def _locate_target(path: str, key: str = "_target_"):
    """The callable ``path`` names, through hgo's allowlist (:func:`hgo.core.targets.locate`)."""
    return targets.locate(path, key)


def _signature_error(group: str, node, err: TypeError) -> ConfigError:
    """A factory's TypeError (unknown or missing keyword) as a ConfigError naming the key."""
    text = " ".join(str(err).split())
    match = re.search(r"unexpected keyword argument '(\w+)'", text)
    try:
        params = [p for p in inspect.signature(_locate_target(node["_target_"])).parameters
                  if p != "name"]
    except Exception:  # noqa: BLE001 - the allowed list is a courtesy
        params = []
    allowed = ", ".join(params) or None
    if match:
        return ConfigError(f"{group}.{match.group(1)}", "is not a parameter of "
                           f"{node['_target_']}", allowed)
    return ConfigError(group, text, allowed)


def _is_signature_error(err: TypeError) -> bool:
    """A TypeError of the call itself (a keyword the factory does not take or misses),
    not one raised inside the factory."""
    return bool(re.search(r"unexpected keyword argument|missing \d+ required|takes \d+ "
                          r"positional|got multiple values", str(err)))


def _factory_error(group: str, node, err: InstantiationException) -> Exception:
    """A factory's failure as one line: hgo's own ValueError (it names its key) as it is,
    a keyword it does not take naming that key, anything else as ``plant._target_
    vdp.make_vdp: ZeroDivisionError: division by zero (vdp.py:12)``."""
    cause = err.__cause__
    target = node.get("_target_") if isinstance(node, Mapping) else None
    if isinstance(cause, ConfigError) or (isinstance(cause, ValueError) and
                                          str(target).startswith("hgo.")):
        return cause
    if isinstance(cause, TypeError) and _is_signature_error(cause):
        return _signature_error(group, node, cause)
    if cause is None:
        text = " ".join(line for line in str(err).splitlines() if "full_key" not in line)
        return ConfigError(f"{group}._target_", " ".join(text.split()))
    return UserCodeError(f"{group}._target_ {target}: {targets.code_error(cause)}")


def _instantiate(node: DictConfig, group: str, expected: type, **kwargs):
    if not isinstance(node, Mapping) or "_target_" not in node:
        raise ConfigError(group, "needs a _target_ (the factory to call)")
    try:
        obj = _construct(node, group, **kwargs)
    except InstantiationException as err:  # surface the factory's one-line message
        raise _factory_error(group, node, err) from None
    if not isinstance(obj, expected):
        raise ConfigError(f"{group}._target_", f"must build a {expected.__name__}, "
                          f"got {type(obj).__name__}")
    check_initial_state(obj, group, node)
    return obj


def _initial_key(group: str, node, name: str) -> str:
    """The config key of a component's initial state: ``plant.x0`` when the node sets it."""
    return f"{group}.{name}" if isinstance(node, Mapping) and name in node else group


def check_initial_state(comp, group: str, node) -> None:
    """A plant's ``x0`` and an observer's ``z0``/``d0`` have one entry per declared state
    (a 3-entry x0 for 2 states failed after "integrating", naming the kernel's z0)."""
    pairs = {Plant: [("x0", "state_names", "states")],
             Observer: [("z0", "state_names", "states"), ("d0", "disc_names",
                                                          "discrete states")]}
    for kind, checks in pairs.items():
        if not isinstance(comp, kind):
            continue
        for attr, names_attr, what in checks:
            value, names = np.asarray(getattr(comp, attr)), getattr(comp, names_attr)
            if value.shape != (len(names),):
                raise ConfigError(_initial_key(group, node, attr), f"has shape {value.shape} "
                                  f"({value.size} entries); {comp.name} has {len(names)} "
                                  f"{what} ({', '.join(names)})",
                                  f"{len(names)} numbers")


def plant_argument(node: Mapping, plant: Plant) -> dict:
    """``{"plant": plant}`` for an observer factory with a parameter named ``plant`` (an
    observer derived from the plant's own equations: its model, Jacobians or coordinates),
    else ``{}``: such a factory gets the built plant, never a config node of it."""
    target = node.get("_target_") if isinstance(node, Mapping) else None
    if not isinstance(target, str):
        return {}
    try:
        params = inspect.signature(_locate_target(target)).parameters
    except (TypeError, ValueError):
        return {}
    return {"plant": plant} if "plant" in params else {}


def build_system(nodes: Mapping) -> System:
    """Plant, observers and controller from the ``plant``/``observer``/``controller``
    nodes of a config (a DictConfig or a plain mapping of the same shape)."""
    if not nodes["observer"]:
        raise ValueError("observer: the config group is empty; choose an observer option")
    plant = _instantiate(nodes["plant"], "plant", Plant)
    observers = [_instantiate(node, f"observer.{name}", Observer, name=name,
                              **plant_argument(node, plant))
                 for name, node in nodes["observer"].items()]
    ctrl = nodes.get("controller")
    system = System(plant, observers,
                    _instantiate(ctrl, "controller", Controller) if ctrl else None)
    check_user_code(system)  # its functions called once in plain Python
    return system


def vacuous_factor(cfg: DictConfig) -> float:
    """``metrics.vacuous_factor``, checked: a number > 1."""
    factor = cfg.metrics.get("vacuous_factor", 1e6)
    if not (isinstance(factor, int | float) and factor > 1 and math.isfinite(factor)):
        raise ValueError(f"metrics.vacuous_factor must be a finite number > 1, got {factor}")
    return float(factor)


def solver_settings(cfg: DictConfig) -> SolverSettings:
    """The ``solver`` group plus the metrics window, validated."""
    s = cfg.solver
    settings = SolverSettings(
        t_end=s.t_end, dt_out=s.dt_out, method=s.method, h_max=s.h_max, rtol=s.rtol,
        atol=s.atol, state_bound=s.state_bound, window=cfg.metrics.window,
        stability_safety=s.stability_safety, max_steps=s.get("max_steps", 10 ** 9),
        max_output_rows=s.get("max_output_rows", 10 ** 8),
        split_observers=s.get("split_observers", False))
    settings.validate()
    # a configured run asks for an error control; the engine's API also takes rtol >= 1
    # (every step accepted: fixed steps h_max, as tests/test_engine.py's order test does)
    if not 1e-15 <= settings.rtol < 1:
        raise ConfigError("solver.rtol", f"must be in [1e-15, 1) (a relative error; below "
                          f"1e-15 it asks for more than double precision), got "
                          f"{settings.rtol}", "[1e-15, 1)")
    return settings


@dataclass
class RunSize:
    """A run's size, estimated before it is made: output rows x columns, noise samples,
    integration steps (a lower estimate)."""

    rows: int
    columns: int
    noise: int
    steps: float


def run_size(system: System, solver: SolverSettings, noise: NoiseModel) -> RunSize:
    n_rows = int(round(solver.t_end / solver.dt_out)) + 1
    ny, nu = len(system.plant.output_names), len(system.plant.input_names)
    n_cols = system.nz + system.nd + 2 * ny + nu + system.nxh
    period = noise.period if noise.kind != "none" else math.inf
    n_noise = int(math.ceil(solver.t_end / period)) + 1 if math.isfinite(period) else 1
    return RunSize(n_rows, n_cols, n_noise * ny, solver.min_steps(system.spectral_radius(),
                                                                   period))


def check_cost(system: System, solver: SolverSettings, noise: NoiseModel) -> None:
    """Refuse a run whose output rows, noise samples or steps, estimated now, are too many
    (:func:`hgo.core.validate.check_cost`)."""
    size = run_size(system, solver, noise)
    _check_sizes(size.rows, size.columns, size.noise, size.steps, solver.max_output_rows,
                 solver.max_steps)


def build_postprocessors(cfg: DictConfig, system: System, solver: SolverSettings) -> dict:
    """The ``postprocess`` group, instantiated and checked against the run before it."""
    post = {}
    for name, node in (cfg.get("postprocess") or {}).items():
        obj = _instantiate(node, f"postprocess.{name}", object)
        if not callable(getattr(obj, "apply", None)):
            raise ConfigError(f"postprocess.{name}._target_", "must build an object with "
                              f"apply(system, traj), got {type(obj).__name__}")
        if callable(getattr(obj, "check", None)):
            obj.check(system, solver, f"postprocess.{name}")
        post[name] = obj
    return post


def check_single_run(cfg: DictConfig) -> None:
    """``ensemble.shard`` on a single run was silently ignored (``ensemble.vary`` stays
    allowed: ``ensemble.size=0`` runs an ensemble preset's base config, tests do)."""
    if (cfg.get("ensemble") or {}).get("shard"):
        raise ConfigError("ensemble.shard", "applies to ensembles only; this is a single "
                          "run (ensemble.size = 0, no ensemble.grid)",
                          "set ensemble.size >= 1 or ensemble.grid, or drop ensemble.shard")


def build(cfg: DictConfig) -> Experiment:
    """Check the values, instantiate and check every component against the others and the
    run's size: raises ValueError (mostly :class:`ConfigError`) naming the bad key."""
    check_values(cfg)
    check_single_run(cfg)
    solver = solver_settings(cfg)
    vacuous_factor(cfg)
    figure_settings(cfg)
    check_figures(cfg)
    recording_settings(cfg)
    system = build_system(cfg)
    check_split(system, solver)
    noise = _instantiate(cfg.noise, "noise", NoiseModel)
    noise.check_channels(len(system.plant.output_names))
    post = build_postprocessors(cfg, system, solver)
    solver = with_dense_steps(solver, post)
    check_cost(system, solver, noise)
    return Experiment(system, solver, noise, int(cfg.seed), post)


def with_dense_steps(solver: SolverSettings, post: dict) -> SolverSettings:
    """``solver`` keeping its steps (``dense_steps``) when a post-processor measures from
    them (its ``needs_steps``: :mod:`hgo.postprocess.dense`); those need an adaptive
    method (RK4 has no continuous extension)."""
    needing = [name for name, obj in post.items() if getattr(obj, "needs_steps", False)]
    if not needing:
        return solver
    if solver.method == "rk4":
        raise ConfigError("solver.method", f"postprocess.{needing[0]} measures from the "
                          "steps' continuous extension, which rk4 has not", "dopri5, dop853")
    return replace(solver, dense_steps=True)


def run_experiment(exp: Experiment) -> Trajectory:
    """Sample the noise from the seed and integrate."""
    ny = len(exp.system.plant.output_names)
    noise = exp.noise.sample(exp.solver.t_end, ny, exp.seed)
    return simulate(exp.system, exp.solver, noise)


def _columns(values: np.ndarray, cols: list[int]) -> np.ndarray:
    """``values[:, cols]``: a view where ``cols`` are consecutive (no copy of the run's
    length), a copy otherwise."""
    if cols and cols == list(range(cols[0], cols[0] + len(cols))):
        return values[:, cols[0]:cols[0] + len(cols)]
    return values[:, cols]


def signals(system: System, traj: Trajectory) -> list[Series]:
    """Every time series of a run, under the entity paths of :mod:`hgo.outputs.recording`;
    no copy of the run's length: views of the trajectory, the estimation errors as
    :class:`~hgo.outputs.recording.Difference` (computed when read)."""
    plant = system.plant
    x = traj.z[:, : plant.nx]
    out = [Series("/plant/x", plant.state_names, x),
           Series("/measurement/y", plant.output_names, traj.y),
           Series("/measurement/noise", [f"m_{n}" for n in plant.output_names], traj.m)]
    if plant.input_names:
        out.append(Series("/input/u", plant.input_names, traj.u))
    for obs, (za, _), (da, db), (xa, xb) in zip(system.observers, system.z_slices[1:],
                                                system.d_slices, system.xh_slices, strict=True):
        est = [plant.state_names[i] for i in obs.estimated_states]
        xh = traj.xh[:, xa:xb]
        out.append(Series(f"/observer/{obs.name}/xhat", [f"{n}_hat" for n in est], xh))
        out.append(Series(f"/error/{obs.name}", [f"e_{n}" for n in est],
                          Difference(xh, x, tuple(obs.estimated_states))))
        for sig, cols in obs.signals.items():
            names = [sig] if len(cols) == 1 else [f"{sig}{i + 1}" for i in range(len(cols))]
            out.append(Series(f"/observer/{obs.name}/{sig}", names,
                              _columns(traj.z, [za + c for c in cols])))
        if db > da:
            out.append(Series(f"/observer/{obs.name}/discrete", obs.disc_names,
                              traj.d[:, da:db]))
    return out


def job_config_yaml(cfg: DictConfig) -> str:
    """The composed job config (without Hydra's own node), resolved, as YAML."""
    job = {k: v for k, v in cfg.items() if k != "hydra"}
    return OmegaConf.to_yaml(OmegaConf.create(job), resolve=True)


def recording_id(out_dir: Path) -> str:
    """A unique id per job (Rerun merges recordings that share one)."""
    stem = re.sub(r"[^A-Za-z0-9_-]", "_", "_".join(out_dir.parts[-3:]))
    return f"{stem}_{uuid.uuid4().hex[:8]}"


def postprocess(cfg: DictConfig, exp: Experiment, traj: Trajectory) -> PostOutput:
    """Apply every post-processor of the ``postprocess`` group, in config order."""
    total, seen = PostOutput(), {}
    post = exp.post or build_postprocessors(cfg, exp.system, exp.solver)
    for name, obj in post.items():
        out = obj.apply(exp.system, traj)
        total.series += out.series
        for row in out.rows:  # a row two post-processors both give (same value) once
            key = (row["observer"], row["quantity"])
            if key in seen and seen[key] == row["empirical"]:
                continue
            seen[key] = row["empirical"]
            total.rows.append({"postprocess": name, **row})
        total.bounds.update(out.bounds)
    return total


def recording_settings(cfg: DictConfig) -> None:
    """``recording.mode`` and ``recording.max_rows``, checked before any integration."""
    node = cfg.get("recording")
    if node is not None:
        check_recording(recording_mode(node), node.max_rows)


@dataclass
class MemoryRun:
    """A run composed, simulated and post-processed, nothing written yet."""

    experiment: Experiment
    trajectory: Trajectory
    post: PostOutput
    metrics: pd.DataFrame
    simulate_seconds: float  # without compiling
    compile_seconds: float  # numba compiling a kernel not in the cache (0 when cached)
    postprocess_seconds: float = 0.0  # the post-processors and the metrics table

    @property
    def timings(self) -> dict[str, float]:
        """Seconds: ``compile``, ``simulate``, ``postprocess``."""
        return {"compile": self.compile_seconds, "simulate": self.simulate_seconds,
                "postprocess": self.postprocess_seconds}


def simulate_config(cfg: DictConfig) -> MemoryRun:
    """Build, simulate, post-process and tabulate the metrics of a composed config."""
    with interrupted_while("building the experiment"):
        exp = build(cfg)
    log.info("integrating t = 0 .. %g s (%s)", exp.solver.t_end, exp.solver.method)
    what = (f"the kernel of plant {exp.system.plant.name} with observers "
            + ", ".join(o.name for o in exp.system.observers))
    with run_seconds() as seconds, compile_progress(exp.solver.method, what) as compiling:
        with interrupted_while(lambda: "compiling the kernel (numba)" if compiling.interrupted
                               else "integrating"):
            traj = run_experiment(exp)
    t0 = time.perf_counter()
    with interrupted_while("post-processing"):
        post = postprocess(cfg, exp, traj) if traj.ok else PostOutput()
    table = metrics_table(exp.system, traj.acc, traj.status, traj.t_stop, post.bounds,
                          post.rows, vacuous_factor(cfg))
    table.insert(0, "run", cfg.get("run_name", "run"))
    return MemoryRun(exp, traj, post, table, seconds["simulate"], seconds["compile"],
                     time.perf_counter() - t0)


@contextmanager
def interrupted_while(phase: str | Callable[[], str]) -> Iterator[None]:
    """Ctrl-C (or SIGTERM, SIGHUP) inside the block, before anything is written: a
    :class:`RunInterrupted` naming ``phase`` (a callable: asked when it happens)."""
    try:
        yield
    except KeyboardInterrupt as err:
        if isinstance(err, RunInterrupted):
            raise
        name = phase() if callable(phase) else phase
        raise RunInterrupted(f"interrupted while {name}; nothing was written") from None


@contextmanager
def kept_if_interrupted(cfg: DictConfig, result: RunResult, started: datetime, phase: str,
                        written: str) -> Iterator[None]:
    """Ctrl-C inside the block, after the simulation: ``metrics.csv`` (unless written) and
    ``run.json`` still written, the run marked interrupted while ``phase``; then a
    :class:`RunInterrupted` naming the phase and what was kept."""
    try:
        yield
    except KeyboardInterrupt as err:
        out_dir, traj = result.out_dir, result.trajectory
        if not (out_dir / "metrics.csv").exists():
            with atomic_output(out_dir / "metrics.csv") as partial:
                result.metrics.to_csv(partial, index=False)
        done = ("the simulation had finished" if traj.ok else
                f"the simulation had {status_word(traj.status)} at t = {traj.t_stop:g} s")
        track(cfg, out_dir, started, f"interrupted while {phase} ({done}; {written} "
              "complete)", result.timings, result.metrics)
        stopped = RunInterrupted(f"interrupted while {phase}; {done}: {written} and run.json "
                                 f"are in {out_dir}")
        stopped.result = result
        raise stopped from err if isinstance(err, RunInterrupted) else None


def status_text(traj: Trajectory) -> str:
    """The run's status line (``/run/status`` of the recording)."""
    if traj.ok:
        return f"ok: t = 0 .. {traj.t_stop:g} s"
    return f"{status_word(traj.status)} at t = {traj.t_stop:g} s: {traj.message}"


def run(cfg: DictConfig, out_dir: str | Path, figures: FigureWorker | None = None) -> RunResult:
    """Build, simulate and write ``recording.rrd``, ``metrics.csv`` and figures.

    Every file is written under ``<name>.partial`` and renamed when complete. A run that
    stopped early raises :class:`SimulationFailed`, an interrupted one (Ctrl-C)
    :class:`RunInterrupted`, both after writing what was computed. With ``figures`` (a
    :class:`hgo.running.figure_worker.FigureWorker` forked for ``cfg``), the figures are drawn
    there while the recording is written."""
    out_dir = Path(out_dir)
    started = datetime.now()
    last_words = functools.partial(_busy_kernel_stopped, cfg, out_dir, started)
    LAST_WORDS.append(last_words)
    try:
        mem = simulate_config(cfg)
    finally:
        LAST_WORDS.remove(last_words)
    out_dir.mkdir(parents=True, exist_ok=True)
    exp, traj, table = mem.experiment, mem.trajectory, mem.metrics
    series = styled(exp.system, signals(exp.system, traj)) + mem.post.series
    result = RunResult(exp, traj, table, out_dir, series, mem.timings)
    if figures is not None and traj.ok:
        figures.submit(cfg, result)
    t1 = time.perf_counter()
    recording = cfg.get("recording")
    # (the blueprint imports Rerun, ~0.4 s: not for a run that writes no recording)
    with kept_if_interrupted(cfg, result, started, "writing recording.rrd", "metrics.csv"):
        layout = None if recording_mode(recording) == "off" else blueprint(exp.system,
                                                                            series)
        write_run_recording(recording, out_dir / "recording.rrd", traj.t, series,
                            recording_id=recording_id(out_dir), blueprint=layout,
                            recording_name=recording_name(cfg, out_dir.name),
                            text={"/run/status": status_text(traj),
                                  "/run/config": job_config_yaml(cfg)})
    result.timings["write"] = t_write = time.perf_counter() - t1
    log.info("simulated in %.3f s (compiling %.3f s), post-processed in %.3f s; recording of "
             "%d samples x %d columns written in %.3f s", mem.simulate_seconds,
             mem.compile_seconds, mem.postprocess_seconds, len(traj.t),
             sum(len(s.names) for s in series), t_write)
    with atomic_output(out_dir / "metrics.csv") as partial:
        table.to_csv(partial, index=False)
    log.info("metrics (all columns in metrics.csv):\n%s", compact_table(table))
    stopped = (f"run {status_word(traj.status)} at t = {traj.t_stop:g} s: {traj.message} "
               f"(outputs up to then are in {out_dir})")
    if not traj.ok:
        track(cfg, out_dir, started, f"{status_word(traj.status)}: {traj.message}",
              result.timings, table)
        err = (RunInterrupted if traj.status == INTERRUPTED else SimulationFailed)(stopped)
        err.result = result  # what was written, for hgo.api.run
        raise err
    t2 = time.perf_counter()
    with kept_if_interrupted(cfg, result, started, "drawing the figures",
                             "metrics.csv, recording.rrd"):
        if figures is not None:
            figures.collect()
        else:
            draw_figures(cfg, result)
    # the drawing, or with a figure process (it drew while the recording was written) the
    # time this run still waited for it
    result.timings["figures"] = time.perf_counter() - t2
    track(cfg, out_dir, started, "ok", result.timings, table)
    return result


def _busy_kernel_stopped(cfg: DictConfig, out_dir: Path, started: datetime) -> None:
    """``run.json`` of a run whose kernel ignored Ctrl-C (user code looping) and is ended
    by a second one (:mod:`hgo.engine.interrupt`): no trajectory, the status says why."""
    out_dir.mkdir(parents=True, exist_ok=True)
    track(cfg, out_dir, started, "interrupted while integrating: the kernel was busy (user "
          "code that does not return) and was stopped without its trajectory", {}, None)


def track(cfg: DictConfig, out_dir: Path, started: datetime, status: str,
          timings: dict[str, float], metrics: pd.DataFrame) -> None:
    """``run.json``: provenance, timings, status, config and metrics (:mod:`hgo.outputs.runs`)."""
    job = OmegaConf.masked_copy(cfg, [k for k in cfg if k != "hydra"])
    write_run_json(out_dir, OmegaConf.to_container(job, resolve=True), status, started,
                   timings, metrics)
