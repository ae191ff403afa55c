"""Reliability, second round (issue 28): iterative routines that must stop, inputs that
must be refused, failures that must not exit 0, commands that survive bad files.

Each test names the case of the issue it covers and the one line (or result) the user
gets now instead of a hang, a traceback or a silent accept.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

# --- iterative numerics stop on NaN/inf ----------------------------------------------


def test_zoom_refuses_a_nan_bracket_instead_of_looping():
    """``_zoom`` waited for ``hi - lo < xatol``, never true for NaN (P not positive
    definite gave s_min = NaN): now one error naming the values."""
    from hgo.core.lmi import NonFiniteError
    from hgo.papers.sanfelice_praly.bounds import _zoom, minimise_over_s

    with pytest.raises(NonFiniteError, match="lo = nan"):
        _zoom(np.log, math.nan, 1.0)
    with pytest.raises(NonFiniteError, match="s_min = nan"):
        minimise_over_s(np.log, math.nan)


def test_zoom_ends_where_float_spacing_stops_the_bracket():
    """A tolerance below the spacing of floats (xatol = 0) used to loop forever: the
    bracket stops shrinking, and the zoom returns the minimiser."""
    from hgo.papers.sanfelice_praly.bounds import _zoom

    u, v = _zoom(lambda s: (np.log(s) - 1.25) ** 2, 1.0, 2.0, xatol=0.0)
    assert abs(u - 1.25) < 1e-12 and v < 1e-24


def test_bisection_refuses_nan_and_stops_at_float_spacing():
    """A NaN end used to return ``good`` unchanged (NaN comparisons are false); an rtol
    below float spacing now ends at adjacent floats."""
    from hgo.core.lmi import NonFiniteError, bisect

    with pytest.raises(NonFiniteError, match="bad = nan"):
        bisect(lambda x: x < 1, 0.0, math.nan, 1e-6)
    with pytest.raises(NonFiniteError, match="good = inf"):
        bisect(lambda x: x < 1, math.inf, 2.0, 1e-6)
    x = bisect(lambda x: x < 0.3, 0.0, 1.0, 1e-30)
    assert x < 0.3 and np.nextafter(x, 1.0) >= 0.3


def test_sp_bounds_refuses_a_p_that_is_not_positive_definite():
    """``postprocess.sp_bounds.P=[[1,0],[0,-1]]`` looped forever in the bound's zoom."""
    from hgo.papers.sanfelice_praly.postprocess import sp_bounds

    with pytest.raises(ValueError, match=r"P must be positive definite .*\[-1.0, 1.0\]"):
        sp_bounds(P=[[1, 0], [0, -1]])


# --- a corpus of inputs: one line each, checked before any integration --------------

SP = "experiment=sp_fig1"
ENS = "experiment=sp_ensemble"
APA = "experiment=apa_fig1"
APA2 = "experiment=apa_fig2"
DHLM = "experiment=dhlm_example"
MORENO = "experiment=moreno_pe"
GRID = "experiment=sp_fig3_grid"
SI = "observer.sign_indefinite"
GRID10 = "[" + ",".join(str(k) for k in range(10)) + "]"

