"""Sanfelice & Praly (4) and (6): signs of dr/dt, invariance of r >= 1."""

import numpy as np
import pytest

from hgo.engine.simulate import SolverSettings, simulate
from hgo.engine.system import System
from hgo.noise import noise_model
from hgo.observers.triangular import LAWS, gain_rate, triangular_hgo
from hgo.plants.sp_linear import sp_linear_plant

P1, P2, B = 4 / 3, 0.008, 0.28
SIGN, DEAD = LAWS["sign_indefinite"], LAWS["dead_zone"]


@pytest.mark.parametrize("n", [1, 2, 3, 5])
@pytest.mark.parametrize("r", [1.0, 1.7, 4.0, 30.0])
def test_law6_increases_above_p2_and_decreases_below_threshold(n, r):
    above = np.sqrt(P2) * np.array([1.001, 1.5, 10.0])
    threshold = P2 * (1 - r ** -(2 * n + 1 - 2 * B))  # (6): decrease below this
    below = np.sqrt(threshold) * np.array([0.0, 0.5, 0.999])
    assert all(gain_rate(SIGN, e, r, n, P1, P2, B) > 0 for e in above)
    if r > 1:
        assert all(gain_rate(SIGN, e, r, n, P1, P2, B) < 0 for e in below)


@pytest.mark.parametrize("n", [1, 2, 4])
def test_law6_never_pushes_r_below_one(n):
    # at r = 1, dr/dt = p1 e^2 >= 0 for every e: [1, inf) is forward invariant
    for e in np.linspace(-3, 3, 61):
        assert gain_rate(SIGN, e, 1.0, n, P1, P2, B) >= 0


def test_dead_zone_never_decreases_r():
    for r in (1.0, 2.0, 50.0):
        for e in np.linspace(-1, 1, 41):
            assert gain_rate(DEAD, e, r, 2, P1, P2, B) >= 0


def test_r_stays_above_one_in_a_noisy_run():
    """Large noise makes (y^ - y)^2 cross p2 all the time; r(t) >= 1 must still hold."""
    plant = sp_linear_plant(nu1=0.01, nu2=0.0, x0=(0.0, 0.0))
    obs = triangular_hgo("o", K=[2, 2], xhat0=[0.0, 0.0], r0=1.0, p2=0.008,
                         M=[[0.01, 0], [0, 0]])
    noise = noise_model("uniform", amplitude=0.2, period=0.01).sample(60.0, 1, seed=3)
    traj = simulate(System(plant, [obs]), SolverSettings(t_end=60.0, dt_out=0.01), noise)
    r = traj.z[:, 4]
    assert traj.ok
    assert r.max() > 1.05, "the noise should have excited r"
    assert r.min() >= 1.0 - 1e-9, f"r dipped to {r.min()}"
