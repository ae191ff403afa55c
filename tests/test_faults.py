"""Faults: damaged kernel caches, unwritable folders, interrupts, hangs and full disks.

Each test names the fault it injects and what the user gets instead of a crash, a hang
or a file that looks complete.
"""

from __future__ import annotations

import os
import subprocess
import sys
import textwrap
from pathlib import Path

import pytest

RUN = textwrap.dedent('''
    import warnings
    warnings.simplefilter("always")
    from hgo.engine.simulate import SolverSettings, no_noise, simulate
    from hgo.engine.system import System
    from hgo.observers.triangular import triangular_hgo
    from hgo.plants.sp_linear import sp_linear_plant
    obs = triangular_hgo("o", K=[2, 2], xhat0=[0, 0], law="constant")
    solver = SolverSettings(t_end=1.0, dt_out=0.5, method="rk4")
    tr = simulate(System(sp_linear_plant(), [obs]), solver, no_noise(1))
    print(tr.z[-1, 2])
''')
ROOT = Path(__file__).parents[1]


def _kernel_run(tmp_path: Path, cache: Path) -> subprocess.CompletedProcess:
    env = {**os.environ, "HGO_CACHE_DIR": str(cache), "NUMBA_CACHE_DIR": str(tmp_path / "nb"),
           "PYTHONPATH": str(ROOT)}
    return subprocess.run([sys.executable, "-c", RUN], cwd=tmp_path, env=env, check=True,
                          capture_output=True, text=True, timeout=300)


def test_damaged_kernel_cache_is_rebuilt_with_one_warning(tmp_path):
    """A truncated kernel module (text no longer matching its hash) and truncated numba
    cache files (index and data, of the kernel and of a helper it calls): one warning
    each, the same result; the next run is silent."""
    cache = tmp_path / "kernels"
    value = float(_kernel_run(tmp_path, cache).stdout.split()[-1])
    (entry,) = cache.glob("hgo_kernel_*.py")
    entry.write_text(entry.read_text()[:200])
    damaged = list((tmp_path / "nb").rglob("*.nb[ic]"))
    assert any("triangular" in p.name for p in damaged)  # a helper's cache, too
    for path in damaged:
        path.write_bytes(path.read_bytes()[:10])
    out = _kernel_run(tmp_path, cache)
    assert float(out.stdout.split()[-1]) == value
    assert out.stderr.count("RuntimeWarning") == 2, out.stderr
    assert "is corrupted" in out.stderr and "is damaged" in out.stderr
    out = _kernel_run(tmp_path, cache)
    assert float(out.stdout.split()[-1]) == value and "Warning" not in out.stderr


def test_unwritable_kernel_cache_falls_back_to_a_private_folder(tmp_path):
    """HGO_CACHE_DIR below a regular file cannot be created: one warning, same result."""
    blocker = tmp_path / "file"
    blocker.write_text("")
    out = _kernel_run(tmp_path, blocker / "kernels")
    assert out.stderr.count("RuntimeWarning") == 1 and "not writable" in out.stderr
    assert float(out.stdout.split()[-1]) != 0.0


# --- runs that must stop: NaN, step limit, Ctrl-C ------------------------------------

SHORT = ["experiment=sp_oscillation", "postprocess=none", "solver.t_end=2",
         "metrics.window=1"]


def _system_and_noise():
    from hgo.engine.simulate import no_noise
    from hgo.engine.system import System
    from hgo.observers.triangular import triangular_hgo
    from hgo.plants.sp_linear import sp_linear_plant

    obs = triangular_hgo("o", K=[2, 2], xhat0=[0, 0], law="constant")
    return System(sp_linear_plant(), [obs]), no_noise(1)


def test_nan_parameter_ends_the_adaptive_run_as_failed():
    """A NaN parameter made dopri5 reject steps forever (h = NaN); now: status 4, t = 0
    (dop853 shares the loop)."""
    import numpy as np

    from hgo.engine.simulate import STATUS, SolverSettings, simulate

    system, noise = _system_and_noise()
    params = system.params()
    params[0] = np.nan  # nu1 of the plant
    tr = simulate(system, SolverSettings(t_end=1.0, dt_out=0.5, method="dopri5"), noise,
                  params=params)
    assert tr.status == 4 and "non-finite step size" in STATUS[tr.status]
    assert tr.t_stop == 0.0


