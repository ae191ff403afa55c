"""The compiled engine against independent references (scipy), and its failure paths."""

from __future__ import annotations

import math
import warnings

import numpy as np
import pytest
from scipy.integrate import solve_ivp

from hgo.core.components import Observer, Plant
from hgo.engine import codegen, tableau
from hgo.engine.simulate import (
    INTERRUPTED,
    Noise,
    SolverSettings,
    no_noise,
    simulate,
    simulate_ensemble,
)
from hgo.engine.system import System
from hgo.observers.triangular import triangular_hgo
from hgo.plants.sp_linear import sp_linear_plant
from hgo.running.ensemble import stack_members

P1, B, NU1 = 4 / 3, 0.28, 3.0


def sp_system(p2: float = 1.5, e0=(3.0, 3.0), nu2: float = 0.0) -> System:
    plant = sp_linear_plant(nu1=NU1, nu2=nu2, x0=(0, 0))
    obs = triangular_hgo("o", K=[2, 2], xhat0=list(e0), r0=1, law="sign_indefinite", p1=P1,
                         p2=p2, b=B, M=[[NU1, 0], [0, 0]])
    return System(plant, [obs])


def sp_rhs(t, s, p2, nu2, m):
    """Plant (18) + observer (5)-(7), law (6), y = x1 + m, as plain Python."""
    x1, x2, z1, z2, r = s
    e = z1 - (x1 + m)
    return [x2 + NU1 * x1 + nu2, 0.0, z2 + NU1 * z1 - 2 * r * e, -2 * r * r * e,
            P1 * ((e * e - p2) * r ** (1 - 2 * B) + p2 / r ** 4)]


@pytest.mark.parametrize(("method", "limit"), [("dopri5", 1e-5), ("dop853", 1e-6)])
def test_adaptive_matches_tight_reference(method: str, limit: float) -> None:
    """rtol 1e-8 / atol 1e-10 over 40 s (measured: dopri5 5.5e-6, dop853 2.3e-7)."""
    t_end, dt = 40.0, 0.01
    solver = SolverSettings(t_end=t_end, dt_out=dt, method=method, h_max=t_end)
    tr = simulate(sp_system(), solver, no_noise(1))
    assert tr.ok and len(tr.t) == 4001
    ref = solve_ivp(sp_rhs, (0, t_end), [0, 0, 3, 3, 1], method="DOP853", rtol=1e-12,
                    atol=1e-14, t_eval=tr.t, args=(1.5, 0.0, 0.0))
    err = np.abs(tr.z - ref.y.T).max()
    assert err < limit, f"{method}: max error vs DOP853 (rtol 1e-12) = {err:.2e}"


@pytest.mark.parametrize(("method", "scipy_method"), [("dopri5", "RK45"), ("dop853", "DOP853")])
@pytest.mark.parametrize("rtol", [1e-6, 1e-8])
def test_adaptive_takes_the_steps_of_solve_ivp(method: str, scipy_method: str,
                                               rtol: float) -> None:
    """Same tableau, error norm, initial step and step control as scipy: the same steps,
    so the outputs agree to round-off (measured <= 1.5e-12), not merely to the tolerance
    (~1e-5 at rtol 1e-6). A different step sequence (e.g. growth allowed right after a
    rejection) fails this."""
    t_end = 40.0
    solver = SolverSettings(t_end=t_end, dt_out=0.01, method=method, h_max=t_end, rtol=rtol,
                            atol=rtol * 1e-2)
    tr = simulate(sp_system(), solver, no_noise(1))
    ref = solve_ivp(sp_rhs, (0, t_end), [0, 0, 3, 3, 1], method=scipy_method, rtol=rtol,
                    atol=rtol * 1e-2, t_eval=tr.t, args=(1.5, 0.0, 0.0))
    assert np.abs(tr.z - ref.y.T).max() < 1e-10


@pytest.mark.parametrize(("method", "step_order", "dense_order"),
                         [("dopri5", 5, 4), ("dop853", 8, 7)])
