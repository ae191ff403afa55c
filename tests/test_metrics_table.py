"""Honest metric tables: vacuous bounds, no duplicated rows, no round-off in settings."""

from __future__ import annotations

import math

import pytest

from hgo.outputs.metrics import verdict
from hgo.running.in_memory import run_in_memory


@pytest.mark.parametrize("value, bound, factor, expected", [
    (2.415, 4.595e151, 1e6, "vacuous"), (1e-3, 0.008, 1e6, "✓"), (0.0, 0.008, 1e6, "✓"),
    (0.01, 0.008, 1e6, "✗"), (1.0, math.nan, 1e6, ""), (math.nan, 1.0, 1e6, "✗"),
    (1e-3, 0.5, 1e3, "✓"), (1e-3, 2.0, 1e3, "vacuous"),
])
def test_verdict(value, bound, factor, expected):
    assert verdict(value, bound, factor) == expected


def test_fig4_table_has_no_duplicates_and_marks_vacuous_bounds():
    table = run_in_memory(("experiment=sp_fig4", "solver.t_end=20", "metrics.window=10",
                           "metrics.vacuous_factor=1e3")).metrics
    assert not table.duplicated(subset=["observer", "quantity"]).any()
    row = table[(table.observer == "sign_indefinite") & (table.quantity == "mean_sq_error_x2")]
    assert row.bound.iloc[0] > 1e3 * row.empirical.iloc[0]  # (14) against the measured mean
    assert row.verdict.iloc[0] == "vacuous" and bool(row.holds.iloc[0])
    assert (table.window == 10.0).all()  # not 10.000000000000x: the window is the setting
