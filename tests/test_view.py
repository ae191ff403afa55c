"""``hgo view`` (issue 26, item 5): which recordings a RUN names, the Rerun command, the ports
``--web`` prints, and a real headless web viewer serving two runs."""

from __future__ import annotations

import os
import socket
import subprocess
import sys
import time
import urllib.request
from pathlib import Path

import numpy as np
import pytest

from hgo.cli.view import all_recordings, main, recordings, viewer_command
from hgo.outputs.recording import Series, write_recording

ROOT = Path(__file__).resolve().parents[1]


def fake_sweep(root: Path, n: int) -> Path:
    """A sweep directory with jobs job0..job<n-1>, each holding a (placeholder) recording."""
    for i in range(n):
        (root / f"job{i}").mkdir(parents=True)
        (root / f"job{i}" / "recording.rrd").write_bytes(b"")
    return root


def test_a_sweep_directory_opens_all_its_jobs_in_job_order(tmp_path):
    sweep = fake_sweep(tmp_path / "sweep", 11)
    names = [p.parent.name for p in recordings(sweep)]
    assert names == [f"job{i}" for i in range(11)]  # job10 last, not after job1


def test_run_directory_file_and_duplicates(tmp_path):
    sweep = fake_sweep(tmp_path / "sweep", 2)
    job0 = sweep / "job0"
    assert recordings(job0) == [job0 / "recording.rrd"]
    assert recordings(job0 / "recording.rrd") == [job0 / "recording.rrd"]
    assert all_recordings([job0, sweep]) == [job0 / "recording.rrd",
                                             sweep / "job1" / "recording.rrd"]


def test_nothing_to_view_is_one_line_and_exit_2(tmp_path, capsys):
    (tmp_path / "empty").mkdir()
    assert main([str(tmp_path / "empty")]) == 2
    assert capsys.readouterr().err.strip() == (f"error: {tmp_path / 'empty'}: no recording.rrd "
                                                "in this directory or below it "
                                                "(recording.mode=off, or not a run directory)")


def test_native_and_web_commands():
    files = [Path("a/recording.rrd"), Path("b/recording.rrd")]
    native = viewer_command(files)
    assert Path(native[0]).name == "rerun" and os.access(native[0], os.X_OK)
    assert native[1:] == ["a/recording.rrd", "b/recording.rrd"]
    web = viewer_command(files, web=True, web_port=9191, grpc_port=9877)
    assert web[1:] == ["--serve-web", "--web-viewer-port", "9191", "--port", "9877",
                       "--bind", "127.0.0.1", "a/recording.rrd", "b/recording.rrd"]


def test_web_prints_exactly_the_ports_to_forward(tmp_path, capsys):
    sweep = fake_sweep(tmp_path / "sweep", 3)
    assert main([str(sweep), "--web", "--web-port", "9191", "--grpc-port", "9877",
                 "--print-command"]) == 0
    out = capsys.readouterr().out.splitlines()
    assert out[0] == "view: 3 recording(s), each its own recording in the viewer"
    assert out[1].startswith("forward ports 9191 (the web viewer's page, HTTP) and 9877 ")
    assert out[2] == "  ssh -L 9191:localhost:9191 -L 9877:localhost:9877 <this machine>"
    assert out[3] == ("then open  http://localhost:9191/?url="
                      "rerun%2Bhttp%3A%2F%2Flocalhost%3A9877%2Fproxy")
    assert out[4].endswith("job0/recording.rrd " + str(sweep / "job1" / "recording.rrd") + " "
                           + str(sweep / "job2" / "recording.rrd"))


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def _write_run(path: Path, recording_id: str, gain: float) -> None:
    t = np.linspace(0.0, 1.0, 11)
    write_recording(path, t, [Series("/plant/x", ["x1"], gain * t[:, None])],
                    recording_id=recording_id)


def _wait_for(url: str, seconds: float) -> int:
    deadline = time.monotonic() + seconds
    while True:
        try:
            with urllib.request.urlopen(url, timeout=2) as response:
                return response.status
        except OSError:
            if time.monotonic() > deadline:
                raise
            time.sleep(0.3)


def test_web_viewer_serves_two_runs_on_the_printed_ports(tmp_path):
    sweep = tmp_path / "sweep"
    _write_run(sweep / "job0" / "recording.rrd", "job0_a", 1.0)
    _write_run(sweep / "job1" / "recording.rrd", "job1_b", 2.0)
    web, grpc = _free_port(), _free_port()
    env = {**os.environ, "PYTHONPATH": str(ROOT), "RUST_LOG": "info"}
    proc = subprocess.Popen([sys.executable, "-m", "hgo.cli", "view", str(sweep), "--web",
                             "--web-port", str(web), "--grpc-port", str(grpc)],
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, env=env)
    try:
        assert _wait_for(f"http://127.0.0.1:{web}/", 60) == 200
        with socket.create_connection(("127.0.0.1", grpc), timeout=5):
            pass  # the gRPC proxy listens on the other printed port
    finally:
        proc.terminate()
        out, err = proc.communicate(timeout=30)
    assert f"ssh -L {web}:localhost:{web} -L {grpc}:localhost:{grpc}" in out
    for job in ("job0", "job1"):  # Rerun loaded both files
        assert f"{sweep / job / 'recording.rrd'}" in err


@pytest.mark.parametrize("args", [["--help"]])
def test_view_is_a_listed_command(args, capsys):
    from hgo.cli import main as hgo_main

    assert hgo_main(args) == 0
    assert "view" in capsys.readouterr().out
