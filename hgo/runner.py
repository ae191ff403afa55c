"""From a composed Hydra config to a run directory: recording, metrics, config.

    build(cfg)  -> Experiment (system, solver settings, noise model): every parameter is
                   checked here, before any integration.
    run(cfg, out_dir) -> RunResult: simulate, write ``recording.rrd`` and ``metrics.csv``;
                   a run that stops early (non-finite state, state bound) keeps everything
                   up to its stop time and is marked failed in ``metrics.csv``.
"""

from __future__ import annotations

import functools
import logging
import re
import time
import uuid
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path

import pandas as pd
from hydra.errors import InstantiationException
from hydra.utils import get_method, instantiate
from omegaconf import DictConfig, OmegaConf

from hgo.components import Controller, Observer, Plant
from hgo.decimate import write_run_recording
from hgo.engine.simulate import SolverSettings, Trajectory, simulate
from hgo.engine.system import System
from hgo.metrics import metrics_table
from hgo.noise import NoiseModel
from hgo.postprocess import PostOutput
from hgo.recording import Series, time_series_blueprint

log = logging.getLogger(__name__)


class SimulationFailed(RuntimeError):
    """A run stopped early; its outputs up to the stop time are written."""


@dataclass
class Experiment:
    system: System
    solver: SolverSettings
    noise: NoiseModel
    seed: int


@dataclass
class RunResult:
    experiment: Experiment
    trajectory: Trajectory
    metrics: pd.DataFrame
    out_dir: Path
    series: list[Series]


def _has_nested_target(value) -> bool:
    if isinstance(value, dict):
        return "_target_" in value or any(_has_nested_target(v) for v in value.values())
    if isinstance(value, list):
        return any(_has_nested_target(v) for v in value)
    return False


def _construct(node, **kwargs):
    """``instantiate``, with a fast path for a plain, resolved dict of plain values (the
    members of an ensemble: Hydra's instantiate costs ~10 ms a call)."""
    if isinstance(node, dict) and not _has_nested_target(
            {k: v for k, v in node.items() if k != "_target_"}) and not any(
            k.startswith("_") and k != "_target_" for k in node):
        factory = _locate_target(node["_target_"])
        try:
            return factory(**{k: v for k, v in node.items() if k != "_target_"}, **kwargs)
        except Exception as err:
            raise InstantiationException(f"Error in call to target '{node['_target_']}'") \
                from err
    return instantiate(node, **kwargs)


@functools.cache
def _locate_target(path: str):
    return get_method(path)


def _instantiate(node: DictConfig, group: str, expected: type, **kwargs):
    try:
        obj = _construct(node, **kwargs)
    except InstantiationException as err:  # surface the factory's one-line message
        if isinstance(err.__cause__, ValueError):
            raise ValueError(str(err.__cause__)) from None
        raise
    if not isinstance(obj, expected):
        raise TypeError(f"{group}._target_ must build a {expected.__name__}, "
                        f"got {type(obj).__name__}")
    return obj


def build_system(nodes: Mapping) -> System:
    """Plant, observers and controller from the ``plant``/``observer``/``controller``
    nodes of a config (a DictConfig or a plain mapping of the same shape)."""
    if not nodes["observer"]:
        raise ValueError("observer: the config group is empty; choose an observer option")
    plant = _instantiate(nodes["plant"], "plant", Plant)
    observers = [_instantiate(node, f"observer.{name}", Observer, name=name)
                 for name, node in nodes["observer"].items()]
    ctrl = nodes.get("controller")
    return System(plant, observers, _instantiate(ctrl, "controller", Controller) if ctrl else None)


def solver_settings(cfg: DictConfig) -> SolverSettings:
    """The ``solver`` group plus the metrics window, validated."""
    s = cfg.solver
    settings = SolverSettings(
        t_end=s.t_end, dt_out=s.dt_out, method=s.method, h_max=s.h_max, rtol=s.rtol,
        atol=s.atol, state_bound=s.state_bound, window=cfg.metrics.window,
        stability_safety=s.stability_safety)
    settings.validate()
    return settings


def build(cfg: DictConfig) -> Experiment:
    """Instantiate and check every component; raises ValueError naming the bad key."""
    solver = solver_settings(cfg)
    system = build_system(cfg)
    noise = _instantiate(cfg.noise, "noise", NoiseModel)
    return Experiment(system, solver, noise, int(cfg.seed))