def test_step_limit_ends_the_run_as_failed():
    """solver.max_steps bounds every integrator (here 50 steps of a 1000-step run)."""
    from hgo.engine.simulate import SolverSettings, simulate

    system, noise = _system_and_noise()
    for method in ("rk4", "dopri5"):
        solver = SolverSettings(t_end=1.0, dt_out=0.5, method=method, h_max=1e-3,
                                max_steps=50)
        tr = simulate(system, solver, noise)
        assert tr.status == 5 and 0 < tr.t_stop < 0.1, (method, tr.t_stop)


def _run_cli(args: list[str], tmp_path: Path) -> subprocess.Popen:
    env = {**os.environ, "PYTHONPATH": str(ROOT)}
    env.pop("HYDRA_FULL_ERROR", None)
    return subprocess.Popen([sys.executable, str(ROOT / "experiments" / "run.py"), *args],
                            cwd=tmp_path, env=env, stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, text=True)


def _cpu_seconds(pid: int) -> float:
    """CPU seconds (user + system) of process ``pid`` so far (Linux: /proc)."""
    fields = Path(f"/proc/{pid}/stat").read_text().rpartition(")")[2].split()
    return (int(fields[11]) + int(fields[12])) / os.sysconf("SC_CLK_TCK")


KERNEL_LOADED_CPU_S = 3.0  # loading the cached kernel takes ~0.6-1 CPU second (numba's
# registries, scipy.linalg) after "integrating" is logged: 3 CPU seconds on, it has run


def _start_long_run(run_dir: Path, tmp_path: Path) -> subprocess.Popen:
    """A 1e8-step integration into ``run_dir``, returned once the process has used
    ``KERNEL_LOADED_CPU_S`` more CPU seconds after it logs "integrating" (CPU, not wall
    time: on a loaded machine a fixed 1 s wait sent the signal while numba was still
    loading the kernel, and the run stopped at t = 0), and at least 1 s after."""
    import time

    proc = _run_cli(["experiment=sp_oscillation", "postprocess=none", "solver.t_end=100000",
                     "solver.dt_out=1", "solver.h_max=0.001", "metrics.window=5",
                     f"hydra.run.dir={run_dir}"], tmp_path)
    for line in proc.stdout:
        if "integrating" in line:
            break
    start, t0 = _cpu_seconds(proc.pid), time.perf_counter()
    while (_cpu_seconds(proc.pid) - start < KERNEL_LOADED_CPU_S
           or time.perf_counter() - t0 < 1.0) and proc.poll() is None:
        time.sleep(0.05)
    return proc


def test_ctrl_c_stops_a_long_compiled_integration_within_a_second(tmp_path):
    """SIGINT 1 s into a 1e8-step integration: exit 130 within ~1 s, one error line, a
    complete recording up to the stop marked interrupted in /run/status and metrics.csv."""
    import signal
    import time

    import pandas as pd

    from hgo.outputs.recording import read_recording, read_texts

    warm = _run_cli([*SHORT, f"hydra.run.dir={tmp_path}/warm"], tmp_path)  # compile
    assert warm.wait(timeout=300) == 0, warm.stderr.read()
    run_dir = tmp_path / "long"
    proc = _start_long_run(run_dir, tmp_path)
    t0 = time.perf_counter()
    proc.send_signal(signal.SIGINT)
    _, err = proc.communicate(timeout=60)
    elapsed = time.perf_counter() - t0
    assert proc.returncode == 130, err
    lines = [ln for ln in err.splitlines() if ln.strip()]
    assert len(lines) == 1 and lines[0].startswith("error: ") and "interrupted" in lines[0]
    assert elapsed < 3.0, f"stopped {elapsed:.2f} s after Ctrl-C"
    table = pd.read_csv(run_dir / "metrics.csv")
    assert set(table.status) == {"interrupted"}
    t_stop = float(table.t_stop.iloc[0])
    assert 0 < t_stop < 100000
    rec = read_recording(run_dir / "recording.rrd")
    assert rec.index[-1] <= t_stop and len(rec) > 1
    assert read_texts(run_dir / "recording.rrd")["/run/status"].startswith("interrupted at t")
    assert not list(run_dir.glob("*.partial"))


