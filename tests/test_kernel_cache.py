"""The on-disk kernel cache never serves a kernel built from older component code."""

from __future__ import annotations

import os
import subprocess
import sys
import textwrap
from pathlib import Path

PLANT = textwrap.dedent('''
    import numpy as np
    from hgo.core.components import Plant
    from hgo.engine.jit import kernel_helper

    @kernel_helper
    def rate(x):
        return {k} * x

    def f(t, x, u, p, dx):
        dx[0] = rate(1.0)
        dx[1] = 0.0

    def h(t, x, p, y):
        y[0] = x[0]

    def plant():
        return Plant(name="u", state_names=["x1", "x2"], output_names=["y"], input_names=[],
                     x0=np.zeros(2), p=np.zeros(1), f=f, h=h)
''')

RUN = textwrap.dedent('''
    from userplant import plant
    from hgo.engine.simulate import SolverSettings, no_noise, simulate
    from hgo.engine.system import System
    from hgo.observers.triangular import triangular_hgo

    obs = triangular_hgo("o", K=[2, 2], xhat0=[0, 0], law="constant")
    tr = simulate(System(plant(), [obs]), SolverSettings(t_end=1.0, dt_out=0.5), no_noise(1))
    print(tr.z[-1, 0])
''')


def _run(tmp_path: Path) -> float:
    env = {**os.environ, "HGO_CACHE_DIR": str(tmp_path / "kernels"),
           "NUMBA_CACHE_DIR": str(tmp_path / "numba"), "PYTHONPATH": str(tmp_path)}
    out = subprocess.run([sys.executable, "-c", RUN], cwd=tmp_path, env=env, check=True,
                         capture_output=True, text=True, timeout=300)
    return float(out.stdout.split()[-1])


def test_changed_helper_invalidates_the_cached_kernel(tmp_path):
    """A helper (not the component function itself) changes between two processes."""
    (tmp_path / "userplant.py").write_text(PLANT.format(k="1.0"))
    assert abs(_run(tmp_path) - 1.0) < 1e-12
    (tmp_path / "userplant.py").write_text(PLANT.format(k="2.0"))
    os.utime(tmp_path / "userplant.py", (1e9 + 10, 1e9 + 10))  # a distinct mtime for numba
    assert abs(_run(tmp_path) - 2.0) < 1e-12


def test_components_are_not_cached_apart_from_their_kernel(tmp_path):
    """numba's cache key ignores compile options: a component's own cache entry, written
    under other options, would be reused by the next kernel. Only helpers are cached."""
    (tmp_path / "userplant.py").write_text(PLANT.format(k="1.0"))
    _run(tmp_path)
    cached = {p.name.split("-")[0] for p in (tmp_path / "numba").rglob("userplant.*.nbi")}
    assert cached == {"userplant.rate"}
