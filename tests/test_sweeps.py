"""Sweeps at scale (issue 17): grid ensembles, shards, recording modes."""

from __future__ import annotations

import json
import math

import numpy as np
import pandas as pd
import pytest
import yaml
from omegaconf import OmegaConf

from hgo.outputs.console import ensemble_table
from hgo.outputs.decimate import bucket_edges, envelope, write_run_recording
from hgo.outputs.recording import Series, read_arrays
from hgo.outputs.runs import load
from hgo.papers.ahrens_khalil.figures import tradeoff_point, write_tradeoff_report
from hgo.running.ensemble_runner import merge_shards, run_ensemble
from hgo.running.grid import expand_grid, parse_shard, shard_indices
from hgo.running.runner import job_config_yaml, simulate_config

SP_GRID = ["experiment=sp_ensemble", "ensemble.size=0", "solver.t_end=20",
           "metrics.window=5",
           "++ensemble.grid={observer.sign_indefinite.p2: [0.5, 1.5, 3.0], "
           "observer.sign_indefinite.xhat0: [[1.0, 1.0], [-2.0, 0.5]]}"]


def test_grid_is_the_cartesian_product_first_key_slowest():
    points = expand_grid({"a": [1, 2], "b": ["x", "y", "z"]})
    assert points["a"] == [1, 1, 1, 2, 2, 2]
    assert points["b"] == ["x", "y", "z"] * 2
    with pytest.raises(ValueError, match="ensemble.grid.a"):
        expand_grid({"a": []})
    with pytest.raises(ValueError, match="ensemble.grid.a"):
        expand_grid({"a": 3})


def test_shards_partition_the_members():
    parts = [shard_indices(11, f"{i}/3") for i in range(3)]
    np.testing.assert_array_equal(np.concatenate(parts), np.arange(11))
    assert parse_shard(None) == (0, 1)
    for bad in ("3/3", "-1/2", "a/b", "1"):
        with pytest.raises(ValueError, match="ensemble.shard must be 'i/N'"):
            parse_shard(bad)


def test_grid_members_equal_single_runs_and_carry_their_values(compose, tmp_path):
    """Each grid member's window means equal the single run of its values (rel 1e-12),
    and its rows carry the member's grid values."""
    cfg = compose(SP_GRID, tmp_path)
    result = run_ensemble(cfg, tmp_path)
    table = pd.read_csv(tmp_path / "metrics.csv")
    members = table[table.member != "all"]
    assert sorted(members.member.astype(int).unique()) == list(range(6))
    p2 = result.draws["observer.sign_indefinite.p2"]
    xhat0 = result.draws["observer.sign_indefinite.xhat0"]
    np.testing.assert_array_equal(p2, [0.5, 0.5, 1.5, 1.5, 3.0, 3.0])
    for i in (1, 4):
        single = compose(["experiment=sp_ensemble", "ensemble.size=0", "solver.t_end=20",
                          "metrics.window=5", f"observer.sign_indefinite.p2={float(p2[i])!r}",
                          "observer.sign_indefinite.xhat0="
                          f"[{float(xhat0[i][0])!r},{float(xhat0[i][1])!r}]"])
        expected = simulate_config(single).metrics.set_index(["observer", "quantity"])
        rows = members[members.member == str(i)].set_index(["observer", "quantity"])
        assert (rows["observer.sign_indefinite.p2"] == p2[i]).all()
        for key in expected.index:
            assert rows.loc[key, "empirical"] == pytest.approx(
                expected.loc[key, "empirical"], rel=1e-12), (i, key)


def test_grid_combines_with_random_draws_and_seeds(compose, tmp_path):
    """2 grid points x 3 replicates: replicate j has the same draw and seed seed + j at
    every point."""
    cfg = compose(["experiment=sp_ensemble", "ensemble.size=3", "solver.t_end=2",
                   "metrics.window=1", "seed=7",
                   "++ensemble.grid={plant.nu1: [2.0, 3.0]}"], tmp_path)
    result = run_ensemble(cfg, tmp_path)
    table = result.metrics[result.metrics.member != "all"]
    seeds = table.groupby("member").seed.first().reindex([str(i) for i in range(6)])
    assert seeds.tolist() == [7, 8, 9, 7, 8, 9]
    p2 = result.draws["observer.sign_indefinite.p2"]
    np.testing.assert_array_equal(p2[:3], p2[3:])
    assert len(set(p2[:3])) == 3
    np.testing.assert_array_equal(result.draws["plant.nu1"], [2.0] * 3 + [3.0] * 3)


