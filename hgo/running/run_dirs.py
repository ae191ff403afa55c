"""Run and sweep directories written by one run or one sweep at a time.

* :func:`lock_run_dir`: a run (a sweep's job too) holds its directory's lock (``flock`` on
  ``.hgo_lock``) while it writes; another run into it is refused at once.
* :func:`lock_job_dirs_first`: a sweep's job takes that lock before Hydra writes anything
  into its directory (its log file and ``.hydra/``): Hydra writes them before any callback
  of the job runs.
* :func:`guard_sweep_dir`: a live sweep holds its sweep directory's lock, and a sweep into
  a directory holding another sweep (its ``multirun.yaml`` differs) is refused; the same
  sweep again is allowed (``resume=true`` skips its complete jobs).
* :func:`note_job` / :func:`sweep_jobs`: the jobs of the sweep that last ran in a
  directory, so that its summary lists those and no other.
"""

from __future__ import annotations

import os
import shutil
from pathlib import Path

from omegaconf import DictConfig, OmegaConf

from hgo.core.errors import ConfigError, PlainError

LOCK = ".hgo_lock"  # held (flock) in a run directory while a run writes it
JOBS = ".hgo_jobs"  # in a sweep directory: the jobs of the sweep that ran last, one a line
FAILED = ".hgo_failed"  # in a sweep directory: <job name> -> "<exit code>\n<one line>"
MULTIRUN = "multirun.yaml"  # Hydra's record of a sweep in its directory


class RunDirBusy(PlainError, OSError):
    """Another run is writing the run directory."""


_LOCKS: dict[Path, int] = {}  # run directory -> the descriptor holding its lock


def lock_run_dir(out_dir: str | Path, key: str = "hydra.run.dir") -> None:
    """Hold the lock of ``out_dir`` (created if needed; a :class:`ConfigError` naming the
    option ``key`` that sets it when it cannot be) for this process, or raise
    :class:`RunDirBusy` at once when another process holds it: two runs into one
    ``hydra.run.dir`` left a mix of both marked complete. The lock goes with the process
    (``flock``): a killed run leaves none behind. Idempotent within a process."""
    import fcntl

    path = Path(out_dir).resolve()
    if path in _LOCKS:
        return
    try:
        path.mkdir(parents=True, exist_ok=True)
    except FileExistsError:
        raise ConfigError(key, f"{path} is a file, not a directory",
                          "a directory, or a path to create") from None
    except OSError as err:  # a parent that is a file, no permission
        raise ConfigError(key, f"cannot create {path} ({err.strerror or err})") from None
    fd = os.open(path / LOCK, os.O_RDWR | os.O_CREAT, 0o644)
    try:
        fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
    except BlockingIOError:
        holder = os.pread(fd, 32, 0).decode(errors="replace").strip() or "?"
        os.close(fd)
        raise RunDirBusy(f"{path} is being written by another run (pid {holder}); give "
                         f"this run another {key} or wait for that one") from None
    os.ftruncate(fd, 0)
    os.pwrite(fd, f"{os.getpid()}\n".encode(), 0)
    _LOCKS[path] = fd


def unlock_run_dir(out_dir: str | Path) -> None:
    fd = _LOCKS.pop(Path(out_dir).resolve(), None)
    if fd is not None:
        os.close(fd)


def _lock_current_job() -> None:
    """The lock of the directory of the sweep job Hydra is setting up (nothing outside a
    sweep: a single run's is taken by :class:`hgo.running.job.RunGuard`)."""
    from hydra.core.hydra_config import HydraConfig
    from hydra.types import RunMode

    if not HydraConfig.initialized():
        return
    hc = HydraConfig.get()
    out_dir = OmegaConf.select(hc, "runtime.output_dir", default=None)
    if hc.mode == RunMode.MULTIRUN and out_dir:
        lock_run_dir(out_dir, "hydra.sweep.dir")


def lock_job_dirs_first() -> None:
    """Make Hydra's job set-up (``hydra.core.utils.run_job``) take the job directory's lock
    before it writes the job's log file and ``.hydra/`` (idempotent). ``run_job`` looks up
    ``configure_log`` and ``_save_config`` in its module when it calls them, with the job's
    output directory already set; a lock held by another process stops the sweep with one
    line (:class:`RunDirBusy`) before that job writes anything."""
    import hydra.core.utils as hydra_utils

    for name in ("configure_log", "_save_config"):
        original = getattr(hydra_utils, name)
        if getattr(original, "hgo_locks_first", False):
            continue

        def locked(*args, _original=original, **kwargs):
            _lock_current_job()
            return _original(*args, **kwargs)

        locked.hgo_locks_first = True
        setattr(hydra_utils, name, locked)


