"""Andrieu, Praly & Astolfi observer (7)-(8): correction terms, gains, L(0), saturated
estimate, configuration errors, and the end-to-end run of the paper's preset."""

from __future__ import annotations

import math
import re

import numpy as np
import pandas as pd
import pytest

from hgo.controllers.schedule import schedule_input
from hgo.observers.homogeneous_dynamic import (
    correction,
    estimate,
    homogeneous_dynamic_hgo,
    linear_gains,
)
from hgo.plants.contois import invariance_eps, rate_bound, x2_high, x2_low
from hgo.running.runner import run


@pytest.mark.parametrize(("d", "hom", "gains"), [(0.0, True, (2.0, 12.0)),
                                                 (0.0, False, (1.0, 3.0)),
                                                 (0.9, True, (1.0, 3.0))])
def test_linear_part_of_the_correction(d, hom, gains):
    """Near s = 0 the correction is (c1 L, c2 L^2)(x^1 - y): C3 p0 gives (2, 4 ell) = (2, 12),
    C3 unit and p = 0.9 give (1, ell) = (1, 3) (ell = 3); checked on the correction itself."""
    assert tuple(linear_gains(2, d, 3.0, hom)) == gains
    out = np.zeros(2)
    L, s = 2.0, 1e-7
    correction(s, L, math.sqrt(L), d, 3.0, hom, 2, out)  # b = 0.5
    for i in range(2):  # out_i = L^(i+1+b) c_i s = c_i L^(i+1) (x^1 - y), x^1 - y = L^b s
        assert out[i] == pytest.approx(gains[i] * L ** (i + 1) * math.sqrt(L) * s, rel=1e-5)


def test_correction_is_homogeneous_at_infinity_for_any_n():
    """n = 3, d = 0.3: the log-slope of K_i(lam^r1 s) in lam between lam = 1e6 and 1e8 is
    r_i + d, r_i = 1 - d (n - i) (the weights of the bi-limit homogeneity), to 0.02 (the
    linear parts decay relatively as lam^(-d r_1) ~ 1e-2 there; a wrong weight is off by
    >= d = 0.3)."""
    n, d, s = 3, 0.3, 0.7
    r = [1 - d * (n - i) for i in range(1, n + 1)]
    a, b = np.zeros(n), np.zeros(n)
    correction(1e6 ** r[0] * s, 1.0, 1.0, d, 2.0, True, n, a)
    correction(1e8 ** r[0] * s, 1.0, 1.0, d, 2.0, True, n, b)
    for i in range(n):
        assert math.log(b[i] / a[i]) / math.log(100.0) == pytest.approx(r[i] + d, abs=0.02)


def test_estimate_stays_in_M_eta_for_any_state():
    """eta^ = F^{-1} of the saturated x^ is in M_eta (hbar_o = 0.8) for 2000 random x^ in
    [-10, 10]^2, including peaking values far outside M_x (reading C7)."""
    obs = homogeneous_dynamic_hgo("o")
    eps1, eps2 = invariance_eps(0.8, 0.01, 0.7)
    rng = np.random.default_rng(0)
    xh = np.zeros(2)
    for z in rng.uniform(-10, 10, (2000, 2)):
        estimate(0.0, np.array([z[0], z[1], 1.0]), obs.d0, obs.p, xh)
        assert xh[0] >= eps1 - 1e-15 and xh[1] >= eps2 * (1 - 1e-12)
        assert xh.sum() <= 1 + 1e-12


@pytest.mark.parametrize(("key", "value", "message"), [
    ("rate_bound", "omega3", "observer.o.rate_bound: 'omega3' not in"),
    ("p", 1.0, "observer.o.p must be in [0, 1/(n-1))"),
    ("phi1", -1.0, "observer.o.phi1 must be > 0, got -1.0"),
    ("eta_hat0", [0.9, 0.3], "observer.o.eta_hat0 must be 2 entries > 0 with sum <= 1"),
    ("L0", 0.001, "observer.o.L0 must be null (equilibrium of (8)) or >= phi2=0.01"),
    ("u_max", 1.5, "observer.o: need 0 < u_min < u_max < 1"),
])
def test_observer_configuration_errors(key, value, message):
    with pytest.raises(ValueError, match="^" + re.escape(message)):
        homogeneous_dynamic_hgo("o", **{key: value})


