"""Bad input gets one clear line naming the key: a corpus of bad configurations.

Each case of ``CORPUS`` is (overrides, expected text): composing the config and checking
it (``hgo.running.job.check_config``: everything a run checks before integrating, nothing
integrated) must raise, and :func:`hgo.core.errors.one_line` of the error must be one line that
contains the expected text (the full key, or the key the message points at). A case
that composes and checks without error is a silent accept and fails. Add a component's
bad values by appending rows (``P_<paper>`` picks the preset).

A few cases go through ``experiments/run.py`` itself (one line on stderr, exit code 2, no
run directory left).
"""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import pytest

from hgo.core.config import compose
from hgo.core.errors import ConfigError, one_line
from hgo.running.job import check_config

SP = "experiment=sp_fig1"  # sp_linear + sp_pair (two law (4)/(6) observers) + sp_bounds
OSC = "experiment=sp_fig4"  # sp_single + oscillation + notch + sp_bounds
COLL = "experiment=sp_fig5"  # sp_single + sp_collection
ENS = "experiment=sp_ensemble"  # ensemble of 1000 members (built, not integrated)
AK = "experiment=ak_fig1"  # dc_motor + ak_switched + dc_motor_speed + ak_metrics + rk4
AK3 = "experiment=ak_fig2"  # three AK observers in one run
TRADE = "experiment=ak_tradeoff"  # one fixed-gain AK observer
SW = "observer.switched"
SI = "observer.sign_indefinite"
CO = "observer.collection"

