"""Sanfelice & Praly, complete (issue 3): claims 1-5 on real runs of the presets, the notch
discretisation, the oscillation measurements, the collection (21), the sweep aggregation.

Horizons are shortened for the test budget where the oscillation has settled: Figs. 3-4
use t_end = 40 s with the trailing 20 s as window (the presets: 60 s / 30 s; the
peak-to-peak amplitudes agree to 4 digits in every 20 s block from 20 s to 120 s), Fig. 5
uses 70 s / 20 s (the copies lock their phases within ~40 s with kappa = 0.1).
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
import yaml
from scipy import signal

from hgo.observers.collection import sp_collection
from hgo.observers.triangular import triangular_hgo
from hgo.postprocess.notch import discrete_notch, filter_signal, notch_state_space
from hgo.postprocess.oscillation import spectral_period, zero_crossing_period
from hgo.running.runner import build, run, run_experiment

ROOT = Path(__file__).resolve().parents[1]
OSC_SHORT = ["solver.t_end=40", "metrics.window=20"]
FIG5_SHORT = ["solver.t_end=70", "metrics.window=20"]
P2S = (3.0, 2.0, 1.5)


def _metrics(table: pd.DataFrame) -> dict[tuple[str, str, str], pd.Series]:
    pp = table["postprocess"].fillna("")
    return {(o, p, q): row for (o, p, q), (_, row) in
            zip(zip(table.observer, pp, table.quantity, strict=True), table.iterrows(),
                strict=True)}


def _value(m, observer, quantity, postprocess="") -> float:
    return float(m[(observer, postprocess, quantity)].empirical)


def _run(experiment: str, out: Path, *overrides: str):
    from conftest import compose_config

    cfg = compose_config([f"experiment={experiment}", *overrides], out)
    result = run(cfg, out)
    return result, _metrics(result.metrics)


@pytest.fixture(scope="module")
def runs(tmp_path_factory):
    """One real run of every figure's preset (Fig. 3: the three values of p2)."""
    base = tmp_path_factory.mktemp("sp_runs")
    out = {
        "fig1": _run("sp_fig1", base / "fig1"),
        "fig2": _run("sp_fig2", base / "fig2"),
        "fig4": _run("sp_fig4", base / "fig4", *OSC_SHORT),
        "fig5": _run("sp_fig5", base / "fig5", *FIG5_SHORT),
    }
    for p2 in P2S:
        out[f"fig3_p2={p2:g}"] = _run("sp_fig3", base / f"fig3_{p2:g}", *OSC_SHORT,
                                      f"observer.sign_indefinite.p2={p2}")
    return out


# ------------------------------------------------------------------------ figures exist


@pytest.mark.parametrize("name", ["fig1", "fig2", "fig3_p2=1.5", "fig4", "fig5"])
def test_each_preset_writes_its_figure_recording_and_metrics(runs, name):
    result, _ = runs[name]
    fig = name.split("_")[0]
    for f in (f"{fig}.png", "recording.rrd", "metrics.csv"):
        assert (result.out_dir / f).stat().st_size > 0, f


# ------------------------------------------------------------------------------ claim 1


def test_claim1_fig1_law6_r_decreases_dead_zone_r_constant(runs):
    result, _ = runs["fig1"]
    s = {x.entity: x.values for x in result.series}
    t = result.trajectory.t
    r6 = s["/observer/sign_indefinite/r"][:, 0]
    rdz = s["/observer/dead_zone/r"][:, 0]
    k = int(r6.argmax())
    assert t[k] < 5.0, f"law (6): peak of r at t = {t[k]:.2f} s"
    assert np.diff(r6[k:]).max() <= 1e-12 and r6[-1] < 0.7 * r6[k], (
        f"law (6): r(peak) = {r6[k]:.3f}, r(T) = {r6[-1]:.3f}")
    after = t >= 10.0
    assert np.ptp(rdz[after]) < 1e-9 and rdz[-1] > 3.0, (
        f"dead zone: r varies by {np.ptp(rdz[after]):.2e} after 10 s, r(T) = {rdz[-1]:.3f}")


# ------------------------------------------------------------------------------ claim 2


def test_claim2_fig3_amplitude_decreases_with_p2(runs):
    amp = {p2: (_value(runs[f"fig3_p2={p2:g}"][1], "sign_indefinite", "amplitude_xhat1",
                       "oscillation"),
                _value(runs[f"fig3_p2={p2:g}"][1], "sign_indefinite", "amplitude_xhat2",
                       "oscillation")) for p2 in P2S}
    for k in range(2):
        seq = [amp[p2][k] for p2 in P2S]
        assert seq[0] > seq[1] > seq[2], f"x^{k + 1} peak-to-peak for p2 = 3, 2, 1.5: {seq}"
    # the measured values (p2 = 3, 2, 1.5): x^1 4.80, 4.00, 3.45; x^2 10.2, 8.58, 7.37


