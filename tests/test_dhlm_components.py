"""Dimassi et al. components: build-time checks, the kernel against a plain-Python reference."""

from __future__ import annotations

import numpy as np
import pytest

from hgo.observers import adaptive_cascade as ac
from hgo.papers.dimassi.reference import X0, Example
from hgo.running.runner import build, run_experiment

A = [[0.0, 1.0], [0.0, 0.0]]
B = [[0.0], [1.0]]
C = [[1.0, 0.0]]


def test_auxiliary_outputs_of_the_arm_are_the_identity():
    """q_1 = 2 gives H = [C; CA] = I (Dimassi et al. Sec. IV), relative degree 2."""
    H = ac.auxiliary_outputs(np.array(A), np.array(B), np.array(C), [2])
    assert np.array_equal(H, np.eye(2))
    assert ac.relative_degrees(np.array(A), np.array(B), np.array(C)) == [2]


@pytest.mark.parametrize("override, message", [
    ("observer.cascade.q=[1]", "rank(HB) = 0 != rank(B) = 1"),
    ("observer.cascade.q=[3]", "observer.cascade.q[0] must be in [1, r_1=2]"),
    ("observer.cascade.gamma=[[-6.0,8.0]]", "observer.cascade.gamma[0]: s^2 + gamma_1"),
    ("observer.cascade.eps=1.5", "observer.cascade.eps must be in (0, 1)"),
    ("observer.cascade.S=[150.0]", "observer.cascade.S must be 2 levels"),
    ("observer.cascade.psi_at=x", "observer.cascade.psi_at must be one of"),
    ("observer.cascade.sigma=-1", "observer.cascade.sigma must be in [0, inf)"),
    ("observer.cascade.L=[[5.0,0.0]]", "observer.cascade.L must be a 2x2 matrix"),
    ("plant.outputs=z", "plant.outputs must be one of"),
    ("controller.a=[5.0]", "controller.a must have 2 entries"),
])
def test_bad_configuration_raises_one_line_error(compose, override, message):
    """Each bad key raises ValueError naming the full key and the allowed range."""
    with pytest.raises(ValueError) as err:
        build(compose(["experiment=dhlm_example", override]))
    assert message in str(err.value)
    assert "\n" not in str(err.value)


@pytest.mark.parametrize("psi_at", ["y", "xhat"])
def test_kernel_matches_plain_python_reference(compose, psi_at):
    """The composed kernel's trajectory over [0, 2] s equals solve_ivp on the independent
    reference right-hand side (hgo/papers/dimassi/reference.py), both DOP853 at tight
    tolerances: max difference < 1e-6 on every state, including theta^ (peaks ~400)."""
    from scipy.integrate import solve_ivp

    cfg = compose(["experiment=dhlm_example", "solver.t_end=2.0", "solver.dt_out=0.01",
                   f"observer.cascade.psi_at={psi_at}", "postprocess=none", "metrics.window=1.0"])
    exp = build(cfg)
    traj = run_experiment(exp)
    ref = solve_ivp(Example(psi_at=psi_at).rhs, (0.0, 2.0), X0, method="DOP853", rtol=1e-12,
                    atol=1e-12, t_eval=traj.t)
    ours = traj.z[:, :8]  # x, z_h, x^, theta^ (omega^ last, unused)
    scale = np.maximum(1.0, np.abs(ref.y.T).max(axis=0))
    assert np.max(np.abs(ours - ref.y.T) / scale) < 1e-6


def test_ideal_mode_without_the_auxiliary_outputs_stops_at_t0(compose):
    """hgo=ideal reads z = Hx from the plant's outputs; with the paper's plant (y = x1 only)
    the run stops at t = 0 with a non-finite state instead of reading past y."""
    cfg = compose(["experiment=dhlm_example", "observer.cascade.hgo=ideal", "solver.t_end=1.0",
                   "metrics.window=0.5", "postprocess=none"])
    traj = run_experiment(build(cfg))
    assert traj.message == "non-finite state" and traj.t_stop == 0.0
