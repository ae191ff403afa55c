"""Memory of long runs (issue 27: a 1e7-sample run with its figure within 2 GB): the run's
series hold no copy of its length, the recording is not held whole by the writing process,
and the figure process receives a view whose size does not grow with the run."""

from __future__ import annotations

import pickle
import sys
from pathlib import Path

import numpy as np
import pytest

import hgo.outputs.decimate as decimate
import hgo.outputs.recording as recording
from hgo.core.config import compose
from hgo.outputs.recording import Derived, Difference, Series, materialized


def _simulated(tmp_path, t_end: float):
    from hgo.running.runner import simulate_config

    cfg = compose(["experiment=sp_fig1", f"solver.t_end={t_end}", "metrics.window=1"],
                  tmp_path)
    return simulate_config(cfg)


def test_signals_hold_no_copy_of_the_run(tmp_path):
    """Every series of a run is a view of its trajectory or a Difference of two views
    (the errors x^ - x, equal to their arrays): a 1e7-sample run held 480 MB of copies."""
    from hgo.running.runner import signals

    mem = _simulated(tmp_path, 5)
    traj = mem.trajectory
    record = [traj.z, traj.d, traj.y, traj.m, traj.u, traj.xh]
    for s in signals(mem.experiment.system, traj):
        parts = [s.values.a, s.values.b] if isinstance(s.values, Difference) else [s.values]
        for part in parts:
            assert any(np.shares_memory(part, r) for r in record), s.entity
    errors = {s.entity: s.values for s in signals(mem.experiment.system, traj)
              if s.entity.startswith("/error/")}
    assert len(errors) == 2
    for obs, (xa, xb) in zip(mem.experiment.system.observers,
                                    mem.experiment.system.xh_slices, strict=True):
        expected = traj.xh[:, xa:xb] - traj.z[:, obs.estimated_states]
        np.testing.assert_array_equal(np.asarray(errors[f"/error/{obs.name}"]),
                                      expected)


def test_difference_reads_like_the_array_it_stands_for():
    """Rows, columns, fancy rows, reductions and a pickle round trip of a Difference give
    what the same indexing of ``a - b[:, columns]`` gives (non-consecutive columns)."""
    rng = np.random.default_rng(3)
    a, b = rng.standard_normal((50, 2)), rng.standard_normal((50, 4))
    lazy, full = Difference(a, b, (3, 1)), a - b[:, [3, 1]]
    assert lazy.shape == full.shape and len(lazy) == 50 and lazy.ndim == 2
    for key in (slice(None), slice(5, 17), 7, -1, np.array([0, 9, 49]), (slice(None), 1),
                (slice(2, 8), slice(0, 1)), (4, 0), (np.array([1, 2]), 1), ...,
                (..., 0)):
        np.testing.assert_array_equal(lazy[key], full[key], err_msg=str(key))
    np.testing.assert_array_equal(lazy.min(axis=0), full.min(axis=0))
    np.testing.assert_array_equal(np.asarray(lazy, dtype=np.float32), full.astype(np.float32))
    np.testing.assert_array_equal(np.asarray(pickle.loads(pickle.dumps(lazy))), full)
    (back,) = materialized([Series("/error/x", ["e1", "e2"], lazy)])
    assert isinstance(back.values, np.ndarray)
    np.testing.assert_array_equal(back.values, full)


def test_derived_reads_like_the_array_it_stands_for():
    """A Derived series (fn of rows of its arrays, here hypot(a, b)) reads like fn of the
    whole arrays: rows, columns, fancy rows, a pickle round trip, materialized."""
    rng = np.random.default_rng(4)
    a, b = rng.standard_normal((50, 2)), rng.standard_normal((50, 2))
    lazy, full = Derived(np.hypot, (a, b), 2), np.hypot(a, b)
    assert lazy.shape == full.shape and len(lazy) == 50
    for key in (slice(None), slice(5, 17), 7, np.array([0, 9, 49]), (slice(2, 8), 1), ...):
        np.testing.assert_array_equal(lazy[key], full[key], err_msg=str(key))
    np.testing.assert_array_equal(np.asarray(pickle.loads(pickle.dumps(lazy))), full)
    (back,) = materialized([Series("/d", ["d1", "d2"], lazy)])
    np.testing.assert_array_equal(back.values, full)


@pytest.mark.parametrize("derived", [False, True])
def test_bucket_min_max_in_passes_equals_one_pass(monkeypatch, derived):
    """Read a few rows at a time (PASS_ROWS = 7, buckets of 1-9 rows, one longer than a
    pass), the min/max of every bucket is that of the whole array; also of a Difference."""
    rng = np.random.default_rng(5)
    a, b = rng.standard_normal((200, 3)), rng.standard_normal((200, 3))
    values = Difference(a, b, (0, 1, 2)) if derived else a - b
    edges = np.concatenate([[0], np.cumsum(rng.integers(1, 10, 30))])
    edges = edges[edges <= 200]
    full = a - b
    lo = np.minimum.reduceat(full[:edges[-1]], edges[:-1])
    hi = np.maximum.reduceat(full[:edges[-1]], edges[:-1])
    monkeypatch.setattr(decimate, "PASS_ROWS", 7)
    got = decimate.bucket_min_max(values, edges)
    np.testing.assert_array_equal(got[0::2], lo)
    np.testing.assert_array_equal(got[1::2], hi)


