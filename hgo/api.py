"""hgo's Python API: compose a config, run it, sweep a grid — what ``hgo run`` does, from a
notebook or a script. Everything here is re-exported from ``hgo`` (``hgo.run``,
``hgo.compose``, ``hgo.sweep``, ``hgo.Result``, ``hgo.HgoError``).

Errors of the configuration (an unknown option, a misspelt key, a bad value) raise
``hgo.HgoError`` with the one line ``hgo run`` prints after ``error:``; the
original exception is its ``__cause__``. A simulation that stops early (diverged, step
limit) is not an error here: its ``Result`` says so in ``status``.
"""

from __future__ import annotations

import logging
import tempfile
from collections.abc import Iterator, Mapping, Sequence
from contextlib import contextmanager, nullcontext
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import pandas as pd
from omegaconf import DictConfig, OmegaConf, open_dict

from hgo.core.errors import HgoError, is_config_error, one_line

__all__ = ["HgoError", "Result", "compose", "run", "signals_frame", "sweep"]


@dataclass
class Result:
    """One run of ``run``.

    Attributes:
        config: the composed config (Hydra's node included).
        metrics: the metrics table, as ``metrics.csv``: one row per (observer, quantity)
            with ``empirical``, ``bound``, ``ratio``, ``holds``, ``verdict``, ``status``.
        signals: every logged series, indexed by ``sim_time`` (seconds), one column per
            series named ``<entity>/<series>`` as ``hgo.read_recording`` names them
            (``/plant/x/x1``, ``/observer/<name>/xhat/x1_hat``, ``/error/<name>/e_x1``).
        status: ``"ok"``, or ``"failed: <why>"`` / ``"interrupted: <why>"`` for a run that
            stopped early (its signals end there, its metrics are NaN).
        timings: seconds: ``compile`` (numba, new kernels only), ``simulate``,
            ``postprocess`` (post-processors and metrics); with an ``out_dir`` also
            ``write`` (the recording) and ``figures`` (drawing them, or waiting for the
            process that draws them while the recording is written).
        out_dir: the run directory, or None when nothing was written.
    """

    config: DictConfig
    metrics: pd.DataFrame
    signals: pd.DataFrame
    status: str
    timings: dict[str, float] = field(default_factory=dict)
    out_dir: Path | None = None

    @property
    def ok(self) -> bool:
        """Whether the run reached ``solver.t_end``."""
        return self.status == "ok"

    @property
    def recording(self) -> Path | None:
        """``recording.rrd`` of the run directory (None when nothing was written or
        ``recording.mode=off``)."""
        path = self.out_dir / "recording.rrd" if self.out_dir else None
        return path if path is not None and path.is_file() else None


@contextmanager
def _as_hgo_errors() -> Iterator[None]:
    """What ``hgo run`` reports as one line — configuration errors, and a folder that cannot
    be written (``OSError``) — as ``HgoError`` with that line; anything else (a bug) as is."""
    try:
        yield
    except HgoError:
        raise
    except Exception as err:
        if not (is_config_error(err) or isinstance(err, OSError)):
            raise
        raise HgoError(one_line(err)) from err


def compose(overrides: Sequence[str] | None = None,
            config_dir: str | Path | None = None) -> DictConfig:
    """The config ``hgo run <overrides>`` would run, e.g.
    ``hgo.compose(["experiment=sp_fig1", "solver.t_end=5"])``.

    Args:
        overrides: Hydra overrides, as on the command line.
        config_dir: a folder of your own config groups and presets (``plant/vdp.yaml``,
            ``experiment/mine.yaml``), added to hgo's as ``hgo run --config-dir`` does.

    Raises:
        HgoError: the one-line message of a bad override or config.
    """
    from hgo.core.config import compose as compose_config

    with _as_hgo_errors():
        return compose_config(list(overrides or []), config_dir=config_dir)


def _config(cfg_or_overrides: DictConfig | Sequence[str] | None) -> DictConfig:
    if isinstance(cfg_or_overrides, DictConfig):
        return cfg_or_overrides
    if isinstance(cfg_or_overrides, str):  # one override, not a list of characters
        cfg_or_overrides = [cfg_or_overrides]
    return compose(cfg_or_overrides)