CORPUS: list[tuple[tuple[str, ...], str]] = [
    # --- top-level keys -------------------------------------------------------------
    ((SP, "seed=1.5"), "seed"),
    ((SP, "seed=-1"), "seed"),
    ((SP, "seed=abc"), "seed"),
    ((SP, "seed=nan"), "seed"),
    ((SP, "seed=true"), "seed"),
    ((SP, "seed=[1,2]"), "seed"),
    ((SP, "run_name=a/b"), "run_name"),
    ((SP, "run_name=[1,2]"), "run_name"),
    ((SP, "run_name=''"), "run_name"),
    ((SP, "+foo=${nope}"), "nope"),
    # --- plant ----------------------------------------------------------------------
    ((SP, "plant.nu1=abc"), "plant.nu1"),
    ((SP, "plant.nu1=nan"), "plant.nu1"),
    ((SP, "plant.nu1=inf"), "plant.nu1"),
    ((SP, "plant.nu2=-inf"), "plant.nu2"),
    ((SP, "plant.nu2=1e400"), "plant.nu2"),
    ((SP, "plant.nu3=1"), "plant.nu3"),
    ((SP, "+plant.nu3=1"), "plant.nu3"),
    ((SP, "plant.x0=[1,2,3]"), "plant.x0"),
    ((SP, "plant.x0=[1]"), "plant.x0"),
    ((SP, "plant.x0=[]"), "plant.x0"),
    ((SP, "plant.x0=[nan,0]"), "plant.x0"),
    ((SP, "plant.x0=abc"), "plant.x0"),
    ((SP, "plant.x0=[a,b]"), "plant.x0"),
    ((SP, "plant=nonexistent"), "plant"),
    ((SP, "plant.nu1=${nope}"), "plant.nu1"),
    ((SP, "plant.nu1=${oc.env:HGO_TEST_UNSET_VARIABLE}"), "plant.nu1"),
    ((SP, "plant.nu1=[1"), "plant.nu1"),
    ((SP, "plant._target_=os.system"), "plant._target_"),
    ((SP, "plant._target_=subprocess.run"), "plant._target_"),
    ((SP, "plant._target_=hgo.plants.nope.nothing"), "plant._target_"),
    ((SP, "plant._target_=hgo.noise.noise_model"), "hgo.noise.noise_model"),
    ((AK, "plant.a=0"), "plant.a"),
    ((AK, "plant.c=-1"), "plant.c"),
    ((AK, "plant.e=nan"), "plant.e"),
    ((AK, "plant.x0=[0,0]"), "plant.x0"),
    ((AK, "plant.b=inf"), "plant.b"),
    # --- observers: Sanfelice & Praly (5)-(7) ----------------------------------------
    ((SP, f"{SI}.K=[2]"), SI),
    ((SP, f"{SI}.K=[2,2,2]"), SI),
    ((SP, f"{SI}.K=[2,2,2]", f"{SI}.xhat0=[3,3,3]", f"{SI}.M=null"), SI),
    ((SP, f"{SI}.K=[]"), SI),
    ((SP, f"{SI}.law=quadratic"), f"{SI}.law"),
    ((SP, f"{SI}.p1=-1"), f"{SI}.p1"),
    ((SP, f"{SI}.p2=0"), f"{SI}.p2"),
    ((SP, f"{SI}.b=0.5"), f"{SI}.b"),
    ((SP, f"{SI}.b=nan"), f"{SI}.b"),
    ((SP, f"{SI}.r0=0.5"), f"{SI}.r0"),
    ((SP, f"{SI}.r0=inf"), f"{SI}.r0"),
    ((SP, f"{SI}.M=[[1,2],[3,4]]"), f"{SI}.M"),
    ((SP, f"{SI}.M=[[1,0]]"), f"{SI}.M"),
    ((SP, f"{SI}.M=[[a,0],[0,0]]"), f"{SI}.M"),
    ((SP, f"{SI}.M=[[1,0],[0]]"), f"{SI}.M"),
    ((SP, f"{SI}.M=[[nan,0],[0,0]]"), f"{SI}.M"),
    ((SP, f"{SI}.c=[1]"), f"{SI}.c"),
    ((SP, f"{SI}.xhat0=[]"), SI),
    ((SP, f"{SI}.kk=1"), f"{SI}.kk"),
    ((SP, "observer.dead_zone.p2=-1"), "observer.dead_zone.p2"),
    ((SP, "observer=nonexistent"), "observer"),
    ((SP, "~observer"), "observer"),
    ((SP, f"{SI}._target_=os.system"), f"{SI}._target_"),
    # --- observers: the collection (21) ---------------------------------------------
    ((COLL, f"{CO}.N=0"), f"{CO}.N"),
    ((COLL, f"{CO}.N=1.5"), f"{CO}.N"),
    ((COLL, f"{CO}.kappa=[1]"), f"{CO}.kappa"),
    ((COLL, f"{CO}.kbar_scaling=bad"), f"{CO}.kbar_scaling"),
    ((COLL, f"{CO}.p2=-1"), f"{CO}.p2"),
    ((COLL, f"{CO}.spread=[0,0]"), f"{CO}"),
    ((COLL, f"{CO}.xhat0_copies=[[1,2]]"), f"{CO}.xhat0_copies"),
    ((COLL, f"{CO}.M=[[1,2],[3,4]]"), f"{CO}.M"),
    ((COLL, f"{CO}.r0=0"), f"{CO}.r0"),
    # --- observers: Ahrens & Khalil (8)-(10), (26)-(28) ------------------------------
    ((AK, f"{SW}.w_index=5"), SW),
    ((AK, f"{SW}.w_index=-2"), f"{SW}.w_index"),
    ((AK, f"{SW}.w_index=1.5"), f"{SW}.w_index"),
    ((AK, f"{SW}.eps1=0"), f"{SW}.eps1"),
    ((AK, f"{SW}.eps1=-1"), f"{SW}.eps1"),
    ((AK, f"{SW}.eps1=nan"), f"{SW}.eps1"),
    ((AK, f"{SW}.eps1=inf"), f"{SW}.eps1"),
    ((AK, f"{SW}.eps2=1e-5"), f"{SW}.eps2"),
    ((AK, f"{SW}.alpha1=[1]"), SW),
    ((AK, f"{SW}.alpha1=[-1,1]"), f"{SW}.alpha1"),
    ((AK, f"{SW}.alpha1=[71,70,5]"), SW),
    ((AK, f"{SW}.delta=0"), f"{SW}.delta"),
    ((AK, f"{SW}.T_d=-1"), f"{SW}.T_d"),
    ((AK, f"{SW}.saturation=0"), f"{SW}.saturation"),
    ((AK, f"{SW}.saturation=nan"), f"{SW}.saturation"),
    ((AK, f"{SW}.model=[1]"), f"{SW}.model"),
    ((AK, f"{SW}.xhat0=[1]"), f"{SW}.xhat0"),
    ((AK, f"{SW}.saturate_x1=maybe"), f"{SW}.saturate_x1"),
    ((AK, f"{SW}.input_gain=nan"), f"{SW}.input_gain"),
    ((TRADE, "observer.fixed.alpha2=[2,1]"), "observer.fixed.alpha2"),
    ((AK3, "observer.fixed_eps1.eps1=0"), "observer.fixed_eps1.eps1"),
    ((AK, "plant=sp_linear"), SW),  # reads y[1] (x3) of a plant with one output
    ((AK, "plant=sp_linear", f"{SW}.w_index=-1"), "controller"),  # no input to control
    ((AK, "observer=sp_single"), "plant.nu1"),  # its model interpolates the S-P plant's nu1
    # --- controllers ----------------------------------------------------------------
    ((SP, "controller=dc_motor_speed"), "controller"),
    ((SP, "controller=open_loop"), "controller"),
    ((SP, "controller=nonexistent"), "controller"),
    ((AK, "controller.k=0"), "controller.k"),
    ((AK, "controller.k=-1"), "controller.k"),
    ((AK, "controller.k=nan"), "controller.k"),
    ((AK, "controller.k=abc"), "controller.k"),
    ((AK, "controller.T_rise=0"), "controller.T_rise"),
    ((AK, "controller.x3_min=0"), "controller.x3_min"),
    ((AK, "controller.u_max=0"), "controller.u_max"),
    ((AK, "controller.u_max=-inf"), "controller.u_max"),
    ((AK, "controller.w0=inf"), "controller.w0"),
    ((AK, "controller.observer=nope"), "controller.observer"),
    ((AK, "controller.gain=5"), "controller.gain"),
    # --- noise ----------------------------------------------------------------------
    ((SP, "noise=uniform", "noise.amplitude=nan"), "noise.amplitude"),
    ((SP, "noise=uniform", "noise.amplitude=-1"), "noise.amplitude"),
    ((SP, "noise=uniform", "noise.amplitude=inf"), "noise.amplitude"),
    ((SP, "noise=uniform", "noise.period=0"), "noise.period"),
    ((SP, "noise=uniform", "noise.period=-0.01"), "noise.period"),
    ((SP, "noise=uniform", "noise.period=inf"), "noise.period"),
    ((SP, "noise=uniform", "noise.period=1e-12"), "noise.period"),
    ((SP, "noise.amplitude=0.1"), "noise.amplitude"),  # noise=none ignores it
    ((SP, "noise.std=0.1"), "noise.std"),
    ((SP, "noise=uniform", "noise.std=0.1"), "noise.std"),
    ((SP, "noise=gaussian", "noise.amplitude=0.1"), "noise.amplitude"),
    ((SP, "noise=gaussian", "noise.std=-1"), "noise.std"),
    ((SP, "noise=uniform", "noise.channels=[]"), "noise.channels"),
    ((SP, "noise=uniform", "noise.channels=[1]"), "noise.channels"),
    ((SP, "noise=uniform", "noise.channels=[0,0]"), "noise.channels"),
    ((SP, "noise=uniform", "noise.channels=[-1]"), "noise.channels"),
    ((SP, "noise=uniform", "noise.channels=[a]"), "noise.channels"),
    ((AK, "noise.channels=[2]"), "noise.channels"),
    ((SP, "noise.kind=pink"), "noise.kind"),
    ((SP, "noise=pink"), "noise"),
    # --- solver ---------------------------------------------------------------------
    ((SP, "solver.t_end=-1"), "solver.t_end"),
    ((SP, "solver.t_end=0"), "solver.t_end"),
    ((SP, "solver.t_end=nan"), "solver.t_end"),
    ((SP, "solver.t_end=inf"), "solver.t_end"),
    ((SP, "solver.t_end=abc"), "solver.t_end"),
    ((SP, "solver.t_end=1e12"), "solver.dt_out"),
    ((SP, "solver.dt_out=0"), "solver.dt_out"),
    ((SP, "solver.dt_out=-1"), "solver.dt_out"),
    ((SP, "solver.dt_out=nan"), "solver.dt_out"),
    ((SP, "solver.dt_out=1e-9"), "solver.dt_out"),
    ((SP, "solver.dt_out=0.03"), "solver.t_end"),
    ((SP, "solver.h_max=0"), "solver.h_max"),
    ((SP, "solver.h_max=-1"), "solver.h_max"),
    ((SP, "solver.h_max=nan"), "solver.h_max"),
    ((SP, "solver.h_max=1e-12"), "solver.max_steps"),
    ((SP, "solver.rtol=0"), "solver.rtol"),
    ((SP, "solver.rtol=inf"), "solver.rtol"),
    ((SP, "solver.atol=-1"), "solver.atol"),
    ((SP, "solver.method=euler"), "solver.method"),
    ((SP, "solver.state_bound=0"), "solver.state_bound"),
    ((SP, "solver.max_steps=0"), "solver.max_steps"),
    ((SP, "solver.max_output_rows=0"), "solver.max_output_rows"),
    ((SP, "solver.max_output_rows=1000"), "solver.dt_out"),
    ((SP, "solver.foo=1"), "solver.foo"),
    ((SP, "solver=nonexistent"), "solver"),
    ((AK, "solver.stability_safety=0"), "solver.stability_safety"),
    ((AK, "solver.stability_safety=-1"), "solver.stability_safety"),
    ((AK, "solver.stability_safety=2"), "solver.stability_safety"),
    ((AK, "solver.max_steps=1000"), "solver.max_steps"),
    # --- metrics --------------------------------------------------------------------
    ((SP, "metrics.window=-1"), "metrics.window"),
    ((SP, "metrics.window=1000"), "metrics.window"),
    ((SP, "metrics.window=nan"), "metrics.window"),
    ((SP, "metrics.foo=1"), "metrics.foo"),
    # --- post-processing (checked before the run) -----------------------------------
    ((SP, "postprocess.sp_bounds.d0=-1"), "postprocess.sp_bounds"),
    ((SP, "postprocess.sp_bounds.P=[[1,0],[1,1]]"), "postprocess.sp_bounds.P"),
    ((SP, "postprocess.sp_bounds.K=[1,2,3]"), "postprocess.sp_bounds.K"),
    ((SP, "postprocess.sp_bounds.b=0.1"), "postprocess.sp_bounds.b"),
    ((SP, "postprocess.sp_bounds.P=[[1]]"), "postprocess.sp_bounds.P"),
    ((SP, "postprocess=nonexistent"), "postprocess"),
    ((OSC, "postprocess.oscillation.window=-1"), "postprocess.oscillation.window"),
    ((OSC, "postprocess.oscillation.window=100"), "postprocess.oscillation.window"),
    ((OSC, "postprocess.notch.period=0"), "postprocess.notch.period"),
    ((OSC, "postprocess.notch.w0=-1"), "postprocess.notch.w0"),
    ((OSC, "postprocess.notch.phi2=0"), "postprocess.notch"),
    ((OSC, "postprocess.notch.method=tustin"), "postprocess.notch.method"),
    ((OSC, "postprocess.notch.init=bad"), "postprocess.notch.init"),
    ((AK, "postprocess.ak.transient=-1"), "postprocess.ak"),
    ((AK, "postprocess.ak.late_window=0"), "postprocess.ak"),
    ((AK, "postprocess.ak.late_window=10", "metrics.window=1"), "postprocess.ak.late_window"),
    ((AK, "postprocess.ak.transient=10"), "postprocess.ak.transient"),
    # --- the papers added later: Andrieu et al., Dimassi et al., Moreno -----------------
    (("experiment=apa_fig2", "plant.hbar=-1"), "plant.hbar"),
    (("experiment=apa_fig2", "plant.eta0=[0.3]"), "plant.eta0"),
    (("experiment=apa_fig2", "observer.omega2.p=nan"), "observer.omega2.p"),
    (("experiment=apa_fig2", "observer.omega1.rate_bound=bogus"), "observer.omega1.rate_bound"),
    (("experiment=dhlm_example", "observer.cascade.eps=0"), "observer.cascade.eps"),
    (("experiment=dhlm_example", "observer.cascade.gamma=[[6.0,-8.0]]"), "observer.cascade"),
    (("experiment=dhlm_example", "observer.cascade.q=[1]"), "observer.cascade"),
    (("experiment=dhlm_example", "plant.I=0"), "plant.I"),
    (("experiment=moreno_fig1", "observer.circle.L=[200.0]"), "observer.circle.L"),
    (("experiment=moreno_fig1", "observer.circle.N=inf"), "observer.circle.N"),
    (("experiment=moreno_fig1", "plant.a=nan"), "plant.a"),
    (("experiment=moreno_fig1", "plant.x0=[0.0]"), "plant.x0"),
    # --- recording, figures, vacuous bounds, launcher -----------------------------------
    ((SP, "recording.mode=bogus"), "recording.mode"),
    ((SP, "recording.max_rows=1"), "recording.max_rows"),
    ((SP, "recording.max_rows=abc"), "recording.max_rows"),
    ((SP, "recording=nonexistent"), "recording"),
    ((SP, "figures.format=jpg"), "figures.format"),
    ((SP, "figures.dpi=0"), "figures.dpi"),
    ((SP, "metrics.vacuous_factor=0.5"), "metrics.vacuous_factor"),
    ((SP, "hydra/launcher=nonexistent"), "hydra.launcher"),
    # --- ensembles ------------------------------------------------------------------
    ((SP, "ensemble.size=-5"), "ensemble.size"),
    ((SP, "ensemble.size=1.5"), "ensemble.size"),
    ((ENS, "ensemble.seed=-1"), "ensemble.seed"),
    ((ENS, "++ensemble.vary={plant.nu9: [0, 1]}"), "plant.nu9"),
    ((ENS, "++ensemble.vary={plant.nu1: [2, 1]}"), "ensemble.vary.plant.nu1"),
    ((ENS, "++ensemble.vary={plant.nu1: [nan, 1]}"), "ensemble.vary.plant.nu1"),
    ((ENS, "++ensemble.vary={plant.nu1: abc}"), "ensemble.vary.plant.nu1"),
    ((ENS, "++ensemble.vary={plant.nu1: [1, 2, 3]}"), "ensemble.vary.plant.nu1"),
    ((ENS, f"{SI}.b=0.7"), f"{SI}.b"),
    ((ENS, "plant._target_=os.system"), "plant._target_"),
    ((ENS, "solver.h_max=1e-12"), "solver.max_steps"),
]


