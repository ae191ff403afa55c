"""A user's component code checked before it is compiled (issue 40, item 3).

Each user function is called once in plain Python on guarded arrays of the kernel's sizes
(:mod:`hgo.engine.dry_call`): an index out of range, an output never written, an array
returned instead of written are one line naming the component, the function, the index and
the names there. Built in memory: nothing here compiles a kernel.
"""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import numba
import numpy as np
import pytest

from hgo.core.components import Controller, Observer, Params, Plant
from hgo.core.errors import ConfigError, UserCodeError, one_line
from hgo.engine import dry_call
from hgo.engine.dry_call import check_user_code
from hgo.engine.system import System
from hgo.observers.normal_form import standard_hgo
from hgo.running.runner import _instantiate

ROOT = Path(__file__).resolve().parents[1]


def h(t, x, p, y):
    y[0] = x[0]


def f(t, x, u, p, dx):
    dx[0] = x[1]
    dx[1] = -p.mu * x[0]


def f_reads_x7(t, x, u, p, dx):
    dx[0] = x[1]
    dx[1] = -x[0] + 0.0 * x[7]


@numba.njit
def f_reads_x7_compiled(t, x, u, p, dx):
    dx[0] = x[7]
    dx[1] = 0.0


@numba.njit
def f_compiled(t, x, u, p, dx):
    dx[0] = x[1]
    dx[1] = -x[0]


def f_writes_dx2(t, x, u, p, dx):
    dx[0] = x[1]
    dx[1] = -x[0]
    dx[2] = 0.0


def f_returns(t, x, u, p, dx):
    return np.array([x[1], -x[0]])


def f_reads_x1_only(t, x, u, p, dx):
    dx[:] = 0.0
    dx[0] = -x[0]


def f_divides_by_x2(t, x, u, p, dx):  # x2(0) = 0: ZeroDivisionError in plain Python
    dx[0] = 1.0 / x[1]
    dx[1] = 0.0


def f_positional(t, x, u, p, dx):
    dx[0] = p[3]
    dx[1] = 0.0


def h_two_outputs_one_written(t, x, p, y):
    y[0] = x[0]


def plant(fn=f, hn=h, outputs=("y",), p=None) -> Plant:
    return Plant(name="vdp", state_names=["x1", "x2"], output_names=list(outputs),
                 input_names=["u"], x0=np.array([2.0, 0.0]),
                 p=Params(mu=1.0) if p is None else p, f=fn, h=hn)


def obs_f(t, z, d, y, u, p, dz):
    dz[0] = z[1] + p.L * (y[0] - z[0])
    dz[1] = 0.0


def obs_f_reads_y1(t, z, d, y, u, p, dz):
    dz[0] = z[1] + p.L * (y[1] - z[0])
    dz[1] = 0.0


def obs_estimate(t, z, d, p, xhat):
    xhat[0] = z[0]
    xhat[1] = z[1]


def observer(fn=obs_f) -> Observer:
    return Observer(name="mine", state_names=["z1", "z2"], disc_names=[],
                    estimated_states=[0, 1], z0=np.zeros(2), d0=np.zeros(0),
                    p=Params(L=2.0), f=fn, estimate=obs_estimate)


def u_leaves_u0(t, xhat, y, p, u):
    return


def phi0_reads_x5(x, u, p):
    return x[5]


def phi0_ok(x, u, p):
    return -x[0]


@pytest.fixture(autouse=True)
def fresh_check():
    """Every test checks its layouts anew (the module caches the ones it passed)."""
    dry_call._CHECKED.clear()


def at(fn, offset: int = 0) -> str:
    """``(file:line)`` of ``fn``'s definition plus ``offset`` lines."""
    code = getattr(fn, "py_func", fn).__code__
    return f"({Path(code.co_filename).name}:{code.co_firstlineno + offset})"


CASES = [
    (lambda: System(plant(f_reads_x7), [observer()]),
     f"plant.f reads x[7]; vdp has 2 states (x1, x2) {at(f_reads_x7, 2)}"),
    (lambda: System(plant(f_reads_x7_compiled), [observer()]),
     f"plant.f reads x[7]; vdp has 2 states (x1, x2) {at(f_reads_x7_compiled, 2)}"),
    (lambda: System(plant(f_writes_dx2), [observer()]),
     f"plant.f writes dx[2]; vdp has 2 states (x1, x2) {at(f_writes_dx2, 3)}"),
    (lambda: System(plant(f_returns), [observer()]),
     "plant.f returns ndarray instead of writing dx in place (dx[0], dx[1] never written); "
     f"vdp has 2 states (x1, x2) {at(f_returns)}"),
    (lambda: System(plant(f, h_two_outputs_one_written, ("y1", "y2")), [observer()]),
     f"plant.h never writes y[1]; vdp has 2 outputs (y1, y2) {at(h_two_outputs_one_written)}"),
    (lambda: System(plant(f_positional, p=np.array([1.0, 2.0])), [observer()]),
     f"plant.f reads p[3]; vdp has 2 parameters {at(f_positional, 1)}"),
    (lambda: System(plant(), [observer(obs_f_reads_y1)]),
     f"observer.mine.f reads y[1]; vdp has 1 output (y) {at(obs_f_reads_y1, 1)}"),
    (lambda: System(plant(), [standard_hgo(name="std", n=2, eps=0.1, phi0=phi0_reads_x5)]),
     f"observer.std.f reads z[5]; observer std has 2 states (xhat1, xhat2) "
     f"{at(phi0_reads_x5, 1)}"),
    (lambda: System(plant(), [observer()], Controller(name="c", p=np.zeros(0),
                                                      u=u_leaves_u0)),
     f"controller.u never writes u[0]; vdp has 1 input (u) {at(u_leaves_u0)}"),
]