def test_adaptive_convergence_order(method: str, step_order: int, dense_order: int) -> None:
    """Fixed steps h = h_max (tolerances so loose that every step is accepted): halving h
    divides the error at step ends by ~2^order and between them (dense output) by
    ~2^dense_order. Asserted with one order of slack: a wrong coefficient of the
    generated tableau drops the order to <= 4."""
    t_end = 2.0
    errors = []
    for h in (0.02, 0.01):
        solver = SolverSettings(t_end=t_end, dt_out=h / 4, method=method, h_max=h,
                                rtol=1e3, atol=1e3)
        tr = simulate(sp_system(), solver, no_noise(1))
        ref = solve_ivp(sp_rhs, (0, t_end), [0, 0, 3, 3, 1], method="DOP853", rtol=1e-13,
                        atol=1e-14, t_eval=tr.t, args=(1.5, 0.0, 0.0)).y.T
        err = np.abs(tr.z - ref).max(axis=1)
        on_step = np.arange(len(tr.t)) % 4 == 0
        errors.append((err[on_step].max(), err[~on_step].max()))
    (step1, dense1), (step2, dense2) = errors
    assert step1 / step2 > 2 ** (step_order - 1), (step1, step2)
    assert dense1 / dense2 > 2 ** (dense_order - 1), (dense1, dense2)


@pytest.mark.parametrize("method", ["rk4", "dop853"])
def test_held_noise_matches_segmentwise_reference(method: str) -> None:
    """Noise held on [k dt, (k+1) dt): steps must be cut at every sample instant."""
    t_end, noise_dt, nu2 = 2.0, 0.013, 0.1  # noise instants not on the output grid
    rng = np.random.default_rng(3)
    samples = rng.uniform(-0.05, 0.05, (int(t_end / noise_dt) + 2, 1))
    solver = SolverSettings(t_end=t_end, dt_out=0.01, method=method, h_max=2e-3,
                            rtol=1e-10, atol=1e-12)
    tr = simulate(sp_system(nu2=nu2), solver, Noise(samples, noise_dt))
    assert tr.ok
    # reference: DOP853 from sample instant to sample instant with the held value
    s = np.array([0, 0, 3, 3, 1], float)
    edges = np.unique(np.r_[np.arange(0, t_end, noise_dt), t_end])
    dense = []
    for k, (a, b) in enumerate(zip(edges[:-1], edges[1:], strict=True)):
        sol = solve_ivp(sp_rhs, (a, b), s, method="DOP853", rtol=1e-12, atol=1e-14,
                        dense_output=True, args=(1.5, nu2, samples[k, 0]))
        dense.append((a, b, sol.sol))
        s = sol.y[:, -1]
    ref = np.array([next(sol(t) for a, b, sol in dense if a <= t <= b + 1e-12)
                    for t in tr.t])
    err = np.abs(tr.z - ref).max()
    # RK4 truncation at h <= 2e-3 is ~1e-8; a step straddling a noise jump would give
    # an O(h * jump) ~ 1e-4 error
    assert err < 1e-7, f"max error vs segment-wise DOP853 = {err:.2e}"
    # the recorded noise is the held sample
    k = np.minimum((tr.t / noise_dt + 1e-9).astype(int), len(samples) - 1)
    np.testing.assert_array_equal(tr.m[:, 0], samples[k, 0])


@pytest.mark.parametrize(("method", "h_max"),
                         [("dopri5", 1e-2), ("rk4", 1e-2), ("dop853", 20.0)])
def test_ensemble_equals_single_runs(method: str, h_max: float) -> None:
    """Members keep no record and skip the outputs before the metrics window; their window
    integrals equal those of single runs (dop853 with long steps: dense outputs)."""
    rng = np.random.default_rng(0)
    systems = [sp_system(p2=float(p2), e0=tuple(e0))
               for p2, e0 in zip(rng.uniform(0.5, 3, 6), rng.uniform(-3, 3, (6, 2)),
                                 strict=True)]
    params, z0, d0 = stack_members(systems)
    solver = SolverSettings(t_end=20.0, dt_out=0.01, method=method, h_max=h_max)
    res = simulate_ensemble(systems[0], solver, no_noise(1), params, z0, d0)
    for i, s in enumerate(systems):
        tr = simulate(s, solver, no_noise(1))
        assert res["status"][i] == tr.status
        np.testing.assert_allclose(res["acc"][i], tr.acc, rtol=1e-12, atol=0,
                                   err_msg=f"member {i}")
        assert res["t_stop"][i] == tr.t_stop


def _drift_f(t, z, d, y, u, p, dz):
    dz[0] = d[0]  # the discrete state sets the drift: members differ only in d0


def _drift_system(drift: float) -> System:
    plant = sp_linear_plant(nu1=0.0, nu2=0.0, x0=(0.0, 0.0))
    obs = Observer("o", ["xh"], ["drift"], [0], np.zeros(1), np.array([drift]), np.zeros(0),
                   _drift_f, _copy_est)
    return System(plant, [obs])


