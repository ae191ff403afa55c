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


def test_components_are_cached_only_in_a_folder_of_their_compile_options(tmp_path):
    """numba's cache key ignores compile options: a component's entry in numba's own cache,
    written under other options, would be reused by the next kernel. There only the
    helper is; the plant's f and h are in hgo's kernel cache, in the folder named by their
    sources and options (hgo.engine.component_cache), one folder each."""
    (tmp_path / "userplant.py").write_text(PLANT.format(k="1.0"))
    _run(tmp_path)
    cached = {p.name.split("-")[0] for p in (tmp_path / "numba").rglob("userplant.*.nbi")}
    assert cached == {"userplant.rate"}
    components = list((tmp_path / "kernels" / "components").rglob("userplant.*.nbi"))
    assert sorted(p.name.split("-")[0] for p in components) == ["userplant.f", "userplant.h"]
    assert len({p.parent for p in components}) == 2


COMPILE_ONE = textwrap.dedent('''
    import sys, time
    from hgo.engine.codegen import load_kernel
    from hgo.engine.simulate import SolverSettings, no_noise, simulate
    from hgo.engine.system import System
    from hgo.observers.triangular import triangular_hgo
    from hgo.plants.sp_linear import sp_linear_plant

    system = System(sp_linear_plant(), [triangular_hgo("o", K=[2, 2], xhat0=[0, 0])])
    while time.time() < float(sys.argv[1]):  # both processes start the call together
        time.sleep(0.01)
    simulate(system, SolverSettings(t_end=1.0, dt_out=0.5), no_noise(1))
    stats = load_kernel(system, noisy=False).integrate.stats  # (zero noise: that kernel)
    print(sum(stats.cache_misses.values()), sum(stats.cache_hits.values()))
''')


def test_two_processes_needing_one_new_kernel_compile_it_once(tmp_path):
    """Two processes that need the same kernel at the same time, on an empty cache: one
    compiles it (a numba cache miss), the other waits on the entry's lock and loads it
    from numba's cache (a hit)."""
    import time

    env = {**os.environ, "HGO_CACHE_DIR": str(tmp_path / "kernels"),
           "NUMBA_CACHE_DIR": str(tmp_path / "numba")}
    start = str(time.time() + 8.0)  # after both have imported hgo and numba
    procs = [subprocess.Popen([sys.executable, "-c", COMPILE_ONE, start], env=env,
                              stdout=subprocess.PIPE, text=True) for _ in range(2)]
    counts = sorted(tuple(map(int, p.communicate(timeout=600)[0].split())) for p in procs)
    assert counts == [(0, 1), (1, 0)]  # (misses, hits): one compile, one cache load


TRAJECTORY_HASH = textwrap.dedent('''
    import hashlib
    import numpy as np
    from hgo.engine.simulate import SolverSettings, no_noise, simulate
    from hgo.engine.system import System
    from hgo.observers.triangular import triangular_hgo
    from hgo.plants.sp_linear import sp_linear_plant

    obs = triangular_hgo("b", K=[2, 2], xhat0=[3.0, 3.0], r0=1, law="sign_indefinite",
                         p1=4 / 3, p2=1.5, b=0.28, M=[[3, 0], [0, 0]])
    system = System(sp_linear_plant(nu1=3, nu2=0, x0=(0, 0)), [obs])
    tr = simulate(system, SolverSettings(t_end=20.0, dt_out=0.01, method="dop853",
                                         h_max=20.0, rtol=1e-7, atol=1e-9), no_noise(1))
    print(hashlib.sha1(np.ascontiguousarray(tr.z).tobytes() + tr.acc.tobytes()).hexdigest())
''')


def test_a_kernel_loaded_from_the_cache_computes_what_its_compiling_process_did(tmp_path):
    """The same run, bit for bit, in the process that compiled its kernel and in a later
    one that loads it from numba's cache (Sanfelice & Praly (20), DOP853, 20 s). A step
    helper compiled as a function of its own was linked into the kernel and also loaded
    apart: the compiling process ran the separate copy, a loading process the kernel's
    own, optimised in another context (last bits, then the adaptive steps, apart)."""
    env = {**os.environ, "HGO_CACHE_DIR": str(tmp_path / "kernels"),
           "NUMBA_CACHE_DIR": str(tmp_path / "numba")}
    runs = [subprocess.run([sys.executable, "-c", TRAJECTORY_HASH], env=env, check=True,
                           capture_output=True, text=True, timeout=600).stdout.split()[-1]
            for _ in range(2)]
    assert runs[0] == runs[1]
