"""Metrics from the integration, not from the output grid (issue 25, item 4): the paper
post-processors measure on the steps' continuous extensions (hgo.postprocess.dense), so
their rows do not move with solver.dt_out."""

from __future__ import annotations

import math

import numpy as np
import pytest

from hgo.engine.simulate import Trajectory
from hgo.postprocess import dense
from hgo.postprocess.dense import GridRun
from hgo.running.in_memory import run_rows

GRIDS = ("0.0001", "0.001", "0.005")


@pytest.mark.parametrize("experiment", ["apa_fig2", "dhlm_example", "moreno_fig1"])
def test_every_metric_is_the_same_for_three_output_grids(experiment: str) -> None:
    """Every row of the run (APA: windows, t1/ts crossings, peaks, L and rate extrema,
    saturation shares; Dimassi: peaking, settling, window maxima/RMS, theta^ statistics,
    fraction-of-window, transient maxima, theory maxima; Moreno: margin_i, c_need, settling,
    ||e|| at instants, the certificate integrals (12)-(14) and Remark 6: eta(t_f), tail
    slope, I(t_f), alpha1, gamma, max varrho over the last quarter) equal for dt_out = 1e-4,
    1e-3 and 5e-3 s to 1e-9 relative (absolute 1e-12; measured: identical, the Moreno
    certificate to 3e-15 relative, gamma ~ 1e-13 is rounding of a zero)."""
    rows = {dt: run_rows((f"experiment={experiment}", f"solver.dt_out={dt}")) for dt in GRIDS}
    base = rows["0.001"]
    for dt in GRIDS:
        assert rows[dt].keys() == base.keys()
        for key, ref in base.items():
            value = rows[dt][key]
            if isinstance(ref, float) and math.isnan(ref):
                assert math.isnan(value), (dt, key)
                continue
            assert value == pytest.approx(ref, rel=1e-9, abs=1e-12), (dt, key, value, ref)


def _grid_run(t: np.ndarray, v: np.ndarray) -> GridRun:
    """A one-signal trajectory (z[:, 0] = v) joined by straight lines."""
    n = len(t)
    col = v[:, None].astype(float)
    return GridRun(Trajectory(t, col, np.zeros((n, 0)), np.zeros((n, 1)), np.zeros((n, 1)),
                              np.zeros((n, 0)), np.zeros((n, 0)), 0, float(t[-1]),
                              np.zeros(0)))


def _v(s: Trajectory) -> np.ndarray:
    return s.z[:, 0]


def test_crossings_and_shares_are_located_between_the_samples() -> None:
    """On the broken line through (0, 2), (1, 0), (2, 2), (3, 0.5): first time below 1 is
    0.5; settling below 1 is 2 + 2/3 on [0, 3], 0.25 below 1.5 on [0, 1.2], NaN ("never") on
    [0, 2] (above 1 at t = 2: it leaves the band before the end); the share of [0, 3] above
    1 is (0.5 + 0.5 + 2/3) / 3, the maximum 2 at t = 2, the mean over [0, 1] is 1."""
    run = _grid_run(np.array([0.0, 1.0, 2.0, 3.0]), np.array([2.0, 0.0, 2.0, 0.5]))
    assert dense.first_below(run, _v, 1.0, 0.0, 3.0) == pytest.approx(0.5, abs=1e-11)
    assert dense.settles_below(run, _v, 1.0, 0.0, 3.0) == pytest.approx(2 + 2 / 3, abs=1e-11)
    assert dense.settles_below(run, _v, 1.5, 0.0, 1.2) == pytest.approx(0.25, abs=1e-11)
    assert math.isnan(dense.settles_below(run, _v, 1.0, 0.0, 2.0))
    assert dense.settles_below(run, _v, 2.5, 0.0, 3.0) == 0.0
    share = dense.fraction_above(run, _v, 1.0, 0.0, 3.0)
    assert share == pytest.approx((0.5 + 0.5 + 2 / 3) / 3, abs=1e-11)
    peak, when = dense.maximum(run, _v, 0.5, 3.0)
    assert peak == pytest.approx(2.0, abs=1e-9) and when == pytest.approx(2.0, abs=1e-6)
    assert dense.mean(run, _v, 0.0, 1.0) == pytest.approx(1.0, abs=1e-12)


class _JumpRun(GridRun):
    """v = 3 on [0, 0.3), -3 from 0.3 (a jump over the band), scanned as one step [0, 2]."""

    def at(self, ts: np.ndarray) -> Trajectory:
        v = np.where(np.asarray(ts) < 0.3, 3.0, -3.0)
        return _grid_run(np.asarray(ts, float), v).traj

    def boundaries(self, a: float, b: float) -> np.ndarray:
        return np.array([a, b])