def signals_frame(t, series) -> pd.DataFrame:
    """``hgo.outputs.recording.Series`` on the time grid ``t`` as one DataFrame indexed by
    ``sim_time``, columns named as ``hgo.read_recording`` names them."""
    from hgo.outputs.recording import materialized

    columns = {f"{s.entity}/{name}": s.values[:, j]
               for s in materialized(series) for j, name in enumerate(s.names)}
    return pd.DataFrame(columns, index=pd.Index(t, name="sim_time"))


def _status(traj) -> str:
    """The status ``run.json`` records (``hgo.running.runner.track``)."""
    from hgo.outputs.metrics import status_word

    return "ok" if traj.ok else f"{status_word(traj.status)}: {traj.message}"


def _refuse_ensemble(cfg: DictConfig) -> None:
    from hgo.running.ensemble_runner import is_ensemble

    if is_ensemble(cfg):
        raise HgoError("ensemble: hgo.run runs one simulation; run ensemble.size / "
                       "ensemble.grid with hgo.sweep(cfg)")


def _in_memory(cfg: DictConfig) -> Result:
    from hgo.running.runner import signals, simulate_config

    mem = simulate_config(cfg)
    traj = mem.trajectory
    series = signals(mem.experiment.system, traj) + mem.post.series
    return Result(cfg, mem.metrics, signals_frame(traj.t, series), _status(traj),
                  mem.timings)


def _hydra_files(cfg: DictConfig, out_dir: Path) -> None:
    """``.hydra/{config,hydra,overrides}.yaml`` as Hydra writes them for ``hgo run``."""
    hydra_dir = out_dir / ".hydra"
    hydra_dir.mkdir(parents=True, exist_ok=True)
    job = OmegaConf.masked_copy(cfg, [k for k in cfg if k != "hydra"])
    OmegaConf.save(job, hydra_dir / "config.yaml")
    if "hydra" in cfg:
        OmegaConf.save(OmegaConf.create({"hydra": cfg.hydra}), hydra_dir / "hydra.yaml")
        OmegaConf.save(OmegaConf.create(list(cfg.hydra.overrides.task)),
                       hydra_dir / "overrides.yaml")


@contextmanager
def _job_log(out_dir: Path) -> Iterator[None]:
    """hgo's log lines of the run into ``<out_dir>/app.log``, in the format of Hydra's job
    log (``hgo run`` writes that file); nothing more on the console than before."""
    logger = logging.getLogger("hgo")
    handler = logging.FileHandler(out_dir / "app.log")
    handler.setFormatter(logging.Formatter("[%(asctime)s][%(name)s][%(levelname)s] - "
                                           "%(message)s"))
    level, propagate = logger.level, logger.propagate
    logger.addHandler(handler)
    if logger.getEffectiveLevel() > logging.INFO:  # INFO to the file only
        logger.setLevel(logging.INFO)
        logger.propagate = False
    try:
        yield
    finally:
        logger.removeHandler(handler)
        handler.close()
        logger.setLevel(level)
        logger.propagate = propagate


def _into_directory(cfg: DictConfig, out_dir: Path) -> Result:
    """What ``hgo run`` writes: recording, metrics, figures, run.json, app.log, .hydra/ and
    the completion marker."""
    from hgo.running.job import mark_complete
    from hgo.running.runner import SimulationFailed
    from hgo.running.runner import run as run_to_directory

    out_dir.mkdir(parents=True, exist_ok=True)
    cfg = cfg.copy()  # (the caller's config keeps its own run directory)
    if "hydra" in cfg:
        with open_dict(cfg):
            cfg.hydra.runtime.output_dir = str(out_dir.resolve())
    _hydra_files(cfg, out_dir)
    with _job_log(out_dir):
        try:
            done = run_to_directory(cfg, out_dir)
        except SimulationFailed as err:  # outputs up to the stop are written
            done = err.result
        else:
            mark_complete(cfg, out_dir)
    traj = done.trajectory
    return Result(cfg, done.metrics, signals_frame(traj.t, done.series), _status(traj),
                  dict(done.timings), out_dir)