def test_ensemble_members_keep_their_own_discrete_state() -> None:
    """Each member starts from its own d0 (before, member 0's d0 served all)."""
    systems = [_drift_system(c) for c in (1.0, -2.0, 3.0)]
    params, z0, d0 = stack_members(systems)
    solver = SolverSettings(t_end=4.0, dt_out=0.01, method="dopri5", h_max=4.0)
    res = simulate_ensemble(systems[0], solver, no_noise(1), params, z0, d0)
    for i, s in enumerate(systems):  # x^ = c t, x1 = 0: window integral of (c t)^2 on [3, 4]
        np.testing.assert_allclose(res["acc"][i], simulate(s, solver, no_noise(1)).acc,
                                   rtol=1e-12)
        assert res["acc"][i][0] == pytest.approx(s.d0()[0] ** 2 * (64 - 27) / 3, rel=1e-4)


def test_ctrl_c_stops_a_chunked_ensemble_after_the_chunk_it_interrupted(monkeypatch) -> None:
    """The ensemble runner integrates its members in chunks (one call each). When Ctrl-C
    interrupts a chunk (its members come back with status 6), no later chunk runs: their
    members are interrupted at t = 0, with NaN metrics and no samples (before, every
    remaining chunk ran to its end after the Ctrl-C)."""
    from hgo.running import ensemble_runner

    systems = [_drift_system(c) for c in (1.0, -2.0, 3.0)]  # three chunks of one member
    params, z0, d0 = stack_members(systems)
    solver = SolverSettings(t_end=4.0, dt_out=0.01, method="dopri5", h_max=4.0)
    real, calls = ensemble_runner.simulate_ensemble, []

    def second_chunk_interrupted(*args, **kwargs):
        out = real(*args, **kwargs)
        calls.append(out)
        if len(calls) == 2:
            out["status"][:] = INTERRUPTED
        return out

    monkeypatch.setattr(ensemble_runner, "simulate_ensemble", second_chunk_interrupted)
    out = ensemble_runner._simulate_chunks(solver, [no_noise(1)] * 3, params, z0, d0, systems,
                                           record=True)
    assert len(calls) == 2
    assert out["status"].tolist() == [0, INTERRUPTED, INTERRUPTED]
    np.testing.assert_array_equal(out["acc"][:2], np.vstack([c["acc"] for c in calls]))
    assert np.isnan(out["acc"][2]).all() and out["t_stop"][2] == 0.0
    never = out["trajectories"][2]
    assert never.status == INTERRUPTED and never.t.shape == (0,)
    assert never.z.shape == (0, systems[2].nz) and never.xh.shape == (0, systems[2].nxh)


def _noisy_members(seed: int, n: int, t_end: float) -> tuple:
    """``n`` members of problem B (random p2, e(0)), each with its own noise held 0.013 s
    over ``t_end``: (systems, params, z0, d0, noises)."""
    rng = np.random.default_rng(seed)
    systems = [sp_system(p2=float(p2), e0=tuple(e0))
               for p2, e0 in zip(rng.uniform(0.5, 3, n), rng.uniform(-3, 3, (n, 2)),
                                 strict=True)]
    noises = [Noise(rng.uniform(-0.05, 0.05, (int(t_end / 0.013) + 2, 1)), 0.013)
              for _ in systems]
    return (systems, *stack_members(systems), noises)


def test_ensemble_members_with_own_noise_and_early_exits() -> None:
    """An adaptive ensemble with per-member held noise, an odd count and members that leave
    the state bound early: every member equals its single run."""
    systems, params, z0, d0, noises = _noisy_members(5, 5, 10.0)
    solver = SolverSettings(t_end=10.0, dt_out=0.01, method="dop853", h_max=10.0,
                            state_bound=6.0)
    res = simulate_ensemble(systems[0], solver, noises, params, z0, d0)
    assert 0 < (res["status"] == 2).sum() < len(systems)  # some exit early, some do not
    for i, (s, noise) in enumerate(zip(systems, noises, strict=True)):
        tr = simulate(s, solver, noise)
        assert res["status"][i] == tr.status and res["t_stop"][i] == tr.t_stop
        np.testing.assert_allclose(res["acc"][i], tr.acc, rtol=1e-12, atol=0,
                                   err_msg=f"member {i}")


