"""One Hydra job of ``experiments/run.py``, with errors as one line on stderr.

:func:`run_job` runs a composed config (a single run or an ensemble) into its run
directory; an error becomes ``error: <one line>`` (:func:`hgo.core.errors.one_line`) and an
exit code: 2 for a configuration error (its run directory, holding nothing but Hydra's
own files, is removed), 1 for a run that failed, 130 for an interrupted one. The other
jobs of a multirun still run. :func:`one_line_errors` gives Hydra's own errors
(composition, schema, YAML, override syntax) the same one line, and sets the exit code
when the application ends. ``HYDRA_FULL_ERROR=1`` restores Hydra's full tracebacks.
"""

from __future__ import annotations

import hashlib
import logging
import os
import shutil
import sys
from collections.abc import Iterator
from contextlib import contextmanager, nullcontext
from pathlib import Path

from hydra.experimental.callback import Callback
from omegaconf import DictConfig, OmegaConf

from hgo.core.errors import PlainError, is_config_error, one_line
from hgo.core.memory import release_freed_memory, skip_exit_collection
from hgo.core.validate import check_run_name
from hgo.outputs.integrity import DONE, Damaged, check_run, manifest, manifest_text, read_marker
from hgo.running.run_dirs import LOCK, RunDirBusy, guard_sweep_dir, lock_run_dir, unlock_run_dir

log = logging.getLogger(__name__)
EXIT_CONFIG, EXIT_FAILED, EXIT_INTERRUPTED = 2, 1, 130
_EXIT_CODES: list[int] = []  # of the jobs of this process that did not succeed
_HYDRA_FILES = {".hydra", LOCK}


def full_error() -> bool:
    """``HYDRA_FULL_ERROR=1``: show tracebacks, as Hydra does."""
    return os.environ.get("HYDRA_FULL_ERROR", "") == "1"


_LAST_ERROR: list[str] = []  # the one line of this process's last failed job


def report(err: BaseException, code: int) -> None:
    """Write ``error: <one line>`` to stderr and remember the job's exit code."""
    line = one_line(err)
    try:
        sys.stderr.write(f"error: {line}\n")
        sys.stderr.flush()
    except OSError:  # a closed terminal (SIGHUP): run.json holds the status
        pass
    _EXIT_CODES.append(code)
    _LAST_ERROR[:] = [line]


def last_error() -> str:
    """The one line of the last job of this process that failed ("" if none)."""
    return _LAST_ERROR[0] if _LAST_ERROR else ""


def exit_with(code: int) -> None:
    """Make this process exit with at least ``code`` when the application ends (the sweep's
    summary: jobs that ran in other processes, under submitit, joblib or ray)."""
    _EXIT_CODES.append(code)


def remove_if_empty(out_dir: str | Path) -> None:
    """Remove a run directory holding only Hydra's files (``.hydra/``, ``*.log``)."""
    path = Path(out_dir)
    if not path.is_dir():
        return
    if all(p.name in _HYDRA_FILES or p.suffix == ".log" for p in path.iterdir()):
        shutil.rmtree(path, ignore_errors=True)
        parent = path.parent  # outputs/<run_name>/ of a single run, if now empty
        if parent.name not in ("", ".") and not any(parent.iterdir()):
            parent.rmdir()


def check_config(cfg: DictConfig) -> None:
    """Everything a run checks before integrating, without integrating (build-only)."""
    from hgo.running.ensemble_runner import is_ensemble, prepare_ensemble
    from hgo.running.runner import build

    if is_ensemble(cfg):
        prepare_ensemble(cfg)
    else:
        build(cfg)


def config_hash(cfg: DictConfig) -> str:
    """Hash of the composed job config (without Hydra's node and ``resume``), resolved."""
    from hgo.running.runner import job_config_yaml

    job = OmegaConf.create({k: cfg._get_node(k) for k in cfg if k not in ("hydra", "resume")})
    return hashlib.sha256(job_config_yaml(job).encode()).hexdigest()


def is_complete(cfg: DictConfig, out_dir: str | Path) -> bool:
    """Whether ``out_dir`` holds the complete outputs of a successful run of ``cfg``: the
    marker names this config's hash and every file the run wrote still has its recorded
    size and sha256 (:mod:`hgo.outputs.integrity`). A damaged file is one warning line
    naming it; the job then runs again."""
    marker = read_marker(Path(out_dir))
    if marker is None or marker[1] is None or marker[0] != config_hash(cfg):
        return False
    try:
        check_run(Path(out_dir))
    except Damaged as err:
        log.warning("resume: %s; running the job again", err)
        return False
    return True


def mark_complete(cfg: DictConfig, out_dir: str | Path) -> None:
    """Record that ``out_dir`` holds the complete outputs of ``cfg``: the config's hash and
    the size and sha256 of each file written (not Hydra's); atomic, written last."""
    from hgo.outputs.recording import atomic_output

    out_dir = Path(out_dir)
    with atomic_output(out_dir / DONE) as partial:
        partial.write_text(manifest_text(config_hash(cfg), manifest(out_dir)))


