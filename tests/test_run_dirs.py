"""Run and sweep directories: never shared by runs started together, written by one run or
sweep at a time, and a sweep's summary lists its own jobs only (issue 40, item 1)."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import pytest
import yaml

ROOT = Path(__file__).parents[1]
SHORT = ["experiment=sp_oscillation", "postprocess=none", "solver.t_end=2",
         "metrics.window=1", "recording.mode=off"]


def _start(args: list[str], cwd: Path) -> subprocess.Popen:
    env = {**os.environ, "PYTHONPATH": str(ROOT)}
    env.pop("HYDRA_FULL_ERROR", None)
    return subprocess.Popen([sys.executable, str(ROOT / "experiments" / "run.py"), *args],
                            cwd=cwd, env=env, stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                            text=True)


def _finish(proc: subprocess.Popen) -> tuple[int, str, str]:
    out, err = proc.communicate(timeout=300)
    return proc.returncode, out, err


def _hold_lock(path: Path) -> subprocess.Popen:
    """A process holding the run-directory lock of ``path`` (as a live run does)."""
    holder = subprocess.Popen(
        [sys.executable, "-c", "import time\nfrom hgo.running.run_dirs import lock_run_dir\n"
         f"lock_run_dir({str(path)!r})\nprint('locked', flush=True)\ntime.sleep(60)"],
        env={**os.environ, "PYTHONPATH": str(ROOT)}, stdout=subprocess.PIPE, text=True)
    assert holder.stdout.readline().strip() == "locked"
    return holder


def test_default_directories_composed_in_one_second_differ(tmp_path):
    """Three configs composed back to back (well within a second): three run directories
    and three sweep directories (``${now:}`` to the second gave one); a name carries the
    process id, so other processes' names differ too, and names sort by time."""
    from hgo.core.config import compose

    dirs = [compose(["experiment=sp_oscillation"]).hydra for _ in range(3)]
    runs = [str(d.run.dir) for d in dirs]
    sweeps = [str(d.sweep.dir) for d in dirs]
    assert len(set(runs)) == 3 and len(set(sweeps)) == 3, runs
    assert runs == sorted(runs) and all(r.endswith(f"_{os.getpid()}") for r in runs)
    assert all(r.startswith("outputs/sp_oscillation/") for r in runs)


def test_two_sweeps_and_two_runs_started_together_keep_their_own_results(tmp_path):
    """Two 2-job sweeps and two single runs with default directories, started at once:
    each exits 0 in a directory of its own, each job's run.json holds its own seed, and
    each sweep's summary lists its own 2 jobs."""
    sweeps = {"0,1": _start(["-m", *SHORT, "seed=0,1"], tmp_path),
              "2,3": _start(["-m", *SHORT, "seed=2,3"], tmp_path)}
    runs = {seed: _start([*SHORT, f"seed={seed}"], tmp_path) for seed in (4, 5)}
    for seeds, proc in sweeps.items():
        code, out, err = _finish(proc)
        assert code == 0, err[-2000:]
        (head,) = [ln for ln in out.splitlines() if ln.startswith("sweep: ")]
        assert head.endswith(": 2 ok"), out
        sweep = Path(head.split(" jobs in ")[1].split(":")[0])
        sweep = sweep if sweep.is_absolute() else tmp_path / sweep
        seen = [json.loads((sweep / f"job{k}" / "run.json").read_text())["seed"]
                for k in range(2)]
        assert seen == [int(s) for s in seeds.split(",")]
    run_dirs = set()
    for seed, proc in runs.items():
        code, out, err = _finish(proc)
        assert code == 0, err[-2000:]
        run_dir = Path(out.strip().splitlines()[-1].split("outputs in ")[1])
        assert json.loads((run_dir / "run.json").read_text())["seed"] == seed
        run_dirs.add(run_dir)
    assert len(run_dirs) == 2
    assert len(list((tmp_path / "outputs" / "multirun" / "sp_oscillation").iterdir())) == 2


def test_a_sweep_into_a_directory_of_another_sweep_is_refused(tmp_path):
    """A 2-job sweep, then a 1-job sweep into the same directory: refused in one line
    (exit 2) before any job, the old jobs untouched (it replaced job0 and counted the old
    job1 as its own); the same sweep again with resume=true is allowed, 2 jobs skipped."""
    sweep = tmp_path / "sw"
    code, _, err = _finish(_start(["-m", *SHORT, "seed=0,1", f"hydra.sweep.dir={sweep}"],
                                  tmp_path))
    assert code == 0, err[-2000:]
    stamps = {p: p.stat().st_mtime_ns for p in sweep.glob("job*/metrics.csv")}
    code, out, err = _finish(_start(["-m", *SHORT, "seed=0", f"hydra.sweep.dir={sweep}"],
                                    tmp_path))
    assert code == 2 and "Launching" not in err + out
    assert err.strip().splitlines() == [
        f"error: hydra.sweep.dir: {sweep} holds another sweep (it ran seed=0,1 where this "
        "runs seed=0); its results would mix with this one's (allowed: a new "
        "hydra.sweep.dir, or the same sweep again (resume=true skips its complete jobs))"]
    assert {p: p.stat().st_mtime_ns for p in sweep.glob("job*/metrics.csv")} == stamps
    code, out, err = _finish(_start(["-m", *SHORT, "seed=0,1", "resume=true",
                                     f"hydra.sweep.dir={sweep}"], tmp_path))
    assert code == 0, err[-2000:]
    assert out.count("skipped (resume") == 2 and f"sweep: 2 jobs in {sweep}: 2 ok" in out