def test_fig3_oscillation_is_steady_and_period_near_paper(runs):
    """The window shows a settled oscillation; its period for p2 = 1.5 is the notch's 2.23 s.

    Measured: periods 2.02, 2.15, 2.27 s for p2 = 3, 2, 1.5 (zero crossings and spectrum
    agree to 1e-3 s); the paper's 2.23 s is within 2 % of 2.27 s.
    """
    result, m = runs["fig3_p2=1.5"]
    t = result.trajectory.t
    x1 = result.trajectory.xh[:, 0]
    halves = [np.ptp(x1[(t >= a) & (t < a + 10)]) for a in (20.0, 30.0)]
    assert halves[0] == pytest.approx(halves[1], rel=1e-3)
    period = _value(m, "sign_indefinite", "period_xhat1", "oscillation")
    period_fft = _value(m, "sign_indefinite", "period_fft_xhat1", "oscillation")
    assert period == pytest.approx(period_fft, rel=5e-3)
    assert period == pytest.approx(2.23, rel=0.03), f"measured period {period:.4f} s"
    periods = [_value(runs[f"fig3_p2={p2:g}"][1], "sign_indefinite", "period_xhat1",
                      "oscillation") for p2 in P2S]
    assert periods[0] < periods[1] < periods[2], periods


# ------------------------------------------------------------------------------ claim 3


def test_claim3_fig4_notch_reduces_oscillation_by_a_large_factor(runs):
    """Claim: the notch filter (w0 = 2 pi/2.23, phi1 = 0, phi2 = 1) reduces the oscillation
    of x^1 and x^2 "significantly". Stated factor: at least 8 in peak-to-peak amplitude.
    Measured: 16.0 (x^1: 3.45 -> 0.22) and 10.6 (x^2: 7.37 -> 0.69).
    """
    _, m = runs["fig4"]
    for k in (1, 2):
        before = _value(m, "sign_indefinite", f"amplitude_xhat{k}", "oscillation")
        after = _value(m, "sign_indefinite", f"amplitude_xhat{k}_f", "notch")
        factor = _value(m, "sign_indefinite", f"notch_reduction_xhat{k}", "notch")
        assert factor == pytest.approx(before / after)
        assert factor >= 8.0, f"x^{k}: {before:.3f} -> {after:.3f} (factor {factor:.2f})"


# ------------------------------------------------------------------------------ claim 4


def _fig5_numbers(m) -> dict[str, float]:
    return {
        "single": _value(m, "sign_indefinite", "amplitude_xhat2", "oscillation"),
        "average": _value(m, "collection", "amplitude_xhat2", "oscillation"),
        "notch": _value(m, "sign_indefinite", "amplitude_xhat2_f", "notch"),
        "average+notch": _value(m, "collection", "amplitude_xhat2_f", "notch"),
        "mse_average": _value(m, "collection", "mean_sq_error_x2"),
        "mse_notch": _value(m, "sign_indefinite", "mean_sq_error_x2_f", "notch"),
    }


def test_claim4a_fig5_averaging_reduces_the_oscillation_of_x2(runs):
    """<x^2> of N = 3 copies against one observer's x^2 (same p1, p2): at least 5x smaller
    peak-to-peak. Measured: 7.37 -> 0.76 (factor ~9.6)."""
    result, m = runs["fig5"]
    v = _fig5_numbers(m)
    assert v["average"] < v["single"] / 5, v
    # the copies do oscillate (the average is small because they are out of phase)
    copies = [_value(m, "collection", f"amplitude_copy{i}_xhat2", "oscillation")
              for i in (1, 2, 3)]
    assert min(copies) > 0.8 * v["single"], copies


def test_claim4b_fig5_averaging_substantially_better_than_notch(runs, request):
    """The paper: on x^2 "compared to filtering, the improvement obtained with the averaging
    method is substantial". Read as: <x^2> oscillates at least 2x less than the notch output
    x^2f of the single observer (peak-to-peak over the trailing window). It does not
    reproduce with N = 3, kappa = 0.1 (measured ~0.76 vs ~0.69: the notch is slightly
    better, and its mean-square error of x^2 is smaller, 0.043 vs 0.073); kbar is not given
    in the paper. Why N = 3 is unfavourable here: the oscillation of (20) is half-wave
    symmetric (x^(t + T/2) = -x^(t), only odd harmonics), the copies lock T/N apart, and
    the average keeps only the harmonics that are multiples of N, so N = 3 keeps the 3rd.
    Measured (150 s runs, <x^2> peak-to-peak): N = 2: 0.000, 4: 0.047, 5: 0.15, 7: 0.33."""
    _, m = runs["fig5"]
    v = _fig5_numbers(m)
    request.node.add_marker(pytest.mark.xfail(strict=True, reason=(
        "averaging is not substantially better than the notch on x^2: peak-to-peak "
        f"<x^2> = {v['average']:.3f}, notch x^2f = {v['notch']:.3f}, single x^2 = "
        f"{v['single']:.3f}, average+notch = {v['average+notch']:.3f}; mean (x^2 est)^2: "
        f"average {v['mse_average']:.4f}, notch {v['mse_notch']:.4f} (kappa = 0.1, N = 3)")))
    assert v["average"] < v["notch"] / 2, v