def test_ensemble_is_bit_identical_across_thread_counts() -> None:
    """The ensemble's members (prange) run the same functions on one thread and on every
    thread numba has: acc, status, t_stop and the recorded trajectories are equal bit for
    bit (issue 41: the members must keep calling thread-safe, shared-nothing code)."""
    import numba

    threads = numba.config.NUMBA_NUM_THREADS
    if threads < 2:
        pytest.skip("numba has one thread here")
    systems, params, z0, d0, noises = _noisy_members(7, 17, 4.0)
    solver = SolverSettings(t_end=4.0, dt_out=0.01, method="dop853", h_max=10.0,
                            state_bound=6.0)
    before = numba.get_num_threads()
    runs = []
    try:
        for n in (1, threads):
            numba.set_num_threads(n)
            runs.append(simulate_ensemble(systems[0], solver, noises, params, z0, d0,
                                          record=True))
    finally:
        numba.set_num_threads(before)
    one, many = runs
    for key in ("acc", "status", "t_stop"):
        np.testing.assert_array_equal(one[key], many[key], err_msg=key)
    for a, b in zip(one["trajectories"], many["trajectories"], strict=True):
        for field in ("t", "z", "y", "u", "xh"):
            np.testing.assert_array_equal(getattr(a, field), getattr(b, field))


def test_stack_members_rejects_different_layouts() -> None:
    other = System(sp_linear_plant(), [triangular_hgo("o", K=[2], xhat0=[0.0])])
    with pytest.raises(ValueError, match="member 1"):
        stack_members([sp_system(), other])
    hooked = sp_system()
    hooked.observers[0].stiffness = _drift_f  # another kernel: a stiffness hook
    with pytest.raises(ValueError, match="member 1"):
        stack_members([sp_system(), hooked])


def _blowup_f(t, x, u, p, dx):
    dx[0] = x[0] * x[0]  # x' = x^2, x(0) = 1: x = 1 / (1 - t), infinite at t = 1


def _blowup_h(t, x, p, y):
    y[0] = x[0]


def _copy_f(t, z, d, y, u, p, dz):
    dz[0] = 0.0


def _copy_est(t, z, d, p, xhat):
    xhat[0] = z[0]


def _blowup_system() -> System:
    plant = Plant("blowup", ["x"], ["y"], [], np.array([1.0]), np.zeros(0), _blowup_f,
                  _blowup_h)
    obs = Observer("o", ["xh"], [], [0], np.zeros(1), np.zeros(0), np.zeros(0), _copy_f,
                   _copy_est)
    return System(plant, [obs])


@pytest.mark.parametrize("method", ["rk4", "dopri5", "dop853"])
def test_non_finite_state_stops_and_keeps_samples(method: str) -> None:
    solver = SolverSettings(t_end=2.0, dt_out=0.01, method=method, h_max=0.01,
                            state_bound=math.inf)
    tr = simulate(_blowup_system(), solver, no_noise(1))
    assert tr.status in (1, 3), tr.message  # rk4: non-finite; adaptive may underflow first
    if method == "rk4":
        assert tr.status == 1 and tr.message == "non-finite state"
    assert 0.9 < tr.t_stop <= 1.05
    assert len(tr.t) >= 90 and np.all(np.isfinite(tr.z))
    np.testing.assert_allclose(tr.z[:50, 0], 1 / (1 - tr.t[:50]), rtol=1e-6)


class _Gains:
    a = -1.0


GAINS = _Gains()


def _dict_f(t, x, u, p, dx):
    dx[0] = GAINS.a * x[0]  # an arbitrary Python object: numba cannot type this


def test_uncompilable_user_plant_runs_on_python_path_with_warning() -> None:
    plant = Plant("dict", ["x"], ["y"], [], np.array([1.0]), np.zeros(0), _dict_f, _blowup_h)
    obs = Observer("o", ["xh"], [], [0], np.zeros(1), np.zeros(0), np.zeros(0), _copy_f,
                   _copy_est)
    solver = SolverSettings(t_end=1.0, dt_out=0.1, method="rk4", h_max=0.01)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        tr = simulate(System(plant, [obs]), solver, no_noise(1))
    msgs = [str(w.message) for w in caught if issubclass(w.category, RuntimeWarning)]
    assert any("pure-Python path" in m and "numba could not compile" in m for m in msgs), msgs
    assert tr.ok
    np.testing.assert_allclose(tr.z[:, 0], np.exp(-tr.t), rtol=1e-8)


def test_kernel_decorators_set_llvm_noalias() -> None:
    """codegen._noalias reaches LLVM: array data pointers get ``noalias`` (the engine's
    speed on problem A depends on it; a numba version without the hook would drop it)."""
    import re

    import numba

    from hgo.engine.codegen import _noalias

    def double(a, b):
        for i in range(a.shape[0]):
            b[i] = 2.0 * a[i]

    data_arg = r'ptr noalias [a-z() ]*%"?arg\.a\.4\b'  # field 4 of an array: its data
    for decorator, expected in ((numba.njit, False), (_noalias(numba.njit), True)):
        fn = decorator(double)
        fn(np.ones(3), np.zeros(3))
        ir = next(iter(fn.inspect_llvm().values()))
        define = next(line for line in ir.splitlines()
                      if line.startswith("define") and "arg.a.4" in line)
        assert bool(re.search(data_arg, define)) is expected


