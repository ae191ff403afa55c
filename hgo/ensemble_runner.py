"""An ensemble experiment from a Hydra config: ``ensemble.size`` members in one call.

Members differ by the values drawn for ``ensemble.vary`` (dotted config keys -> uniform
ranges) and by their noise seed (member i uses ``seed + i``, so member 0 is the plain run
of the config when nothing is varied). All members share one compiled kernel and run in
parallel (:func:`hgo.engine.simulate.simulate_ensemble`); only the trailing-window
metrics come back. Outputs in the run directory:

* ``metrics.csv``: one row per (member, observer, quantity) with the drawn values, then
  aggregate rows (``member = all``): mean (``empirical``), ``std``, ``min``, ``max``,
  ``n_ok``, ``n_failed``, and ``holds_fraction`` where a bound exists.
* ``recording.rrd``: the full trajectory of member 0 (a representative run).
* ``ensemble.png``: the distribution of every metric over the members.

The ``postprocess`` and ``figures`` of the config need trajectories and are not applied
(a warning says so).
"""

from __future__ import annotations

import logging
import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pandas as pd
from omegaconf import DictConfig

from hgo.engine.simulate import INTERRUPTED, STATUS, simulate, simulate_ensemble
from hgo.engine.system import System
from hgo.ensemble import draw_members, member_nodes, stack_members, stiffest_envelope
from hgo.errors import ConfigError
from hgo.figures.ensemble import metric_histograms
from hgo.metrics import metric_row, status_word, window_means
from hgo.noise import NoiseModel
from hgo.progress import bar
from hgo.recording import atomic_output, write_recording
from hgo.runner import (
    RunInterrupted,
    _instantiate,
    blueprint,
    build_system,
    check_cost,
    job_config_yaml,
    recording_id,
    signals,
    solver_settings,
    status_text,
)
from hgo.validate import check_values

log = logging.getLogger(__name__)
CHUNKS = 10  # progress is reported after each tenth of the members


@dataclass
class EnsembleResult:
    systems: list[System]
    draws: dict[str, np.ndarray]
    acc: np.ndarray
    status: np.ndarray
    t_stop: np.ndarray
    metrics: pd.DataFrame


def _simulate_chunks(system: System, solver, noise, params, z0, d0) -> dict[str, np.ndarray]:
    """simulate_ensemble in chunks, logging progress (one compiled call per chunk)."""
    n = len(params)
    edges = np.unique(np.linspace(0, n, min(CHUNKS, n) + 1).astype(int))
    parts, start = [], time.perf_counter()
    with bar(n, "ensemble", "members") as progress:
        for a, b in zip(edges[:-1], edges[1:], strict=True):
            parts.append(simulate_ensemble(system, solver, noise[a:b], params[a:b], z0[a:b],
                                           d0[a:b]))
            progress.update(b - a)
            log.info("ensemble: %d/%d members (%.2f s)", b, n, time.perf_counter() - start)
    return {k: np.concatenate([p[k] for p in parts]) for k in parts[0]}


def _member_rows(systems, draws, out) -> list[dict]:
    rows = []
    for i, system in enumerate(systems):
        st = int(out["status"][i])
        drawn = {k: (v[i].tolist() if v.ndim > 1 else float(v[i])) for k, v in draws.items()}
        bounds = {o.name: o.bounds for o in system.observers}
        for (obs, quantity), value in window_means(system, out["acc"][i]).items():
            value = float(value) if st == 0 else np.nan
            rows.append({"member": str(i),
                         **metric_row(obs, quantity, value, bounds[obs].get(quantity)),
                         "status": status_word(st),
                         "t_stop": float(out["t_stop"][i]), "message": STATUS[st], **drawn})
    return rows


