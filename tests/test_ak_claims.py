"""Ahrens & Khalil (2008) claims 1-4 on real runs through the Hydra path.

Each run is composed from the presets (``compose_config`` + ``hgo.running.runner.build`` /
``run_experiment`` / ``postprocess``), i.e. the configs the commands of the README run,
with shorter horizons where the claim allows. Setup (ak_fig1/ak_fig2): DC motor (38)-(39),
speed controller (r' a smoothed step to 10 rad/s over 1 s, k = 5), H1 = (71/eps1, 70/eps1^2)
with eps1 = 5e-4, H2 = (2/eps2, 1/eps2^2) with eps2 = 0.01, delta = 0.05, encoder noise
+-0.0016 held 0.8 ms, RK4 at half the stability cap (9e-6 s).

Numerics (step convergence, no straddling) are in tests/test_ak_components.py.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from conftest import compose_config
from omegaconf import open_dict

from hgo.papers.ahrens_khalil.postprocess import analyse_tradeoff
from hgo.running.runner import build, postprocess, run_experiment

LOOPS = ("switched", "fixed_eps2", "fixed_eps1")


def _run(overrides: list[str]):
    cfg = compose_config(overrides)
    exp = build(cfg)
    traj = run_experiment(exp)
    assert traj.ok, traj.message
    post = postprocess(cfg, exp, traj)
    rows = {(r["observer"], r["quantity"]): r["empirical"] for r in post.rows}
    return traj, rows


# --- claim 1: one switch with T_d = 0.15, repeated switching with T_d = 0 ----------------


def test_claim1_switches_once_after_entering_zone():
    """ak_fig1 over 0.5 s: exactly one switch, T_d after the error entered the zone."""
    traj, rows = _run(["experiment=ak_fig1", "solver.t_end=0.5", "postprocess.ak.late_window=0.2"])
    sw = lambda q: rows[("switched", q)]  # noqa: E731
    assert sw("n_switches") == 1
    assert sw("t_switch_first") == sw("t_switch_last")
    assert sw("t_enter_first") >= 0 and sw("t_switch_first") > sw("t_enter_first")
    # the timer ran T_d inside the zone, without a reset, and the switch came at the first
    # step boundary after that (substep 5e-5/6 = 8.3e-6 s)
    assert 0.15 <= sw("zone_time_at_first_switch") < 0.15 + 1e-5
    assert sw("t_switch_first") == pytest.approx(sw("t_enter_first") + 0.15, abs=1e-5)
    gain = traj.d[:, 0]
    assert np.all(gain[traj.t > sw("t_switch_first")] == 2)


@pytest.mark.parametrize("safety", [0.9, 0.45, 0.225])
def test_claim1_no_delay_switches_repeatedly(safety):
    """T_d = 0: repeated switching (Ahrens & Khalil Section 4), for every RK4 step.

    Only "more than one switch" is asserted: the count, its parity and the time of the last
    switch are properties of the discretisation, not of the continuous system (the error
    chatters along the zone edge while x^2 recovers from peaking, and each substep can
    cross it). Measured over 0.5 s (dt_out = 5e-5 s, substep 5e-5 s / n): safety 0.9
    (n = 3): 73 switches, last at 0.0031 s; 0.45 (n = 6): 169, last at 0.102 s; 0.225
    (n = 12): 191, last at 0.0029 s. With h = 1e-5 the issue measured 1443 switches, the
    last at 1.49 s: switching need not stop after the peaking.
    """
    _, rows = _run(["experiment=ak_fig1", "solver.t_end=0.5", "observer.switched.T_d=0",
                    f"solver.stability_safety={safety}", "postprocess.ak.late_window=0.2"])
    n = rows[("switched", "n_switches")]
    print(f"T_d = 0, stability_safety = {safety}: {n:g} switches, last at "
          f"{rows[('switched', 't_switch_last')]:.4g} s")
    assert n > 1


# --- claims 2 and 3: the three closed loops of ak_fig2 -------------------------------------


@pytest.fixture(scope="module")
def loops():
    """The three jobs of ``-m experiment=ak_fig2`` (3 s each: e2 of the eps2 loop has
    decayed from its 12 rad/s peak by t = 2 s; late window [2, 3] s)."""
    out = {}
    for name in LOOPS:
        _, rows = _run(["experiment=ak_fig2", f"controller.observer={name}"])
        out[name] = rows
    return out


def test_claim2_transient_like_eps1(loops):
    """Largest |e2| over the first 0.5 s: switched = fixed eps1 << fixed eps2.

    Measured: 1.24 (switched), 1.24 (eps1), 12.3 (eps2) rad/s: the switch comes after the
    peaking, so the transient is that of the eps1 observer."""
    peak = {n: loops[n][(n, "max_abs_e2_transient")] for n in LOOPS}
    print("max |e2| over [0, 0.5] s:", peak)
    assert peak["switched"] == pytest.approx(peak["fixed_eps1"], rel=0.05)
    assert peak["switched"] < 0.25 * peak["fixed_eps2"]


def test_claim3_steady_state_like_eps2(loops):
    """RMS e2 over [2, 3] s: switched ~ fixed eps2 and below fixed eps1.

    Measured: 2.13e-3 (switched), 2.27e-3 (eps2), 3.11e-3 (eps1) rad/s. At eps2 the
    e2 floor is the model-error bias (phi0 has -0.11 x2 for -0.1 x2: x^2 is off by
    ~alpha1 eps2 0.1 x2 / alpha2 = 2e-3); at eps1 the noise dominates. The velocity
    estimate shows the noise attenuation directly: RMS(x^2 - x2) 0.0123 vs 1.28 (over
    every integration step; the 0.8 ms output grid of the noise jumps gave 3.59e-3 and
    0.48, see test_ak_metrics_do_not_depend_on_the_output_grid)."""
    rms = {n: loops[n][(n, "rms_e2_late")] for n in LOOPS}
    est = {n: loops[n][(n, "rms_err_x2_late")] for n in LOOPS}
    print("RMS e2 over [2, 3] s:", rms, "RMS x^2 - x2:", est)
    assert rms["switched"] == pytest.approx(rms["fixed_eps2"], rel=0.1)
    assert rms["switched"] < 0.8 * rms["fixed_eps1"]
    assert est["switched"] == pytest.approx(est["fixed_eps2"], rel=0.05)
    assert est["switched"] < 0.1 * est["fixed_eps1"]


GRID_METRICS = ("max_abs_e2_transient", "rms_e2_late", "max_abs_e2_late",
                "ultimate_bound_err", "rms_err_x2_late")


def test_ak_metrics_do_not_depend_on_the_output_grid(loops):
    """Each AK metric of the fixed-eps1 loop (the noisiest) changes by < 1 % when dt_out
    is divided by 10 (5e-5 -> 5e-6 s). Estimation-error metrics come from the kernel
    (every step); e2 metrics from a grid of 16 samples per noise hold."""
    _, fine = _run(["experiment=ak_fig2", "controller.observer=fixed_eps1",
                    "solver.dt_out=5e-6"])
    coarse = loops["fixed_eps1"]
    changes = {key: abs(fine[key] / coarse[key] - 1) for key in coarse
               if key[1] in GRID_METRICS}
    print("relative change with dt_out / 10:", {k: f"{v:.2e}" for k, v in changes.items()})
    assert len(changes) == 2 + 2 * len(LOOPS) + 1
    assert max(changes.values()) < 0.01


# --- claim 4: the trade-off (25) -----------------------------------------------------------

EPS_GRID = [0.001, 0.0025, 0.0063, 0.016, 0.025, 0.04, 0.063, 0.1, 0.16, 0.25]
MU_GRID = [0.0001, 0.0004, 0.0016, 0.0064]


def _tradeoff(period: float):
    """The ak_tradeoff sweep on a reduced eps grid, one composed config, values swapped."""
    cfg = compose_config(["experiment=ak_tradeoff", f"noise.period={period}"])
    eps, mu, bound = [], [], []
    for m in MU_GRID:
        for e in EPS_GRID:
            with open_dict(cfg):
                cfg.observer.fixed.eps1 = e
                cfg.noise.amplitude = m
            exp = build(cfg)
            traj = run_experiment(exp)
            assert traj.ok, traj.message
            rows = {r["quantity"]: r["empirical"] for r in postprocess(cfg, exp, traj).rows}
            eps.append(e), mu.append(m), bound.append(rows["ultimate_bound_err"])
    return analyse_tradeoff(eps, mu, bound, r=2)


def _describe(a) -> str:
    pf, pg = a.power_fit, a.power_grid
    stars = ", ".join(f"mu={p['mu']:g}: {p['eps_star_fit']:.4g}/{p['eps_star_grid']:.4g}"
                      for p in a.per_mu)
    return (f"exponent of eps* (fit of (25)) = {pf.exponent:.4f} +- {pf.stderr:.4f}, "
            f"(grid minimum) = {pg.exponent:.4f} +- {pg.stderr:.4f}; eps* fit/grid: {stars}; "
            f"global c1 = {a.global_fit.c1:.4g}, c2 = {a.global_fit.c2:.4g}, rms rel. "
            f"residual {a.global_fit.rms_residual:.3g}")


@pytest.fixture(scope="module")
def tradeoff_held():
    return _tradeoff(0.2)


def test_claim4_eps_star_grows_like_mu_to_one_over_r(tradeoff_held):
    """ak_tradeoff (noise held 0.2 s): eps* grows with mu, exponent consistent with 1/2.

    Consistent: within two standard errors of 1/r for the model-free minimiser; the
    per-mu fit of (25) is within 0.05 of 1/r (its standard error is small, and c1 drifts
    with mu by ~20 %: the fit exponent is biased, 0.53 +- 0.005 on the full grid)."""
    a = tradeoff_held
    print(_describe(a))
    assert a.global_fit.rms_residual < 0.1  # (25) describes the measured bounds
    for key in ("eps_star_fit", "eps_star_grid"):
        stars = [p[key] for p in a.per_mu]
        assert np.all(np.isfinite(stars)) and np.all(np.diff(stars) > 0), (key, stars)
    assert abs(a.power_grid.exponent - 0.5) <= 2 * a.power_grid.stderr, _describe(a)
    assert abs(a.power_fit.exponent - 0.5) <= 0.05, _describe(a)


def test_claim4_with_encoder_noise(request):
    """The paper's encoder noise (held 0.8 ms): the minimiser does NOT scale like mu^(1/2).

    For eps >> 0.8 ms the held noise averages out, its effect on x^2 scales like
    eps^-1.5 instead of eps^-(r-1), and eps* ~ mu^(1/(1+1.5)) = mu^0.4."""
    a = _tradeoff(0.0008)
    ok = math.isfinite(a.power_grid.exponent)
    request.node.add_marker(pytest.mark.xfail(strict=True, reason=(
        "(25) is a worst case over |v| <= mu; fast held noise averages out, so the "
        "measured minimiser scales like mu^0.4: " + _describe(a))))
    assert ok and abs(a.power_grid.exponent - 0.5) <= 2 * a.power_grid.stderr


# --- the trade-off report over a sweep with failed jobs ------------------------------------


def test_tradeoff_report_skips_failed_jobs(tmp_path):
    """experiments/ak_tradeoff.py on a sweep where one job failed and one crashed."""
    import subprocess
    import sys
    from pathlib import Path

    import pandas as pd
    import yaml

    from hgo.papers.ahrens_khalil.design import ultimate_bound

    c1, c2 = 0.2, 0.5
    k = 0
    for m in (1e-4, 4e-4, 1.6e-3):
        for e in (0.002, 0.005, 0.01, 0.02, 0.05, 0.1, 0.2):
            job = tmp_path / f"job{k}"
            (job / ".hydra").mkdir(parents=True)
            cfg = {"observer": {"fixed": {"alpha1": [2.0, 1.0], "eps1": e, "eps2": None}},
                   "controller": {"observer": None}, "noise": {"amplitude": m, "period": 0.2}}
            (job / ".hydra" / "config.yaml").write_text(yaml.safe_dump(cfg))
            status = "failed" if k == 3 else "ok"
            if k != 5:  # job5 crashed before writing metrics.csv
                pd.DataFrame([{"observer": "fixed", "quantity": "ultimate_bound_err",
                               "empirical": ultimate_bound(e, m, c1, c2, 2),
                               "status": status, "t_stop": 1.0, "message": status}]
                             ).to_csv(job / "metrics.csv", index=False)
            k += 1
    script = Path(__file__).resolve().parents[1] / "experiments" / "ak_tradeoff.py"
    proc = subprocess.run([sys.executable, str(script), str(tmp_path)], capture_output=True,
                          text=True, check=True)
    assert "skipped job3: run failed" in proc.stderr
    assert "skipped job5: no metrics.csv" in proc.stderr
    md = (tmp_path / "tradeoff.md").read_text()
    assert "job3" in md and "job5" in md and "c1 = 0.2," in md
    fit = pd.read_csv(tmp_path / "tradeoff_fit.csv")
    np.testing.assert_allclose(fit.c1, c1, rtol=1e-6)
    np.testing.assert_allclose(fit.eps_star_fit, np.sqrt(fit.mu * c2 / c1), rtol=1e-6)
    assert len(pd.read_csv(tmp_path / "tradeoff_points.csv")) == 19
    assert (tmp_path / "tradeoff.png").exists()
