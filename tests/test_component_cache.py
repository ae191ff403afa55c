"""hgo's components compiled once (issue 41, item 2): a component function is compiled
once per process for all the compositions that call it, and loaded from the on-disk
cache by a later process (:mod:`hgo.engine.component_cache`), except where its compiled
code is not determined by its source (a closure, a function without a source file)."""

from __future__ import annotations

import json
import os
import pickle
import subprocess
import sys
import textwrap
from pathlib import Path

from numba.core import types

from hgo.core import records
from hgo.core.records import record_class
from hgo.engine.codegen import _identity, determined
from hgo.engine.component_cache import stable
from hgo.engine.jit import KernelFunctionType

# A user's plant in a module of their working directory: x1' = x2 + g phi(x1),
# x2' = -x1 with phi a constant of the plant (a module function, or a closure), observed
# by hgo's triangular observer; RK4 (the cheapest integrator to compile).
USER_MODULE = '''
import numpy as np
from hgo.core.components import Params, Plant


def f(t, x, u, p, dx):
    dx[0] = x[1] + p.g * p.phi(x[0])
    dx[1] = -x[0]


def h(t, x, p, y):
    y[0] = x[0]


def cube(s):
    return s * s * s


def scaled(k):
    def phi(s):
        return k * s
    return phi


def plant(phi):
    return Plant(name="user", state_names=["x1", "x2"], output_names=["y"], input_names=[],
                 x0=np.array([1.0, 0.0]), p=Params({"phi": phi}, g=-0.5), f=f, h=h)
'''

RUN = '''
import json, sys
from numba.core import event
from hgo.engine.simulate import SolverSettings, no_noise, simulate
from hgo.engine.system import System
from hgo.observers.triangular import triangular_hgo
import user

observer = triangular_hgo("hgo", K=[2.0, 1.0], xhat0=[0.0, 0.0], r0=2.0, law="constant")
solver = SolverSettings(t_end=2.0, dt_out=0.5, method="rk4", h_max=1e-3)
out = {}
for name, phi in (("cube", user.cube), ("k2", user.scaled(2.0)), ("k3", user.scaled(3.0))):
    rec = event.RecordingListener()
    with event.install_listener("numba:compile", rec):
        traj = simulate(System(user.plant(phi), [observer]), solver, no_noise(1))
    functions = [getattr(ev.data["dispatcher"], "py_func", None)  # a dispatcher's
                 or ev.data["dispatcher"]._pyfunc for _, ev in rec.buffer if ev.is_start]
    compiled = sorted({fn.__qualname__ for fn in functions})
    out[name] = {"z": traj.z.tolist(), "compiled": compiled}
print(json.dumps(out))
'''


def _run(tmp_path: Path, cache: Path) -> dict:
    env = dict(os.environ, HGO_CACHE_DIR=str(cache), PYTHONPATH=str(tmp_path))
    done = subprocess.run([sys.executable, "-c", RUN], cwd=tmp_path, env=env, check=True,
                          capture_output=True, text=True)
    return json.loads(done.stdout.strip().splitlines()[-1])


def test_a_later_process_loads_the_components_it_can(tmp_path) -> None:
    """Three compositions (phi = cube, and closures 2 s and 3 s of one source), each run in
    two fresh processes sharing a kernel cache (the observer's ``estimate``, whose record is
    the same in all three, compiled once in the first process) from which the compositions
    are deleted between them: the second compiles the entry points again but no component
    (the closures' values are part of their cache key), and every trajectory equals the
    first process's bit for bit; the two closures give two trajectories (one process's and
    the other's: not mixed up, which they were before this key, 2026-12-01)."""
    (tmp_path / "user.py").write_text(textwrap.dedent(USER_MODULE))
    cache = tmp_path / "cache"
    first = _run(tmp_path, cache)
    assert {"f", "h", "estimate"} <= set(first["cube"]["compiled"])
    assert "f" in first["k2"]["compiled"] and "f" in first["k3"]["compiled"]
    assert "estimate" not in first["k2"]["compiled"]  # one process: compiled once for all
    for path in cache.rglob("hgo_kernel_*"):
        path.unlink()
    second = _run(tmp_path, cache)
    components = {"f", "h", "estimate", "cube", "scaled.<locals>.phi"}
    for name in ("cube", "k2", "k3"):
        assert second[name]["z"] == first[name]["z"], name
        compiled = set(second[name]["compiled"])
        assert "c_system" in compiled and not compiled & components, (name, compiled)
    assert first["k2"]["z"] != first["k3"]["z"]


def test_a_function_whose_values_pickle_refuses_is_named_for_this_process_only() -> None:
    """A closure over a local function: its name ends in ``@<id>`` (never cached)."""

    def local(s):
        return s

    def phi(s):
        return local(s)

    assert not determined(_identity(phi))
    assert determined(_identity(_identity))


def test_record_classes_are_importable_by_name() -> None:
    """pickle finds a record class again by its name (what numba's cache index needs),
    and the name spells its fields."""
    cls = record_class(("eps", "A", "K2", "n_y"))
    assert pickle.loads(pickle.dumps(cls)) is cls
    assert cls.__name__ == "Record_3eps_1A_2K2_3n_y"
    assert records.Record_1a._fields == ("a",)


def test_only_types_another_process_rebuilds_equal_are_cached() -> None:
    """Numbers, arrays, hgo's records of them and functions named by their source are
    cached; a record of another class, a closure's function, a Python object are not."""
    from collections import namedtuple

    arr = types.float64[::1]
    rec = types.NamedTuple([types.float64, arr, types.int64],
                           record_class(("eps", "L", "n")))
    assert stable((types.float64, arr, rec))
    named = KernelFunctionType("user.cube 0123 []", True)
    closure = KernelFunctionType("user.scaled.<locals>.phi 0123 [] @140", False)
    assert stable((types.NamedTuple([named], record_class(("phi",))),))
    assert not stable((types.NamedTuple([closure], record_class(("phi",))),))
    other = types.NamedTuple([types.float64], namedtuple("Other", ["eps"]))
    assert not stable((other,))
    assert not stable((types.pyobject,))