CORPUS: list[tuple[tuple[str, ...], str]] = [
    # members estimated up front (MemoryError after 1-20 s before)
    ((ENS, "ensemble.size=100000000"), "ensemble.size: the ensemble has 1e+08 members"),
    ((ENS, "ensemble.size=1000000000000"), "over half the free memory"),
    ((ENS, "ensemble.size=1", "++ensemble.grid={" + ",".join(f"{key}:{GRID10}" for key in (
        "seed", "plant.nu1", "plant.nu2", "noise.amplitude", *(f"{SI}.{k}" for k in (
            "p1", "p2", "b", "r0")))) + f",{SI}.xhat0:[" + ",".join(["[0,0]"] * 10) + "]}"),
     "ensemble.grid: the ensemble has 1e+09 members"),
    ((ENS, "ensemble.size=1000000", "solver.h_max=0.001"), "over solver.max_steps"),
    # iterative numerics fed a NaN (looped forever in the bound's zoom)
    ((SP, "postprocess.sp_bounds.P=[[1,0],[0,-1]]"), "P must be positive definite"),
    # unknown keys added with + / ++ (Hydra skips the schema)
    ((SP, "+solver.foo=1"), "solver.foo: is not a key of solver (allowed: method,"),
    ((SP, "++solver.foo=1"), "solver.foo: is not a key of solver"),
    ((SP, "+metrics.foo=1"), "metrics.foo: is not a key of metrics"),
    ((SP, "+recording.foo=1"), "recording.foo: is not a key of recording"),
    ((ENS, "+ensemble.foo=1"), "ensemble.foo: is not a key of ensemble"),
    ((SP, "+figures.foo=1"), "figures.foo: must be a figure node with a _target_"),
    ((SP, "+foo=1"), "foo: is not a key hgo reads, and nothing in the config interpolates it"),
    ((SP, "+sed=3"), "sed: is not a key hgo reads"),
    ((SP, "+figures.fig1.bogus=1"), "figures.fig1.bogus: is not a parameter of "
                                    "hgo.papers.sanfelice_praly.figures.fig1"),
    # tolerances and physical parameters in range
    ((SP, "solver.rtol=1e3"), "solver.rtol: must be in [1e-15, 1)"),
    ((SP, "solver.rtol=1"), "solver.rtol: must be in [1e-15, 1)"),
    ((SP, "solver.rtol=1e-20"), "solver.rtol: must be in [1e-15, 1)"),
    ((APA, "plant.hbar=1e300"), "plant.hbar must be in [0.001, 1000]"),
    ((APA, "plant.hbar=0"), "plant.hbar must be in [0.001, 1000]"),
    ((APA, "observer.omega2.hbar=1e-9"), "observer.omega2.hbar must be in [0.001, 1000]"),
    # seeds of a grid: integers >= 0, the key and the value named
    ((GRID, "++ensemble.grid={seed: [0.5, 1.5]}"),
     "ensemble.grid.seed: 0.5 is not a seed (allowed: integers >= 0), in [0.5, 1.5]"),
    ((GRID, "++ensemble.grid={seed: [-1, 0]}"), "ensemble.grid.seed: -1 is not a seed"),
    ((GRID, "++ensemble.grid={seed: [a, 0]}"), "ensemble.grid.seed: 'a' is not a seed"),
    # ensemble keys that did nothing
    ((SP, "ensemble.shard=1/2"), "ensemble.shard: applies to ensembles only"),
    ((ENS, "ensemble.vary={}"), "ensemble.vary: 'ensemble.vary={}' does not clear it"),
    # shards: one line naming the key
    ((ENS, "ensemble.shard=0/10000000000"),
     "ensemble.shard: '0/10000000000' splits 1,000 member(s) into 10,000,000,000 shards"),
    ((GRID, "ensemble.shard=3/4"), "ensemble.shard: '3/4' splits 3 member(s) into 4 shards"),
    ((GRID, "ensemble.shard=1/0"), "ensemble.shard must be 'i/N'"),
    ((GRID, "ensemble.shard=x"), "ensemble.shard must be 'i/N'"),
    # the newer papers' presets, per config group (values checked before the run)
    ((APA2, "plant.eta0=[0.7,0.7]"), "plant.eta0 must be > 0 with eta1 + eta2 <= 1"),
    ((APA2, "observer.omega2.p=1.5"), "observer.omega2.p must be in [0, 1/(n-1))"),
    ((APA2, "observer.omega2.u_min=0.8"), "need 0 < u_min < u_max < 1"),
    ((APA2, "observer.omega2.eta_hat0=[0.6,0.6]"), "observer.omega2.eta_hat0"),
    ((APA2, "observer.omega2.L0=0"), "observer.omega2.L0 must be null"),
    ((APA2, "observer.omega2.gain=bogus"), "observer.omega2.gain: 'bogus' not in"),
    ((APA2, "noise.std=-1"), "noise.std: must be >= 0"),
    ((APA2, "noise.channels=[3]"), "noise.channels: 3 is not a channel"),
    ((APA2, "postprocess.apa.late=[50,40]"), "postprocess.apa.late must be [a, b]"),
    ((APA2, "postprocess.apa.post=[0,100]"),
     "postprocess.apa.post = [0.0, 100.0] ends after solver.t_end = 50"),
    ((APA2, "+postprocess.apa.foo=1"), "postprocess.apa.foo: is not a parameter of"),
    ((DHLM, "observer.cascade.eps=-1"), "observer.cascade.eps must be in (0, 1)"),
    ((DHLM, "observer.cascade.S=[0,0]"), "observer.cascade.S must be 2 levels"),
    ((DHLM, "observer.cascade.L=[[1]]"), "observer.cascade.L must be a 2x2 matrix"),
    ((DHLM, "observer.cascade.psi_at=bogus"), "observer.cascade.psi_at must be one of"),
    ((DHLM, "observer.cascade.gamma=[[nan,1]]"), "observer.cascade.gamma[0][0]"),
    ((DHLM, "plant.m=-1"), "plant.m must be in (0, inf)"),
    ((DHLM, "plant.outputs=bogus"), "plant.outputs must be one of"),
    ((DHLM, "controller.omega=[1]"), "controller.a must have 1 entries"),
    ((DHLM, "postprocess.dhlm.window_start=1e9"),
     "postprocess.dhlm.window_start must be in (0, t_end=20)"),
    ((DHLM, "postprocess.dhlm.beta=bogus"), "postprocess.dhlm.beta must be"),
    ((MORENO, "observer.circle.e0=[1]"), "observer.circle.e0 must have n=2"),
    ((MORENO, "controller.kind=bogus"), "controller.kind: 'bogus' not in"),
    ((MORENO, "controller.tau=0"), "controller.tau must be > 0"),
    ((MORENO, "controller.ramp=bogus"), "controller.ramp: 'bogus' not in"),
    ((MORENO, "postprocess.moreno.regularisation=bogus"),
     "postprocess.moreno.regularisation must be 'margin' or 'decay'"),
    ((MORENO, "postprocess.moreno.eps_fraction=2"), "postprocess.moreno.eps_fraction"),
    ((MORENO, "postprocess.moreno.lambda_P=bogus"), "postprocess.moreno.lambda_P"),
    ((MORENO, "plant.x0=[nan,0]"), "plant.x0[0]: must be a number, got nan"),
]