def _definition(cfg: DictConfig) -> dict:
    """What makes a sweep, as its ``multirun.yaml`` records it: the composed config without
    Hydra's node and ``resume``, the task overrides without ``resume``, and the sweeper's
    params. Read through YAML text, as the file is written."""
    plain = OmegaConf.to_container(OmegaConf.create(OmegaConf.to_yaml(cfg)), resolve=False)
    hydra = plain.pop("hydra", None) or {}
    plain.pop("resume", None)
    task = (hydra.get("overrides") or {}).get("task") or []
    return {"overrides": [o for o in task if o.partition("=")[0].lstrip("+~") != "resume"],
            "params": (hydra.get("sweeper") or {}).get("params"), "config": plain}


def _only(overrides: list[str], other: list[str]) -> str:
    """The overrides of ``overrides`` that ``other`` has not (in order)."""
    return " ".join(o for o in overrides if o not in other) or "no other overrides"


def check_same_sweep(config: DictConfig, sweep: Path) -> None:
    """Refuse (:class:`ConfigError`) a sweep into ``sweep`` when that directory holds
    another sweep: its ``multirun.yaml`` differs from this one in the overrides, the
    sweeper's params or the composed config (``resume`` aside)."""
    saved = sweep / MULTIRUN
    if not saved.exists():
        return
    now = _definition(config)
    try:
        before = _definition(OmegaConf.load(saved))
    except Exception:  # noqa: BLE001 - any unreadable file: not provably the same sweep
        before = None
    if before == now:
        return
    if before is None:
        what = f"its {MULTIRUN} is unreadable"
    elif before["overrides"] != now["overrides"]:
        what = (f"it ran {_only(before['overrides'], now['overrides'])} where this runs "
                f"{_only(now['overrides'], before['overrides'])}")
    elif before["params"] != now["params"]:
        what = "its hydra.sweeper.params differ"
    else:
        what = "its composed config differs (a preset or group file changed)"
    raise ConfigError("hydra.sweep.dir", f"{sweep} holds another sweep ({what}); its "
                      "results would mix with this one's",
                      "a new hydra.sweep.dir, or the same sweep again (resume=true skips "
                      "its complete jobs)")


def guard_sweep_dir(config: DictConfig) -> None:
    """At a sweep's start: hold its directory's lock for the sweep (another live sweep into
    it is refused), refuse a directory holding another sweep (:func:`check_same_sweep`),
    and forget the job and failure notes of the sweep that ran there before."""
    sweep = Path(config.hydra.sweep.dir)
    lock_run_dir(sweep, "hydra.sweep.dir")
    check_same_sweep(config, sweep)
    shutil.rmtree(sweep / FAILED, ignore_errors=True)
    (sweep / JOBS).write_text("")


def note_job(sweep: Path, job: str) -> None:
    """Record that ``job`` (a folder of ``sweep``) belongs to the sweep now running (one
    appended line: jobs in other processes may add theirs at once)."""
    notes = Path(sweep) / JOBS
    if notes.is_file():
        with open(notes, "a") as fh:
            fh.write(f"{job}\n")


def _job_key(p: Path) -> tuple:
    digits = "".join(c for c in p.name if c.isdigit())
    return (int(digits) if digits else float("inf"), p.name)


def sweep_jobs(sweep: Path) -> list[Path]:
    """The job directories of the sweep that ran last in ``sweep`` (its notes), in job
    order; without notes (a sweep of an older hgo, a folder made by hand), every folder
    with a ``.hydra/`` or named ``job*``."""
    sweep = Path(sweep)
    notes = sweep / JOBS
    if notes.is_file():
        jobs = [sweep / name for name in notes.read_text().split("\n")
                if name and (sweep / name).is_dir()]
    else:
        jobs = [p for p in sweep.iterdir() if p.is_dir()
                and ((p / ".hydra").is_dir() or p.name.startswith("job"))]
    return sorted(set(jobs), key=_job_key)