def _case_id(case: tuple[tuple[str, ...], str]) -> str:
    return " ".join(o.removeprefix("experiment=") for o in case[0])


def _error(overrides: tuple[str, ...]) -> BaseException | None:
    try:
        check_config(compose(list(overrides)))
    except Exception as err:  # composition, schema or check: all must be reported
        return err
    return None


def test_corpus_is_large_and_covers_every_config_group():
    """>= 120 cases; every config group and the top-level keys have bad cases."""
    assert len(CORPUS) >= 120
    keys = {expected.split(".")[0] for _, expected in CORPUS}
    groups = {p.name for p in (Path(__file__).parents[1] / "conf").iterdir() if p.is_dir()}
    missing = groups - {"experiment"} - keys
    assert not missing, f"no bad-input case for config groups {missing}"
    assert {"seed", "run_name", "metrics"} <= keys


@pytest.mark.parametrize("case", CORPUS, ids=_case_id)
def test_bad_input_is_one_line_naming_the_key(case):
    overrides, expected = case
    err = _error(overrides)
    assert err is not None, f"silently accepted: {overrides}"
    line = one_line(err)
    assert "\n" not in line and line.strip() == line and line
    assert expected in line, f"{overrides}: {line!r} does not name {expected!r}"
    assert "Traceback" not in line


