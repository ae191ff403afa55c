"""Moreno's example: accuracy of the engine through the stiff start, no false bound stop,
and grid independence of the certificate metrics."""

from __future__ import annotations

import numpy as np
import pytest

from hgo.core.config import compose
from hgo.papers.moreno.reference import joint_rhs, plain_rhs, reference_run
from hgo.running.in_memory import run_in_memory
from hgo.running.runner import build, simulate_config

FIG1 = ("experiment=moreno_fig1",)


@pytest.fixture(scope="module")
def radau():
    """Radau (rtol 1e-13, atol 1e-14) of plant + observer (3) + error system (5) on Fig. 1."""
    mem = run_in_memory(FIG1)
    obs = mem.experiment.system.observers[0]
    return reference_run(obs, mem.experiment.system.controller, 0.0, 10.0, 1e-3, "Radau",
                         rtol=1e-13, atol=1e-14)


def test_fig1_run_matches_radau_through_the_stiff_start(radau):
    """The preset's DOP853 (rtol 1e-10) run of Fig. 1 (e0 = (70, -50), z(0) = -190, Jacobian
    ~2e5 at t = 0) agrees with Radau at rtol 1e-13 to 1e-8 on [0, 10] s, including the
    first 10 ms, and the error system (5) integrated beside it equals x - x^ to 1e-8."""
    t, w, _ = radau
    tr = run_in_memory(FIG1).trajectory
    ours = np.hstack([tr.z[:, :2], tr.xh])
    assert np.max(np.abs(ours - w[:, :4])) <= 1e-8
    assert np.max(np.abs(ours[t <= 0.01] - w[t <= 0.01, :4])) <= 1e-8
    assert np.max(np.abs(w[:, 4:6] - (w[:, :2] - w[:, 2:4]))) <= 1e-8


def test_refining_the_tolerance_converges(radau):
    """Refining rtol from 1e-10 to 1e-12 brings the run within 3e-10 of Radau (the
    preset's bound is 1e-8): the engine's error follows its tolerance."""
    _, w, _ = radau
    tr = simulate_config(compose([*FIG1, "solver.rtol=1e-12", "solver.atol=1e-14",
                                  "postprocess=none"])).trajectory
    assert np.max(np.abs(np.hstack([tr.z[:, :2], tr.xh]) - w[:, :4])) <= 3e-10


@pytest.mark.parametrize("scale", [1.0, 10.0])
def test_large_initial_errors_never_stop_on_the_state_bound(scale):
    """e0 = scale * (70, -50) (z(0) = -190 scale): the run finishes (status ok), the largest
    accepted state stays far below solver.state_bound = 1e6 (rejected trial steps are not
    checked against it), and the error reaches 1e-3 after the pulse."""
    mem = simulate_config(compose([*FIG1, f"observer.circle.e0=[{70 * scale},{-50 * scale}]",
                                   "postprocess=none"]))
    tr = mem.trajectory
    assert tr.ok, tr.message
    assert np.max(np.abs(tr.z)) < 1e3 * scale
    assert np.linalg.norm(tr.z[-1, :2] - tr.xh[-1]) < 1e-3


def test_certificate_metrics_do_not_depend_on_the_output_grid():
    """dt_out / 10 (1e-4 s) changes every certificate and norm metric of Fig. 1 by < 1 %
    (relative, or 1e-9 absolute for values near 0)."""
    keys = ("mean_varrho", "eta_end", "eta_tail_slope", "alpha1", "gamma", "int_varrho",
            "max_ratio_ii", "t_norm_below_1e-3", "norm_e_t1", "norm_e_t5", "c_need", "margin_i")

    def rows(dt):
        table = simulate_config(compose([*FIG1, f"solver.dt_out={dt}"])).metrics
        return table.set_index("quantity")["empirical"]

    coarse, fine = rows(1e-3), rows(1e-4)
    for k in keys:
        assert abs(coarse[k] - fine[k]) <= max(0.01 * abs(fine[k]), 1e-9), k


@pytest.mark.parametrize("controller", ["moreno_bad", "moreno_pulse", "moreno_sin5"])
def test_plain_baseline_rhs_equals_the_numpy_one(controller):
    """The benchmark's plain-float right-hand side of [x, x^] is joint_rhs's to round-off
    (a = 0.5, l2 = 20, states and times drawn at random, the pulse's ramp included)."""
    exp = build(compose(["experiment=moreno_pe", "postprocess=none", "plant.a=0.5",
                         "observer.circle.L=[200.0,20.0]", f"controller={controller}"]))
    obs, ctrl = exp.system.observers[0], exp.system.controller
    numpy_rhs = joint_rhs(obs, ctrl, 0.5, with_error=False)
    plain = plain_rhs(obs, ctrl, 0.5)
    rng = np.random.default_rng(1)
    for t, w in zip(rng.uniform(0.0, 10.0, 300), rng.normal(0.0, 50.0, (300, 4)), strict=True):
        expected = numpy_rhs(t, w)
        np.testing.assert_allclose(plain(t, w), expected, rtol=1e-14,
                                   atol=1e-14 * np.max(np.abs(expected)))