def test_an_ensemble_run_writes_run_json_with_its_status_and_aggregate_metrics(
        compose, tmp_path):
    """An ensemble job is tracked like a single run (``hgo runs`` lists it): run.json with
    status ok, its timings and the aggregate (member 'all') rows as metrics."""
    run_ensemble(compose(SP_GRID, tmp_path), tmp_path)
    info = json.loads((tmp_path / "run.json").read_text())
    table = pd.read_csv(tmp_path / "metrics.csv")
    aggregate = table[table.member == "all"].iloc[0]
    assert info["status"] == "ok" and info["seconds"]["simulate"] > 0
    assert info["metrics"][f"{aggregate.observer}/{aggregate.quantity}"] == pytest.approx(
        aggregate.empirical, rel=1e-12)
    assert load(tmp_path).path.tolist() == [str(tmp_path)]


def test_grid_rejects_keys_shared_by_all_members(compose, tmp_path):
    cfg = compose(["experiment=sp_ensemble", "++ensemble.grid={solver.rtol: [1e-6, 1e-7]}"],
                  tmp_path)
    with pytest.raises(ValueError, match="ensemble.grid.solver.rtol: only keys under"):
        run_ensemble(cfg, tmp_path)


def test_merged_shards_equal_the_unsharded_table(compose, tmp_path):
    """Three shards of the 6-member grid, merged, give the unsharded metrics.csv (member
    rows and aggregates); a member in two shards is refused."""
    run_ensemble(compose(SP_GRID, tmp_path / "all"), tmp_path / "all")
    dirs = [tmp_path / str(i) for i in range(3)]
    for i, d in enumerate(dirs):
        run_ensemble(compose([*SP_GRID, f"++ensemble.shard={i}/3"], d), d)
    shard0 = pd.read_csv(dirs[0] / "metrics.csv", dtype={"member": str})
    assert set(shard0.member) == {"0", "1", "all"}
    merge_shards(dirs[::-1], tmp_path / "merged")
    read = {k: pd.read_csv(tmp_path / k / "metrics.csv", dtype={"member": str})
            for k in ("all", "merged")}
    pd.testing.assert_frame_equal(read["merged"], read["all"])
    with pytest.raises(ValueError, match="more than one shard"):
        merge_shards([dirs[0], dirs[0]])


@pytest.fixture(scope="module")
def ak_grid(tmp_path_factory):
    from hgo.core.config import compose

    out = tmp_path_factory.mktemp("ak_grid")
    return run_ensemble(compose(["experiment=ak_tradeoff_grid"], out), out), out


def test_ensemble_console_table_fits_100_columns_with_integer_counts(ak_grid):
    """What an ensemble run prints: one line per aggregate row, at most 100 columns, the
    member counts as integers (52 ok, 0 failed)."""
    _, out = ak_grid
    table = pd.read_csv(out / "metrics.csv")
    aggregate = table[table.member == "all"]
    lines = ensemble_table(aggregate).splitlines()
    assert len(lines) == 2 + len(aggregate.drop_duplicates(["observer", "quantity"]))
    assert max(len(line) for line in lines) <= 100
    assert all(line.split()[-2:] == ["52", "0"] for line in lines[2:]), lines


