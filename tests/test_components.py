"""Observer (5)-(7) beyond n = 2, and the noise models."""

from __future__ import annotations

import math

import numpy as np
import pytest

from hgo.core.components import Plant
from hgo.engine.simulate import SolverSettings, no_noise, simulate
from hgo.engine.system import System
from hgo.noise import noise_model
from hgo.observers.triangular import triangular_hgo


def chain_f(t, x, u, p, dx):
    """dx_i/dt = x_{i+1}, dx_n/dt = -sum_j p_j x_j (a chain in the form (3))."""
    n = x.shape[0]
    last = 0.0
    for i in range(n - 1):
        dx[i] = x[i + 1]
    for j in range(n):
        last -= p[j] * x[j]
    dx[n - 1] = last


def chain_h(t, x, p, y):
    y[0] = x[0]


def chain_plant(n: int) -> Plant:
    return Plant(name=f"chain{n}", state_names=[f"x{i + 1}" for i in range(n)],
                 output_names=["y"], input_names=[], x0=np.linspace(1.0, 0.2, n),
                 p=0.2 * _binomial(n)[::-1], f=chain_f, h=chain_h)


def _binomial(n: int) -> np.ndarray:
    """Coefficients of (s + 1)^n after s^n: [C(n,1), ..., C(n,n)]."""
    return np.array([math.comb(n, i + 1) for i in range(n)], float)


@pytest.mark.parametrize("n", [1, 3, 4])
def test_observer_any_n_converges(n):
    """A constant-gain HGO of order n with the exact model (last row of M = -p) converges
    to the plant state. K~ = binomial coefficients: A - K~C has all its eigenvalues at -1,
    so A - K(r)C has them at -r."""
    K = _binomial(n).tolist()
    plant = chain_plant(n)
    M = np.zeros((n, n))
    M[n - 1] = -plant.p
    obs = triangular_hgo("hgo", K=list(K), xhat0=[0.0] * n, r0=2.0, law="constant",
                         M=M.tolist())
    traj = simulate(System(plant, [obs]), SolverSettings(t_end=30.0, dt_out=0.05),
                    no_noise(1))
    assert traj.ok
    err = np.abs(traj.xh[-1] - traj.z[-1, :n])
    assert err.max() < 1e-6, f"n = {n}: final error {err}"
    assert np.abs(traj.xh[0] - traj.z[0, :n]).max() > 0.1  # it did start away


def test_gaussian_noise_is_seeded_held_and_has_its_std():
    model = noise_model("gaussian", std=0.02, period=0.005)
    a, b = model.sample(100.0, 2, seed=4), model.sample(100.0, 2, seed=4)
    np.testing.assert_array_equal(a.samples, b.samples)
    assert a.dt == 0.005 and a.samples.shape == (20001, 2)
    assert a.samples[:, 0].std() == pytest.approx(0.02, rel=0.03)
    assert not a.samples[:, 1].any()  # channel 1 is measured noise-free by default
    assert model.bound == np.inf


@pytest.mark.parametrize("kwargs, words", [
    ({"kind": "pink"}, "noise.kind: 'pink' is not a noise kind"),
    ({"kind": "uniform", "period": 0.0}, "noise.period: must be > 0"),
    ({"kind": "uniform", "amplitude": -1.0}, "must be >= 0"),
])
def test_bad_noise_config_is_named(kwargs, words):
    with pytest.raises(ValueError, match=None) as err:
        noise_model(**kwargs)
    assert words in str(err.value)


def test_noise_of_the_wrong_width_is_refused_before_the_kernel():
    """The kernel indexes noise by the plant's outputs: a mismatch must not reach it."""
    from hgo.engine.simulate import Noise, simulate_ensemble

    plant = chain_plant(2)
    obs = triangular_hgo("hgo", K=[2, 1], xhat0=[0.0, 0.0], law="constant")
    system = System(plant, [obs])
    solver = SolverSettings(t_end=1.0, dt_out=0.1)
    with pytest.raises(ValueError, match=r"noise 0: samples must have shape \(n >= 1, 1\)"):
        simulate(system, solver, Noise(np.zeros((11, 2)), 0.1))
    noises = [Noise(np.zeros((11, 1)), 0.1), Noise(np.zeros((21, 1)), 0.05)]
    params, z0 = np.tile(system.params(), (2, 1)), np.tile(system.z0(), (2, 1))
    with pytest.raises(ValueError, match="sample period 0.05 differs"):
        simulate_ensemble(system, solver, noises, params, z0)
    with pytest.raises(ValueError, match="1 members' noise for 2 parameter rows"):
        simulate_ensemble(system, solver, noises[:1], params, z0)
