"""End to end: Hydra compose -> run -> recording.rrd read back with Rerun, metrics.csv."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from hydra.errors import ConfigCompositionException

from hgo.core.components import Plant
from hgo.outputs.recording import read_arrays
from hgo.running.runner import SimulationFailed, run

ROOT = Path(__file__).resolve().parents[1]
SHORT = ["solver.t_end=20", "solver.dt_out=0.01", "metrics.window=5"]


def test_sp_fig1_run_writes_recording_and_metrics(compose, tmp_path):
    cfg = compose(["experiment=sp_fig1", *SHORT], tmp_path)
    result = run(cfg, tmp_path)
    traj = result.trajectory
    rec = read_arrays(tmp_path / "recording.rrd")
    n = 2001
    assert len(rec["sim_time"]) == n
    np.testing.assert_allclose(rec["sim_time"], np.arange(n) * 0.01, atol=1e-9)
    for name in ("sign_indefinite", "dead_zone"):
        for entity, cols in ((f"/observer/{name}/xhat", 2), (f"/observer/{name}/r", 1),
                             (f"/error/{name}", 2)):
            assert rec[entity].shape == (n, cols), entity
    for entity in ("/plant/x", "/measurement/y", "/measurement/noise"):
        assert entity in rec
    # values are the simulation's, not a copy of something else
    np.testing.assert_array_equal(rec["/plant/x"], traj.z[:, :2])
    np.testing.assert_array_equal(rec["/observer/sign_indefinite/r"][:, 0], traj.z[:, 4])
    np.testing.assert_allclose(rec["/error/dead_zone"],
                               traj.z[:, 5:7] - traj.z[:, :2], atol=1e-15)

    table = pd.read_csv(tmp_path / "metrics.csv", keep_default_na=False,
                        na_values=["", "NaN", "nan"])
    engine_rows = table[table.postprocess.isna()]
    assert set(engine_rows.observer) == {"sign_indefinite", "dead_zone"}
    assert set(engine_rows.quantity) == {"mean_sq_error_x1", "mean_sq_error_x2",
                                         "mean_sq_output_error"}
    assert len(engine_rows) == 6
    out = engine_rows.set_index(["observer", "quantity"])
    # the sp_bounds post-processor fills B_io of (14) for the law-(6) observer only
    assert out.loc[("sign_indefinite", "mean_sq_error_x1"), "bound"] > 0
    assert np.isnan(out.loc[("dead_zone", "mean_sq_error_x1"), "bound"])
    row = out.loc[("sign_indefinite", "mean_sq_output_error")]
    assert row.bound == pytest.approx(0.008) and bool(row.holds)
    assert row.ratio == pytest.approx(row.empirical / row.bound)
    # window mean recomputed from the recording (trapezoid over the last 5 s)
    e1 = rec["/error/sign_indefinite"][-501:, 0]
    expected = np.trapezoid(e1 ** 2, dx=0.01) / 5.0
    assert out.loc[("sign_indefinite", "mean_sq_error_x1"), "empirical"] == pytest.approx(
        expected, rel=1e-6)
    assert (table.status == "ok").all() and np.allclose(table.window, 5.0)


def test_noise_is_seeded_and_held(compose, tmp_path):
    cfg = compose(["experiment=sp_fig2", *SHORT, "seed=7"], tmp_path)
    a = run(cfg, tmp_path / "a").trajectory
    b = run(cfg, tmp_path / "b").trajectory
    c = run(compose(["experiment=sp_fig2", *SHORT, "seed=8"], tmp_path), tmp_path / "c")
    np.testing.assert_array_equal(a.m, b.m)
    assert not np.array_equal(a.m, c.trajectory.m)
    assert np.abs(a.m).max() <= 0.004
    # held over 0.01 s periods: with dt_out = 0.01 every recorded sample is a new draw,
    # and the measured output is x1 + m exactly
    np.testing.assert_allclose(a.y[:, 0], a.z[:, 0] + a.m[:, 0], atol=1e-15)


# --- a user's own plant, defined here, outside hgo/ -------------------------------------

def double_integrator_f(t, x, u, p, dx):
    dx[0] = x[1]
    dx[1] = -p[0] * x[0]


def double_integrator_h(t, x, p, y):
    y[0] = x[0]


def make_oscillator(omega2: float = 1.0, x0: tuple = (1.0, 0.0)) -> Plant:
    """A harmonic oscillator, dx1 = x2, dx2 = -omega2 x1, y = x1."""
    return Plant(name="oscillator", state_names=["x1", "x2"], output_names=["y"],
                 input_names=[], x0=np.asarray(x0, float), p=np.array([omega2]),
                 f=double_integrator_f, h=double_integrator_h)


def test_user_plant_through_target(compose, tmp_path):
    conf = tmp_path / "userconf" / "plant"
    conf.mkdir(parents=True)
    (conf / "oscillator.yaml").write_text(
        f"_target_: {__name__}.make_oscillator\nomega2: 4.0\nx0: [1.0, 0.0]\n")
    cfg = compose([f"hydra.searchpath=[file://{tmp_path / 'userconf'}]", "plant=oscillator",
                   "observer.sign_indefinite.law=constant", "observer.sign_indefinite.r0=5",
                   "observer.dead_zone.law=constant", "observer.dead_zone.r0=5",
                   "observer.sign_indefinite.M=null", "observer.dead_zone.M=null",
                   *SHORT], tmp_path)
    result = run(cfg, tmp_path / "run")
    x = result.trajectory.z[:, :2]
    t = result.trajectory.t
    np.testing.assert_allclose(x[:, 0], np.cos(2 * t), atol=1e-6)
    # a constant-gain HGO with r = 5 tracks the oscillator up to its model error
    assert abs(result.trajectory.xh[-1, 0] - x[-1, 0]) < 0.05


# --- bad input: clear errors before any integration ------------------------------------

@pytest.mark.parametrize("override, words", [
    ("observer.sign_indefinite.p2=0", "p2 must be > 0"),
    ("observer.sign_indefinite.p1=-1", "p1 must be > 0"),
    ("observer.sign_indefinite.b=0.5", "b must be in (0, 1/2)"),
    ("observer.dead_zone.r0=0.5", "r0 must be >= 1"),
    ("solver.t_end=-1", "solver.t_end: must be > 0"),
    ("solver.h_max=0", "solver.h_max: must be > 0"),
    ("solver.dt_out=0", "solver.dt_out: must be > 0"),
    ("observer.sign_indefinite.law=quadratic", "not in ['constant', 'dead_zone'"),
    ("solver.method=euler", "solver.method: 'euler' is not a method"),
])
def test_bad_parameters_fail_before_integration(compose, tmp_path, override, words):
    cfg = compose(["experiment=sp_fig1", override], tmp_path)
    with pytest.raises(ValueError, match=None) as err:
        run(cfg, tmp_path)
    assert words in str(err.value)
    assert not (tmp_path / "recording.rrd").exists()


@pytest.mark.parametrize("override, words", [
    ("plant.nu3=1", "Key 'nu3' not in 'SPLinearPlantConf'"),
    ("observer.sign_indefinite.p2=abc", "could not be converted to Float"),
    ("plant=pendulum", "Could not find 'plant/pendulum'"),
])
def test_schema_errors_name_the_key(compose, override, words):
    with pytest.raises(ConfigCompositionException) as err:
        compose(["experiment=sp_fig1", override])
    message = str(err.value) + str(err.value.__cause__)
    assert words in message


def test_diverging_run_keeps_outputs_and_is_marked_failed(compose, tmp_path):
    # nu1 = 1 makes (18) unstable: x1 = -0.01 - 0.99 e^t leaves the bound 50 at
    # t = ln(49.99 / 0.99) = 3.92 s
    cfg = compose(["experiment=sp_fig1", *SHORT, "plant.nu1=1.0", "solver.state_bound=50"],
                  tmp_path)
    with pytest.raises(SimulationFailed, match="state left the bound"):
        run(cfg, tmp_path)
    table = pd.read_csv(tmp_path / "metrics.csv")
    assert (table.status == "failed").all()
    t_exit = np.log(49.99 / 0.99)
    assert table.t_stop.iloc[0] == pytest.approx(t_exit, abs=0.01)
    assert table.empirical.isna().all()
    rec = read_arrays(tmp_path / "recording.rrd")
    assert len(rec["sim_time"]) == int(t_exit / 0.01) + 1  # every grid sample before the exit
    assert np.isfinite(rec["/plant/x"]).all()


@pytest.mark.slow
def test_sweep_runs_every_job_even_when_one_fails(tmp_path):
    cmd = [sys.executable, "experiments/run.py", "-m", "experiment=sp_fig1", *SHORT,
           "solver.state_bound=50", "plant.nu1=0.01,1.0,0.02",
           f"hydra.sweep.dir={tmp_path}"]
    proc = subprocess.run(cmd, cwd=ROOT, capture_output=True, text=True, timeout=300)
    assert proc.returncode == 1, proc.stderr[-2000:]
    status = {p.parent.name: pd.read_csv(p).status.iloc[0]
              for p in tmp_path.glob("job*/metrics.csv")}
    assert status == {"job0": "ok", "job1": "failed", "job2": "ok"}
    assert all((tmp_path / j / ".hydra" / "config.yaml").exists() for j in status)
