"""``hgo run`` of a single run draws its figures in a forked process
(:mod:`hgo.running.figure_worker`): the same files, the same errors, matplotlib never imported
by the run's own process."""

from __future__ import annotations

import os
import subprocess
import sys
import textwrap
from pathlib import Path

import pytest

from hgo.core.config import compose
from hgo.running.figure_worker import FigureWorker
from hgo.running.runner import run

ROOT = Path(__file__).resolve().parents[1]
SHORT = ["experiment=sp_fig1", "solver.t_end=6", "metrics.window=2"]
pytestmark = pytest.mark.skipif(not FigureWorker.available(), reason="needs fork (Linux)")

RUN_AND_REPORT = textwrap.dedent('''
    import sys
    from hgo.cli import main
    try:
        main(["run", *sys.argv[1:]])
    finally:
        print("matplotlib imported:", "matplotlib" in sys.modules)
''')

FIGURES = textwrap.dedent('''
    import os
    import sys
    from pathlib import Path

    def pid(result, path):
        Path(path).write_text(str(os.getpid()))

    def fails(result, path):
        raise ValueError("this figure cannot be drawn")

    def dies(result, path):
        os._exit(3)

    def app_imported(result, path):
        Path(path).write_text(str("hgo.cli.app" in sys.modules))
''')


def hgo_run(tmp_path: Path, *overrides: str, **kwargs) -> subprocess.Popen:
    """The run, ended; its ``returncode``, ``stdout``, ``stderr`` and ``pid``."""
    (tmp_path / "user_figures.py").write_text(FIGURES)
    env = {**os.environ, "PYTHONPATH": os.pathsep.join([str(tmp_path), str(ROOT)])}
    env.pop("HYDRA_FULL_ERROR", None)
    proc = subprocess.Popen([sys.executable, "-c", RUN_AND_REPORT, *overrides], cwd=tmp_path,
                            env=env, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                            **kwargs)
    proc.stdout, proc.stderr = proc.communicate(timeout=300)
    return proc


def session_processes(sid: int) -> list[int]:
    """The processes of session ``sid`` still there (``/proc/<pid>/stat``: ``pid (comm)
    state ppid pgrp session ...``)."""
    found = []
    for stat in Path("/proc").glob("[0-9]*/stat"):
        try:
            fields = stat.read_text().rsplit(")", 1)[1].split()
        except OSError:  # (ended meanwhile)
            continue
        if int(fields[3]) == sid:
            found.append(int(stat.parent.name))
    return found


def test_forked_figure_is_the_in_process_one_and_the_run_never_imports_matplotlib(tmp_path):
    """sp_fig1 over 6 s: fig1.png from ``hgo run`` (forked) equals, byte for byte, the one
    ``hgo.running.runner.run`` draws in its own process; the run's process has not imported
    matplotlib when it ends."""
    forked = tmp_path / "forked"
    proc = hgo_run(tmp_path, *SHORT, f"hydra.run.dir={forked}")
    assert proc.returncode == 0, proc.stderr[-2000:]
    assert "matplotlib imported: False" in proc.stdout
    in_process = tmp_path / "in_process"
    run(compose(SHORT, in_process), in_process)
    assert (forked / "fig1.png").read_bytes() == (in_process / "fig1.png").read_bytes()
    assert (forked / "run.json").is_file() and (forked / ".hgo_done").is_file()


def test_a_run_without_figures_never_imports_matplotlib(tmp_path):
    """sp_fig1 over 6 s with its figure dropped (``figures.fig1=null``): complete, no figure
    file, and the run's process has not imported matplotlib when it ends."""
    out = tmp_path / "run"
    proc = hgo_run(tmp_path, *SHORT, "figures.fig1=null", f"hydra.run.dir={out}")
    assert proc.returncode == 0, proc.stderr[-2000:]
    assert "matplotlib imported: False" in proc.stdout
    assert (out / ".hgo_done").is_file() and not list(out.glob("*.png"))


