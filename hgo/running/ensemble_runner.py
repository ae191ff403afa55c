"""An ensemble experiment from a Hydra config: many members in one compiled call.

Members (:func:`hgo.running.ensemble.plan_members`) are the points of ``ensemble.grid`` (dotted
keys -> value lists, Cartesian product) times ``ensemble.size`` replicates that differ by
the values drawn for ``ensemble.vary`` (dotted keys -> uniform ranges) and by their noise
seed (replicate j uses ``seed + j``: without a grid, member i is the run of seed + i; a
grid of one replicate reproduces the jobs of the multirun over the same lists).
``ensemble.shard = "i/N"`` runs the i-th of N blocks of the members. All members share
one compiled kernel and run in parallel (:func:`hgo.engine.simulate.simulate_ensemble`),
each with its own RK4 step cap, as its single run. With a ``postprocess`` group the
members' trajectories are kept and post-processed (the same rows as a single run's
``metrics.csv``); otherwise only the trailing-window metrics come back. Outputs:

* ``metrics.csv``: one row per (member, observer, quantity) with the member's index and
  varied values, then aggregate rows (``member = all``): mean (``empirical``), ``std``,
  ``min``, ``max``, ``n_ok``, ``n_failed``, and ``holds_fraction`` where a bound exists.
* ``recording.rrd``: the trajectory of member 0 (a representative run; ``recording.mode``).
* ``ensemble.png``: the distribution of every metric over the members (with
  ``ensemble.size`` > 1 replicates; a grid's figures are its reports').
* what each entry of ``ensemble.reports`` (name -> ``_target_`` of ``f(result, out_dir)``)
  writes: the combined tables and figures of the equivalent multirun's callback.

The ``figures`` of the config draw one run and are not applied (a warning says so).
"""

from __future__ import annotations

import logging
import time
from dataclasses import dataclass
from datetime import datetime
from pathlib import Path

import numpy as np
import pandas as pd
from omegaconf import DictConfig

from hgo.core import targets
from hgo.core.errors import ConfigError
from hgo.core.memory import collection_paused
from hgo.core.validate import check_ensemble_cost, check_values
from hgo.engine.jit import run_seconds
from hgo.engine.simulate import (
    INTERRUPTED,
    not_run,
    rho_const,
    simulate,
    simulate_ensemble,
)
from hgo.engine.system import System
from hgo.noise import NoiseModel
from hgo.outputs.console import ensemble_table
from hgo.outputs.decimate import recording_mode, write_run_recording
from hgo.outputs.metrics import metric_rows
from hgo.outputs.recording import atomic_output
from hgo.postprocess import PostOutput
from hgo.running.ensemble import (
    build_members,
    member_count,
    member_nodes,
    plain_value,
    plan_members,
    stack_members,
)
from hgo.running.figures import figure_nodes
from hgo.running.progress import bar
from hgo.running.runner import (
    RunInterrupted,
    _construct,
    _instantiate,
    blueprint,
    build_system,
    check_cost,
    job_config_yaml,
    recording_id,
    run_size,
    signals,
    solver_settings,
    status_text,
    track,
)
from hgo.running.viewer_layout import styled

log = logging.getLogger(__name__)
CHUNKS = 10  # progress is reported after each tenth of the members


@dataclass
class EnsembleResult:
    systems: list[System]
    draws: dict[str, np.ndarray]  # varied key -> values of the members (grid and drawn)
    acc: np.ndarray
    status: np.ndarray
    t_stop: np.ndarray
    metrics: pd.DataFrame
    trajectories: list | None = None  # per member, when post-processed
    nodes: list | None = None  # per member: its config groups (hgo.running.ensemble.GROUPS)
    index: np.ndarray | None = None  # per member: its index in the unsharded ensemble


def is_ensemble(cfg: DictConfig) -> bool:
    """True if the config asks for an ensemble (``ensemble.size`` other than 0, or a grid;
    a negative size is refused by :func:`prepare_ensemble`)."""
    return int(cfg.ensemble.size) != 0 or bool(cfg.ensemble.get("grid"))