@pytest.mark.parametrize(("system", "line"), CASES)
def test_a_wrong_index_or_output_is_one_line_naming_it(system, line):
    with pytest.raises(UserCodeError) as err:
        check_user_code(system())
    assert one_line(err.value) == line


@pytest.mark.parametrize("fn", [f, f_compiled, f_reads_x1_only, f_divides_by_x2])
def test_legitimate_functions_pass(fn):
    """Reading only some states, a numba dispatcher (its py_func is called), a function
    that raises at the initial state in plain Python (left to the run): no finding."""
    check_user_code(System(plant(fn), [observer()]))
    check_user_code(System(plant(), [standard_hgo(name="std", n=2, eps=0.1, phi0=phi0_ok)]))


def f_interrupted(t, x, u, p, dx):  # (as Ctrl-C in a function that never returns)
    raise KeyboardInterrupt


def test_ctrl_c_in_the_call_names_the_function():
    with pytest.raises(KeyboardInterrupt, match=r"^interrupted \(Ctrl-C\) while plant\.f was "
                       "called once in plain Python"):
        check_user_code(System(plant(f_interrupted), [observer()]))


def test_hgo_components_are_not_called(monkeypatch):
    """A system of hgo's own functions only is not dry-called (no cost per run)."""
    from hgo.plants.sp_linear import sp_linear_plant

    monkeypatch.setattr(dry_call, "_signals", lambda *a: pytest.fail("called"))
    check_user_code(System(sp_linear_plant(), [standard_hgo(name="s", n=2, eps=0.1)]))


# ------------------------------------------------------------------ factories, x0


def make_vdp(mu: float = 1.0, x0=(2.0, 0.0)) -> Plant:
    return Plant(name="vdp", state_names=["x1", "x2"], output_names=["y"], input_names=[],
                 x0=np.asarray(x0, float), p=Params(mu=mu), f=f, h=h)


def make_observer(name: str, z0=(0.0, 0.0)) -> Observer:
    obs = observer()
    obs.name, obs.z0 = name, np.asarray(z0, float)
    return obs


def divides(mu: float = 0.0) -> Plant:
    return 1.0 / mu  # type: ignore[return-value]


def test_x0_longer_than_the_states_names_its_key():
    node = {"_target_": f"{__name__}.make_vdp", "x0": [1.0, 2.0, 3.0]}
    with pytest.raises(ConfigError) as err:
        _instantiate(node, "plant", Plant)
    assert one_line(err.value) == ("plant.x0: has shape (3,) (3 entries); vdp has 2 states "
                                   "(x1, x2) (allowed: 2 numbers)")


def test_z0_shorter_than_the_states_names_its_key():
    node = {"_target_": f"{__name__}.make_observer", "z0": [1.0]}
    with pytest.raises(ConfigError, match=r"^observer\.o\.z0: has shape \(1,\) \(1 entries\); "
                       r"o has 2 states \(z1, z2\)"):
        _instantiate(node, "observer.o", Observer, name="o")


def test_a_factory_exception_names_target_type_and_line():
    node = {"_target_": f"{__name__}.divides", "mu": 0.0}
    with pytest.raises(UserCodeError) as err:
        _instantiate(node, "plant", Plant)
    line = divides.__code__.co_firstlineno + 1
    assert one_line(err.value) == (f"plant._target_ {__name__}.divides: ZeroDivisionError: "
                                   f"float division by zero (test_user_functions.py:{line})")


def test_a_syntax_error_in_a_user_module_names_its_file_and_line(tmp_path, monkeypatch):
    (tmp_path / "broken_plant.py").write_text("def make():\n    return (\n")
    monkeypatch.chdir(tmp_path)
    monkeypatch.syspath_prepend(str(tmp_path))
    node = {"_target_": "broken_plant.make"}
    with pytest.raises(ConfigError) as err:
        _instantiate(node, "plant", Plant)
    assert one_line(err.value).startswith("plant._target_ broken_plant.make: SyntaxError: ")
    assert one_line(err.value).endswith("(broken_plant.py:2)")


def test_a_yaml_py_in_the_working_directory_does_not_replace_yaml(tmp_path):
    """The working directory goes last on sys.path: a user's ``yaml.py`` does not shadow
    the YAML library hgo composes with (it broke every run)."""
    (tmp_path / "yaml.py").write_text("raise RuntimeError('the user yaml.py was imported')\n")
    launcher = tmp_path / "bin" / "hgo_launcher.py"
    launcher.parent.mkdir()
    launcher.write_text("from hgo.cli import main\nraise SystemExit(main())\n")
    env = {**os.environ, "PYTHONPATH": str(ROOT)}
    done = subprocess.run([sys.executable, str(launcher), "run", "--cfg", "job"], cwd=tmp_path,
                          env=env, capture_output=True, text=True, timeout=300)
    assert done.returncode == 0, done.stderr
    assert "the user yaml.py" not in done.stderr and "plant:" in done.stdout