def test_ak_tradeoff_grid_fit_equals_the_multirun_fit(ak_grid, compose, tmp_path):
    """The 52-point trade-off fit of (25) from the grid ensemble equals the fit from the
    52 jobs of ``-m experiment=ak_tradeoff`` (each job's own composed config and single
    run, as the multirun runs it): points and fit to 1e-9 relative."""
    result, out = ak_grid
    grid = result.draws
    points = []
    for k, (eps, mu) in enumerate(zip(grid["observer.fixed.eps1"], grid["noise.amplitude"],
                                      strict=True)):
        cfg = compose(["experiment=ak_tradeoff", f"observer.fixed.eps1={float(eps)!r}",
                       f"noise.amplitude={float(mu)!r}"])
        job = yaml.safe_load(job_config_yaml(cfg))
        points.append(tradeoff_point(f"job{k}", job, simulate_config(cfg).metrics))
    multirun = write_tradeoff_report(points, [], tmp_path, "multirun")
    ensemble = pd.read_csv(out / "tradeoff_points.csv")
    assert len(ensemble) == 52
    np.testing.assert_allclose(ensemble.bound, [p["bound"] for p in points], rtol=1e-9)
    fit_m = pd.DataFrame(multirun["analysis"].per_mu)
    fit_e = pd.read_csv(out / "tradeoff_fit.csv")
    for col in ("c1", "c2", "eps_star_fit", "eps_star_grid"):
        np.testing.assert_allclose(fit_e[col], fit_m[col], rtol=1e-9, err_msg=col)
    q_m = multirun["analysis"].power_fit.exponent
    md = (out / "tradeoff.md").read_text()
    assert f"| fit of (25) per mu | {q_m:.4f} |" in md
    assert math.isfinite(q_m) and (out / "tradeoff.png").exists()


# --- recording modes ------------------------------------------------------------------------

def test_envelope_keeps_every_peak_and_fits_max_rows():
    """A one-sample spike in each column and each column's extremes per bucket survive."""
    rng = np.random.default_rng(0)
    n, max_rows = 100_003, 1024
    t = np.arange(n) * 1e-3
    values = rng.normal(size=(n, 2))
    values[54_321, 0], values[777, 1] = 50.0, -60.0
    t_dec, (dec,) = envelope(t, [Series("/x", ["a", "b"], values)], max_rows)
    assert len(t_dec) <= max_rows and np.all(np.diff(t_dec) > 0)
    assert dec.values.max(axis=0)[0] == 50.0 and dec.values.min(axis=0)[1] == -60.0
    edges = bucket_edges(n, max_rows)
    for k in (0, 17, len(edges) - 2):
        block = values[edges[k]:edges[k + 1]]
        np.testing.assert_array_equal(dec.values[2 * k], block.min(axis=0))
        np.testing.assert_array_equal(dec.values[2 * k + 1], block.max(axis=0))
        assert t_dec[2 * k] == t[edges[k]] and t_dec[2 * k + 1] == t[edges[k + 1] - 1]
    same_t, (same,) = envelope(t[:1000], [Series("/x", ["a", "b"], values[:1000])], 1024)
    np.testing.assert_array_equal(same_t, t[:1000])
    np.testing.assert_array_equal(same.values, values[:1000])


@pytest.mark.parametrize("mode", ["decimated", "off"])
def test_recording_modes_never_change_metrics(compose, tmp_path, mode):
    """metrics.csv is the same in full, decimated and off; decimated writes <= max_rows
    rows and says so in /run/config; off writes no recording."""
    from hgo.running.runner import run

    base = ["experiment=sp_fig3", "solver.t_end=20", "metrics.window=5", "figures={}"]
    full = run(compose(base, tmp_path / "full"), tmp_path / "full").metrics
    other = run(compose([*base, f"recording={mode}", "recording.max_rows=256"],
                        tmp_path / mode), tmp_path / mode).metrics
    pd.testing.assert_frame_equal(full, other)
    rrd = tmp_path / mode / "recording.rrd"
    if mode == "off":
        assert not rrd.exists()
        return
    rec = read_arrays(rrd)
    assert len(rec["sim_time"]) == 256 < len(read_arrays(tmp_path / "full" /
                                                            "recording.rrd")["sim_time"])
    full_r = read_arrays(tmp_path / "full" / "recording.rrd")["/observer/sign_indefinite/r"]
    assert rec["/observer/sign_indefinite/r"].max() == full_r.max()  # the peak stays