# ------------------------------------------------------------------------------ claim 5


def test_claim5_output_error_mean_below_p2_in_every_run(runs):
    """Theorem 2.2 (11): trailing-window mean (y^ - y)^2 <= p2, every law-(6) observer of
    Figs. 1-5 (for the collection: every copy)."""
    checked = []
    for name, (_result, m) in runs.items():
        for (obs, pp, q), row in m.items():
            if q == "mean_sq_output_error" and pp == "" and obs != "dead_zone" \
                    and obs != "collection" or q.startswith("mean_sq_output_error_copy"):
                assert math.isfinite(row.bound), (name, obs, q)
                assert row.empirical <= row.bound, (name, obs, q, row.empirical, row.bound)
                checked.append((name, obs, q, round(float(row.ratio), 3)))
    assert len(checked) == 10, checked  # figs 1, 2, 4: 1 each; fig 5: 1 + 3 copies; fig 3: 3


# ------------------------------------------------------------------- bounds (8)-(15) rows


def test_sp_bounds_rows_fill_the_table(runs):
    _, m = runs["fig2"]
    row = m[("sign_indefinite", "", "mean_sq_error_x1")]
    assert row.bound == pytest.approx(3.98e5, rel=0.01) and bool(row.holds)
    assert _value(m, "sign_indefinite", "s_star_x1", "sp_bounds") == pytest.approx(1.6053,
                                                                                    rel=1e-3)
    lb = m[("sign_indefinite", "sp_bounds", "p2_lower_bound_13")]
    assert lb.empirical == pytest.approx(7.84e-3, rel=1e-3) and lb.bound == 0.008
    assert bool(lb.holds)
    assert _value(m, "sign_indefinite", "conditions_8_10_min_margin", "sp_bounds") > 0
    assert ("dead_zone", "sp_bounds", "s_star_x1") not in m  # law (4): no bound


# -------------------------------------------------------------------- notch discretisation


def test_notch_foh_is_exact_for_the_output_grid():
    """The FOH discretisation is the continuous filter driven by the linear interpolation of
    the samples (scipy's lsim, which interpolates linearly, to 1e-9), sin(w0 t) sampled every
    0.01 s is removed (phi1 = 0), a smooth signal matches the continuous filter on a 100x
    finer grid to the interpolation error, and a filter for the wrong rate fails."""
    w0, dt = 2 * np.pi / 2.23, 0.01
    filt = discrete_notch(w0, 0.0, 1.0, dt, "foh")
    sys_c = signal.lti([1, 0, w0**2], [1, 2 * w0, w0**2])
    u = lambda s: np.sin(1.3 * s) + 0.5 * np.cos(5.0 * s) + 0.2 * s  # noqa: E731
    td = np.arange(0, 20 + 1e-12, dt)
    _, y_lin, _ = signal.lsim(sys_c, u(td), td)
    yd = filter_signal(u(td)[:, None], filt, "zero")[:, 0]
    np.testing.assert_allclose(yd, y_lin, atol=1e-9)
    tf = np.arange(0, 20 + 1e-12, dt / 100)
    _, y_fine, _ = signal.lsim(sys_c, u(tf), tf)
    np.testing.assert_allclose(yd, y_fine[::100], atol=2e-4)
    # steady init: a constant input passes unchanged (T(0) = 1), no start-up transient
    np.testing.assert_allclose(filter_signal(np.full((50, 2), 3.0), filt), 3.0, atol=1e-12)
    t = np.arange(0, 60, dt)
    y = filter_signal(np.sin(w0 * t)[:, None], filt, "zero")[:, 0]
    assert np.ptp(y[t > 40]) < 2e-3
    wrong = discrete_notch(w0, 0.0, 1.0, 2 * dt, "foh")  # designed for 0.02 s, fed 0.01 s
    y2 = filter_signal(np.sin(w0 * t)[:, None], wrong, "zero")[:, 0]
    assert np.ptp(y2[t > 40]) > 0.3