@pytest.mark.parametrize("overrides", [
    (SP, f"{SI}.M=[[1,0],[3,4]]"),  # ints where floats are expected (lower triangular)
    (SP, "plant.x0=[1,0]"),
    (SP, "solver.h_max=inf"),  # inf means "no cap" here
    (AK, "controller.u_max=inf"),
    (SP, "noise=gaussian", "noise.std=0.01"),
    (ENS, "ensemble.size=3"),
])
def test_good_values_are_accepted(overrides):
    """Ints wherever floats are accepted, and +inf where the key means "no limit"."""
    assert _error(overrides) is None, one_line(_error(overrides))


def test_config_error_reads_key_problem_allowed():
    assert str(ConfigError("solver.rtol", "must be < 1, got 2", "(0, 1)")) == \
        "solver.rtol: must be < 1, got 2 (allowed: (0, 1))"


def test_malformed_user_yaml_is_one_line_with_file_and_line(tmp_path):
    """A YAML syntax error in a user's config file names the file and line."""
    (tmp_path / "plant").mkdir()
    (tmp_path / "plant" / "mine.yaml").write_text("_target_: hgo.plants.sp_linear.x\nnu1: [1,\n")
    err = _error((SP, f"hydra.searchpath=[file://{tmp_path}]", "plant=mine"))
    line = one_line(err)
    assert "mine.yaml" in line and "YAML syntax error" in line and "\n" not in line


