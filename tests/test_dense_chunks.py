"""Window metrics measured a chunk of steps at a time (issue 41, item 5: memory per output
sample independent of the horizon): the same numbers, to the bit, as the whole window at
once. ``dense.CHUNK_STEPS`` is forced small so that short runs take the chunked path."""

from __future__ import annotations

import math

import numpy as np
import pytest

from hgo.engine.simulate import Trajectory
from hgo.postprocess import dense
from hgo.postprocess.dense import GridRun

ONE_CHUNK = 10 ** 9


def _kinked_run() -> GridRun:
    """v = |sin 3t| + 0.3 t on 301 samples of [0, 3] (kinks where sin 3t = 0: pieces
    halved by the integrals), z[:, 0] = v."""
    t = np.linspace(0.0, 3.0, 301)
    v = np.abs(np.sin(3 * t)) + 0.3 * t
    n = len(t)
    return GridRun(Trajectory(t, v[:, None], np.zeros((n, 0)), np.zeros((n, 1)),
                              np.zeros((n, 1)), np.zeros((n, 0)), np.zeros((n, 0)), 0,
                              float(t[-1]), np.zeros(0)))


def _v(s: Trajectory) -> np.ndarray:
    return s.z[:, 0]


def _every_metric(run) -> list:
    """Every metric of :mod:`hgo.postprocess.dense` on [0.05, 2.93] (one function call
    each), then the same asked of one Window and measured in one pass."""
    a, b = 0.05, 2.93
    one = [dense.maximum(run, _v, a, b), dense.minimum(run, _v, a, b),
           dense.integral(run, _v, a, b), dense.mean(run, _v, a, b), dense.rms(run, _v, a, b),
           dense.std(run, _v, a, b), dense.settles_below(run, _v, 1.6, a, b),
           dense.first_below(run, _v, 0.5, 0.6, b),
           dense.first_within(run, lambda s: _v(s) - 1.0, 0.01, a, b),
           dense.fraction_above(run, _v, 1.0, a, b)]
    w = dense.Window(run, a, b)
    pending = [w.maximum(_v), w.minimum(_v), w.integral(_v), w.mean(_v), w.rms(_v),
               w.settles_below(_v, 1.6), w.fraction_above(_v, 1.0)]
    return one + [p.value for p in pending]


def _flat(values: list) -> list[float]:
    return [x for v in values for x in (v if isinstance(v, tuple) else (v,))]


def _same(got: list, ref: list) -> None:
    for k, (x, y) in enumerate(zip(_flat(got), _flat(ref), strict=True)):
        assert x == y or (math.isnan(x) and math.isnan(y)), (k, x, y)


@pytest.mark.parametrize("chunk", [1, 7, 64])
def test_every_metric_in_chunks_equals_the_whole_window(monkeypatch, chunk: int) -> None:
    """Maxima and minima with their instants, integrals, means, RMS, std, settling, first
    crossings and shares of a kinked signal over 288 steps, measured ``chunk`` steps at a
    time, equal (bit for bit) those measured over the whole window at once."""
    monkeypatch.setattr(dense, "CHUNK_STEPS", ONE_CHUNK)
    ref = _every_metric(_kinked_run())
    assert not any(math.isnan(x) for x in _flat(ref))
    monkeypatch.setattr(dense, "CHUNK_STEPS", chunk)
    _same(_every_metric(_kinked_run()), ref)


@pytest.fixture(scope="module")
def dhlm():
    """dhlm_example over its 20 s (the kernel other tests use), not post-processed."""
    from hgo.core.config import compose
    from hgo.running.runner import build, run_experiment

    exp = build(compose(["experiment=dhlm_example"]))
    return exp, run_experiment(exp)


def _post(dhlm):
    exp, traj = dhlm
    (post,) = exp.post.values()
    traj.dense.__dict__.pop("_dense_samples", None)  # nothing kept from another pass
    return post.apply(exp.system, traj)


def test_dhlm_rows_in_chunks_equal_one_chunk(monkeypatch, dhlm) -> None:
    """Every row of the Dimassi et al. post-processor (73: peaking, settling, window maxima
    and RMS, theta^ statistics and shares, theory) measured 50 steps at a time equals the
    row measured in one chunk (the whole 20 s run, ~4,000 steps), bit for bit; its series
    computed when read give the same rows read in blocks of 999 as all at once."""
    monkeypatch.setattr(dense, "CHUNK_STEPS", ONE_CHUNK)
    ref = _post(dhlm)
    monkeypatch.setattr(dense, "CHUNK_STEPS", 50)
    got = _post(dhlm)
    assert [(r["quantity"]) for r in got.rows] == [r["quantity"] for r in ref.rows]
    for r, g in zip(ref.rows, got.rows, strict=True):
        _same([g["empirical"]], [r["empirical"]])
        assert (g["bound"] is None) == (r["bound"] is None)
        if r["bound"] is not None:
            _same([g["bound"]], [r["bound"]])
    for s in got.series:
        whole = np.asarray(s.values)
        blocks = np.concatenate([s.values[i:i + 999] for i in range(0, len(whole), 999)])
        np.testing.assert_array_equal(blocks, whole, err_msg=s.entity)
