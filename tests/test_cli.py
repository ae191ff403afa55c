"""The ``hgo`` command from outside the checkout: run, sweep, runs, show, export, list."""

from __future__ import annotations

import json
import re
import shutil
import subprocess
import time
from pathlib import Path

import pandas as pd
import pytest

from hgo.outputs.runs import load, write_run_json

HGO = shutil.which("hgo")
pytestmark = pytest.mark.skipif(HGO is None, reason="the hgo console script is not installed")
SHORT = ["solver.t_end=6", "metrics.window=2"]


def hgo(cwd, *args: str) -> subprocess.CompletedProcess:
    return subprocess.run([HGO, *args], cwd=cwd, capture_output=True, text=True, timeout=300)


@pytest.fixture(scope="module")
def workdir(tmp_path_factory):
    """An empty directory (not the checkout) with one single run and one 3-job sweep."""
    cwd = tmp_path_factory.mktemp("elsewhere")
    single = hgo(cwd, "run", "experiment=sp_fig1", *SHORT)
    assert single.returncode == 0, single.stderr[-2000:]
    sweep = hgo(cwd, "run", "-m", "experiment=sp_fig3", *SHORT)
    assert sweep.returncode == 0, sweep.stderr[-2000:]
    return cwd, single, sweep


def test_single_run_prints_its_directory_and_latest_is_the_newest(workdir):
    cwd, single, sweep = workdir
    line = single.stdout.strip().splitlines()[-1]
    assert line.startswith("ok: outputs in ") and "outputs/sp_fig1/" in line
    run_dir = Path(line.split("outputs in ")[1].split(" (")[0])
    for name in ("recording.rrd", "metrics.csv", "fig1.png", "run.json"):
        assert (run_dir / name).stat().st_size > 0, name
    job_lines = [ln for ln in sweep.stdout.splitlines() if ln.startswith("[3/3]")]
    last_job = job_lines[0].rsplit("(", 1)[1].rstrip(")")
    assert (cwd / "outputs" / "latest").resolve() == Path(last_job)
    info = json.loads((run_dir / "run.json").read_text())
    assert info["status"] == "ok" and info["seed"] == 0 and info["hgo"] == "0.1.0"
    assert {"numpy", "numba", "rerun-sdk", "hydra-core", "python"} <= set(info)
    assert set(info["seconds"]) == {"compile", "simulate", "postprocess", "write", "figures"}
    assert info["config"]["observer.sign_indefinite.p2"] == 0.008


def test_sweep_prints_one_line_per_job_and_combines(workdir):
    cwd, _, sweep = workdir
    lines = [ln for ln in sweep.stdout.splitlines() if re.match(r"\[\d+/\d+\] ", ln)]
    assert [ln[:5] for ln in lines] == ["[1/3]", "[2/3]", "[3/3]"]
    assert all(" → ok, " in ln for ln in lines)
    sweep_dir = next((cwd / "outputs" / "multirun" / "sp_fig3").iterdir())
    assert (sweep_dir / "compare.png").stat().st_size > 0  # the aggregation callback ran
    assert "failed" not in sweep.stderr


def test_runs_lists_every_run_with_a_metric(workdir):
    cwd, _, _ = workdir
    out = hgo(cwd, "runs", "--metrics", "mean_sq_output_error")
    assert out.returncode == 0, out.stderr
    assert "4 run(s)" in out.stdout and "sign_indefinite/mean_sq_output_error" in out.stdout
    where = hgo(cwd, "runs", "--where", "observer.sign_indefinite.p2=2.0")
    assert "1 run(s)" in where.stdout, where.stdout
    df = load(cwd / "outputs")
    assert len(df) == 4 and "metric.sign_indefinite/mean_sq_output_error" in df


def test_compare_shows_the_differing_key(workdir):
    cwd, _, _ = workdir
    jobs = sorted(str(p) for p in (cwd / "outputs" / "multirun").rglob("job[01]"))
    out = hgo(cwd, "runs", "--compare", *jobs)
    assert "observer.sign_indefinite.p2" in out.stdout and "config: 1 difference(s)" in out.stdout


def test_export_csv_has_named_series(workdir):
    cwd, _, _ = workdir
    out = hgo(cwd, "export", "outputs/latest", "--format", "csv")
    assert out.returncode == 0, out.stderr
    df = pd.read_csv(cwd / "outputs" / "latest" / "recording.csv", index_col="sim_time")
    assert "/observer/sign_indefinite/xhat/x1_hat" in df and "/plant/x/x2" in df
    assert df.index[-1] == pytest.approx(6.0)


def test_show_and_list(workdir):
    cwd, _, _ = workdir
    show = hgo(cwd, "show", "outputs/latest")
    assert show.returncode == 0 and "status: ok" in show.stdout and "holds" in show.stdout
    listing = hgo(cwd, "list")
    assert "sp_fig1" in listing.stdout and "Sanfelice & Praly, Fig. 1" in listing.stdout
    assert hgo(cwd, "nonsense").returncode == 2


def test_metrics_table_fits_100_columns(workdir):
    _, single, _ = workdir
    table = (single.stdout + single.stderr).split("metrics (all columns in metrics.csv):")[1]
    rows = []
    for line in table.splitlines()[1:]:
        if line.startswith(("[", "ok:", "wrote:")) or not line.strip():
            break
        rows.append(line)
    assert len(rows) > 10 and max(len(r) for r in rows) <= 100, rows


def test_index_reads_run_json_only(tmp_path):
    """load() over 200 synthetic runs equals what was written (its speed: benchmarks)."""
    table = pd.DataFrame({"observer": ["a"], "quantity": ["q"], "empirical": [1.5]})
    for k in range(200):
        d = tmp_path / f"r{k}"
        d.mkdir()
        write_run_json(d, {"run_name": "x", "seed": k, "observer": {"a": {"p": k}}}, "ok",
                       pd.Timestamp.now().to_pydatetime(), {"simulate": 0.1}, table)
    t0 = time.perf_counter()
    df = load(tmp_path)
    assert len(df) == 200 and sorted(df["config.observer.a.p"]) == list(range(200))
    assert (df["metric.a/q"] == 1.5).all()
    print(f"indexed 200 runs in {time.perf_counter() - t0:.3f} s")


def test_sweep_ends_with_a_summary_of_its_jobs(workdir):
    _, _, sweep = workdir
    tail = sweep.stdout[sweep.stdout.index("sweep: 3 jobs in "):].splitlines()
    assert tail[0].endswith(": 3 ok")
    assert tail[1].split()[:1] == ["job"] and "status" in tail[1]  # the header
    assert [row.split()[0] for row in tail[2:5]] == ["job0", "job1", "job2"]