def _simulate_chunks(solver, noise, params, z0, d0, systems, record) -> dict:
    """simulate_ensemble in chunks, logging progress (one compiled call per chunk). Ctrl-C
    stops it after the chunk it interrupted: the members of the chunks not run are
    interrupted at t = 0, their metrics NaN (:func:`~hgo.engine.simulate.not_run`)."""
    n = len(params)
    rho = np.array([rho_const(s, solver) for s in systems])
    edges = np.unique(np.linspace(0, n, min(CHUNKS, n) + 1).astype(int))
    parts, start, done = [], time.perf_counter(), 0
    with bar(n, "ensemble", "members") as progress:
        for a, b in zip(edges[:-1], edges[1:], strict=True):
            parts.append(simulate_ensemble(systems[0], solver, noise[a:b], params[a:b],
                                           z0[a:b], d0[a:b], rho=rho[a:b], record=record))
            progress.update(b - a)
            done, interrupted = b, bool((parts[-1]["status"] == INTERRUPTED).any())
            log.info("ensemble: %d/%d members%s (%.2f s)", b, n,
                     ", interrupted" if interrupted else "", time.perf_counter() - start)
            if interrupted:
                break
    out = {k: np.concatenate([p[k] for p in parts]) for k in ("acc", "status", "t_stop")}
    if done < n:
        out["acc"] = np.vstack([out["acc"], np.full((n - done, out["acc"].shape[1]), np.nan)])
        out["status"] = np.concatenate([out["status"], np.full(n - done, INTERRUPTED)])
        out["t_stop"] = np.concatenate([out["t_stop"], np.zeros(n - done)])
    if record:
        out["trajectories"] = [tr for p in parts for tr in p["trajectories"]] + [
            not_run(system) for system in systems[done:]]
    return out


def _post(nodes: list, systems: list[System], trajectories: list) -> list[PostOutput]:
    """Every member's post-processing, in config order (post-processors built once per
    distinct node)."""
    built: dict[str, object] = {}
    outs = []
    for node, system, traj in zip(nodes, systems, trajectories, strict=True):
        total = PostOutput()
        if traj.ok:
            for name, spec in (node or {}).items():
                key = f"{name}={spec!r}"
                if key not in built:
                    built[key] = _construct(spec, f"postprocess.{name}")
                out = built[key].apply(system, traj)
                total.series += out.series
                total.rows += [{"postprocess": name, **row} for row in out.rows]
                total.bounds.update(out.bounds)
        outs.append(total)
    return outs


def _member_rows(systems, plan, out, posts) -> list[dict]:
    rows = []
    for i, system in enumerate(systems):
        varied = {k: plain_value(v[i]) for k, v in plan.values.items()}
        post = posts[i] if posts else PostOutput()
        for row in metric_rows(system, out["acc"][i], int(out["status"][i]),
                               float(out["t_stop"][i]), post.bounds, post.rows):
            rows.append({"member": str(int(plan.index[i])), **row, "seed": plan.seeds[i],
                         **varied})
    return rows


def _aggregate(members: pd.DataFrame) -> pd.DataFrame:
    """Mean and spread of every (observer, quantity) over the members that ran to the end."""
    rows = []
    keys = ["observer", "postprocess", "quantity"]
    for (obs, pp, quantity), grp in members.groupby(keys, sort=False, dropna=False):
        ok = grp[grp.status == "ok"]
        values = ok.empirical.to_numpy(float)
        has_bound = bool(np.isfinite(ok.bound.to_numpy(float)).any())
        rows.append({"member": "all", "observer": obs, "postprocess": pp, "quantity": quantity,
                     "empirical": values.mean() if len(values) else np.nan,
                     "std": _std(values),
                     "min": values.min() if len(values) else np.nan,
                     "max": values.max() if len(values) else np.nan,
                     "n_ok": len(ok), "n_failed": int((grp.status != "ok").sum()),
                     "holds_fraction": ok.holds.astype(float).mean() if has_bound else np.nan})
    return pd.DataFrame(rows)