@pytest.fixture
def writer_growth(tmp_path, monkeypatch):
    """``growth(n, width)``: (MB the writing process grew by over what it shared with its
    parent, MB of scalars written) for a recording of ``n`` rows x ``width`` columns."""
    report = tmp_path / "growth"
    stream = recording._stream_to_file

    def measured(*args):  # runs in the writing process (forked by bounded_write)
        start = _status_kb("VmRSS")
        done = stream(*args)
        report.write_text(str((_status_kb("VmHWM") - start) / 1024))
        return done

    monkeypatch.setattr(recording, "_stream_to_file", measured)
    monkeypatch.delenv("HGO_WRITE_IN_PROCESS", raising=False)
    monkeypatch.delenv("RERUN", raising=False)

    def growth(n: int, width: int) -> tuple[float, float]:
        rng = np.random.default_rng(0)
        series = [Series(f"/s{k}", ["a", "b"], rng.standard_normal((n, 2)))
                  for k in range(width // 2)]
        path = recording.write_recording(tmp_path / f"{n}.rrd", np.arange(n) * 0.01, series,
                                         recording_id="growth")
        assert path.is_file()
        return float(report.read_text()), n * width * 8 / 2**20

    return growth


def _status_kb(key: str) -> int:
    text = Path("/proc/self/status").read_text()
    return int(text.split(f"{key}:")[1].split()[0])


@pytest.mark.skipif(not sys.platform.startswith("linux"),
                    reason="reads /proc/self/status; the writer is forked on Linux")
def test_writing_process_does_not_hold_the_recording(writer_growth):
    """Writing 128 MB of scalars (2^21 rows x 8 columns) instead of 32 MB (2^19 rows) grows
    the writing process by less than a quarter of the 96 MB more, in the best of up to three
    pairs of writes: Rerun's file sink queued every chunk until written, the whole recording
    (measured on a 2-core machine at load ~2.5: 96 -> 223 MB without a flush; 83-87 -> 84 MB
    flushing every 16 MB). One pair is not enough: the growth varies with how the writer
    thread keeps up (idle here: -7 to +7 MB between the two sizes; one CI run: 81 -> 107 MB),
    while a sink holding the recording adds its 96 MB to every pair."""
    pairs = []
    for _ in range(3):
        (small, small_data), (big, big_data) = writer_growth(1 << 19, 8), writer_growth(1 << 21, 8)
        limit = (big_data - small_data) / 4
        pairs.append((small, big))
        if big - small < limit:
            break
    assert min(big - small for small, big in pairs) < limit, \
        "writing process grew by (MB, for 32 MB -> 128 MB of scalars): " + \
        ", ".join(f"{small:.0f} -> {big:.0f}" for small, big in pairs)


def test_figure_view_does_not_grow_with_the_run(tmp_path, monkeypatch):
    """With the thresholds scaled down (50 full-rate samples at each end, 100 buckets), the
    pickled view of a 5,001-sample run is the size of a 501-sample run's (the figure
    process receives what the figures draw), and far under the full result's."""
    import dataclasses

    import hgo.running.figure_worker as fw
    from hgo.running.results import RunResult
    from hgo.running.runner import signals

    monkeypatch.setattr(fw, "FULL_RATE", 50)
    monkeypatch.setattr(fw, "BUCKETS", 100)
    sizes = {}
    for t_end in (5, 50):
        mem = _simulated(tmp_path / str(t_end), t_end)
        series = signals(mem.experiment.system, mem.trajectory) + mem.post.series
        result = RunResult(mem.experiment, mem.trajectory, mem.metrics, Path(tmp_path),
                           series, {})
        view = fw.drawing_view(result)
        assert len(view.trajectory.t) == 300
        assert all(isinstance(s.values, np.ndarray) for s in view.series)
        sizes[t_end] = len(pickle.dumps(view, protocol=pickle.HIGHEST_PROTOCOL))
        full = dataclasses.replace(result, series=materialized(series))
        sizes[f"full {t_end}"] = len(pickle.dumps(full, protocol=pickle.HIGHEST_PROTOCOL))
    assert abs(sizes[50] - sizes[5]) < 0.02 * sizes[5], sizes
    assert sizes[50] < 0.2 * sizes["full 50"], sizes


def test_collection_paused_restores_the_collector_as_it_was():
    """The collector is off inside ``collection_paused`` (an ensemble's members are built
    there) and back as it was after it, also after an exception; it stays off after the
    block when it was off before."""
    import gc

    from hgo.core.memory import collection_paused

    assert gc.isenabled()
    with pytest.raises(RuntimeError), collection_paused():
        assert not gc.isenabled()
        raise RuntimeError
    assert gc.isenabled()
    gc.disable()
    try:
        with collection_paused():
            assert not gc.isenabled()
        assert not gc.isenabled()
    finally:
        gc.enable()
