"""Theory results cached on disk by their inputs; the theory modules import cvxpy lazily."""

from __future__ import annotations

import subprocess
import sys

import numpy as np

from hgo.core.memo import disk_cached

CALLS: list[tuple] = []


@disk_cached
def _slow_sum(a: np.ndarray, scale: float = 1.0, note=None) -> float:
    CALLS.append((a.tobytes(), scale, note))
    return float(a.sum() * scale)


def test_a_result_is_computed_once_per_distinct_input(tmp_path, monkeypatch):
    monkeypatch.setenv("HGO_CACHE_DIR", str(tmp_path / "kernels"))
    CALLS.clear()
    a = np.arange(6.0).reshape(2, 3)
    assert _slow_sum(a) == _slow_sum(a.copy()) == 15.0
    assert len(CALLS) == 1  # the second call read the disk entry
    assert _slow_sum(a, scale=2.0) == 30.0 and _slow_sum(a.T.copy()) == 15.0
    assert len(CALLS) == 3  # another scale, another shape: computed
    assert len(list((tmp_path / "kernels" / "theory").glob("*.pkl"))) == 3
    _slow_sum(a, note=object())  # an argument it cannot key: computed, not stored
    _slow_sum(a, note=object())
    assert len(CALLS) == 5


def test_importing_the_dimassi_theory_does_not_import_cvxpy():
    code = "import sys, hgo.papers.dimassi.theory; print('cvxpy' in sys.modules)"
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         check=True, timeout=120).stdout.strip()
    assert out == "False"
