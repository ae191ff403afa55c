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

    def fails(result, path):
        raise ValueError("this figure cannot be drawn")

    def dies(result, path):
        os._exit(3)
''')


def hgo_run(tmp_path: Path, *overrides: str) -> subprocess.CompletedProcess:
    (tmp_path / "user_figures.py").write_text(FIGURES)
    env = {**os.environ, "PYTHONPATH": os.pathsep.join([str(tmp_path), str(ROOT)])}
    env.pop("HYDRA_FULL_ERROR", None)
    return subprocess.run([sys.executable, "-c", RUN_AND_REPORT, *overrides], cwd=tmp_path,
                          env=env, capture_output=True, text=True, timeout=300)


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