class RunGuard(Callback):
    """Hydra callback (``conf/config.yaml``): before Hydra writes anything, ``run_name``
    must be a plain name (``run_name=..`` wrote outside ``outputs/``), a single run's
    directory must not be in use by another run (:func:`lock_run_dir`; Hydra would
    overwrite that run's ``.hydra/`` first), and a sweep's directory neither in use nor
    holding another sweep (:func:`hgo.running.run_dirs.guard_sweep_dir`). Hydra turns a
    callback's exception into a warning and goes on, so a refusal here is the one line and
    ``SystemExit``."""

    def on_run_start(self, config: DictConfig, **kwargs) -> None:
        self._refuse_unless(lambda: (check_run_name(config.get("run_name", "run")),
                                     lock_run_dir(config.hydra.run.dir)))

    def on_multirun_start(self, config: DictConfig, **kwargs) -> None:
        self._refuse_unless(lambda: (check_run_name(config.get("run_name", "run")),
                                     guard_sweep_dir(config)))

    @staticmethod
    def _refuse_unless(check) -> None:
        try:
            check()
        except (ValueError, RunDirBusy) as err:
            sys.stderr.write(f"error: {one_line(err)}\n")
            raise SystemExit(EXIT_FAILED if isinstance(err, RunDirBusy) else EXIT_CONFIG) \
                from None


def run_job(cfg: DictConfig, out_dir: str | Path, figures_aside: bool = False,
            complete: bool | None = None) -> int:
    """Run ``cfg`` into ``out_dir``; returns the exit code (0: ok), errors reported as one
    line (see module doc). Ctrl-C ends the process (exit 130) after the one line: a sweep
    stops there; the interrupted job keeps its outputs (``*.partial`` if mid-write).

    ``resume=true``: a job whose directory already holds the complete outputs of the same
    composed config (:func:`is_complete`; ``complete``: the caller's answer, when it asked
    already) is skipped; any other is run (again).
    ``figures_aside``: a single run draws its figures in a forked process
    (:mod:`hgo.running.figure_worker`); for the one run of a process."""
    from hgo.running.ensemble_runner import is_ensemble, run_ensemble
    from hgo.running.figure_worker import discard_prestarted
    from hgo.running.figure_worker import figures_aside as worker
    from hgo.running.runner import SimulationFailed, run

    skip_exit_collection()  # this process (a sweep, a joblib worker) exits in ~0.2 s
    try:
        lock_run_dir(out_dir)
    except RunDirBusy as err:
        report(err, EXIT_FAILED)
        return EXIT_FAILED
    if cfg.get("resume", False) and (is_complete(cfg, out_dir) if complete is None
                                     else complete):
        log.info("resume: %s already holds this job's complete outputs; skipped", out_dir)
        unlock_run_dir(out_dir)
        return 0
    try:
        (Path(out_dir) / DONE).unlink(missing_ok=True)
        if is_ensemble(cfg):
            discard_prestarted()  # (its reports are drawn here; its members use every core)
            run_ensemble(cfg, out_dir)
        else:
            with worker(cfg) if figures_aside else nullcontext() as figures:
                run(cfg, out_dir, figures)
        mark_complete(cfg, out_dir)
    except KeyboardInterrupt as err:
        if full_error():
            raise
        report(PlainError(str(err) or "interrupted while writing; incomplete files in "
                          f"{out_dir} end in .partial"), EXIT_INTERRUPTED)
        raise SystemExit(EXIT_INTERRUPTED) from None
    except SimulationFailed as err:
        if full_error():
            raise
        report(err, EXIT_FAILED)
        return EXIT_FAILED
    except OSError as err:  # a full disk, a folder that cannot be written
        if full_error():
            raise
        report(err, EXIT_FAILED)
        return EXIT_FAILED
    except Exception as err:
        if full_error() or not is_config_error(err):
            raise
        remove_if_empty(out_dir)
        report(err, EXIT_CONFIG)
        return EXIT_CONFIG
    finally:  # the next job of a sweep starts from the memory this one began with
        unlock_run_dir(out_dir)
        release_freed_memory()
    return 0


@contextmanager
def one_line_errors() -> Iterator[None]:
    """Hydra's errors as one line; exit with the worst code of the jobs at the end."""
    import hydra._internal.utils as hydra_utils

    original = hydra_utils.run_and_report

    def run_and_report(func):
        if full_error():
            return original(func)
        try:
            return func()
        except Exception as err:
            sys.stderr.write(f"error: {one_line(err)}\n")
            sys.exit(EXIT_CONFIG if is_config_error(err) else EXIT_FAILED)

    hydra_utils.run_and_report = run_and_report
    try:
        yield
    finally:
        hydra_utils.run_and_report = original
    if _EXIT_CODES:
        sys.exit(max(_EXIT_CODES))
