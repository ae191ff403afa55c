"""Break points (issue 25, item 1): the engine ends a step exactly where a component declares
a jump, the step ending there sees the values before it, everything from it on the values
after it, and output samples are taken at their own instants."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest
from scipy.integrate import solve_ivp

from hgo.controllers.profile_input import breakpoints, profile, profile_input
from hgo.controllers.schedule import schedule_input
from hgo.core.components import Observer, Plant
from hgo.engine import codegen
from hgo.engine import simulate as simulate_module
from hgo.engine.simulate import Noise, SolverSettings, no_noise, simulate
from hgo.engine.system import System
from hgo.running.in_memory import run_in_memory, run_rows

SWITCHES = (0.5, 1.25, 2.0)


def _lag_f(t, x, u, p, dx):
    dx[0] = -p[0] * x[0] + u[0]  # x' = -a x + u


def _lag_h(t, x, p, y):
    y[0] = x[0]


def _hold_f(t, z, d, y, u, p, dz):
    dz[0] = 0.0


def _hold_est(t, z, d, p, xhat):
    xhat[0] = z[0]


def _lag_system(controller, a: float) -> System:
    plant = Plant("lag", ["x"], ["y"], ["u"], np.zeros(1), np.array([a]), _lag_f, _lag_h)
    obs = Observer("o", ["xh"], [], [0], np.zeros(1), np.zeros(0), np.zeros(0), _hold_f,
                   _hold_est)
    return System(plant, [obs], controller)


@pytest.mark.parametrize("rtol", [1e-8, 1e-10, 1e-11])
def test_apa_nominal_input_and_max_rate_do_not_depend_on_the_tolerance(rtol: float) -> None:
    """apa_nominal (DOP853, no noise, input switches at 10, 20, 35 declared as break points):
    the recorded input is the schedule itself at every output instant, right-continuous at
    the switches (u(10) = 0.02, u(20) = 0.6, u(35) = 0.1) for every tolerance, and
    max_rate_true (df2/dx2 along the plant, largest at t = 35) agrees with the rtol 1e-11
    run to the tolerance. Before: u(20) was 0.6 at rtol 1e-8 and 0.02 at 1e-10, 1e-11 (the
    output taken at a step end within 1e-11 before the switch)."""
    def run(r: float):
        return run_in_memory(("experiment=apa_nominal", f"solver.rtol={r}",
                              f"solver.atol={r / 100}"))

    tr = run(rtol).trajectory
    assert tr.ok
    t = np.arange(len(tr.t)) * 1e-3
    expected = np.select([t < 10, t < 20, t < 35], [0.5, 0.02, 0.6], 0.1)
    np.testing.assert_array_equal(tr.u[:, 0], expected)
    rows = run_rows(("experiment=apa_nominal", f"solver.rtol={rtol}", f"solver.atol={rtol / 100}"))
    ref = run_rows(("experiment=apa_nominal", "solver.rtol=1e-11", "solver.atol=1e-13"))
    assert rows[("plant", "t_max_rate_true")] == ref[("plant", "t_max_rate_true")] == 35.0
    assert rows[("plant", "max_rate_true")] == pytest.approx(ref[("plant", "max_rate_true")],
                                                             rel=rtol)


def _trials(monkeypatch, system: System, solver: SolverSettings) -> list[tuple]:
    """(t, h, error norm) of every trial step of a run on the pure-Python kernel."""
    module = codegen.load_kernel(system, compiled=False, method=solver.method, noisy=False)
    trial, seen = module.integrator._trial, []

    def spy(S, t, h, *args):
        err = trial(S, t, h, *args)
        seen.append((t, h, err))
        return err

    with monkeypatch.context() as patch:  # (the same module serves the next call)
        patch.setattr(module.integrator, "_trial", spy)
        patch.setattr(simulate_module, "_kernel", lambda system, method, noisy: module)
        assert simulate(system, solver, no_noise(1)).ok
    return seen


@pytest.mark.parametrize("method", ["dopri5", "dop853"])
def test_no_rejected_step_at_a_declared_jump(method: str, monkeypatch) -> None:
    """x' = -x + u with u a schedule jumping by 1-2 at 0.5, 1.25 and 2 s (rtol 1e-10): with
    the switches declared, a step ends exactly at each one, and no rejected step ends at,
    starts at or straddles one (the step after a jump starts with a fresh step size; the
    one rejection of each run, measured, lies elsewhere); with the same input undeclared,
    steps are rejected at every switch (16-30 each: what the declaration removes)."""
    ctrl = schedule_input(SWITCHES, [0.0, 1.0, -1.0, 0.5])
    solver = SolverSettings(t_end=3.0, dt_out=0.01, method=method, h_max=3.0, rtol=1e-10,
                            atol=1e-12)

    def rejected_at(trials: list[tuple], b: float) -> int:
        return sum(t - 1e-12 <= b <= t + h + 1e-12 for t, h, err in trials if not err <= 1.0)

    declared = _trials(monkeypatch, _lag_system(ctrl, 1.0), solver)
    accepted_ends = [t + h for t, h, err in declared if err <= 1.0]
    blind = _trials(monkeypatch, _lag_system(replace(ctrl, breaks=None), 1.0), solver)
    for b in SWITCHES:
        assert min(abs(e - b) for e in accepted_ends) < 1e-14
        assert rejected_at(declared, b) == 0, b
        assert rejected_at(blind, b) > 5, b


def test_undeclared_jump_at_a_segment_end_terminates() -> None:
    """A jump of u that is not declared but falls on a noise instant (a segment end) at
    rtol 1e-11: the last stages of the step ending there see the new value, the step is
    rejected down to < 100 tol of the segment end, and must then shrink for real (it used
    to be re-planned to the same end forever). The run finishes and x = 1 - e^-(t - 0.5)
    after the switch, to 1e-9."""
    ctrl = replace(schedule_input([0.5], [0.0, 1.0]), breaks=None)
    solver = SolverSettings(t_end=1.0, dt_out=0.01, method="dop853", h_max=1.0, rtol=1e-11,
                            atol=1e-13)
    tr = simulate(_lag_system(ctrl, 1.0), solver, Noise(np.zeros((8, 1)), 0.25))
    assert tr.ok and tr.t_stop == 1.0
    exact = np.where(tr.t < 0.5, 0.0, 1.0 - np.exp(-(tr.t - 0.5)))
    assert np.abs(tr.z[:, 0] - exact).max() < 1e-9


def _piecewise_reference(ctrl, a_plant: float, t: np.ndarray) -> np.ndarray:
    """x' = -a x + u(t) by scipy's DOP853 (rtol 1e-13) restarted at every corner of u."""
    edges = [0.0, *breakpoints(ctrl, float(t[-1])), float(t[-1])]
    x, out = [0.0], np.empty_like(t)
    for lo, hi in zip(edges[:-1], edges[1:], strict=True):
        inside = (t >= lo) & (t <= hi)
        mid = 0.5 * (lo + hi)
        sol = solve_ivp(lambda s, x, mid=mid: [-a_plant * x[0] + _u(ctrl, mid, s)], (lo, hi),
                        x, method="DOP853", rtol=1e-13, atol=1e-15, dense_output=True)
        out[inside] = sol.sol(t[inside])[0]
        x = sol.y[:, -1]
    return out


def _u(ctrl, t_piece: float, t: float) -> float:
    """u of the piece containing t_piece, continued to t (the ramp's formula in force
    there, so a reference step ending at a corner sees the left piece)."""
    r0, dr = profile(t_piece, ctrl.p)
    return dr + ctrl.p.a * (r0 + dr * (t - t_piece))


@pytest.mark.parametrize("a_plant", [0.5, 2.0])
@pytest.mark.parametrize(("method", "limit"),
                         [("rk4", 1e-11), ("dopri5", 5e-10), ("dop853", 1e-9)])
def test_linear_pulse_with_its_corners_as_break_points_matches_a_tight_reference(
        method: str, limit: float, a_plant: float) -> None:
    """x' = -a x + u with u = r' + 0.5 r, r the linear pulse up and back down (corners at
    5, 5.5, 9, 9.5 s, u jumping by 4 there). For a = 0.5 the exact solution is x = r; for
    a = 2, scipy's DOP853 (rtol 1e-13) restarted at the corners. hgo at rtol 1e-10 / atol
    1e-12 (RK4: steps of at most 1 ms) over 12 s: every output sample within ``limit``
    (measured for a = 2: rk4 1.8e-13, dopri5 5.8e-11, dop853 2.1e-10; the same input with
    its corners undeclared: 6.7e-4, 3.7e-9, 2.8e-9). The recorded u is the profile's at
    every instant, right-continuous at the corners."""
    ctrl = profile_input("pulse_return", a=0.5, ramp="linear")
    solver = SolverSettings(t_end=12.0, dt_out=0.01, method=method, h_max=1e-3 if method ==
                            "rk4" else 12.0, rtol=1e-10, atol=1e-12)
    tr = simulate(_lag_system(ctrl, a_plant), solver, no_noise(1))
    assert tr.ok
    profiles = np.array([profile(t, ctrl.p) for t in tr.t])
    ref = profiles[:, 0] if a_plant == 0.5 else _piecewise_reference(ctrl, a_plant, tr.t)
    err = np.abs(tr.z[:, 0] - ref).max()
    print(f"{method}, a = {a_plant}: max |x - ref| = {err:.2e}")
    assert err < limit
    np.testing.assert_array_equal(tr.u[:, 0], profiles[:, 1] + 0.5 * profiles[:, 0])