def run(cfg_or_overrides: DictConfig | Sequence[str] | None = None,
        out_dir: str | Path | None = None) -> Result:
    """Run one experiment, e.g. ``hgo.run(["experiment=sp_fig1", "solver.t_end=5"])``.

    Args:
        cfg_or_overrides: a config from ``compose``, or a list of overrides.
        out_dir: write the run directory ``hgo run`` writes (``recording.rrd``,
            ``metrics.csv``, figures, ``run.json``, ``.hydra/``) here; None (default):
            write nothing.

    Returns:
        The ``Result``; a run that stopped early is returned too (see ``status``).

    Raises:
        HgoError: the one-line message of a bad config (as ``hgo run`` prints it).
    """
    with _as_hgo_errors():
        cfg = _config(cfg_or_overrides)
        _refuse_ensemble(cfg)
        return _in_memory(cfg) if out_dir is None else _into_directory(cfg, Path(out_dir))


def members_table(metrics: pd.DataFrame, keys: Sequence[str]) -> pd.DataFrame:
    """An ensemble's long metrics table (one row per member x metric) as one row per
    member: its ``keys`` values, ``seed``, ``status``, then one column per metric named
    ``<observer>/<quantity>`` (or ``<quantity>`` for a metric of no observer)."""
    members = metrics[metrics.member != "all"].copy()
    members["member"] = members.member.astype(int)
    observer = members.observer.where(members.observer.apply(isinstance, args=(str,)), "")
    members["metric"] = (observer + "/" + members.quantity).str.lstrip("/")
    values = members.pivot_table(index="member", columns="metric", values="empirical",
                                 aggfunc="first", sort=False, dropna=False)
    params = members.groupby("member", sort=True)[[*keys, "seed", "status"]].first()
    params["seed"] = params.seed.astype(int)  # (a float column in the long table)
    table = params.join(values)
    table.columns.name = None
    return table


def sweep(cfg: DictConfig | Sequence[str] | None = None,
          grid: Mapping[str, Sequence[Any]] | None = None,
          out_dir: str | Path | None = None) -> pd.DataFrame:
    """Run a grid of configs as one ensemble (one compiled call), e.g.
    ``hgo.sweep(["experiment=sp_fig1", "solver.t_end=20"],
    grid={"observer.sign_indefinite.p2": [0.004, 0.008]})``.

    Args:
        cfg: a config from ``compose``, or a list of overrides.
        grid: dotted key -> values; their Cartesian product (``ensemble.grid``), with
            ``ensemble.size`` replicates per point. None: the config's own grid.
        out_dir: write the ensemble's directory (``metrics.csv``, its reports, member 0's
            recording) here; None: nothing is kept (no recording, no reports).

    Returns:
        One row per member (index ``member``): the grid's keys, ``seed``, ``status``,
        then one column per metric ``<observer>/<quantity>`` (the ``empirical`` value).

    Raises:
        HgoError: the one-line message of a bad config or grid key.
    """
    from hgo.running.ensemble_runner import run_ensemble
    from hgo.running.figures import figure_nodes

    with _as_hgo_errors():
        cfg = _config(cfg).copy()
        with open_dict(cfg):
            if grid is not None:
                cfg.ensemble.grid = {key: list(values) for key, values in grid.items()}
            if out_dir is None:  # nothing is kept: no recording, reports or figures
                cfg.recording.mode = "off"
                cfg.ensemble.reports = {}
                for name in figure_nodes(cfg):
                    cfg.figures[name] = None
        if not cfg.ensemble.get("grid") and int(cfg.ensemble.size) == 0:
            raise HgoError("ensemble.grid: hgo.sweep needs a grid (grid={key: values}) "
                           "or ensemble.size > 0")
        keys = [k for k in OmegaConf.to_container(cfg.ensemble.grid) if k != "seed"]
        keys += [k for k in OmegaConf.to_container(cfg.ensemble.vary) if k not in keys]
        where = nullcontext(out_dir) if out_dir is not None else tempfile.TemporaryDirectory()
        with where as directory:
            result = run_ensemble(cfg, Path(directory))
        return members_table(result.metrics, keys)