def test_integrator_source_is_kept_in_the_cache_and_a_damaged_copy_is_made_anew(
        tmp_path, monkeypatch):
    """The generated tableau text is read back from the kernel cache (a cached kernel is
    then found without importing scipy) equal to what scipy's coefficients give; a
    truncated copy is detected by its hash line and written anew."""
    monkeypatch.setenv("HGO_CACHE_DIR", str(tmp_path))
    codegen._integrator_source.cache_clear()
    text = codegen._integrator_source("dop853")
    assert text == tableau.method_source("dop853")
    (entry,) = tmp_path.glob("hgo_tableau_dop853_*.txt")
    whole = entry.read_text()
    entry.write_text(whole[:300])
    codegen._integrator_source.cache_clear()
    assert codegen._integrator_source("dop853") == text
    assert entry.read_text() == whole
    codegen._integrator_source.cache_clear()


@pytest.mark.parametrize("method", ["dopri5", "dop853"])
def test_adaptive_window_metrics_do_not_depend_on_the_output_grid(method: str) -> None:
    """The window integrals and maxima come from the steps only (Gauss nodes on each
    step's continuous extension): output grids of 0.5 s, 0.016 s and none in the window
    give the same values to round-off (S–P system, 40 s, window 10 s), and the integrals
    agree with a trapezoid over a 1e-4 s grid of a tight run to 1e-6 relative."""
    def acc(dt_out: float, **tight) -> np.ndarray:
        solver = SolverSettings(t_end=40.0, dt_out=dt_out, method=method, h_max=40.0,
                                window=10.0, **tight)
        return simulate(sp_system(), solver, no_noise(1)).acc

    base = acc(0.5)
    for dt_out in (0.016, 40.0):
        np.testing.assert_allclose(acc(dt_out), base, rtol=1e-12, atol=1e-300)
    fine = simulate(sp_system(), SolverSettings(t_end=40.0, dt_out=1e-4, method="dop853",
                                                h_max=40.0, window=10.0, rtol=1e-12,
                                                atol=1e-14), no_noise(1))
    late = fine.t >= 30.0 - 1e-9
    e1 = (fine.xh[late, 0] - fine.z[late, 0]) ** 2
    ref = np.trapezoid(e1, fine.t[late])
    assert base[0] == pytest.approx(ref, rel=1e-6), (base[0], ref)


def test_step_lookup_finds_the_step_numpy_searchsorted_finds() -> None:
    """The kernel's ``_step_of`` (pure-Python module: the same text numba compiles) gives the
    last step starting at or before t, as ``searchsorted(starts, t, "right") - 1`` (0 before
    the first start, the last for NaN), from any previous step k: 600 steps of random
    lengths, instants at the starts, between them, outside, NaN, in order and not."""
    module = codegen.load_kernel(sp_system(), compiled=False, method="dopri5")
    rng = np.random.default_rng(3)
    starts = np.cumsum(rng.uniform(1e-4, 1.0, 600))
    record = np.zeros((610, 4))
    record[:600, 0] = starts
    ts = np.concatenate([starts, starts + 1e-9, rng.uniform(-1, starts[-1] + 1, 400),
                         [np.nan, -np.inf, np.inf]])
    expected = np.maximum(0, np.searchsorted(starts, ts, side="right") - 1)
    for order in (np.argsort(ts), rng.permutation(ts.size)):
        k = 0
        for j in order:
            for k_from in (k, 0, 599, int(rng.integers(600))):
                assert module._step_of(record, 600, ts[j], k_from) == expected[j], (ts[j], k_from)
            k = expected[j]


def test_the_continuous_extension_at_sparse_sorted_instants_is_the_one_at_each_alone() -> None:
    """The compiled ``dense_signals`` at 250 sorted instants ~20 steps apart (5,000 steps of
    0.01 s; the crossings' bisections ask so) equals, bit for bit, the same instants asked
    one at a time (each looked for from step 0)."""
    solver = SolverSettings(t_end=50.0, dt_out=0.5, method="dopri5", h_max=0.01,
                            dense_steps=True)
    run = simulate(sp_system(), solver, no_noise(1)).dense
    ts = np.sort(np.random.default_rng(4).uniform(0.0, 50.0, 250))
    together = run.at(ts)
    alone = [run.at(ts[j:j + 1]) for j in range(ts.size)]
    for field in ("z", "y", "xh"):
        assert np.array_equal(getattr(together, field),
                              np.concatenate([getattr(a, field) for a in alone]))
