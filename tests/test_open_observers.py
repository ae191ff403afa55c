"""Open observers (issue 24, item 3): the user's phi, psi (cascade, Dimassi et al.), model
(homogeneous observer, Andrieu, Praly & Astolfi) and psi (circle criterion, Moreno)."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hydra.utils import instantiate

from hgo.controllers.sinusoids import sinusoids_controller
from hgo.core.components import Params, Plant
from hgo.engine.simulate import SolverSettings, no_noise, simulate
from hgo.engine.system import System
from hgo.observers.adaptive_cascade import adaptive_cascade
from hgo.observers.circle_criterion import circle_criterion_observer
from hgo.observers.homogeneous_dynamic import homogeneous_dynamic_hgo
from hgo.plants.circle_form import EXAMPLE_SUPPORT, circle_form_plant, moreno_example_plant
from hgo.plants.robot_arm import robot_arm_plant

ARM = dict(A=[[0.0, 1.0], [0.0, 0.0]], B=[[0.0], [1.0]], C=[[1.0, 0.0]])


def arm_psi(x, u, out):
    """The robot arm's regressor written by a user: psi = [u, -sin x1]."""
    out[0, 0] = u[0]
    out[0, 1] = -math.sin(x[0])


def _arm_run(observer, t_end=2.0):
    system = System(robot_arm_plant(), [observer], sinusoids_controller())
    return simulate(system, SolverSettings(t_end=t_end, dt_out=0.01, method="dop853",
                                           rtol=1e-9, atol=1e-11), no_noise(1))


def test_cascade_with_the_users_psi_matches_the_robot_arm_instance():
    """model=null with the user's psi (same function as the instance) gives the run of
    model=robot_arm to 1e-9, and theta^ moves (the regressor is used)."""
    ref = _arm_run(adaptive_cascade("c", **ARM))
    user = _arm_run(adaptive_cascade("c", **ARM, model=None, psi=arm_psi, n_theta=2,
                                     K_phi=0.0, K_psi=1.0))
    assert ref.ok and user.ok
    np.testing.assert_allclose(user.z, ref.z, rtol=1e-9, atol=1e-9)
    assert np.abs(user.z[-1, 5:7]).max() > 0.1  # theta^ left 0


def test_cascade_psi_from_a_target_node():
    """A config node {_target_: module.function, _partial_: true} names the user's psi."""
    node = {"_target_": "hgo.observers.adaptive_cascade.adaptive_cascade", "name": "c",
            **ARM, "model": None, "n_theta": 2, "K_psi": 1.0,
            "psi": {"_target_": "test_open_observers.arm_psi", "_partial_": True}}
    obs = instantiate(node)
    assert obs.p.psi is arm_psi and obs.p.K_psi == 1.0


def test_cascade_refuses_a_model_without_psi():
    with pytest.raises(ValueError, match="psi is required"):
        adaptive_cascade("c", **ARM, model=None, n_theta=2, K_psi=1.0)


def oscillator_f(t, x, u, p, dx):
    """x1' = x2, x2' = -w^2 x1 + u."""
    dx[0] = x[1]
    dx[1] = -p.w * p.w * x[0] + u[0]


def oscillator_h(t, x, p, y):
    y[0] = x[0]


def oscillator_model(y, u, x1, x2, p):
    """The user's model in the form (4): y_s = y, f1 = 0, f2 = -w^2 x1 + u, Omega = w^2
    (the Lipschitz constant of f2 in x1: a constant bound for (8))."""
    return y, 0.0, -p.w * p.w * x1 + u, p.w * p.w


def test_homogeneous_observer_on_the_users_model_converges():
    """Andrieu, Praly & Astolfi (7)-(8) on a harmonic oscillator given as the user's model:
    the estimate converges (error < 1e-6 after 20 s from an error of 1)."""
    plant = Plant(name="osc", state_names=["x1", "x2"], output_names=["y"],
                  input_names=["u"], x0=np.array([1.0, 0.0]), p=Params(w=2.0),
                  f=oscillator_f, h=oscillator_h)
    obs = homogeneous_dynamic_hgo("o", model=oscillator_model, model_params={"w": 2.0},
                                  xhat0=[0.0, 0.0], p=0.2)
    traj = simulate(System(plant, [obs]), SolverSettings(t_end=20.0, dt_out=0.1,
                                                         method="dop853"), no_noise(1))
    assert traj.ok
    err = np.abs(traj.xh - traj.z[:, :2])
    assert err[0].max() >= 1.0 - 1e-12 and err[-1].max() < 1e-6


def _psi_cubic(s, c):
    """The Moreno example's psi(s) = s^3 - 2 s, as a user's function."""
    return s * s * s - 2.0 * s


def test_circle_criterion_with_the_users_psi_matches_the_polynomial():
    """A circle-form plant and observer (3) with psi given as a function run as with psi's
    coefficients (to 1e-7 over Fig. 1's transient, rtol 1e-10)."""
    solver = SolverSettings(t_end=1.0, dt_out=0.01, method="dop853", rtol=1e-10, atol=1e-12)
    runs = []
    for plant in (moreno_example_plant(),
                  circle_form_plant(A=[[-1.0, 1.0], [0.0, 0.0]], G=[1.0, 0.0], C=[1.0, 0.0],
                                    H=[0.0, 1.0], B=[0.0, 1.0], psi=_psi_cubic,
                                    x0=[0.0, 0.0], K1=-2.0)):
        obs = circle_criterion_observer("circle", plant, L=[200.0, 120.0], N=2.0,
                                        e0=[70.0, -50.0])
        runs.append(simulate(System(plant, [obs]), solver, no_noise(1)))
    assert all(r.ok for r in runs)
    np.testing.assert_allclose(runs[1].z, runs[0].z, rtol=1e-7, atol=1e-7)
    assert abs(runs[0].z[0, 2] - runs[0].z[0, 0]) == pytest.approx(70.0)  # started apart


def test_circle_form_support_runs_as_the_dense_plant_and_rejects_values_outside_it():
    """The Section 5 example with its declared support (A[1, 0], G[1], C[1], H[0], B[0]
    compiled out) runs as the same plant built dense (every entry in the kernel), to 1e-12
    relative over 1 s (rtol 1e-10: the same steps); a support that excludes a nonzero entry
    is refused, naming it."""
    solver = SolverSettings(t_end=1.0, dt_out=0.01, method="dop853", rtol=1e-10, atol=1e-12)
    dense = dict(A=[[-1.0, 1.0], [0.0, -0.5]], G=[1.0, 0.0], C=[1.0, 0.0], H=[0.0, 1.0],
                 B=[0.0, 1.0], psi=[0.0, -2.0, 0.0, 1.0], x0=[0.0, 0.0])
    runs = []
    for plant in (moreno_example_plant(a=0.5), circle_form_plant(**dense)):
        obs = circle_criterion_observer("circle", plant, L=[200.0, 120.0], N=2.0,
                                        e0=[70.0, -50.0])
        runs.append(simulate(System(plant, [obs], sinusoids_controller(omega=[1.0],
                                                                        a=[2.0], b=[1.0])),
                             solver, no_noise(1)))
    assert moreno_example_plant().p.spec.constants["A_nz"] == (True, True, False, True)
    assert all(r.ok for r in runs)
    np.testing.assert_allclose(runs[0].z, runs[1].z, rtol=1e-12, atol=1e-12)
    with pytest.raises(ValueError, match=r"plant.G = \[1.0, 0.5\] is nonzero outside"):
        circle_form_plant(**{**dense, "G": [1.0, 0.5]}, support={**EXAMPLE_SUPPORT})