def test_cleared_vary_and_the_last_shard_are_accepted():
    """What the refusals point to works: ``ensemble.vary=null`` clears the preset's vary;
    shard 2/3 of 3 members is one member; a top-level helper key that an entry
    interpolates stays allowed (``readings`` of apa_fig2)."""
    assert _config_line((SP, "+helper=3", "++seed=${helper}")) == "(accepted)"
    assert _config_line((ENS, "ensemble.vary=null", "ensemble.size=2")) == "(accepted)"
    assert _config_line((GRID, "ensemble.shard=2/3")) == "(accepted)"


def test_a_user_preset_without_its_package_header_is_refused(tmp_path):
    """Without ``# @package _global_`` its values went under ``experiment.``, unused."""
    (tmp_path / "experiment").mkdir()
    (tmp_path / "experiment" / "mine.yaml").write_text(
        "defaults:\n  - sp_fig1\nsolver:\n  t_end: 5\n")
    line = _config_line((f"hydra.searchpath=[file://{tmp_path}]", "experiment=mine"))
    assert line.startswith("experiment: the preset's values (solver) are not applied: its "
                           "file lacks the first line '# @package _global_'"), line


def _config_line(overrides: tuple[str, ...]) -> str:
    from hgo.core.config import compose
    from hgo.core.errors import one_line
    from hgo.running.job import check_config

    try:
        check_config(compose(list(overrides)))
    except Exception as err:  # noqa: BLE001 - any error is what the case looks at
        return one_line(err)
    return "(accepted)"


@pytest.mark.parametrize("case", CORPUS, ids=lambda c: " ".join(c[0])[:60])
def test_bad_input_gives_one_line(case):
    overrides, expected = case
    line = _config_line(overrides)
    assert expected in line and "\n" not in line and len(line) < 600, line


LAUGHS = "# @package _global_\ndefaults:\n  - sp_fig1\na: &a [1, 1, 1, 1, 1, 1, 1, 1, 1, 1]\n" + \
    "".join(f"{b}: &{b} [{', '.join(['*' + a] * 10)}]\n" for a, b in zip("abcdefgh", "bcdefghi",
                                                                      strict=True))


