"""The dhlm_example preset end to end: figures, recording entities, metrics rows."""

from __future__ import annotations

import numpy as np
import pandas as pd

from hgo.outputs.recording import read_arrays
from hgo.running.runner import run


def test_dhlm_example_writes_figures_recording_and_metrics(compose, tmp_path):
    """experiment=dhlm_example writes fig1-fig5 (+ errors), recording.rrd with the HGO state
    (raw and saturated) and theta^ under /observer/cascade/, and metrics.csv with the LMI
    rows and the D_R row (max V after T(eps) against R^2, within it)."""
    result = run(compose(["experiment=dhlm_example"], tmp_path), tmp_path)
    for name in ("fig1", "fig2", "fig3", "fig4", "fig5", "errors"):
        assert (tmp_path / f"{name}.png").stat().st_size > 10_000
    rec = read_arrays(tmp_path / "recording.rrd")
    raw, sat = rec["/observer/cascade/hgo/raw"], rec["/observer/cascade/hgo/saturated"]
    assert raw.shape == sat.shape == (20001, 2)
    assert np.max(np.abs(raw[:, 1])) > 150.0 and np.max(np.abs(sat)) <= 150.0
    assert rec["/observer/cascade/theta_hat"].shape == (20001, 2)
    assert np.allclose(rec["/observer/cascade/theta_hat"], result.trajectory.z[:, 6:8])
    table = pd.read_csv(tmp_path / "metrics.csv").set_index("quantity")
    for q in ("r_star", "margin10", "lmi28_rho", "lmi28_rho_free", "tau", "K0", "R2"):
        assert np.isfinite(table.loc[q, "empirical"])
    dr = table.loc["max_V_after_T_eps"]
    assert np.isfinite(dr["bound"]) and str(dr["holds"]) == "True"
    assert dr["empirical"] <= dr["bound"]