REPRODUCE_STUCK = textwrap.dedent('''
    import os, signal, sys, time
    from pathlib import Path
    import hgo.reproduce.run as rr

    def claims_that_ignore_ctrl_c(paper, path):
        # as a claim does: a Ctrl-C stops the kernel's current run, the task goes on
        signal.signal(signal.SIGINT, signal.SIG_IGN)
        Path(sys.argv[1], str(os.getpid())).touch()
        time.sleep(120)

    rr.run_claims = claims_that_ignore_ctrl_c
    rr.plan_jobs = lambda papers, root, fingerprint: []
    try:
        rr.reproduce(["sanfelice_praly", "moreno", "dimassi"], 2, Path(sys.argv[2]))
    except KeyboardInterrupt:
        sys.exit(130)
''')


def test_ctrl_c_ends_hgo_reproduce_and_its_workers_at_once(tmp_path):
    """Ctrl-C (SIGINT to the process group, as a terminal sends it) while both workers run
    a task that goes on after it: reproduce exits within seconds (it waited for every task
    left before, here 120 s each), the busy workers are gone and the third task never
    starts."""
    import signal
    import time

    marks = tmp_path / "marks"
    marks.mkdir()
    env = {**os.environ, "HGO_CACHE_DIR": str(tmp_path / "kernels")}
    proc = subprocess.Popen([sys.executable, "-c", REPRODUCE_STUCK, str(marks),
                             str(tmp_path / "out")], env=env, start_new_session=True)
    try:
        deadline = time.monotonic() + 120
        while len(list(marks.iterdir())) < 2 and time.monotonic() < deadline:
            time.sleep(0.1)
        workers = [int(p.name) for p in marks.iterdir()]
        assert len(workers) == 2
        t0 = time.monotonic()
        os.killpg(proc.pid, signal.SIGINT)
        assert proc.wait(timeout=60) == 130
        assert time.monotonic() - t0 < 10.0
    finally:  # (a failure leaves no process behind)
        if proc.poll() is None:
            os.killpg(proc.pid, signal.SIGKILL)
    time.sleep(0.5)
    for pid in workers:
        with pytest.raises(ProcessLookupError):
            os.kill(pid, 0)
    assert len(list(marks.iterdir())) == 2


# --- writes that do not finish -------------------------------------------------------


def _interrupt_in(monkeypatch, target: str, exc: BaseException, after: int = 1) -> None:
    """Make ``target`` (module:function) raise ``exc`` on its call number ``after + 1``."""
    import importlib

    module_name, name = target.split(":")
    module = importlib.import_module(module_name)
    original = getattr(module, name)
    calls = {"n": 0}

    def wrapped(*args, **kwargs):
        calls["n"] += 1
        if calls["n"] > after:
            raise exc
        return original(*args, **kwargs)

    monkeypatch.setattr(module, name, wrapped)


CTRL_C_WRITER = textwrap.dedent('''
    import sys
    import hgo.outputs.recording
    from hgo.core.config import compose
    from hgo.running.job import run_job
    send = hgo.outputs.recording._send_series
    calls = {"n": 0}

    def interrupted(*args, **kwargs):  # KeyboardInterrupt where SIGINT would raise it
        calls["n"] += 1
        if calls["n"] > 1:
            raise KeyboardInterrupt
        return send(*args, **kwargs)

    hgo.outputs.recording._send_series = interrupted
    run_job(compose(SHORT, sys.argv[1]), sys.argv[1])
''')