def _aggregate(members: pd.DataFrame) -> pd.DataFrame:
    """Mean and spread of every (observer, quantity) over the members that ran to the end."""
    rows = []
    for (obs, quantity), grp in members.groupby(["observer", "quantity"], sort=False):
        ok = grp[grp.status == "ok"]
        values = ok.empirical.to_numpy(float)
        has_bound = bool(np.isfinite(ok.bound.to_numpy(float)).any())
        rows.append({"member": "all", "observer": obs, "quantity": quantity,
                     "empirical": values.mean() if len(values) else np.nan,
                     "std": values.std(ddof=1) if len(values) > 1 else np.nan,
                     "min": values.min() if len(values) else np.nan,
                     "max": values.max() if len(values) else np.nan,
                     "n_ok": len(ok), "n_failed": int((grp.status != "ok").sum()),
                     "holds_fraction": ok.holds.astype(float).mean() if has_bound else np.nan})
    return pd.DataFrame(rows)


@dataclass
class EnsemblePlan:
    """An ensemble built and checked, not yet integrated."""

    systems: list[System]
    draws: dict[str, np.ndarray]
    solver: object
    noise: list
    params: np.ndarray
    z0: np.ndarray
    d0: np.ndarray


def prepare_ensemble(cfg: DictConfig) -> EnsemblePlan:
    """Check the config, draw and build every member and sample its noise (no integration)."""
    check_values(cfg)
    size, seed = int(cfg.ensemble.size), int(cfg.seed)
    if size < 1:
        raise ConfigError("ensemble.size", f"must be >= 1 for an ensemble, got {size}",
                          "0 for a single run, or >= 1")
    solver = solver_settings(cfg)
    noise_model = _instantiate(cfg.noise, "noise", NoiseModel)
    draws = draw_members(cfg.ensemble.vary, size, int(cfg.ensemble.seed))
    systems = [build_system(nodes) for nodes in member_nodes(cfg, draws)] if draws else \
        [build_system(cfg)] * size
    ny = len(systems[0].plant.output_names)
    noise_model.check_channels(ny)
    check_cost(stiffest_envelope(systems), solver, noise_model)
    params, z0, d0 = stack_members(systems)
    noise = [noise_model.sample(solver.t_end, ny, seed + i) for i in range(size)]
    return EnsemblePlan(systems, draws, solver, noise, params, z0, d0)


def run_ensemble(cfg: DictConfig, out_dir: str | Path) -> EnsembleResult:
    """Draw, build, integrate and tabulate ``cfg.ensemble.size`` members."""
    out_dir = Path(out_dir)
    skipped = [k for k in ("postprocess", "figures") if cfg.get(k)]
    if skipped:
        log.warning("ensemble: %s not applied (members keep metrics, not trajectories)",
                    " and ".join(skipped))
    plan = prepare_ensemble(cfg)
    size, systems, draws, solver, noise = (len(plan.systems), plan.systems, plan.draws,
                                           plan.solver, plan.noise)
    params, z0 = plan.params, plan.z0
    out_dir.mkdir(parents=True, exist_ok=True)
    out = _simulate_chunks(stiffest_envelope(systems), solver, noise, params, z0, plan.d0)

    members = pd.DataFrame(_member_rows(systems, draws, out))
    table = pd.concat([members, _aggregate(members)], ignore_index=True)
    table.insert(0, "run", cfg.get("run_name", "run"))
    with atomic_output(out_dir / "metrics.csv") as partial:
        table.to_csv(partial, index=False)
    log.info("ensemble metrics (aggregate):\n%s",
             table[table.member == "all"].dropna(axis=1, how="all").to_string(index=False))

    first = simulate(systems[0], solver, noise[0], params[0], z0[0])
    series = signals(systems[0], first)
    write_recording(out_dir / "recording.rrd", first.t, series,
                    recording_id=recording_id(out_dir),
                    blueprint=blueprint(systems[0], series),
                    text={"/run/status": f"ensemble of {size}; this recording: member 0, "
                                         + status_text(first),
                          "/run/config": job_config_yaml(cfg)})
    metric_histograms(members, out_dir / "ensemble.png")
    n_failed = int((out["status"] != 0).sum())
    if n_failed:
        log.warning("ensemble: %d of %d members stopped early (see metrics.csv)", n_failed, size)
    if (out["status"] == INTERRUPTED).any() or first.status == INTERRUPTED:
        raise RunInterrupted(f"ensemble interrupted (outputs up to then are in {out_dir})")
    return EnsembleResult(systems, draws, out["acc"], out["status"], out["t_stop"], table)