def run_experiment(exp: Experiment) -> Trajectory:
    """Sample the noise from the seed and integrate."""
    ny = len(exp.system.plant.output_names)
    noise = exp.noise.sample(exp.solver.t_end, ny, exp.seed)
    return simulate(exp.system, exp.solver, noise)


def signals(system: System, traj: Trajectory) -> list[Series]:
    """Every time series of a run, under the entity paths of :mod:`hgo.recording`."""
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
                          xh - x[:, obs.estimated_states]))
        for sig, cols in obs.signals.items():
            names = [sig] if len(cols) == 1 else [f"{sig}{i + 1}" for i in range(len(cols))]
            out.append(Series(f"/observer/{obs.name}/{sig}", names,
                              traj.z[:, [za + c for c in cols]]))
        if db > da:
            out.append(Series(f"/observer/{obs.name}/discrete", obs.disc_names,
                              traj.d[:, da:db]))
    return out


def blueprint(system: System, series: list[Series]):
    """Default layout: states vs estimates, errors, gains and measurement."""
    entities = [s.entity for s in series]
    gains = [e for e in entities if e.startswith("/observer/") and not e.endswith("/xhat")]
    groups = {
        "states vs estimates": ["/plant/x"] + [e for e in entities if e.endswith("/xhat")],
        "estimation errors x^ - x": ["/error/**"],
        "observer gains and internal signals": gains or ["/observer/**"],
        "measurement": ["/measurement/**"] + (["/input/u"] if "/input/u" in entities else []),
    }
    return time_series_blueprint(groups, entities=entities)


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
    total = PostOutput()
    for name, node in (cfg.get("postprocess") or {}).items():
        out = instantiate(node).apply(exp.system, traj)
        total.series += out.series
        total.rows += [{"postprocess": name, **row} for row in out.rows]
        total.bounds.update(out.bounds)
    return total


def _figures(cfg: DictConfig, result: RunResult) -> list[Path]:
    """PNG figures of the ``figures`` mapping (name -> ``_target_`` taking the result)."""
    paths = []
    for name, node in (cfg.get("figures") or {}).items():
        if node is None:  # a preset drops an inherited figure with `figures.<name>: null`
            continue
        path = result.out_dir / f"{name}.png"
        instantiate(node, _partial_=True)(result, path)
        paths.append(path)
    return paths


@dataclass
class MemoryRun:
    """A run composed, simulated and post-processed, nothing written yet."""

    experiment: Experiment
    trajectory: Trajectory
    post: PostOutput
    metrics: pd.DataFrame
    simulate_seconds: float


def simulate_config(cfg: DictConfig) -> MemoryRun:
    """Build, simulate, post-process and tabulate the metrics of a composed config."""
    exp = build(cfg)
    t0 = time.perf_counter()
    traj = run_experiment(exp)
    t_sim = time.perf_counter() - t0
    post = postprocess(cfg, exp, traj) if traj.ok else PostOutput()
    table = metrics_table(exp.system, traj.acc, traj.status, traj.t_stop, post.bounds,
                          post.rows)
    table.insert(0, "run", cfg.get("run_name", "run"))
    return MemoryRun(exp, traj, post, table, t_sim)


def run(cfg: DictConfig, out_dir: str | Path) -> RunResult:
    """Build, simulate and write ``recording.rrd``, ``metrics.csv`` and figures."""
    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    mem = simulate_config(cfg)
    exp, traj, table = mem.experiment, mem.trajectory, mem.metrics
    series = signals(exp.system, traj) + mem.post.series
    status_text = (f"ok: t = 0 .. {traj.t_stop:g} s" if traj.ok else
                   f"failed at t = {traj.t_stop:g} s: {traj.message}")
    t1 = time.perf_counter()
    write_run_recording(cfg.get("recording"), out_dir / "recording.rrd", traj.t, series,
                        recording_id=recording_id(out_dir),
                        blueprint=blueprint(exp.system, series),
                        text={"/run/status": status_text, "/run/config": job_config_yaml(cfg)})
    log.info("simulated in %.3f s; recording of %d samples x %d columns written in %.3f s",
             mem.simulate_seconds, len(traj.t), sum(len(s.names) for s in series),
             time.perf_counter() - t1)
    table.to_csv(out_dir / "metrics.csv", index=False)
    log.info("metrics:\n%s", table.to_string(index=False))
    result = RunResult(exp, traj, table, out_dir, series)
    if not traj.ok:
        raise SimulationFailed(f"run stopped at t = {traj.t_stop:g} s: {traj.message} "
                               f"(outputs up to then are in {out_dir})")
    _figures(cfg, result)
    return result