def test_ctrl_c_while_writing_keeps_the_metrics_and_a_partial_recording(tmp_path):
    """KeyboardInterrupt in the middle of the recording (where SIGINT would raise it):
    no recording.rrd, a recording.rrd.partial that read_recording calls truncated; the
    finished simulation's metrics.csv and a run.json marked interrupted while writing are
    kept (both were lost), one line naming the phase; the job ends with exit 130. In its
    own process, as a Ctrl-C ends one:
    the interrupted stream's native state, left in a long-lived process, made Rerun fail
    every recording of processes later forked from it (hgo reproduce's workers)."""
    import json

    import pandas as pd
    import pytest

    from hgo.outputs.recording import RecordingIncomplete, read_recording

    script = f"SHORT = {SHORT!r}\n" + CTRL_C_WRITER
    env = {**os.environ, "PYTHONPATH": str(ROOT)}
    ended = subprocess.run([sys.executable, "-c", script, str(tmp_path)], env=env,
                           capture_output=True, text=True, timeout=300)
    assert ended.returncode == 130, ended.stderr[-2000:]
    assert not (tmp_path / "recording.rrd").exists()
    assert ended.stderr.strip().splitlines() == [
        "error: interrupted while writing recording.rrd; the simulation had finished: "
        f"metrics.csv and run.json are in {tmp_path}"]
    assert set(pd.read_csv(tmp_path / "metrics.csv").status) == {"ok"}
    assert json.loads((tmp_path / "run.json").read_text())["status"] == (
        "interrupted while writing recording.rrd (the simulation had finished; metrics.csv "
        "complete)")
    with pytest.raises(RecordingIncomplete, match="truncated"):
        read_recording(tmp_path / "recording.rrd.partial")
    with pytest.warns(RuntimeWarning, match="truncated"):
        assert len(read_recording(tmp_path / "recording.rrd.partial", allow_incomplete=True))


def test_full_disk_fails_the_job_with_one_line_and_no_complete_looking_file(
        tmp_path, monkeypatch, capsys):
    """An injected ENOSPC while writing metrics.csv (after the recording): exit code 1,
    one error line, metrics.csv absent (its .partial left), recording.rrd complete."""
    import errno

    import pandas as pd

    from hgo.core.config import compose as compose_config
    from hgo.running.job import run_job

    cfg = compose_config(SHORT, tmp_path)
    full = OSError(errno.ENOSPC, "No space left on device")
    original = pd.DataFrame.to_csv

    def to_csv(self, path, *args, **kwargs):
        original(self, path, *args, **kwargs)
        raise full

    monkeypatch.setattr(pd.DataFrame, "to_csv", to_csv)
    assert run_job(cfg, tmp_path) == 1
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "No space left on device" in err[0]
    assert not (tmp_path / "metrics.csv").exists()
    assert (tmp_path / "metrics.csv.partial").exists()
    assert (tmp_path / "recording.rrd").exists()


KILL_WRITER = textwrap.dedent('''
    import numpy as np, sys
    from hgo.outputs.recording import Series, write_recording
    n = 3_000_000
    t = np.arange(n) * 1e-3
    series = [Series(f"/s{k}", ["a", "b", "c"], np.random.default_rng(k).random((n, 3)))
              for k in range(8)]
    write_recording(sys.argv[1], t, series, recording_id="killed")
''')


def test_sigkill_while_writing_leaves_no_complete_looking_file(tmp_path):
    """SIGKILL as soon as the .partial has data: no recording.rrd; the .partial is
    refused by read_recording (unreadable or truncated)."""
    import time

    import pytest

    from hgo.outputs.recording import RecordingIncomplete, read_recording

    target = tmp_path / "recording.rrd"
    partial = tmp_path / "recording.rrd.partial"
    env = {**os.environ, "PYTHONPATH": str(ROOT)}
    proc = subprocess.Popen([sys.executable, "-c", KILL_WRITER, str(target)], env=env)
    deadline = time.monotonic() + 120
    while time.monotonic() < deadline and proc.poll() is None:
        if partial.exists() and partial.stat().st_size > 1_000_000:
            break
        time.sleep(0.01)
    proc.kill()
    proc.wait()
    assert partial.exists(), "the writer finished before it could be killed"
    assert not target.exists()
    with pytest.raises(RecordingIncomplete):
        read_recording(partial)


# --- resume --------------------------------------------------------------------------