def test_nested_yaml_aliases_in_a_user_preset_are_refused(tmp_path):
    """A "billion laughs" (9 levels of 10 aliases: 1e9 values) ran for minutes and
    exhausted memory; now one line with the file, at once."""
    import time

    (tmp_path / "experiment").mkdir()
    (tmp_path / "experiment" / "laughs.yaml").write_text(LAUGHS)
    t0 = time.perf_counter()
    line = _config_line((f"hydra.searchpath=[file://{tmp_path}]", "experiment=laughs"))
    assert time.perf_counter() - t0 < 10
    assert line.startswith(f"{tmp_path}/experiment/laughs.yaml:") and \
        "aliases expand to more than 100,000 values" in line, line


def test_a_few_yaml_aliases_still_work(tmp_path):
    (tmp_path / "experiment").mkdir()
    (tmp_path / "experiment" / "alias.yaml").write_text(
        "# @package _global_\ndefaults:\n  - sp_fig1\nplant:\n  x0: &x0 [1.0, 2.0]\n"
        "observer:\n  sign_indefinite:\n    xhat0: *x0\n")
    from hgo.core.config import compose

    cfg = compose([f"hydra.searchpath=[file://{tmp_path}]", "experiment=alias"])
    assert list(cfg.observer.sign_indefinite.xhat0) == [1.0, 2.0]


# --- failures never exit 0 -------------------------------------------------------------

ROOT = __import__("pathlib").Path(__file__).parents[1]


def _cli(args: list[str], cwd, timeout: float = 300):
    import os
    import subprocess
    import sys

    env = {**os.environ, "PYTHONPATH": str(ROOT)}
    env.pop("HYDRA_FULL_ERROR", None)
    return subprocess.run([sys.executable, str(ROOT / "experiments" / "run.py"), *args],
                          cwd=cwd, env=env, capture_output=True, text=True, timeout=timeout)


def test_sweep_summary_lists_failed_jobs_and_gives_the_worst_exit_code(tmp_path):
    """A job that wrote run.json ok, one that failed (its note: a configuration error,
    no directory left), one without run.json (killed): 1 ok, 2 failed, exit code 2."""
    import json

    from hgo.running.aggregate import record_failure, sweep_exit_code, sweep_summary

    for name, status in (("job0", "ok"), ("job2", None)):
        (tmp_path / name / ".hydra").mkdir(parents=True)
        if status:
            (tmp_path / name / "run.json").write_text(json.dumps({"status": status}))
    assert sweep_exit_code(tmp_path) == 1  # job2 did not finish
    record_failure(tmp_path, "job1", 2, "observer.x.p2 must be > 0, got -1.0")
    text = sweep_summary(tmp_path)
    assert text.splitlines()[0] == f"sweep: 3 jobs in {tmp_path}: 1 ok, 2 failed"
    assert "  job1: error: observer.x.p2 must be > 0, got -1.0" in text
    assert "no run.json" in text and sweep_exit_code(tmp_path) == 2


def test_submitit_sweep_of_failing_jobs_exits_non_zero(tmp_path):
    """Jobs run by submitit in other processes: the sweep exited 0 printing '0 ok'; now
    the summary lists each failed job's line and the sweep exits 2."""
    pytest.importorskip("hydra_plugins.hydra_submitit_launcher")
    done = _cli(["-m", "hydra/launcher=submitit_local", "experiment=sp_oscillation",
                 "observer.sign_indefinite.p2=-1,-2", f"hydra.sweep.dir={tmp_path}/sw"],
                tmp_path)
    assert done.returncode == 2, done.stderr[-2000:]
    assert f"sweep: 2 jobs in {tmp_path}/sw: 0 ok, 2 failed" in done.stdout
    assert "job1: error: observer.sign_indefinite.p2 must be > 0, got -2.0" in done.stdout


def test_a_run_directory_in_use_is_refused_at_once(tmp_path):
    """Another process holds the run directory: a run into it fails with one line and
    exit 1 before Hydra writes anything there (both exited 0 and left a mix)."""
    import os
    import subprocess
    import sys

    busy = tmp_path / "busy"
    holder = subprocess.Popen(
        [sys.executable, "-c", "import sys, time\nfrom hgo.running.job import lock_run_dir\n"
         f"lock_run_dir({str(busy)!r})\nprint('locked', flush=True)\ntime.sleep(60)"],
        env={**os.environ, "PYTHONPATH": str(ROOT)}, stdout=subprocess.PIPE, text=True)
    try:
        assert holder.stdout.readline().strip() == "locked"
        done = _cli(["experiment=sp_oscillation", f"hydra.run.dir={busy}"], tmp_path)
    finally:
        holder.kill()
        holder.wait()
    assert done.returncode == 1
    assert done.stderr.strip().splitlines() == [
        f"error: {busy} is being written by another run (pid {holder.pid}); give this run "
        "another hydra.run.dir or wait for that one"]
    assert sorted(p.name for p in busy.iterdir()) == [".hgo_lock"]  # no .hydra written