def test_first_within_sees_a_zero_crossing_between_scan_points() -> None:
    """On the line from 3 at t = 0 to -7 at t = 1 (then -7), |v| < 0.1 first at t = 0.29:
    the scan points of [0, 1] (its ends and Gauss nodes 0.113, 0.5, 0.887) all have
    |v| >= 1.8, but v changes sign between 0.113 and 0.5; first_below of |v| finds no
    entry (NaN). A jump over the band (no value inside it) is no entry."""
    run = _grid_run(np.array([0.0, 1.0, 2.0]), np.array([3.0, -7.0, -7.0]))
    assert dense.first_within(run, _v, 0.1, 0.0, 2.0) == pytest.approx(0.29, abs=1e-11)
    assert math.isnan(dense.first_below(run, lambda s: np.abs(_v(s)), 0.1, 0.0, 2.0))
    jump = _JumpRun(run.traj)
    assert math.isnan(dense.first_within(jump, _v, 0.1, 0.0, 2.0))
    assert dense.first_within(jump, _v, 4.0, 0.0, 2.0) == 0.0


def test_dimassi_settle_time_is_never_when_the_signal_leaves_the_band_in_the_window() -> None:
    """settle_time: |err| back below the band at 19.86 s after an excursion inside the window
    [10, 20] s is "never" (NaN; before: 19.86 s); an excursion only before the window gives
    the last exit from the band."""
    from hgo.papers.dimassi.postprocess import settle_time

    t = np.array([0.0, 5.0, 15.0, 19.86, 20.0])
    leaves = _grid_run(t, np.array([1.0, 0.01, 0.5, 0.1, 0.01]))
    assert math.isnan(settle_time(leaves, _v, 0.1, 10.0, 20.0))
    settles = _grid_run(t, np.array([1.0, 0.01, 0.05, 0.02, 0.01]))
    assert settle_time(settles, _v, 0.1, 10.0, 20.0) == pytest.approx(
        (1.0 - 0.1) / (1.0 - 0.01) * 5.0, abs=1e-10)


class _Counting:
    """A signal source whose bound method counts its calls."""

    def __init__(self) -> None:
        self.calls = 0

    def v(self, s: Trajectory) -> np.ndarray:
        self.calls += 1
        return np.abs(s.z[:, 0] - 1.0)  # kinks at the crossings of 1: refined pieces


def test_a_bound_method_signal_is_integrated_once_per_window() -> None:
    """std after mean of the same bound method reuses the integral (the signal is not sampled
    again for it) and gives the value computed afresh; a lambda is not remembered."""
    t = np.linspace(0.0, 3.0, 31)
    run = _grid_run(t, 1.0 + np.sin(3 * t))
    fresh = _grid_run(t, 1.0 + np.sin(3 * t))
    src = _Counting()
    m = dense.mean(run, src.v, 0.2, 2.9)
    after_mean = src.calls
    sd = dense.std(run, src.v, 0.2, 2.9)
    m_ref = dense.mean(fresh, lambda s: src.v(s), 0.2, 2.9)
    sd_ref = math.sqrt(dense.mean(fresh, lambda s: (src.v(s) - m_ref) ** 2, 0.2, 2.9))
    assert m == m_ref and sd == sd_ref
    again = src.calls
    dense.mean(run, src.v, 0.2, 2.9)
    assert src.calls == again  # remembered
    dense.mean(run, lambda s: src.v(s), 0.2, 2.9)
    assert src.calls > again  # not remembered
    assert after_mean > 0


def test_a_run_with_its_steps_pickles_after_use_and_evaluates_alike() -> None:
    """A run whose steps were already evaluated (its kernel function loaded) pickles, as the
    figure process needs (``hgo run experiment=apa_fig1`` failed: "Can't pickle local object
    'compiled_first.<locals>.call'"), and the copy gives the same signals."""
    import pickle
    from dataclasses import replace

    from hgo.core.config import compose
    from hgo.engine.simulate import simulate
    from hgo.running.runner import build

    exp = build(compose(["experiment=apa_fig1"]))
    solver = replace(exp.solver, t_end=2.0, window=1.0, dense_steps=True)
    traj = simulate(exp.system, solver, exp.noise.sample(2.0, 1, exp.seed))
    ts = np.linspace(0.0, 2.0, 7)
    before = traj.dense.at(ts)
    after = pickle.loads(pickle.dumps(traj)).dense.at(ts)
    for field in ("z", "y", "xh"):
        np.testing.assert_array_equal(getattr(after, field), getattr(before, field))


class _CountingRun(GridRun):
    """A grid run that counts the instants it is sampled at."""

    samples = 0

    def at(self, ts: np.ndarray) -> Trajectory:
        self.samples += len(np.atleast_1d(ts))
        return super().at(ts)


def test_integral_halves_a_large_signal_no_more_often_than_a_small_one() -> None:
    """The quadrature's halving samples 1e6 * signal (values >= 1) at as many instants as
    the signal itself and gives 1e6 times its integral (1e-12 relative): a piece is accepted
    when its halves agree to QTOL of its integral too, not only to QTOL times its length in
    signal units. With the absolute tolerance alone, a signal that grows over a long run
    (dhlm_example's errors over 2000 s) was halved on nearly every step: 21.6 M samples
    against 0.32 M for 200 s."""
    t = np.linspace(0.0, 3.0, 31)
    counts, values = [], []
    for scale in (1.0, 1e6):
        run = _CountingRun(_grid_run(t, t).traj)
        values.append(dense.integral(run, lambda s, c=scale: c * np.exp(s.z[:, 0]), 0.1, 2.9))
        counts.append(run.samples)
    assert counts[1] == counts[0]
    assert values[1] == pytest.approx(1e6 * values[0], rel=1e-12)