def test_resume_skips_complete_jobs_and_redoes_the_others(tmp_path):
    """``resume=true`` skips a job whose directory holds complete outputs of the same
    composed config; a changed config, a missing file or a failed run is redone."""
    from hgo.core.config import compose as compose_config
    from hgo.running.job import DONE, is_complete, run_job

    cfg = compose_config([*SHORT, "resume=true"], tmp_path)
    assert run_job(cfg, tmp_path) == 0 and is_complete(cfg, tmp_path)
    stamp = (tmp_path / "metrics.csv").stat().st_mtime_ns
    assert run_job(cfg, tmp_path) == 0
    assert (tmp_path / "metrics.csv").stat().st_mtime_ns == stamp  # skipped
    other = compose_config([*SHORT, "resume=true", "seed=1"], tmp_path)
    assert not is_complete(other, tmp_path)  # another composed config: redone
    (tmp_path / DONE).unlink()  # e.g. killed before the end: redone
    assert run_job(cfg, tmp_path) == 0
    assert (tmp_path / "metrics.csv").stat().st_mtime_ns != stamp
    assert is_complete(cfg, tmp_path)


def test_multirun_resumed_into_its_sweep_directory(tmp_path):
    """A 2-job sweep, one job's outputs removed: re-run with resume=true into the same
    hydra.sweep.dir, only that job runs again."""
    sweep = tmp_path / "sweep"
    args = ["-m", *SHORT, "seed=0,1", f"hydra.sweep.dir={sweep}", "resume=true"]
    first = _run_cli(args, tmp_path)
    assert first.wait(timeout=300) == 0, first.stderr.read()
    kept = (sweep / "job0" / "metrics.csv").stat().st_mtime_ns
    (sweep / "job1" / "metrics.csv").unlink()
    again = _run_cli(args, tmp_path)
    out, err = again.communicate(timeout=300)
    assert again.returncode == 0, err
    assert (sweep / "job0" / "metrics.csv").stat().st_mtime_ns == kept
    assert (sweep / "job1" / "metrics.csv").exists()
    assert out.count("skipped") + err.count("skipped") == 1


# --- writes that cannot finish: a full disk, a stuck writer, Ctrl-C ------------------


def _blocked_write(partial: Path):
    """A stream function that writes a little and then never returns (as Rerun's flush
    on a dead file writer)."""
    def stream() -> bool:
        import time

        partial.write_bytes(b"x" * 100)
        time.sleep(600)
        return True
    return stream


def test_a_stuck_write_on_a_full_disk_ends_within_seconds(tmp_path, monkeypatch):
    """The writer stops making progress while the disk has no space: OSError(ENOSPC)
    naming the file after ~FULL_DISK_SECONDS, the writing process killed."""
    import errno
    import time

    import pytest

    from hgo.core.errors import one_line
    from hgo.outputs import recording

    monkeypatch.setattr(recording, "_free_bytes", lambda folder: 0)
    partial = tmp_path / "recording.rrd.partial"
    t0 = time.monotonic()
    with pytest.raises(OSError) as info:
        recording.bounded_write(partial, _blocked_write(partial))
    assert time.monotonic() - t0 < 10
    assert info.value.errno == errno.ENOSPC
    assert one_line(info.value).startswith(f"no space left on {partial} (")


def test_a_stalled_write_ends_after_the_stall_limit(tmp_path, monkeypatch):
    import time

    import pytest

    from hgo.outputs import recording

    monkeypatch.setattr(recording, "STALL_SECONDS", 0.5)
    partial = tmp_path / "r.partial"
    t0 = time.monotonic()
    with pytest.raises(TimeoutError, match="made no progress for 0.5 s"):
        recording.bounded_write(partial, _blocked_write(partial))
    assert time.monotonic() - t0 < 10


def test_ctrl_c_ends_a_blocked_write_at_once(tmp_path):
    """SIGINT while the writer is blocked (where Rerun's native flush ignored it):
    KeyboardInterrupt within a second, the writing process gone."""
    import signal
    import time

    import pytest

    from hgo.outputs import recording

    partial = tmp_path / "r.partial"
    previous = signal.signal(signal.SIGALRM, lambda *a: signal.raise_signal(signal.SIGINT))
    signal.setitimer(signal.ITIMER_REAL, 0.5)
    t0 = time.monotonic()
    try:
        with pytest.raises(KeyboardInterrupt):
            recording.bounded_write(partial, _blocked_write(partial))
    finally:
        signal.setitimer(signal.ITIMER_REAL, 0)
        signal.signal(signal.SIGALRM, previous)
    assert time.monotonic() - t0 < 3


