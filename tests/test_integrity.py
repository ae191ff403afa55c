"""A completed run's files are recorded (size, sha256) and checked before they are trusted:
resume, reproduce's reuse, hgo show / export / view / runs --compare (issue 40, item 2)."""

from __future__ import annotations

import json
import logging
import shutil
from pathlib import Path

import pytest

SHORT = ["experiment=sp_oscillation", "postprocess=none", "solver.t_end=2",
         "metrics.window=1", "resume=true"]


@pytest.fixture(scope="module")
def completed(tmp_path_factory) -> Path:
    """One completed run (recording, metrics, run.json), copied by each test."""
    from hgo.core.config import compose
    from hgo.running.job import run_job

    out = tmp_path_factory.mktemp("integrity") / "run"
    assert run_job(compose(SHORT, out), out) == 0
    return out


@pytest.fixture
def run_dir(completed, tmp_path) -> Path:
    return Path(shutil.copytree(completed, tmp_path / "run"))


def _flip_byte(path: Path, at: int = 200) -> None:
    data = bytearray(path.read_bytes())
    data[at] ^= 0xFF
    path.write_bytes(bytes(data))


def test_a_completed_run_records_the_size_and_sha256_of_each_file(run_dir):
    from hgo.outputs.integrity import DONE, sha256

    head, *lines = (run_dir / DONE).read_text().splitlines()
    files = {name: (int(size), digest) for name, size, digest in
             (line.split("\t") for line in lines)}
    assert set(files) == {"metrics.csv", "recording.rrd", "run.json"}
    for name, (size, digest) in files.items():
        assert (run_dir / name).stat().st_size == size and sha256(run_dir / name) == digest


@pytest.mark.parametrize("damage", ["truncate metrics.csv", "flip a byte of recording.rrd"])
def test_resume_runs_a_job_with_a_damaged_file_again(run_dir, caplog, damage):
    """resume=true skipped a job whose metrics.csv was truncated or whose recording had a
    byte changed (only the files' existence was checked): now one warning naming the file,
    and the job runs again, restoring the file."""
    from hgo.core.config import compose
    from hgo.running.job import is_complete, run_job

    name = damage.split()[-1]
    original = (run_dir / name).read_bytes()
    if damage.startswith("truncate"):
        (run_dir / name).write_bytes(original[:40])
    else:
        _flip_byte(run_dir / name, len(original) // 2)
    damaged = (run_dir / name).read_bytes()
    cfg = compose(SHORT, run_dir)
    with caplog.at_level(logging.WARNING, logger="hgo"):
        assert not is_complete(cfg, run_dir)
    (line,) = [r.getMessage() for r in caplog.records if "damaged" in r.getMessage()]
    assert f"damaged: {run_dir / name}" in line and "running the job again" in line
    assert run_job(cfg, run_dir) == 0
    assert (run_dir / name).read_bytes() != damaged and is_complete(cfg, run_dir)


def test_show_and_compare_refuse_a_changed_file_in_one_line(run_dir, completed, capsys):
    from hgo.cli.runs import runs, show

    _flip_byte(run_dir / "metrics.csv", 50)
    assert show([str(run_dir)]) == 1
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith(f"error: damaged: {run_dir / 'metrics.csv'}, "
                                               "expected sha256 ")
    (run_dir / "run.json").write_text((run_dir / "run.json").read_text()[:-30])
    assert runs(["--compare", str(completed), str(run_dir)]) == 1
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith(f"error: damaged: {run_dir / 'run.json'} has ")


def test_export_refuses_a_changed_recording_and_view_skips_a_truncated_one(run_dir, completed,
                                                                          capsys):
    """A byte flipped in the recording was exported with exit 0; a truncated one opened in
    the viewer without a word."""
    from hgo.cli.runs import export
    from hgo.cli.view import main as view

    _flip_byte(run_dir / "recording.rrd", 3000)
    assert export([str(run_dir)]) == 1
    (line,) = capsys.readouterr().err.strip().splitlines()
    assert "damaged" in line and "expected sha256" in line
    assert not (run_dir / "recording.csv").exists()
    rrd = run_dir / "recording.rrd"
    rrd.write_bytes(rrd.read_bytes()[:2000])
    assert view([str(run_dir), str(completed), "--print-command"]) == 0
    out, err = capsys.readouterr()
    assert err.strip().splitlines() == [
        f"skipped: damaged: {rrd} has 2000 bytes, expected "
        f"{(completed / 'recording.rrd').stat().st_size} (sha256 "
        f"{err.split('(sha256 ')[1].split(';')[0]}; truncated or replaced since the run)"]
    assert str(completed / "recording.rrd") in out and str(rrd) not in out


def test_export_never_leaves_a_truncated_file_under_its_name(run_dir, monkeypatch, capsys):
    """A write that fails half-way (a full disk) leaves at most ``<out>.partial``."""
    import errno

    import pandas as pd

    from hgo.cli.runs import export

    def half_then_full(self, path, *args, **kwargs):
        Path(path).write_text("sim_time,x\n0.0,")
        raise OSError(errno.ENOSPC, "No space left on device")

    monkeypatch.setattr(pd.DataFrame, "to_csv", half_then_full)
    assert export([str(run_dir), "--out", str(run_dir / "x.csv")]) == 2
    assert not (run_dir / "x.csv").exists()
    assert "No space left on device" in capsys.readouterr().err


def test_view_prints_a_shell_quoted_command(tmp_path, completed, capsys):
    """A path with a space, a quote and a ``$``: one word each when pasted (item 6)."""
    import shlex

    from hgo.cli.view import main as view

    odd = tmp_path / "a b'$x"
    shutil.copytree(completed, odd)
    assert view([str(odd), "--print-command"]) == 0
    command = capsys.readouterr().out.strip().splitlines()[-1]
    assert shlex.split(command)[-1] == str(odd / "recording.rrd")


def _job(tmp_path: Path, key: str = "k"):
    from hgo.reproduce.run import Job

    return Job("paper", None, ("experiment=x",), tmp_path, key)


def test_reproduce_reuses_a_job_only_when_its_json_and_files_are_intact(tmp_path, capsys):
    """A truncated reproduce.json was a JSONDecodeError traceback; a truncated output was
    reused. Now both are "not done" (run again), the damaged file named in one line."""
    from hgo.outputs.integrity import manifest

    (tmp_path / "metrics.csv").write_text("a,b\n1,2\n")
    files = {n: list(v) for n, v in manifest(tmp_path).items()}
    info = json.dumps({"key": "k", "status": "ok", "files": files})
    (tmp_path / "reproduce.json").write_text(info)
    assert _job(tmp_path).done() and not _job(tmp_path, "other").done()
    (tmp_path / "reproduce.json").write_text(info[: len(info) // 2])
    assert not _job(tmp_path).done()
    (tmp_path / "reproduce.json").write_text(info)
    (tmp_path / "metrics.csv").write_text("a,b\n1,")
    assert not _job(tmp_path).done()
    assert f"damaged: {tmp_path / 'metrics.csv'} has 6 bytes" in capsys.readouterr().err
