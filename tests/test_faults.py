"""Faults: damaged kernel caches, unwritable folders, interrupts, hangs and full disks.

Each test names the fault it injects and what the user gets instead of a crash, a hang
or a file that looks complete.
"""

from __future__ import annotations

import os
import subprocess
import sys
import textwrap
from pathlib import Path

RUN = textwrap.dedent('''
    import warnings
    warnings.simplefilter("always")
    from hgo.engine.simulate import SolverSettings, no_noise, simulate
    from hgo.engine.system import System
    from hgo.observers.triangular import triangular_hgo
    from hgo.plants.sp_linear import sp_linear_plant
    obs = triangular_hgo("o", K=[2, 2], xhat0=[0, 0], law="constant")
    solver = SolverSettings(t_end=1.0, dt_out=0.5, method="rk4")
    tr = simulate(System(sp_linear_plant(), [obs]), solver, no_noise(1))
    print(tr.z[-1, 2])
''')
ROOT = Path(__file__).parents[1]


def _kernel_run(tmp_path: Path, cache: Path) -> subprocess.CompletedProcess:
    env = {**os.environ, "HGO_CACHE_DIR": str(cache), "NUMBA_CACHE_DIR": str(tmp_path / "nb"),
           "PYTHONPATH": str(ROOT)}
    return subprocess.run([sys.executable, "-c", RUN], cwd=tmp_path, env=env, check=True,
                          capture_output=True, text=True, timeout=300)


def test_damaged_kernel_cache_is_rebuilt_with_one_warning(tmp_path):
    """A truncated kernel module and truncated numba cache files (index and data) give one
    warning each run and the same result; the run after the repair is silent."""
    cache = tmp_path / "kernels"
    ref = _kernel_run(tmp_path, cache)
    value = float(ref.stdout.split()[-1])
    (entry,) = cache.glob("hgo_kernel_*.py")
    entry.write_text(entry.read_text()[:200])  # truncated kernel text
    out = _kernel_run(tmp_path, cache)
    assert float(out.stdout.split()[-1]) == value
    assert out.stderr.count("RuntimeWarning") == 1 and "corrupted" in out.stderr
    damaged = list((tmp_path / "nb").rglob("*.nb[ic]"))
    assert damaged
    for path in damaged:  # every numba cache file truncated
        path.write_bytes(path.read_bytes()[:10])
    out = _kernel_run(tmp_path, cache)
    assert float(out.stdout.split()[-1]) == value
    assert out.stderr.count("RuntimeWarning") == 1 and "damaged" in out.stderr, out.stderr
    out = _kernel_run(tmp_path, cache)
    assert float(out.stdout.split()[-1]) == value and "Warning" not in out.stderr


def test_unwritable_kernel_cache_falls_back_to_a_private_folder(tmp_path):
    """HGO_CACHE_DIR below a regular file cannot be created: one warning, same result."""
    blocker = tmp_path / "file"
    blocker.write_text("")
    out = _kernel_run(tmp_path, blocker / "kernels")
    assert out.stderr.count("RuntimeWarning") == 1 and "not writable" in out.stderr
    assert float(out.stdout.split()[-1]) != 0.0