def test_schedule_errors_and_values():
    """u(t) right-continuous; wrong lengths / order raise naming the key."""
    ctrl = schedule_input([10, 20, 35], [0.5, 0.02, 0.6, 0.1])
    out = np.zeros(1)
    for t, v in ((0.0, 0.5), (9.999, 0.5), (10.0, 0.02), (19.9, 0.02), (20.0, 0.6),
                 (35.0, 0.1), (50.0, 0.1)):
        ctrl.u(t, None, None, ctrl.p, out)
        assert out[0] == v
    with pytest.raises(ValueError, match="controller.values must have len"):
        schedule_input([10, 20], [0.5])
    with pytest.raises(ValueError, match="controller.times must be > 0 and strictly"):
        schedule_input([20, 10], [1, 2, 3])


@pytest.fixture(scope="module")
def paper_run(tmp_path_factory):
    """apa_fig2 through runner.run (files written), horizon 50."""
    from hgo.core.config import compose

    out = tmp_path_factory.mktemp("apa_fig2")
    return run(compose(["experiment=apa_fig2"], out), out)


def test_apa_fig2_writes_figures_recording_metrics(paper_run):
    """The preset writes fig1.png, fig2.png, recording.rrd and metrics.csv with a row of every
    metric of the issue for each observer."""
    out = paper_run.out_dir
    for name in ("fig1.png", "fig2.png", "recording.rrd", "metrics.csv"):
        assert (out / name).stat().st_size > 1000, name
    table = pd.read_csv(out / "metrics.csv")
    for obs in ("df2max", "omega1", "omega2"):
        q = set(table.loc[table.observer == obs, "quantity"])
        assert {"bias_late", "std_late", "rms_post", "peak_e_x2", "max_L",
                "mean_Omega"} <= q
    entities = {s.entity for s in paper_run.series}
    for obs in ("df2max", "omega1", "omega2"):
        assert {f"/observer/{obs}/xhat", f"/error/{obs}", f"/observer/{obs}/L",
                f"/observer/{obs}/Omega"} <= entities


def test_initial_gains_are_the_equilibrium_of_8(paper_run):
    """L(0) = phi2 + (phi3/phi1) Omega(u(0), y_s(0), x^2s(0)) with y(0) including the first
    noise sample (C6); the df2max observer keeps L = phi2 + (phi3/phi1) df2max (C4)."""
    traj, system = paper_run.trajectory, paper_run.experiment.system
    y0, u0 = traj.y[0, 0], traj.u[0, 0]
    assert traj.m[0, 0] != 0.0
    for obs, (a, _) in zip(system.observers, system.z_slices[1:], strict=True):
        p = obs.p
        L = traj.z[:, a + 2]
        if obs.name == "df2max":
            assert np.all(L == p.phi2 + p.phi3 / p.phi1 * p.df2max)
            continue
        eps1, eps2 = p.eps1, p.eps2
        ys = min(max(y0, eps1), 1 - eps2)
        lo, hi = x2_low(ys, eps2, 0.8), x2_high(ys, 0.8)
        xh = min(max(obs.z0[1], lo), hi)
        q = 0.0 if obs.name == "omega1" else 0.9
        assert L[0] == pytest.approx(p.phi2 + p.phi3 / p.phi1
                                     * rate_bound(u0, ys, xh, lo, hi, 0.8, q), rel=1e-12)


@pytest.mark.parametrize(("preset", "hbar_o", "noise"), [
    ("apa_fig1", 0.8, "gaussian"), ("apa_nominal", 1.0, "none"), ("apa_model", 0.8, "none"),
    ("apa_noise", 1.0, "gaussian"), ("apa_readings", 0.8, "gaussian")])
def test_presets_build_the_scenarios_of_the_notes(preset, hbar_o, noise):
    """Each preset composes and builds: the observers' hbar_o, the noise, and the constants
    computed from hbar_o (eps2 = u_min hbar/(1 - u_min (1 - hbar)), df2max from the search)."""
    from hgo.core.config import compose
    from hgo.plants.contois import df2max
    from hgo.running.runner import build

    exp = build(compose([f"experiment={preset}"]))
    assert exp.noise.kind == noise and exp.system.plant.p[0] == 1.0
    for obs in exp.system.observers:
        assert obs.p.hbar == hbar_o
        assert obs.p.eps2 == pytest.approx(0.01 * hbar_o / (1 - 0.01 * (1 - hbar_o)), rel=1e-14)
        assert obs.p.df2max == df2max(hbar_o, 0.01, 0.7)["df2max"]
