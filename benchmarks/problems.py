"""The core benchmark problems A and B (issue 5), shared by run.py, sweeps_bench.py and
hand_bench.py: hgo's systems, solver settings and noise for them.

* B: the Sanfelice & Praly error system (20) as hgo integrates it (plant x = 0 and the
  triangular observer with the sign-indefinite law), horizon 200 s, output every 0.01 s;
* A: the DC motor with the switched-gain HGO (eps 5e-4 -> 0.01 at t = 1 s), uniform noise
  +-0.0016 held 0.8 ms, RK4, horizon 20 s, output every 4 ms.
"""

from __future__ import annotations

import os
import subprocess
import sys
import tempfile
import textwrap
from pathlib import Path

import numpy as np

from hgo.controllers.open_loop import open_loop_controller
from hgo.engine.simulate import Noise, SolverSettings, no_noise, simulate  # noqa: F401 (re-exported)
from hgo.engine.system import System
from hgo.observers.switched_hgo import stiffness as switched_stiffness
from hgo.observers.switched_hgo import switched_hgo
from hgo.observers.triangular import triangular_hgo
from hgo.plants.dc_motor import dc_motor_plant
from hgo.plants.sp_linear import sp_linear_plant

ROOT = Path(__file__).resolve().parent.parent

RTOL_B, ATOL_B = 1e-8, 1e-10  # problem B: solve_ivp, the hand kernel and hgo's dopri5
# hgo's choice for problem B: DOP853 at a looser rtol, still more accurate than solve_ivp
# at 1e-8 (the benchmark prints both errors and checks it)
FAST_B = {"method": "dop853", "rtol": 1e-7, "atol": 1e-9}
# work-precision of problem B: hgo DOP853 at these rtol (atol = rtol / 100, FAST_B among
# them) and solve_ivp RK45 on (20) at these rtol (atol = rtol / 100; full run only)
WP_RTOLS_HGO = (1e-6, 3e-7, 1e-7, 1e-8, 1e-9)
WP_RTOLS_IVP = (1e-6, 1e-7, 1e-9)
B_T, B_DT = 200.0, 0.01
A_T, A_NOISE_DT, A_DT_OUT, A_NOISE = 20.0, 0.0008, 0.004, 0.0016
A_SWITCH = 1.0


# ---------------------------------------------------------------------- problem B
def b_system(p2: float = 1.5, e0=(3.0, 3.0)) -> System:
    plant = sp_linear_plant(nu1=3, nu2=0, x0=(0, 0))
    obs = triangular_hgo("b", K=[2, 2], xhat0=list(e0), r0=1, law="sign_indefinite",
                         p1=4 / 3, p2=p2, b=0.28, M=[[3, 0], [0, 0]])
    return System(plant, [obs])


def b_solver(t_end: float = B_T, dt_out: float = B_DT, method: str = "dopri5",
             rtol: float = RTOL_B, atol: float = ATOL_B) -> SolverSettings:
    # h_max only caps adaptive steps (outputs are interpolated): no cap below the horizon
    return SolverSettings(t_end=t_end, dt_out=dt_out, method=method, h_max=t_end,
                          rtol=rtol, atol=atol)


def fast_label(method: str, rtol: float, atol: float) -> str:
    return f"{method.upper()} rtol {rtol:g} atol {atol:g}"


def b_errors(tr) -> np.ndarray:
    """(e1, e2, r) on the grid from an hgo trajectory (x = 0, so e = x^ - x)."""
    return np.c_[tr.xh[:, 0] - tr.z[:, 0], tr.xh[:, 1] - tr.z[:, 1], tr.z[:, 4]]


def ensemble_members(n: int, seed: int = 0) -> tuple[np.ndarray, np.ndarray]:
    rng = np.random.default_rng(seed)
    return rng.uniform(0.5, 3.0, n), rng.uniform(-3.0, 3.0, (n, 2))


def p2_index(system: System) -> int:
    """Where the observer's p2 lies in the system's parameter vector (by name)."""
    return system.p_slices[1][0] + system.observers[0].params.index("p2")


def ensemble_inputs(system: System, p2: np.ndarray, e0: np.ndarray):
    params = np.tile(system.params(), (len(p2), 1))
    params[:, p2_index(system)] = p2
    z0 = np.tile(system.z0(), (len(p2), 1))
    z0[:, 2:4] = e0
    return params, z0


# ---------------------------------------------------------------------- problem A
def a_system() -> System:
    plant = dc_motor_plant()
    obs = switched_hgo("hgo", alpha1=(71.0, 70.0), eps1=5e-4, alpha2=(2.0, 1.0), eps2=0.01,
                       delta=1e12, T_d=A_SWITCH)  # |y - x^1| never leaves: switch at t = 1 s
    # RK4 steps from the *active* gain's margin (rho = 1.4e5, then 100), as the hand kernel
    obs.stiffness = switched_stiffness
    return System(plant, [obs], open_loop_controller(1.0, 0.5, 1.0))


def a_noise(seed: int = 1, t_end: float = A_T) -> Noise:
    n = int(round(t_end / A_NOISE_DT)) + 1
    samples = np.zeros((n, 2))
    samples[:, 0] = np.random.default_rng(seed).uniform(-A_NOISE, A_NOISE, n)
    return Noise(samples, A_NOISE_DT)


def a_solver(t_end: float = A_T) -> SolverSettings:
    return SolverSettings(t_end=t_end, dt_out=A_DT_OUT, method="rk4", h_max=1.0)


# ---------------------------------------------------------------------- compile times
COMPILE_SNIPPET = textwrap.dedent("""
    import time, sys
    t0 = time.perf_counter()
    sys.path.insert(0, {bench!r})
    import problems as b
    problem = {problem!r}
    if problem == "B":
        system, solver, noise = b.b_system(), b.b_solver(), b.no_noise(1)
    elif problem == "B853":
        system, solver, noise = b.b_system(), b.b_solver(**b.FAST_B), b.no_noise(1)
    else:
        system, solver, noise = b.a_system(), b.a_solver(), b.a_noise()
    t1 = time.perf_counter()
    b.simulate(system, solver, noise)
    t2 = time.perf_counter()
    b.simulate(system, solver, noise)
    t3 = time.perf_counter()
    print(f"{{t1 - t0}} {{t2 - t1}} {{t3 - t2}}")
""")


def _first_run(code: str, env: dict) -> float:
    res = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True,
                         text=True, cwd=ROOT, check=True)
    _, first, steady = (float(v) for v in res.stdout.split()[-3:])
    return first - steady


def compile_times(problem: str) -> tuple[float, float, float]:
    """Time from the first simulate() call to its return, minus one steady-state run, in a
    fresh process: (empty caches, only the kernel new (numba's cache of the components'
    helpers kept, as for a new combination of known components; the components themselves
    are compiled into every new kernel), everything cached)."""
    code = COMPILE_SNIPPET.format(bench=str(Path(__file__).resolve().parent), problem=problem)
    with tempfile.TemporaryDirectory() as cache, tempfile.TemporaryDirectory() as kernels:
        # NUMBA_CACHE_DIR too: the component functions are cached by numba next to their
        # modules, and a truly new configuration compiles them as well
        env = dict(os.environ, HGO_CACHE_DIR=cache, NUMBA_CACHE_DIR=cache)
        empty, cached = _first_run(code, env), _first_run(code, env)
        new_kernel = _first_run(code, dict(env, HGO_CACHE_DIR=kernels))
    return empty, new_kernel, cached