def merge_shards(shard_dirs: list[str | Path], out: str | Path | None = None) -> pd.DataFrame:
    """The metrics table of the whole ensemble from its shards' ``metrics.csv``: member
    rows in member order, aggregates recomputed over all members (the table the unsharded
    run writes). With ``out``, written there as ``metrics.csv``."""
    tables = [pd.read_csv(Path(d) / "metrics.csv", dtype={"member": str}) for d in shard_dirs]
    ids = [set(t.member[t.member != "all"]) for t in tables]
    if sum(map(len, ids)) != len(set().union(*ids)):
        raise ValueError("merge_shards: a member is in more than one shard")
    members = pd.concat([t[t.member != "all"] for t in tables], ignore_index=True)
    order = np.argsort(members.member.astype(int).to_numpy(), kind="stable")
    members = members.iloc[order].reset_index(drop=True)
    run = members.pop("run")
    table = pd.concat([members, _aggregate(members)], ignore_index=True)
    table.insert(0, "run", run.iloc[0])
    if out is not None:
        Path(out).mkdir(parents=True, exist_ok=True)
        table.to_csv(Path(out) / "metrics.csv", index=False)
    return table


def _std(values: np.ndarray) -> float:
    """Sample standard deviation (inf when the squares overflow, e.g. vacuous bounds)."""
    if len(values) < 2:
        return np.nan
    with np.errstate(over="ignore"):
        return float(values.std(ddof=1))


def _record_member0(cfg, out_dir, systems, solver, noise, size, post, first) -> None:
    """The representative recording: member 0's run (``first``, its trajectory if kept,
    else simulated again) with its post-processed series; returns that run (``first`` as
    given when ``recording.mode`` is off: nothing is simulated again, nor Rerun loaded)."""
    if recording_mode(cfg.get("recording")) == "off":
        log.info("recording.mode=off: no recording.rrd")
        return first
    first = first or simulate(systems[0], solver, noise)
    series = styled(systems[0], signals(systems[0], first)) + post.series
    write_run_recording(cfg.get("recording"), out_dir / "recording.rrd", first.t, series,
                        recording_id=recording_id(out_dir),
                        blueprint=blueprint(systems[0], series),
                        text={"/run/status": f"ensemble of {size}; this recording: member 0, "
                                             + status_text(first),
                              "/run/config": job_config_yaml(cfg)})
    return first


@dataclass
class EnsemblePlan:
    """An ensemble planned, built and checked, not yet integrated."""

    plan: object  # hgo.running.ensemble.MemberPlan
    nodes: list
    systems: list[System]
    solver: object
    noise: list
    params: np.ndarray
    z0: np.ndarray
    d0: np.ndarray


def _check_members_cost(cfg: DictConfig, solver) -> None:
    """Members, memory and steps of the ensemble estimated from its count and the base
    config's run, before any member is made (:func:`hgo.core.validate.check_ensemble_cost`):
    a 1e9-point grid or ``ensemble.size=1e8`` ended in MemoryError after 1-20 s."""
    n_members = member_count(cfg)
    one = run_size(build_system(cfg), solver, _instantiate(cfg.noise, "noise", NoiseModel))
    record = bool(cfg.get("postprocess"))  # post-processed members keep their trajectory
    member_bytes = 8 * (one.noise + (one.rows * one.columns if record else 0))
    key = "ensemble.grid" if cfg.ensemble.get("grid") else "ensemble.size"
    check_ensemble_cost(n_members, member_bytes, one.steps, solver.max_steps, key=key)


def prepare_ensemble(cfg: DictConfig) -> EnsemblePlan:
    """Check the config, plan and build every member and sample its noise (no integration)."""
    check_values(cfg)
    if int(cfg.ensemble.size) < 0:
        raise ConfigError("ensemble.size", f"must be >= 0, got {cfg.ensemble.size}",
                          "0 for a single run (or one member per grid point), or >= 1")
    solver = solver_settings(cfg)
    _check_members_cost(cfg, solver)
    with collection_paused():
        return _prepare_members(cfg, solver)