def test_lock_is_released_with_the_run(tmp_path):
    from hgo.running.job import lock_run_dir, unlock_run_dir

    lock_run_dir(tmp_path / "r")
    unlock_run_dir(tmp_path / "r")
    lock_run_dir(tmp_path / "r")  # (a leaked lock would refuse this in a new description)
    unlock_run_dir(tmp_path / "r")


@pytest.mark.parametrize("name", ["..", ".", "../../x", "a/b"])
def test_run_name_is_a_name_not_a_path(name):
    """``run_name=..`` wrote outside outputs/; RunGuard refuses it before Hydra writes."""
    from omegaconf import OmegaConf

    from hgo.running.job import RunGuard

    cfg = OmegaConf.create({"run_name": name, "hydra": {"run": {"dir": "/nonexistent/x"}}})
    for start in (RunGuard().on_run_start, RunGuard().on_multirun_start):
        with pytest.raises(SystemExit) as info:
            start(cfg)
        assert info.value.code == 2


def test_multirun_with_a_path_as_run_name_writes_nothing(tmp_path):
    cwd = tmp_path / "a" / "b"
    cwd.mkdir(parents=True)
    done = _cli(["-m", "experiment=sp_oscillation", "run_name=../../x"], cwd)
    assert done.returncode == 2
    assert done.stderr.strip().splitlines() == [
        "error: run_name: must be a plain name, not a path, got '../../x' (allowed: letters, "
        "digits and _ . + = , - (not only dots))"]
    assert sorted(p.name for p in tmp_path.rglob("*")) == ["a", "b"]


def test_outputs_latest_that_cannot_be_updated_is_a_warning(tmp_path, monkeypatch, capsys):
    """``outputs/latest`` a directory: the completed run is not failed, one warning."""
    from hgo.cli import app

    monkeypatch.chdir(tmp_path)
    (tmp_path / "outputs" / "latest").mkdir(parents=True)
    run = tmp_path / "outputs" / "r" / "1"
    run.mkdir(parents=True)
    app._point_latest(run)
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith("warning: outputs/latest not updated (")


def test_reproduce_lists_failed_jobs_and_claims(tmp_path):
    import json
    from types import SimpleNamespace

    from hgo.reproduce.run import failures

    ok, bad, crashed = (SimpleNamespace(dir=tmp_path / n, overrides=("experiment=" + n,))
                        for n in ("ok", "bad", "crashed"))
    for job, status in ((ok, "ok"), (bad, "failed: state left the bound")):
        job.dir.mkdir()
        (job.dir / "reproduce.json").write_text(json.dumps({"status": status}))
    claims = tmp_path / "c.json"
    claims.write_text(json.dumps({"a": {"holds": True}, "b": {"measured": "error: X",
                                                              "error": "tb"}}))
    assert failures([ok, bad, crashed], {"p": claims}) == [
        "experiment=bad: failed: state left the bound",
        "experiment=crashed: no reproduce.json (the job crashed)",
        "claim p/b: error: X"]


def test_reproduce_exits_1_when_something_failed(monkeypatch, capsys):
    from hgo.reproduce import run as reproduce_run

    def fake(papers, jobs, root):
        reproduce_run.LAST_FAILURES[:] = ["experiment=x: failed: boom"]
        return root

    monkeypatch.setattr(reproduce_run, "reproduce", fake)
    assert reproduce_run.main(["sanfelice_praly"]) == 1
    err = capsys.readouterr().err
    assert "error: experiment=x: failed: boom" in err


# --- commands survive bad files ----------------------------------------------------------


