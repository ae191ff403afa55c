"""Dimassi et al. example: accuracy of the runs behind the figures and claims.

Refinement (DOP853 rtol 1e-10 against 1e-12), independence of the window metrics from the
output grid (dt_out / 10), sensitivity of the driven arm to its initial state (chaos: why
the horizon is 20 s), and what happens beyond it (|q| > S = 150 rad: the saturation clips a
position, implementation notes 6.5).
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from hgo.running.in_memory import run_in_memory

NOMINAL = ("experiment=dhlm_example",)
NO_THEORY = ("postprocess.dhlm.theory=false",)


def _z(*extra: str) -> np.ndarray:
    return run_in_memory(NOMINAL + NO_THEORY + extra).trajectory.z


def test_refinement_rtol_1e10_against_1e12_over_20s():
    """The preset's DOP853 rtol 1e-10 agrees with rtol 1e-12 over [0, 20] s: x, z_h11 and x^1
    within 1e-6, x^2 within 2e-6, z_h12 and theta^ (transient peaks ~170 and ~400) within
    2e-5, at every sample. x^2's largest difference sits at the end of the peaking (t = 0.028 s),
    where the estimate's saturation switches inside a step (a state-dependent kink, not a
    declared break point): its size depends on where the kink falls in the step. Measured
    4.1e-8 (at t = 0.741 s) before the named-parameter port, 1.14e-6 after it (the port changes
    only LLVM's fused multiply-adds; rtol 1e-12 against 1e-13: 6.5e-9 for both)."""
    a, b = _z(), _z("solver.rtol=1e-12", "solver.atol=1e-14")
    diff = np.max(np.abs(a - b), axis=0)
    assert np.all(diff[[0, 1, 2, 4]] < 1e-6), diff  # x1, x2, z_h11, x^1
    assert diff[5] < 2e-6, diff  # x^2
    assert np.all(diff[[3, 6, 7]] < 2e-5), diff  # z_h12, theta^1, theta^2


WINDOW_METRICS = ["max_abs_e1_W", "max_abs_e2_W", "rms_e1_W", "rms_e2_W", "mean_theta_hat1_W",
                  "mean_theta_hat2_W", "rms_rel_theta_err1_W", "rms_rel_theta_err2_W",
                  "max_abs_zerr1_W", "max_abs_zerr2_W", "t_end_peaking", "t_settle_e_0.2",
                  "t_settle_e_0.05", "t_settle_theta2_5pct", "t_settle_theta2_10pct",
                  "frac_W_theta1_within_5pct", "frac_W_theta2_within_1pct", "zh12_peak",
                  "max_V_after_T_eps", "beta_measured"]


def test_metrics_do_not_depend_on_the_output_grid():
    """Dividing dt_out (1 ms) by 10 changes every listed metric by < 1 % (since issue 25 they
    are measured on the steps: identical). t_settle_e_0.05 is "never" (NaN) in both: ||e|| is
    above 0.05 inside the window W (it was 19.86 s, the last re-entry, before issue 25)."""
    def table(*extra):
        m = run_in_memory(NOMINAL + extra).metrics
        return m[m.observer == "cascade"].set_index("quantity")["empirical"]

    a, b = table(), table("solver.dt_out=0.0001")
    never = [q for q in WINDOW_METRICS if math.isnan(b[q])]
    assert never == ["t_settle_e_0.05"] and math.isnan(a["t_settle_e_0.05"]), never
    rel = {q: abs(a[q] - b[q]) / abs(b[q]) for q in WINDOW_METRICS if q not in never}
    assert all(math.isfinite(v) and v < 0.01 for v in rel.values()), rel


def test_arm_is_sensitive_to_its_initial_state_over_20s():
    """q(0) + 1e-9 moves the state at t = 20 s by more than 1e-5 (amplification > 1e4:
    pointwise values of long runs are not reproducible) but by less than 1e-2 (the 20 s
    figures are): the difference is far above the rtol 1e-10 integration error."""
    a, c = _z(), _z("plant.x0=[1.000000001,1.0]")
    d = float(np.max(np.abs(a[-1, :2] - c[-1, :2])))
    assert 1e-5 < d < 1e-2, d


S_LOW = 30.0  # rad: z_h11's saturation level in the test below (the preset's: 150)


@pytest.fixture(scope="module")
def long_run():
    run = run_in_memory(NOMINAL + NO_THEORY + ("solver.t_end=80",
                                               f"observer.cascade.S=[{S_LOW},150.0]"))
    return run.trajectory.t, run.trajectory.z[:, 0], run.trajectory.xh[:, 0]


def test_beyond_the_horizon_saturation_clips_the_position(long_run):
    """Past the paper's horizon the arm rotates past |q| = S (z_h11's level lowered to
    30 rad; first at 21.38 s); from then on z_h11^s is clipped at S and x^1 no longer
    tracks q (|e1| > 1 rad), whereas |e1| < 0.05 rad on [10, 20] s. (With the preset's
    S = 150 rad, whether q reaches it within 80 s is not resolved by the integrator: max |q|
    over 80 s was 84, 266, 114 and 166 rad at rtol 1e-10, 1e-11, 1e-12, 1e-13; the first
    passage of 30 rad is at 21.38 s at each of them.)"""
    t, q, qhat = long_run
    k = np.flatnonzero(np.abs(q) > S_LOW)
    assert k.size and 20.0 < t[k[0]] < 80.0
    e1 = np.abs(qhat - q)
    assert np.max(e1[(t >= 10) & (t <= 20)]) < 0.05
    assert np.max(e1[k[0]:]) > 1.0