def test_decimated_recording_says_so_in_run_config(monkeypatch, tmp_path):
    captured = {}
    monkeypatch.setattr("hgo.outputs.decimate.write_recording",
                        lambda path, t, series, text, **kw: captured.update(text=text, t=t))
    node = OmegaConf.create({"mode": "decimated", "max_rows": 64})
    t = np.linspace(0, 1, 1001)
    write_run_recording(node, tmp_path / "r.rrd", t, [Series("/x", ["a"], t[:, None])],
                        text={"/run/config": "seed: 0\n"}, recording_id="x")
    assert captured["text"]["/run/config"].startswith(
        "# recording.mode=decimated: min/max envelope of 1001 samples in 32 buckets")
    assert captured["text"]["/run/config"].endswith("seed: 0\n") and len(captured["t"]) == 64
    with pytest.raises(ValueError, match="recording.max_rows must be an integer >= 2"):
        write_run_recording(OmegaConf.create({"mode": "full", "max_rows": 1}), tmp_path / "r",
                            t, [], text={}, recording_id="x")


# --- beyond one machine ---------------------------------------------------------------------

def test_every_configured_target_is_importable_from_the_package():
    """Every ``_target_`` of conf/ (callbacks, figures, combiners, reports) lives in ``hgo``
    and imports: a launcher that runs jobs or callbacks elsewhere finds them."""
    from hydra.utils import get_object

    from hgo.core.config import conf_dir

    targets = set()
    for path in conf_dir().rglob("*.yaml"):
        for line in path.read_text().splitlines():
            key, _, value = line.strip().partition(":")
            if key == "_target_" and "hydra_plugins" not in value:
                targets.add(value.strip())
    assert "hgo.running.aggregate.AggregateCallback" in targets and len(targets) > 10
    for target in sorted(targets):
        assert target.startswith("hgo."), target
        assert get_object(target) is not None, target


@pytest.mark.slow
def test_submitit_local_sweep_with_its_aggregation_callback(tmp_path):
    """``-m experiment=sp_fig3 hydra/launcher=submitit_local``: 3 jobs on submitit's local
    executor (one process each), then the sweep's AggregateCallback combines them; the
    grid ensemble ``sp_fig3_grid`` of the same points gives the same metrics_all.csv
    values (rel 1e-9) and its own compare.png."""
    import os
    import subprocess
    import sys

    from hgo.core.config import conf_dir

    root = conf_dir().parent
    env = dict(os.environ, PYTHONPATH=os.pathsep.join([str(root),
                                                       os.environ.get("PYTHONPATH", "")]))
    sweep = tmp_path / "sweep"
    subprocess.run([sys.executable, str(root / "experiments" / "run.py"), "-m",
                    "experiment=sp_fig3", "hydra/launcher=submitit_local", "solver.t_end=10",
                    "metrics.window=5", "figures={}", f"hydra.sweep.dir={sweep}"],
                   cwd=tmp_path, env=env, check=True, capture_output=True, text=True,
                   timeout=600)
    assert len(list((sweep / ".submitit").glob("*/*_result.pkl"))) == 3
    rows = pd.read_csv(sweep / "metrics_all.csv")
    assert sorted(rows.job.unique()) == ["job0", "job1", "job2"]
    assert set(rows.status) == {"ok"}
    p2 = {job: float(o.split("p2=")[1].split()[0]) for job, o in
          rows.groupby("job").overrides.first().items()}
    assert p2 == {"job0": 3.0, "job1": 2.0, "job2": 1.5}
    assert (sweep / "compare.png").stat().st_size > 0
    assert "job2" in (sweep / "metrics_all.md").read_text()
    # the grid ensemble of the same points writes the same table (member k = job k)
    from hgo.core.config import compose

    grid_dir = tmp_path / "grid"
    run_ensemble(compose(["experiment=sp_fig3_grid", "solver.t_end=10", "metrics.window=5"],
                         grid_dir), grid_dir)
    grid = pd.read_csv(grid_dir / "metrics_all.csv")
    assert (grid_dir / "compare.png").stat().st_size > 0
    key = ["observer", "postprocess", "quantity"]
    for k in range(3):
        a = rows[rows.job == f"job{k}"].fillna({"postprocess": ""}).set_index(key)
        b = grid[grid.job == f"member{k}"].fillna({"postprocess": ""}).set_index(key)
        assert list(a.index) == list(b.index)
        np.testing.assert_allclose(b.empirical, a.empirical, rtol=1e-9, equal_nan=True)
        np.testing.assert_allclose(b.bound, a.bound, rtol=1e-9, equal_nan=True)


# --- memory -----------------------------------------------------------------------------------

