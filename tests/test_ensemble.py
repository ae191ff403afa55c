"""Ensembles from the Hydra config: members equal single runs; aggregates are theirs."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest

from hgo.outputs.metrics import window_means
from hgo.running.ensemble import draw_members
from hgo.running.ensemble_runner import run_ensemble
from hgo.running.runner import build, run_experiment

SMALL = ["experiment=sp_ensemble", "ensemble.size=6", "solver.t_end=20", "metrics.window=5"]


def test_members_equal_single_runs(compose, tmp_path):
    """Members 0 and 5 of a 6-member sp_ensemble (20 s): their window metrics equal those of
    the same configs run alone, bit for bit (through metrics.csv), kernels compiled in the
    process or loaded from the cache."""
    cfg = compose(SMALL, tmp_path)
    result = run_ensemble(cfg, tmp_path)
    table = pd.read_csv(tmp_path / "metrics.csv")
    p2 = result.draws["observer.sign_indefinite.p2"]
    xhat0 = result.draws["observer.sign_indefinite.xhat0"]
    assert p2.shape == (6,) and xhat0.shape == (6, 2)
    assert (0.5 <= p2).all() and (p2 <= 3).all() and (np.abs(xhat0) <= 3).all()
    for i in (0, 5):
        single = compose([*SMALL, "ensemble.size=0",
                          f"observer.sign_indefinite.p2={float(p2[i])!r}",
                          "observer.sign_indefinite.xhat0="
                          f"[{float(xhat0[i, 0])!r},{float(xhat0[i, 1])!r}]",
                          f"seed={int(cfg.seed) + i}"])
        exp = build(single)
        expected = window_means(exp.system, run_experiment(exp).acc)
        rows = table[table.member == str(i)].set_index(["observer", "quantity"])
        for key, value in expected.items():
            assert rows.loc[key, "empirical"] == value, (i, key)  # bit for bit
        bound = rows.loc[("sign_indefinite", "mean_sq_output_error"), "bound"]
        assert bound == pytest.approx(p2[i])  # (11) with the member's own p2
    agg = table[table.member == "all"].set_index("quantity")
    members = table[table.member != "all"]
    for quantity, grp in members.groupby("quantity"):
        assert agg.loc[quantity, "empirical"] == pytest.approx(grp.empirical.mean())
        assert agg.loc[quantity, "std"] == pytest.approx(grp.empirical.std(ddof=1))
        assert agg.loc[quantity, "n_ok"] == 6
    assert (tmp_path / "recording.rrd").exists() and (tmp_path / "ensemble.png").exists()


def test_interpolated_key_follows_the_draw(compose, tmp_path):
    """Varying plant.nu1 must also change the observer model M = [[${plant.nu1}, 0], ...]."""
    cfg = compose([*SMALL, "ensemble.size=3", "++ensemble.vary={plant.nu1: [1.0, 2.0]}"],
                  tmp_path)
    result = run_ensemble(cfg, tmp_path)
    nu1 = result.draws["plant.nu1"]
    for system, value in zip(result.systems, nu1, strict=True):
        obs = system.observers[0]
        assert system.plant.p[0] == pytest.approx(value)
        assert obs.p.M[0, 0] == pytest.approx(value)


def test_draws_are_seeded_and_checked():
    a = draw_members({"x": [0, 1], "v": [[0, 1], [5, 6]]}, 4, seed=1)
    b = draw_members({"x": [0, 1], "v": [[0, 1], [5, 6]]}, 4, seed=1)
    np.testing.assert_array_equal(a["v"], b["v"])
    assert a["v"].shape == (4, 2) and (a["v"][:, 1] >= 5).all()
    with pytest.raises(ValueError, match="ensemble.vary.x"):
        draw_members({"x": [1, 2, 3]}, 2, seed=0)