def test_os_system_target_is_never_called(tmp_path):
    """A user's plant config with ``_target_: os.system`` is refused on the single-run path
    (Hydra's instantiate) and on the ensemble path (the members' fast construction)."""
    marker = tmp_path / "pwned"
    (tmp_path / "plant").mkdir()
    (tmp_path / "plant" / "evil.yaml").write_text(
        f"_target_: os.system\ncommand: touch {marker}\nnu1: 1.0\n")
    for base in (SP, ENS):
        err = _error((base, f"hydra.searchpath=[file://{tmp_path}]", "plant=evil"))
        assert err is not None and "os.system" in one_line(err), one_line(err)
    assert not marker.exists()


def _run_cli(args: list[str], cwd: Path) -> subprocess.CompletedProcess:
    root = Path(__file__).parents[1]
    env = {**os.environ, "PYTHONPATH": str(root)}
    env.pop("HYDRA_FULL_ERROR", None)
    return subprocess.run([sys.executable, str(root / "experiments" / "run.py"), *args],
                          cwd=cwd, env=env, capture_output=True, text=True, timeout=120)


@pytest.mark.parametrize("args, key", [
    (["experiment=sp_fig1", "plant.nu1=abc"], "plant.nu1"),  # schema (compose time)
    (["experiment=ak_fig1", "solver.stability_safety=0"], "solver.stability_safety"),
    (["experiment=sp_fig1", "noise=uniform", "noise.amplitude=nan"], "noise.amplitude"),
])
def test_cli_prints_one_line_exit_2_no_run_dir(tmp_path, args, key):
    """The real entry point: one ``error:`` line on stderr, exit 2, nothing in outputs/."""
    proc = _run_cli([*args, f"hydra.run.dir={tmp_path}/out/run"], tmp_path)
    lines = [ln for ln in proc.stderr.splitlines() if ln.strip()]
    assert proc.returncode == 2, proc.stderr
    assert len(lines) == 1 and lines[0].startswith("error: ") and key in lines[0], lines
    assert not (tmp_path / "out").exists() or not any((tmp_path / "out").rglob("*"))