def test_recordings_leave_no_threads_behind(tmp_path):
    """Each write_recording (with its default blueprint) used to leave 4 Rerun threads and
    ~3 MB alive in the process; a sweep of 20 recordings now ends with the threads it began
    with, and each file still holds its blueprint."""
    from pathlib import Path

    from rerun.chunk import RrdReader

    from hgo.outputs.recording import time_series_blueprint, write_recording

    def threads() -> int:
        return len(list(Path("/proc/self/task").iterdir()))

    t = np.arange(200) * 1e-3
    series = [Series("/a", ["x"], t[:, None])]
    write_recording(tmp_path / "warm.rrd", t, series, recording_id="warm",
                    blueprint=time_series_blueprint({"v": ["/a"]}))
    before = threads()
    for k in range(20):
        write_recording(tmp_path / f"r{k}.rrd", t, series, recording_id=f"r{k}",
                        blueprint=time_series_blueprint({"v": ["/a"]}))
    assert threads() <= before
    assert len(RrdReader(tmp_path / "r19.rrd").blueprints()) == 1


def test_freed_memory_goes_back_to_the_os():
    """32 MB of freed heap blocks, each below a block still in use (so glibc cannot trim
    them from the top of its heap): release_freed_memory gives more than 20 MB back (in
    a fresh process: a test process's heap holds other tests' blocks)."""
    import ctypes
    import subprocess
    import sys

    if not hasattr(ctypes.CDLL(None), "malloc_trim"):
        pytest.skip("no glibc malloc_trim")
    code = ("from hgo.core.memory import release_freed_memory\n"
            "def resident_kb():\n"
            "    with open('/proc/self/status') as fh:\n"
            "        return next(int(x.split()[1]) for x in fh if x.startswith('VmRSS:'))\n"
            "freed, kept = [], []\n"
            "for _ in range(500):  # 64 KiB: under the mmap threshold, from the heap\n"
            "    freed.append(bytearray(65536)); kept.append(bytearray(1024))\n"
            "del freed\n"
            "before = resident_kb()\n"
            "release_freed_memory()\n"
            "print(before - resident_kb())\n")
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True)
    assert done.returncode == 0, done.stderr
    assert int(done.stdout) > 20_000


def test_exit_skips_the_final_collection_but_runs_exit_handlers(tmp_path):
    """A process that called skip_exit_collection still runs its exit handlers (logging's
    flush of a file handler here) and ends with status 0."""
    import subprocess
    import sys

    log = tmp_path / "log.txt"
    code = ("import logging\n"
            "from hgo.core.memory import skip_exit_collection\n"
            "skip_exit_collection(); skip_exit_collection()\n"
            f"logging.basicConfig(filename={str(log)!r})\n"
            "logging.getLogger('x').warning('written at exit')\n"
            "cycle = []; cycle.append(cycle)\n")
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True)
    assert done.returncode == 0, done.stderr
    assert "written at exit" in log.read_text()


def test_member_nodes_take_the_fast_path_unless_a_target_is_nested():
    from hgo.running.runner import _has_nested_target

    assert not _has_nested_target({"K": [2.0, 2.0], "M": [[3.0, 0.0], [0.0, 0.0]], "c": None})
    assert _has_nested_target({"K": [2.0, {"x": [{"_target_": "a.b"}]}]})
    assert _has_nested_target({"inner": {"_target_": "a.b"}})


def test_sweep_summary_drops_each_jobs_configs_from_hydras_job_return(compose, tmp_path):
    """Hydra keeps every JobReturn until a sweep ends; in a multirun the last callback to
    see a job drops its configs (a single run keeps them)."""
    from hydra.core.utils import JobReturn, JobStatus
    from hydra.types import RunMode

    from hgo.running.aggregate import SweepSummary

    cfg = compose(["experiment=sp_example"], tmp_path)
    for mode, kept in ((RunMode.RUN, True), (RunMode.MULTIRUN, False)):
        hydra_node = OmegaConf.create({"hydra": {"mode": mode}})
        ret = JobReturn(cfg=cfg, hydra_cfg=hydra_node, status=JobStatus.COMPLETED,
                        _return_value=7)
        SweepSummary().on_job_end(hydra_node, ret)
        assert (ret.cfg is not None, ret.hydra_cfg is not None) == (kept, kept)
        assert ret.return_value == 7
