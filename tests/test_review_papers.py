"""Regression tests for defects found in review of the paper-specific modules."""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np

from hgo.engine.simulate import Noise, SolverSettings, simulate
from hgo.engine.system import System
from hgo.observers.triangular import triangular_hgo
from hgo.papers.sanfelice_praly.postprocess import sp_bounds
from hgo.plants.sp_linear import sp_linear_plant


def test_sp_bounds_keeps_a_lone_gamma_or_L_override():
    """gamma (or L) given alone in the config must not be silently replaced by the plant's."""
    system = SimpleNamespace(plant=sp_linear_plant(nu1=0.01, nu2=0.01))
    gamma, L = sp_bounds(gamma=[0.5, 0.0])._mismatch(system)
    assert np.allclose(gamma, [0.5, 0.0]) and np.allclose(L, [0.01, 0.0])
    gamma, L = sp_bounds(L=[0.2, 0.0])._mismatch(system)
    assert np.allclose(gamma, [0.01, 0.0]) and np.allclose(L, [0.2, 0.0])


def _sp_run(samples: np.ndarray):
    system = System(sp_linear_plant(), [triangular_hgo("o", K=[2, 2], xhat0=[0.0, 0.0])])
    solver = SolverSettings(t_end=4.0, dt_out=0.01)
    return system, simulate(system, solver, Noise(samples, 0.01))


def test_sp_bounds_attaches_14_only_when_the_noise_is_within_M_inf():
    """Theorem 2.2 assumes ||m||_inf <= M_inf: Gaussian noise (or an M_inf below the noise
    applied) must not get a bound of (14) on the mean-error rows."""
    rng = np.random.default_rng(0)
    uniform = rng.uniform(-0.004, 0.004, (402, 1))
    gaussian = rng.normal(0.0, 0.002, (402, 1))
    for samples, bounded in ((uniform, True), (gaussian, False)):
        system, traj = _sp_run(samples)
        out = sp_bounds(M_inf=0.004).apply(system, traj)
        row = next(r for r in out.rows if r["quantity"] == "noise_sup")
        assert row["empirical"] == np.abs(samples[:401]).max()
        assert (row["empirical"] <= row["bound"]) is bounded
        assert (("o", "mean_sq_error_x1") in out.bounds) is bounded
        notes = [r["note"] for r in out.rows if r["quantity"] == "B_io_x1"]
        assert notes == ([] if bounded else ["(14), not attached: the noise exceeds M_inf"])