def test_several_figures_are_drawn_by_two_processes_as_by_one(tmp_path):
    """sp_fig1 over 6 s with four figures (fig1, the same figure again as fig1b, two that
    write their process id): every other one is drawn by a fork of the figure process,
    so the two id figures name two processes; fig1b.png, drawn in the fork, equals
    fig1.png, drawn in the figure process, byte for byte; the run is complete."""
    out = tmp_path / "run"
    proc = hgo_run(tmp_path, *SHORT, f"hydra.run.dir={out}",
                   "+figures.fig1b._target_=hgo.papers.sanfelice_praly.figures.fig1",
                   "+figures.pid_a._target_=user_figures.pid",
                   "+figures.pid_b._target_=user_figures.pid")
    assert proc.returncode == 0, proc.stderr[-2000:]
    assert (out / "pid_a.png").read_text() != (out / "pid_b.png").read_text()
    assert (out / "fig1b.png").read_bytes() == (out / "fig1.png").read_bytes()
    assert (out / ".hgo_done").is_file()


@pytest.mark.parametrize("figure, code, line", [
    ("fails", 2, "error: this figure cannot be drawn"),  # a ValueError, as in process
    ("dies", 1, "error: ChildProcessError: the figure process ended (exit code 3) without "
                "drawing the figures"),
])
def test_a_figure_that_fails_fails_the_run_with_one_line(tmp_path, figure, code, line):
    """A figure raising in the forked process fails the run as it would in the run's own
    (its exception, its exit code); a figure process that dies fails it with one line.
    The run's other outputs are written, and it is not marked complete."""
    out = tmp_path / "run"
    proc = hgo_run(tmp_path, *SHORT, f"+figures.bad._target_=user_figures.{figure}",
                   f"hydra.run.dir={out}")
    assert proc.returncode == code
    assert [ln for ln in proc.stderr.splitlines() if ln.startswith("error")] == [line]
    assert (out / "recording.rrd").is_file() and (out / "metrics.csv").is_file()
    assert not (out / ".hgo_done").exists()


def test_drawing_view_keeps_both_ends_and_every_extreme_of_a_long_run(tmp_path, monkeypatch):
    """With the thresholds scaled down (50 full-rate samples at each end, 100 buckets), a
    501-sample run reaches the figure process as 300 rows a series: both ends exact, the
    min and max of every column kept, the metrics untouched; a short run is unchanged."""
    import numpy as np

    import hgo.running.figure_worker as fw

    cfg = compose(["experiment=sp_fig1", "solver.t_end=5", "metrics.window=1",
                   "figures.fig1=null"], tmp_path)
    result = run(cfg, tmp_path)
    assert fw.drawing_view(result) is result  # 501 samples: far under the thresholds
    monkeypatch.setattr(fw, "FULL_RATE", 50)
    monkeypatch.setattr(fw, "BUCKETS", 100)
    view = fw.drawing_view(result)
    assert len(view.trajectory.t) == 300 and np.all(np.diff(view.trajectory.t) >= 0)
    assert view.metrics is result.metrics
    for full, small in zip(result.series, view.series, strict=True):
        assert small.values.shape == (300, full.values.shape[1])
        np.testing.assert_array_equal(small.values[:50], full.values[:50])
        np.testing.assert_array_equal(small.values[-50:], full.values[-50:])
        np.testing.assert_array_equal(small.values.min(axis=0), full.values.min(axis=0))
        np.testing.assert_array_equal(small.values.max(axis=0), full.values.max(axis=0))
    np.testing.assert_array_equal(view.trajectory.xh[-50:], result.trajectory.xh[-50:])


@pytest.mark.parametrize("overrides, code", [
    ((*SHORT, "+figures.modules._target_=user_figures.app_imported"), 0),  # takes it
    (("experiment=sp_fig1", "observer=no_such_observer"), 2),  # a config error
    (("experiment=sp_ensemble", "ensemble.size=2", "solver.t_end=1", "metrics.window=0.5"),
     0),  # an ensemble
])
def test_the_figure_process_forked_at_start_up_draws_or_ends_with_the_run(tmp_path, overrides,
                                                                            code):
    """``hgo run`` forks its figure process before it imports its Hydra app (the figure
    of a single run, drawn there, finds ``hgo.cli.app`` not imported); a run that does not
    take it (a configuration error, an ensemble, whose reports are drawn in the run's own
    process) ends it: no process of the run's session is left when the run has exited."""
    out = tmp_path / "run"
    proc = hgo_run(tmp_path, *overrides, f"hydra.run.dir={out}", start_new_session=True)
    assert proc.returncode == code, proc.stderr[-2000:]
    assert session_processes(proc.pid) == []
    if any(o.startswith("+figures.modules") for o in overrides):
        assert (out / "modules.png").read_text() == "False"
        assert (out / "fig1.png").is_file() and (out / ".hgo_done").is_file()