def _mount_tmpfs(folder: Path, size: str) -> bool:
    folder.mkdir()
    try:
        done = subprocess.run(["mount", "-t", "tmpfs", "-o", f"size={size}", "tmpfs",
                               str(folder)], capture_output=True, timeout=10)
    except (OSError, subprocess.TimeoutExpired):
        return False
    return done.returncode == 0


def test_full_tmpfs_ends_the_run_with_one_line(tmp_path):
    """A real full disk (a 1 MiB tmpfs; needs root): the run ends with exit 1 and
    ``error: no space left on <dir>/recording.rrd.partial (...)``, no complete-looking
    recording, within seconds (Rerun's writer alone hung in 4 of 15 tries)."""
    import time

    import pytest

    disk = tmp_path / "disk"
    if not _mount_tmpfs(disk, "1m"):
        pytest.skip("cannot mount a tmpfs here (not root?)")
    try:
        t0 = time.monotonic()
        proc = _run_cli([*SHORT, "solver.t_end=200", f"hydra.run.dir={disk}/run"], tmp_path)
        _, err = proc.communicate(timeout=120)
        elapsed = time.monotonic() - t0
        assert proc.returncode == 1, err
        lines = [ln for ln in err.splitlines() if ln.strip()]
        assert lines == [f"error: no space left on {disk}/run/recording.rrd.partial "
                         "(No space left on device, 0 MiB free)"], err
        assert not (disk / "run" / "recording.rrd").exists()
        assert elapsed < 60
    finally:
        subprocess.run(["umount", "-l", str(disk)], capture_output=True, timeout=30)


# --- SIGTERM, a compile interrupted --------------------------------------------------


def test_sigterm_ends_a_run_like_ctrl_c(tmp_path):
    """SIGTERM (kill, a scheduler) ended the run at once without marking it: now exit
    130, one error line, metrics.csv and run.json say interrupted."""
    import json
    import signal

    import pandas as pd

    run_dir = tmp_path / "long"
    proc = _start_long_run(run_dir, tmp_path)
    proc.send_signal(signal.SIGTERM)
    _, err = proc.communicate(timeout=120)
    assert proc.returncode == 130, err
    errors = [ln for ln in err.splitlines() if ln.startswith("error: ")]
    assert len(errors) == 1 and "interrupted" in errors[0], err
    assert set(pd.read_csv(run_dir / "metrics.csv").status) == {"interrupted"}
    assert json.loads((run_dir / "run.json").read_text())["status"].startswith("interrupted")


def test_ctrl_c_while_compiling_says_so_and_stops_when_compiled(capfd):
    """The kernel call is stuck in numba's compiler (its lock held, ~6 s in a real compile):
    Ctrl-C shows one line saying the run stops once compiled, and the call returns as soon
    as it does."""
    import signal
    import time

    import numpy as np
    from numba.core.compiler_lock import global_compiler_lock

    from hgo.engine.interrupt import interruptible

    def compile_then_run():
        with global_compiler_lock:
            time.sleep(1.5)
        return "compiled"

    ctl = np.zeros(1)
    previous = signal.signal(signal.SIGALRM, lambda *a: signal.raise_signal(signal.SIGINT))
    signal.setitimer(signal.ITIMER_REAL, 0.2)
    t0 = time.monotonic()
    try:
        value = interruptible(compile_then_run, (), ctl)
    finally:
        signal.setitimer(signal.ITIMER_REAL, 0)
        signal.signal(signal.SIGALRM, previous)
    assert value == "compiled" and ctl[0] == 1 and time.monotonic() - t0 < 5
    assert capfd.readouterr().err == ("interrupted: stopping once numba has compiled the "
                                      "kernel (Ctrl-C again to stop at once)\n")


BUSY_KERNEL = textwrap.dedent('''
    import sys
    import numba
    import numpy as np
    from hgo.engine.interrupt import LAST_WORDS, interruptible

    @numba.njit(nogil=True, cache=False)
    def spin(a):  # user code that never returns and never reads the stop flag
        x = 0.0
        while a[0] == 0.0:
            x += 1.0
            a[1] = x
        return x

    a = np.zeros(2)
    spin(np.ones(2))  # compiled before the signals
    LAST_WORDS.append(lambda: open(sys.argv[1], "w").write("last words"))
    print("spinning", flush=True)
    interruptible(spin, (a,), np.zeros(3))
''')