@pytest.mark.parametrize("held", ["sw", "sw/job0"])
def test_a_sweep_whose_directory_or_job_directory_is_in_use_writes_nothing(tmp_path, held):
    """Another process holds the sweep directory (a live sweep) or the directory of its
    first job: the sweep stops with one line, exit 1, and writes nothing into the held
    directory (Hydra wrote the job's .hydra/ before hgo's lock was taken)."""
    busy = tmp_path / held
    holder = _hold_lock(busy)
    try:
        code, out, err = _finish(_start(["-m", *SHORT, "seed=0,1",
                                         f"hydra.sweep.dir={tmp_path / 'sw'}"], tmp_path))
    finally:
        holder.kill()
        holder.wait()
    assert code == 1
    assert err.strip().splitlines() == [
        f"error: {busy} is being written by another run (pid {holder.pid}); give this run "
        "another hydra.sweep.dir or wait for that one"]
    assert sorted(p.name for p in busy.iterdir()) == [".hgo_lock"]
    assert not (tmp_path / "sw" / "job1").exists()


def test_the_summary_lists_only_the_jobs_of_the_sweep_that_ran(tmp_path):
    """A directory holding job0..job2 and a failure note of an earlier sweep; the sweep now
    starting there (its guard) and running job0 only: its summary lists job0 alone, without
    the earlier failure, and its exit code is job0's."""
    from hgo.core.config import compose
    from hgo.running.aggregate import record_failure, sweep_exit_code, sweep_summary
    from hgo.running.run_dirs import guard_sweep_dir, note_job, unlock_run_dir

    sweep = tmp_path / "sw"
    for k, status in enumerate(["ok", "ok", "failed: x"]):
        (sweep / f"job{k}" / ".hydra").mkdir(parents=True)
        (sweep / f"job{k}" / "run.json").write_text(json.dumps({"status": status}))
    record_failure(sweep, "job3", 2, "an old failure")
    cfg = compose(["experiment=sp_oscillation", f"hydra.sweep.dir={sweep}"])
    try:
        guard_sweep_dir(cfg)
        note_job(sweep, "job0")
        text = sweep_summary(sweep)
        assert text.splitlines()[0] == f"sweep: 1 jobs in {sweep}: 1 ok", text
        assert "job1" not in text and "old failure" not in text
        assert sweep_exit_code(sweep) == 0
    finally:
        unlock_run_dir(sweep)


def test_the_same_sweep_is_told_from_another_by_its_multirun_yaml(tmp_path):
    """check_same_sweep compares the overrides (resume aside) and the composed config."""
    from omegaconf import OmegaConf

    from hgo.core.config import compose
    from hgo.core.errors import ConfigError
    from hgo.running.run_dirs import MULTIRUN, check_same_sweep

    OmegaConf.save(compose(["experiment=sp_oscillation", "seed=1"]), tmp_path / MULTIRUN)
    check_same_sweep(compose(["experiment=sp_oscillation", "seed=1", "resume=true"]),
                     tmp_path)
    with pytest.raises(ConfigError, match="it ran seed=1 where this runs seed=2"):
        check_same_sweep(compose(["experiment=sp_oscillation", "seed=2"]), tmp_path)
    saved = yaml.safe_load((tmp_path / MULTIRUN).read_text())
    saved["metrics"]["window"] = 3.0  # a preset changed since
    (tmp_path / MULTIRUN).write_text(yaml.safe_dump(saved))
    with pytest.raises(ConfigError, match="composed config differs"):
        check_same_sweep(compose(["experiment=sp_oscillation", "seed=1"]), tmp_path)


@pytest.mark.parametrize("key", ["hydra.run.dir", "hydra.sweep.dir"])
def test_a_run_or_sweep_directory_that_is_a_file_is_one_line(tmp_path, key):
    """``hydra.run.dir=afile``: a UserWarning from Hydra, then a FileExistsError line with
    exit 0; now one line naming the key, exit 2."""
    (tmp_path / "afile").write_text("mine")
    args = ["-m"] if key == "hydra.sweep.dir" else []
    code, _, err = _finish(_start([*args, *SHORT, f"{key}=afile"], tmp_path))
    assert code == 2
    assert err.strip().splitlines() == [
        f"error: {key}: {tmp_path / 'afile'} is a file, not a directory (allowed: a "
        "directory, or a path to create)"]
    assert (tmp_path / "afile").read_text() == "mine"
