"""Moreno presets end to end: moreno_fig1 and moreno_sector write their files."""

from __future__ import annotations

import numpy as np
import pandas as pd

from hgo.core.config import compose
from hgo.outputs.recording import read_arrays
from hgo.running.runner import run


def test_fig1_preset_writes_figure_recording_and_metrics(tmp_path):
    """moreno_fig1 writes fig1.png, recording.rrd (with e, z, psi^/phi and the certificate
    under /observer/circle/) and metrics.csv with the certificate and bound rows."""
    run(compose(["experiment=moreno_fig1"], tmp_path), tmp_path)
    assert (tmp_path / "fig1.png").stat().st_size > 10_000
    rec = read_arrays(tmp_path / "recording.rrd")
    for entity in ("e", "z", "psi", "certificate"):
        assert f"/observer/circle/{entity}" in rec
    z = rec["/observer/circle/z"][:, 0]
    e = rec["/observer/circle/e"]
    assert np.allclose(z, -2 * e[:, 0] + e[:, 1])  # z = H_N e, H_N = [-k, 1]
    m = pd.read_csv(tmp_path / "metrics.csv").set_index("quantity")
    assert m.loc["max_V_over_bound_12", "holds"]
    assert m.loc["t_norm_below_1e-3", "empirical"] > 5.27  # after the band exit (5.2707 s)


def test_sector_preset_writes_both_methods_side_by_side(tmp_path):
    """moreno_sector writes sector_table.csv: K1^a by SDP, exact SPR and closed form, and
    eps_max by LMI and SPR, agreeing to 1e-6 / 1e-5 on every gain set."""
    run(compose(["experiment=moreno_sector"], tmp_path), tmp_path)
    table = pd.read_csv(tmp_path / "sector_table.csv", index_col=0)
    assert (tmp_path / "sector_table.png").exists()
    sets = table.dropna(subset=["K1a_sdp"])
    assert len(sets) == 7
    assert np.all(np.abs(sets["K1a_sdp"] - sets["K1a_closed"]) <= 1e-6)
    assert np.all(np.abs(sets["K1a_fd"] - sets["K1a_closed"]) <= 1e-9)
    both = sets["eps_max_fd_K1t"]
    assert np.all(np.abs(sets["eps_max_lmi_K1t"] - both) <= 1e-5 * both)
