"""Regression tests from the core review."""

from __future__ import annotations

from hgo.engine.simulate import no_noise, simulate
from hgo.running.ensemble_runner import run_ensemble
from hgo.running.runner import solver_settings


def test_rk4_ensemble_caps_steps_with_the_stiffest_member(compose, tmp_path):
    """Members with a larger drawn |nu1| than member 0 must not exceed RK4's stability limit:
    each member behaves in the ensemble as it does alone."""
    cfg = compose(["experiment=sp_ensemble", "ensemble.size=4", "solver.t_end=2",
                   "metrics.window=1", "solver.method=rk4", "solver.h_max=0.01",
                   "++ensemble.vary={plant.nu1: [-3000.0, -1.0]}"], tmp_path)
    result = run_ensemble(cfg, tmp_path)
    nu1 = result.draws["plant.nu1"]
    assert abs(nu1[0]) < abs(nu1).max()  # member 0 is not the stiffest
    solver = solver_settings(cfg)
    alone = [simulate(s, solver, no_noise(1)).status for s in result.systems]
    assert alone == [0] * 4
    assert result.status.tolist() == alone