@pytest.fixture
def runs_root(tmp_path, monkeypatch):
    """outputs/ with three good runs and three damaged run.json, and recordings: one
    good, one not a recording, one truncated."""
    import json

    from hgo.outputs.recording import Series, write_recording

    monkeypatch.chdir(tmp_path)
    good = {"status": "ok", "started": "s", "hgo": "0", "command": "c", "seconds": {},
            "metrics": {"o/q": 1.0}}
    configs = {"good": {"observer.o.p2": 0.008, "seed": 0, "resume": False},
               "num1": {"observer.o.p2": 3, "seed": 1, "resume": True},
               "num2": {"observer.o.p2": "abc", "seed": 2}}
    for name, config in configs.items():
        (tmp_path / "outputs" / name).mkdir(parents=True)
        (tmp_path / "outputs" / name / "run.json").write_text(json.dumps({**good,
                                                                          "config": config}))
    for name, text in (("list", "[]"), ("cfg5", '{"config": 5}'),
                       ("trunc", json.dumps(good)[:50])):
        (tmp_path / "outputs" / name).mkdir()
        (tmp_path / "outputs" / name / "run.json").write_text(text)
    t = np.arange(100) * 0.01
    rrd = write_recording(tmp_path / "outputs" / "good" / "recording.rrd", t,
                          [Series("/a", ["x"], t[:, None])], recording_id="g")
    (tmp_path / "notrrd.rrd").write_text("hello")
    (tmp_path / "trunc.rrd").write_bytes(rrd.read_bytes()[:3000])
    return tmp_path


def _hgo(capsys, *args: str) -> tuple[int, str, str]:
    from hgo.cli import main

    code = main(list(args))
    out, err = capsys.readouterr()
    return code, out, err


def test_runs_lists_the_good_runs_and_one_line_per_bad_run_json(runs_root, capsys):
    code, out, err = _hgo(capsys, "runs")
    assert code == 0 and out.strip().endswith("3 run(s)")
    assert sorted(err.strip().splitlines()) == [
        "skipped: outputs/cfg5/run.json: not a run record ('config' is 5, not an object)",
        "skipped: outputs/list/run.json: not a run record (a JSON list, not an object)",
        "skipped: outputs/trunc/run.json: not valid JSON (truncated?): Unterminated string "
        "starting at: line 1 column 46 (char 45)"]


@pytest.mark.parametrize("run, reason", [
    ("list", "not a run record (a JSON list, not an object)"),
    ("cfg5", "not a run record ('config' is 5, not an object)"),
    ("trunc", "not valid JSON (truncated?)")])
def test_show_and_compare_report_a_bad_run_json_in_one_line(runs_root, capsys, run, reason):
    code, _, err = _hgo(capsys, "show", f"outputs/{run}")
    assert code == 2 and err.count("\n") == 1 and err.startswith("error: run: ")
    assert reason in err
    code, _, err = _hgo(capsys, "runs", "--compare", "outputs/good", f"outputs/{run}")
    assert code == 2 and err.count("\n") == 1 and reason in err


@pytest.mark.parametrize("where, found", [
    (["p2=8e-3"], ["good"]),  # stored as 0.008: compared as numbers
    (["observer.o.p2=0.008"], ["good"]),
    (["p2>1"], ["num1"]),
    (["p2<1"], ["good"]),
    (["p2!=3"], ["good", "num2"]),
    (["p2=abc"], ["num2"]),
    (["resume=true"], ["num1"]),
    (["seed>=1", "p2<=3"], ["num1"])])
def test_where_compares_numbers_as_numbers(runs_root, capsys, where, found):
    code, out, _ = _hgo(capsys, "runs", "--where", *where)
    assert code == 0
    assert sorted(line.split()[0].rsplit("/", 1)[-1] for line in out.splitlines()[1:-1]) \
        == found


@pytest.mark.parametrize("where, line", [
    ("p2", "error: --where: 'p2' needs an operator and a value (allowed: KEY=VALUE, "
           "KEY!=VALUE, KEY<VALUE, KEY>VALUE, KEY<=VALUE, KEY>=VALUE)"),
    ("p2<abc", "error: --where: 'p2<abc': < needs a number, got 'abc'"),
    ("nokey=1", "error: --where: no config key 'nokey' in the runs under outputs")])
def test_where_errors_are_one_line(runs_root, capsys, where, line):
    code, _, err = _hgo(capsys, "runs", "--where", where)
    assert code == 2 and err.strip().splitlines()[-1] == line