@pytest.mark.parametrize("sig", ["SIGINT", "SIGHUP"])
def test_a_second_signal_stops_a_busy_kernel_within_two_seconds(tmp_path, sig):
    """A kernel looping in user code never checks the stop flag, and a Python handler never
    runs while it holds the main thread: every Ctrl-C said "stopping once numba has compiled
    the kernel" and only SIGKILL ended it. Now the first says the kernel is busy, the second
    ends the process within 2 s (exit 130) after the run's last words (its run.json)."""
    import signal
    import time

    env = {**os.environ, "PYTHONPATH": str(ROOT)}
    script = ("import signal\nsignal.signal(signal.SIGHUP, signal.default_int_handler)\n"
              + BUSY_KERNEL)
    proc = subprocess.Popen([sys.executable, "-c", script, str(tmp_path / "last")], env=env,
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    try:
        assert proc.stdout.readline().strip() == "spinning"
        time.sleep(0.5)
        proc.send_signal(getattr(signal, sig))
        time.sleep(1.0)
        assert proc.poll() is None  # the first signal: a notice, the kernel still runs
        proc.send_signal(getattr(signal, sig))
        t0 = time.monotonic()
        code = proc.wait(timeout=10)
        stopped_in = time.monotonic() - t0
    finally:
        proc.kill()
        proc.wait()
    err = proc.stderr.read()
    assert code == 130 and stopped_in < 2.0, (code, stopped_in, err)
    assert err.splitlines() == [
        "interrupted: the kernel is busy and has not stopped (not compiling: user code that "
        "does not return, e.g. a loop, never checks the stop flag); Ctrl-C again to stop at "
        "once",
        "error: interrupted while integrating: the kernel was busy (user code that does not "
        "return); stopped at once, without the trajectory"]
    assert (tmp_path / "last").read_text() == "last words"


def test_sighup_ends_a_run_like_sigterm(tmp_path):
    """SIGHUP (an ssh session dropping) ended a run in 0.5 s leaving only app.log; now it
    is SIGTERM's exit 130 with metrics.csv and run.json marked interrupted."""
    import json
    import signal

    import pandas as pd

    run_dir = tmp_path / "long"
    proc = _start_long_run(run_dir, tmp_path)
    proc.send_signal(signal.SIGHUP)
    _, err = proc.communicate(timeout=120)
    assert proc.returncode == 130, err
    assert set(pd.read_csv(run_dir / "metrics.csv").status) == {"interrupted"}
    assert json.loads((run_dir / "run.json").read_text())["status"].startswith("interrupted")


ENVELOPE = textwrap.dedent('''
    import warnings
    warnings.simplefilter("always")
    import numpy as np
    from hgo.outputs.decimate import envelope
    from hgo.outputs.recording import Series
    t = np.arange(1000) * 0.01
    _, (s,) = envelope(t, [Series("/x", ["a"], np.sin(t)[:, None])], 64)
    print(float(s.values.sum()))
''')


def test_garbage_in_hgos_own_numba_cache_is_repaired_with_one_warning(tmp_path):
    """hgo's own cached numba functions called from Python (the decimated recording's
    envelope): garbage in their cache files failed the run after the simulation; now one
    warning, the same result, and the next run is silent."""
    env = {**os.environ, "NUMBA_CACHE_DIR": str(tmp_path / "nb"), "PYTHONPATH": str(ROOT)}

    def run() -> subprocess.CompletedProcess:
        return subprocess.run([sys.executable, "-c", ENVELOPE], env=env, check=True,
                              capture_output=True, text=True, timeout=300)

    value = float(run().stdout)
    files = [p for p in (tmp_path / "nb").rglob("*.nb[ic]") if "decimate" in p.name]
    assert {p.suffix for p in files} == {".nbi", ".nbc"}
    for path in files:
        path.write_bytes(b"garbage" * 3)
    out = run()
    assert float(out.stdout) == value
    assert out.stderr.count("RuntimeWarning") == 1 and "is damaged" in out.stderr, out.stderr
    out = run()
    assert float(out.stdout) == value and "Warning" not in out.stderr


@pytest.mark.parametrize("where", ["compiling the kernel (numba)", "integrating"])
def test_ctrl_c_before_anything_is_written_names_the_phase(monkeypatch, tmp_path, capsys,
                                                           where):
    """Ctrl-C while numba compiles (inside its compile event) or while integrating: the
    job's one line names that phase (a compile said "while writing ... .partial")."""
    from numba.core.event import trigger_event

    import hgo.running.runner as runner
    from hgo.core.config import compose
    from hgo.running.job import run_job

    def stopped(exp):
        if where == "integrating":
            raise KeyboardInterrupt
        with trigger_event("numba:compile"):
            raise KeyboardInterrupt

    monkeypatch.setattr(runner, "run_experiment", stopped)
    with pytest.raises(SystemExit) as ended:
        run_job(compose(SHORT, tmp_path), tmp_path)
    assert ended.value.code == 130
    assert capsys.readouterr().err.splitlines() == [
        f"error: interrupted while {where}; nothing was written"]


# --- a full or damaged kernel cache (issue 40, item 6) ---------------------------------


def test_a_full_kernel_cache_falls_back_to_a_private_folder(tmp_path, monkeypatch):
    """A write into the kernel cache failing with ENOSPC (a full disk) failed the run; now
    one warning, the entry and every later one in a private folder, as for an unwritable
    cache."""
    import errno

    import pytest

    from hgo.engine import codegen

    wanted = tmp_path / "kernels"
    monkeypatch.setenv("HGO_CACHE_DIR", str(wanted))
    monkeypatch.setattr(codegen, "_PRIVATE", {})
    real = codegen._atomic_write

    def full(path, text):
        if path.parent == wanted:
            raise OSError(errno.ENOSPC, "No space left on device")
        real(path, text)

    monkeypatch.setattr(codegen, "_atomic_write", full)
    with pytest.warns(RuntimeWarning, match=r"kernels cannot be written \(No space left on "
                                            r"device\); compiling into "):
        path = codegen._write_once("x = 1\n")
    assert path.parent != wanted and path.read_text() == "x = 1\n"
    assert codegen.cache_dir() == path.parent


def test_a_kernel_cache_entry_replaced_by_a_folder_is_rebuilt(tmp_path, monkeypatch):
    import pytest

    from hgo.engine import codegen

    monkeypatch.setenv("HGO_CACHE_DIR", str(tmp_path))
    path = codegen._write_once("y = 2\n")
    path.unlink()
    path.mkdir()
    (path / "inside").write_text("")
    with pytest.warns(RuntimeWarning, match="is a folder; rebuilding it"):
        assert codegen._write_once("y = 2\n") == path
    assert path.read_text() == "y = 2\n"


UNSAVED = textwrap.dedent('''
    import errno, sys, warnings
    warnings.simplefilter("always")
    import numba.core.caching as caching
    from hgo.engine.codegen import compiled_first
    sys.path.insert(0, sys.argv[1])
    import kern

    def full(self, key, data):
        raise OSError(errno.ENOSPC, "No space left on device")

    caching.IndexDataCacheFile.save = full
    print(compiled_first(kern.outer, kern.__file__)(1.0))
''')


def test_a_compiled_kernel_that_numba_cannot_save_still_runs(tmp_path):
    """numba saving a compiled kernel and its cached helper hits ENOSPC (a full disk): the
    run failed after compiling; now one warning and the kernel runs (for this process)."""
    (tmp_path / "kern.py").write_text(
        "import numba\n\n@numba.njit(cache=True)\ndef helper(x):\n    return x + 1.0\n\n\n"
        "@numba.njit(cache=True)\ndef outer(x):\n    return 2.0 * helper(x)\n")
    env = {**os.environ, "PYTHONPATH": str(ROOT), "NUMBA_CACHE_DIR": str(tmp_path / "nb")}
    out = subprocess.run([sys.executable, "-c", UNSAVED, str(tmp_path)], env=env,
                         capture_output=True, text=True, timeout=300)
    assert out.returncode == 0, out.stderr[-2000:]
    assert out.stdout.strip() == "4.0"
    assert out.stderr.count("RuntimeWarning") == 1 and "cannot save" in out.stderr
