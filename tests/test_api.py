"""The Python API re-exported from ``hgo`` (issue 26): compose, run, sweep, errors."""

from __future__ import annotations

import json
import subprocess
import sys

import numpy as np
import pandas as pd
import pytest
from omegaconf import OmegaConf

import hgo

SHORT = ["experiment=sp_fig1", "solver.t_end=5", "metrics.window=1"]


def test_import_hgo_loads_neither_hydra_numba_nor_rerun():
    code = ("import sys, hgo; hgo.__version__; "
            "print(sorted(m for m in ('hydra', 'numba', 'rerun', 'hgo.api') if m in sys.modules))")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         check=True).stdout
    assert out.strip() == "[]"


def test_public_names_and_version():
    assert isinstance(hgo.__version__, str) and hgo.__version__
    for name in ("compose", "run", "sweep", "Result", "HgoError", "read_recording", "runs"):
        assert name in dir(hgo)
    assert callable(hgo.runs.load)
    with pytest.raises(AttributeError, match="no attribute 'nope'"):
        hgo.nope  # noqa: B018


def test_run_in_memory_names_signals_as_the_recording_does(tmp_path):
    memory = hgo.run(SHORT)
    cfg = hgo.compose(SHORT)
    written = hgo.run(cfg, out_dir=tmp_path / "run")
    assert OmegaConf.is_missing(cfg.hydra.runtime, "output_dir")  # the caller's cfg unchanged
    assert written.config.hydra.runtime.output_dir == str((tmp_path / "run").resolve())
    assert memory.status == written.status == "ok" and memory.out_dir is None
    assert memory.signals.index.name == "sim_time"
    assert memory.signals.index[-1] == pytest.approx(5.0)
    recording = hgo.read_recording(written.recording)
    assert sorted(recording.columns) == sorted(memory.signals.columns)
    np.testing.assert_allclose(recording[memory.signals.columns].to_numpy(),
                               memory.signals.to_numpy(), rtol=0, atol=0)
    pd.testing.assert_frame_equal(memory.metrics, written.metrics)
    assert set(memory.timings) == {"compile", "simulate", "postprocess"}
    assert set(written.timings) == {"compile", "simulate", "postprocess", "write", "figures"}


def test_run_with_out_dir_writes_what_hgo_run_writes(tmp_path):
    out = tmp_path / "run"
    result = hgo.run(SHORT, out_dir=out)
    names = {p.name for p in out.iterdir()}
    assert names == {"recording.rrd", "metrics.csv", "run.json", "fig1.png", ".hydra",
                     ".hgo_done", "app.log"}  # the files `hgo run` writes (tests/test_cli.py)
    assert "[hgo.running.runner][INFO] - integrating t = 0 .. 5 s" in (out / "app.log").read_text()
    assert {p.name for p in (out / ".hydra").iterdir()} == {"config.yaml", "hydra.yaml",
                                                           "overrides.yaml"}
    info = json.loads((out / "run.json").read_text())
    assert info["status"] == "ok" and info["config"]["solver.t_end"] == 5.0
    assert pd.read_csv(out / "metrics.csv").shape == result.metrics.shape
    assert hgo.runs.load(tmp_path).shape[0] == 1


def test_run_in_memory_writes_nothing(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    hgo.run(SHORT)
    assert list(tmp_path.iterdir()) == []


def test_a_run_that_stops_early_is_returned_with_its_status(tmp_path):
    diverging = [*SHORT, "plant.nu1=1.0", "solver.state_bound=50"]
    memory = hgo.run(diverging)
    written = hgo.run(diverging, out_dir=tmp_path / "run")
    for result in (memory, written):
        assert result.status.startswith("failed: ") and not result.ok
        assert result.signals.index[-1] < 5.0
    assert json.loads((tmp_path / "run" / "run.json").read_text())["status"] == written.status


@pytest.mark.parametrize(("overrides", "line"), [
    (["plant.nu3=1"], "plant.nu3: Key 'nu3' not in 'SPLinearPlantConf'"),
    (["plant=pendulum"], "plant: unknown option 'pendulum' (allowed: "),
    (["experiment=sp_fig1", "solver.t_end=5", "metrics.window=25"],
     "metrics.window: must be in [0, solver.t_end"),
])
def test_errors_are_hgo_errors_with_the_cli_line(overrides, line):
    with pytest.raises(hgo.HgoError) as caught:
        hgo.run(overrides)
    assert str(caught.value).startswith(line)
    cli = subprocess.run([sys.executable, "-m", "hgo.cli", "run", *overrides],
                         capture_output=True, text=True)
    assert cli.returncode == 2
    assert cli.stderr.strip().splitlines()[-1] == f"error: {caught.value}"


def test_an_unwritable_out_dir_is_an_hgo_error(tmp_path):
    (tmp_path / "file").write_text("")
    with pytest.raises(hgo.HgoError, match="file"):
        hgo.run(SHORT, out_dir=tmp_path / "file" / "run")


def test_run_refuses_an_ensemble_and_points_at_sweep():
    with pytest.raises(hgo.HgoError, match=r"use|hgo.sweep"):
        hgo.run([*SHORT, "ensemble.size=2"])


def test_sweep_one_row_per_member_with_its_parameters():
    base = [*SHORT, "noise=uniform", "noise.period=0.01"]
    table = hgo.sweep(base, grid={"observer.sign_indefinite.p2": [0.004, 0.008],
                                  "noise.amplitude": [0.0, 0.01]})
    assert list(table.index) == [0, 1, 2, 3]
    assert table["observer.sign_indefinite.p2"].tolist() == [0.004, 0.004, 0.008, 0.008]
    assert table["noise.amplitude"].tolist() == [0.0, 0.01, 0.0, 0.01]
    assert (table.status == "ok").all()
    # each member equals the single run of the same point (same seed, same kernel settings)
    single = hgo.run([*base, "observer.sign_indefinite.p2=0.008", "noise.amplitude=0.01"])
    row = single.metrics.set_index(["observer", "quantity"]).empirical
    key = ("sign_indefinite", "mean_sq_output_error")
    assert table.loc[3, "/".join(key)] == pytest.approx(row[key], rel=1e-9)
    assert table.loc[3, "/".join(key)] > table.loc[2, "/".join(key)]  # noise raises it


def test_sweep_needs_a_grid():
    with pytest.raises(hgo.HgoError, match="ensemble.grid"):
        hgo.sweep(SHORT)