def _prepare_members(cfg: DictConfig, solver) -> EnsemblePlan:
    """Members planned, built, stacked and their noise sampled."""
    plan = plan_members(cfg)
    size = len(plan.index)
    nodes = member_nodes(cfg, plan.values) if plan.values else [cfg] * size
    systems = build_members(nodes) if plan.values else [build_system(cfg)] * size
    params, z0, d0 = stack_members(systems)
    ny = len(systems[0].plant.output_names)
    models: dict[str, NoiseModel] = {}

    def noise_model(node) -> NoiseModel:
        key = repr(node)
        if key not in models:
            models[key] = _instantiate(node, "noise", NoiseModel)
            models[key].check_channels(ny)
        return models[key]

    noise = [noise_model(n["noise"]).sample(solver.t_end, ny, seed)
             for n, seed in zip(nodes, plan.seeds, strict=True)]
    stiffest = max(range(size), key=lambda i: rho_const(systems[i], solver))
    check_cost(systems[stiffest], solver, noise_model(nodes[stiffest]["noise"]))
    return EnsemblePlan(plan, nodes, systems, solver, noise, params, z0, d0)


def run_ensemble(cfg: DictConfig, out_dir: str | Path) -> EnsembleResult:
    """Plan, build, integrate and tabulate the members of ``cfg.ensemble``."""
    out_dir = Path(out_dir)
    figures = figure_nodes(cfg)
    if figures:
        log.warning("ensemble: figures %s not applied (they draw one run; see "
                    "ensemble.reports)", ", ".join(figures))
    ready = prepare_ensemble(cfg)
    plan, nodes, systems, solver, noise = (ready.plan, ready.nodes, ready.systems,
                                           ready.solver, ready.noise)
    size = len(plan.index)
    out_dir.mkdir(parents=True, exist_ok=True)
    started = datetime.now()
    record = bool(cfg.get("postprocess"))
    with run_seconds() as timings:
        out = _simulate_chunks(solver, noise, ready.params, ready.z0, ready.d0, systems, record)
    posts = _post([n["postprocess"] for n in nodes], systems, out["trajectories"]) \
        if record else None

    members = pd.DataFrame(_member_rows(systems, plan, out, posts))
    table = pd.concat([members, _aggregate(members)], ignore_index=True)
    table.insert(0, "run", cfg.get("run_name", "run"))
    with atomic_output(out_dir / "metrics.csv") as partial:
        table.to_csv(partial, index=False)
    aggregate = table[table.member == "all"]
    log.info("ensemble metrics over %d members (all columns in metrics.csv):\n%s", size,
             ensemble_table(aggregate))
    first = _record_member0(cfg, out_dir, systems, solver, noise[0], size,
                            posts[0] if posts else PostOutput(),
                            out["trajectories"][0] if record else None)
    if int(cfg.ensemble.size) > 1:  # a distribution of replicates (a grid has its reports)
        from hgo.outputs.ensemble_figures import metric_histograms  # (matplotlib: only when drawn)

        metric_histograms(members, out_dir / "ensemble.png")
    n_failed = int((out["status"] != 0).sum())
    if n_failed:
        log.warning("ensemble: %d of %d members stopped early (see metrics.csv)", n_failed, size)
    interrupted = (out["status"] == INTERRUPTED).any() or (
        first is not None and first.status == INTERRUPTED)
    status = ("interrupted" if interrupted else
              f"ok ({n_failed} of {size} members stopped early)" if n_failed else "ok")
    track(cfg, out_dir, started, status, timings, aggregate)
    if interrupted:
        raise RunInterrupted(f"ensemble interrupted (outputs up to then are in {out_dir})")
    values = {k: np.asarray(v) for k, v in plan.values.items()}
    result = EnsembleResult(systems, values, out["acc"], out["status"], out["t_stop"], table,
                            out.get("trajectories"), nodes, plan.index)
    for name, node in (cfg.ensemble.get("reports") or {}).items():
        if node is not None:
            log.info("ensemble report %s", name)
            report = targets.instantiate(node, f"ensemble.reports.{name}", _partial_=True)
            report(result, out_dir)
    return result