@pytest.mark.parametrize("w0, phi1, phi2", [(2 * np.pi / 2.23, 0.0, 1.0),
                                             (3.7, 0.15, 0.8), (0.01, 1e-3, 2.5)])
def test_notch_state_space_is_scipys_tf2ss_bit_for_bit(w0, phi1, phi2):
    """hgo writes T(s)'s controller canonical form itself (no scipy.signal import); it equals
    ``scipy.signal.tf2ss`` exactly, for the paper's notch and two other (w0, phi1, phi2)."""
    A, B, C, D = signal.tf2ss([1.0, 2 * phi1 * w0, w0**2], [1.0, 2 * phi2 * w0, w0**2])
    a, b, c, d = notch_state_space(w0, phi1, phi2)
    assert np.array_equal(a, A) and np.array_equal(b, B[:, 0])
    assert np.array_equal(c, C[0]) and d == D[0, 0]


def test_oscillation_measures_on_a_known_signal():
    t = np.arange(0, 30, 0.01)
    v = 1.5 * np.sin(2 * np.pi * t / 2.23 + 0.3) + 0.7
    assert zero_crossing_period(t, v) == pytest.approx(2.23, rel=1e-3)
    assert spectral_period(t, v) == pytest.approx(2.23, rel=5e-3)
    assert math.isnan(zero_crossing_period(t, np.ones_like(t)))


# -------------------------------------------------------------------------- collection (21)


def test_collection_of_one_copy_is_the_single_observer(compose):
    """N = 1: the injection sum is empty, so the copy is exactly the observer (19)."""
    exp = build(compose(["experiment=sp_fig5", "solver.t_end=10", "metrics.window=5",
                         "observer.collection.N=1", "postprocess=none"]))
    traj = run_experiment(exp)
    (sa, sb), (ca, cb) = exp.system.z_slices[1:]
    np.testing.assert_allclose(traj.z[:, ca:cb], traj.z[:, sa:sb], rtol=0, atol=1e-12)


def test_collection_rejects_coinciding_copies_and_bad_options():
    with pytest.raises(ValueError, match="start apart"):
        sp_collection("c", N=3, spread=[0.0, 0.0])
    with pytest.raises(ValueError, match="kbar_scaling"):
        sp_collection("c", kbar_scaling="quadratic")
    with pytest.raises(ValueError, match="N must be"):
        sp_collection("c", N=0)
    obs = sp_collection("c", N=2, xhat0_copies=[[1.0, 0.0], [0.0, 1.0]])
    np.testing.assert_array_equal(obs.z0, [1.0, 0.0, 1.0, 0.0, 1.0, 1.0])
    assert triangular_hgo("s", [2.0, 2.0], [0.0, 0.0]).nz == 3


def test_schema_rejects_a_misspelt_collection_key(compose):
    from hydra.errors import ConfigCompositionException

    with pytest.raises(ConfigCompositionException, match="kapa"):
        compose(["experiment=sp_fig5", "observer.collection.kapa=[0,0]"])


# ------------------------------------------------------------------------- aggregation


def test_aggregate_combines_jobs_and_skips_failed_ones(runs, tmp_path, capsys):
    """A sweep directory with the three Fig. 3 jobs, one crashed job (no metrics.csv) and
    one failed run: one CSV, a Markdown table with the overrides, the comparison figure."""
    import shutil

    from hgo.running.aggregate import aggregate

    sweep = tmp_path / "sweep"
    for k, p2 in enumerate(P2S):
        job = sweep / f"job{k}"
        shutil.copytree(runs[f"fig3_p2={p2:g}"][0].out_dir, job)
        (job / ".hydra").mkdir(exist_ok=True)
        (job / ".hydra" / "overrides.yaml").write_text(yaml.safe_dump(
            ["experiment=sp_fig3", f"observer.sign_indefinite.p2={p2:g}"]))
    crashed = sweep / "job3" / ".hydra"
    crashed.mkdir(parents=True)
    (crashed / "overrides.yaml").write_text(yaml.safe_dump(["observer.sign_indefinite.p2=9"]))
    failed = sweep / "job4"
    shutil.copytree(sweep / "job2", failed)
    table = pd.read_csv(failed / "metrics.csv")
    table["status"] = "failed"
    table.to_csv(failed / "metrics.csv", index=False)
    paths = aggregate(sweep)
    rows = pd.read_csv(paths["csv"])
    assert sorted(set(rows.job)) == ["job0", "job1", "job2", "job4"]
    md = paths["md"].read_text()
    assert "observer.sign_indefinite.p2=1.5" in md and "job3: no metrics.csv" in md
    assert "job4: run failed" in md
    assert paths["png"].stat().st_size > 0
    assert "open together in the Rerun viewer:  hgo view " in capsys.readouterr().out