def test_export_reports_bad_recordings_and_a_missing_folder(runs_root, capsys):
    code, _, err = _hgo(capsys, "export", "notrrd.rrd")
    assert code == 2 and err.count("\n") == 1
    assert err.startswith("error: source: recording notrrd.rrd is unreadable")
    code, _, err = _hgo(capsys, "export", "trunc.rrd")
    assert code == 2 and err.count("\n") == 1 and "trunc.rrd is unreadable" in err
    code, _, err = _hgo(capsys, "export", "outputs/good", "--out", "missing/x.csv")
    assert (code, err) == (2, "error: --out: folder missing does not exist\n")
    code, out, _ = _hgo(capsys, "export", "outputs/good")
    assert code == 0 and out.startswith("wrote outputs/good/recording.csv (100 rows")


# --- long lists: short lines, fast refusals -------------------------------------------


def test_a_long_list_in_an_error_is_summarised():
    """A 20,000-element plant.x0 printed a 100 KB "one line"."""
    from hgo.core.errors import ConfigError, one_line

    err = ConfigError("plant.x0", f"must have 2 entries [x1, x2], got {[1.0] * 20000}")
    assert one_line(err) == ("plant.x0: must have 2 entries [x1, x2], got [1.0, 1.0, 1.0, "
                             "1.0, 1.0, 1.0, 1.0, 1.0, 1.0, 1.0, 1.0, 1.0, ... (20,000 "
                             "values)]")
    assert len(one_line(ValueError("x" * 100_000))) <= 600


def test_a_long_list_in_a_preset_is_refused_in_seconds_naming_its_key(tmp_path):
    """From a preset (the command line is refused, below): Hydra's instantiate took ~0.4 ms
    a list element; the factory's check now runs on the plain list. (Composing the preset
    itself costs OmegaConf ~1-3 ms a value, not changed: 2,000 values here.)"""
    import time

    (tmp_path / "experiment").mkdir()
    (tmp_path / "experiment" / "big.yaml").write_text(
        "# @package _global_\ndefaults:\n  - sp_fig1\nplant:\n  x0: ["
        + ", ".join(["1.0"] * 2000) + "]\n")
    t0 = time.perf_counter()
    line = _config_line((f"hydra.searchpath=[file://{tmp_path}]", "experiment=big"))
    assert time.perf_counter() - t0 < 15
    assert line.startswith("plant.x0") and line.endswith("(2,000 values)]"), line


def test_a_long_override_is_refused_before_hydra_parses_it(tmp_path):
    """Hydra's override parser took 132 s on a 20,000-value plant.x0 (load ~8)."""
    done = _cli(["experiment=sp_fig1", "plant.x0=[" + ",".join(["1.0"] * 20000) + "]"],
                tmp_path, timeout=60)
    assert done.returncode == 2
    assert done.stderr.startswith("error: plant.x0: the override is 80,010 characters "
                                  "(~20,000 values), over 20,000") and done.stderr.count("\n") == 1


def test_view_skips_a_file_that_is_not_a_recording(runs_root, capsys):
    """``hgo view`` handed a foreign file to the viewer; now one line each, the others go
    on (``--print-command``: the viewer is not started)."""
    code, out, err = _hgo(capsys, "view", "notrrd.rrd", "outputs/good", "--print-command")
    assert code == 0 and out.strip().splitlines()[-1].endswith(" outputs/good/recording.rrd")
    assert err == "skipped: notrrd.rrd: not a Rerun recording (unreadable or another file)\n"
    code, _, err = _hgo(capsys, "view", "notrrd.rrd")
    assert code == 2 and err.strip().splitlines()[-1] == (
        "error: no readable recording among notrrd.rrd")


def test_two_hydra_modes_at_once_are_one_line_exit_2(capsys):
    """``hgo run -m ... --cfg hydra`` (Hydra raised a ValueError with a traceback, exit 1):
    one line naming both modes and the allowed ones, exit 2, before Hydra starts."""
    code, out, err = _hgo(capsys, "run", "-m", "experiment=sp_fig3", "--cfg", "hydra")
    assert code == 2 and out == ""
    assert err == ("error: --cfg and --multirun: one mode at a time (allowed: --cfg, --info, "
                   "--multirun, --run, --shell-completion)\n")
