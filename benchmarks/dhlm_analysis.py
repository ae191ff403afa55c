"""What bounds the Dimassi et al. row of ``dhlm_bench.py`` (hgo against solve_ivp RK45).

    python benchmarks/dhlm_analysis.py     # ~40 s

Prints, for the ``dhlm_example`` preset (20 s, 1 ms output grid):

1. where hgo's time goes: ``run_experiment`` against the compiled ``integrate`` call alone
   (the rest: composing the arrays, the worker thread), and the cost of one output sample
   (``integrate`` at dt_out = 0.25 ms against 1 ms: both prepare the dense output of every
   step, so the difference is 60,000 samples) and of the whole output grid (against
   dt_out = 0.5 s);
2. right-hand-side evaluations, trial steps and rejected steps of hgo's DOP853 and dopri5
   (the same kernel run as plain Python, its functions wrapped by counters) and of
   solve_ivp's RK45 (its ``nfev``), and the compiled cost of one evaluation;
3. the real-axis stability limits of both tableaus, so the step the HGO poles -2/eps,
   -4/eps (-333, -667 1/s) allow an explicit method, and the evaluations a run at that
   limit needs;
4. the slow part's time scales (eigenvalues of the finite-difference Jacobian of
   :mod:`hgo.papers.dimassi.reference` along the reference) and the steps of methods the
   HGO poles do not bound: scipy's Radau (A-stable, order 5) on the full system, and DOP853
   on the cascade with an ideal HGO (z_h := x, no fast block);
5. the 300x budget t_RK45 / 300 against hgo's floor (the fixed part plus the output
   samples), and the evaluations the difference leaves for the integration.

Errors: max over the grid and the 8 states of |w - w_ref| / max(1, max |w_ref|) against
solve_ivp DOP853 rtol = atol = 1e-13 of the same system. Timings are medians of 9
interleaved runs; they move with this machine's load (print ``uptime`` next to them): a
ratio of two of them holds better than either.
"""

from __future__ import annotations

import time
from contextlib import ExitStack
from unittest import mock

import numpy as np
from dhlm_bench import _err, _experiment, _ivp
from scipy.integrate import solve_ivp
from scipy.integrate._ivp import dop853_coefficients
from scipy.integrate._ivp.rk import RK45
from timing import interleaved_median_times

from hgo.engine import simulate as engine
from hgo.engine.codegen import load_kernel
from hgo.papers.dimassi.reference import X0, Example
from hgo.running.runner import run_experiment

HORIZON = 20.0
FAST_POLE = 4.0 / Example().eps  # |-gamma-root| of the HGO (27): s^2 + 6 s/eps + 8/eps^2
SETTINGS = {"dop853": 1e-9, "dopri5": 3e-9}  # hgo's rows of dhlm_bench.py
REPS = 15


def _timings(t: np.ndarray) -> tuple[dict, float, object]:
    """Per setting of SETTINGS: run_experiment and the integrate call alone (ms) at dt_out
    1 ms, 0.25 ms and 0.5 s; and solve_ivp RK45 rtol 1e-8 (s, and its solution), all
    interleaved (the same stretches of this machine's load for every ratio)."""
    grids = ("0.001", "0.00025", "0.5")
    runs = {(m, dt): _experiment(HORIZON, m, rtol, (f"solver.dt_out={dt}",))
            for m, rtol in SETTINGS.items() for dt in grids}
    inside: dict[tuple, list[float]] = {key: [] for key in runs}
    current: list[tuple] = [()]
    kernels = {m: load_kernel(runs[m, grids[0]].system, compiled=True, method=m)
               for m in SETTINGS}
    calls = {m: k.integrate for m, k in kernels.items()}

    def timed(*args):
        t0 = time.perf_counter()
        out = calls[current[0][0]](*args)
        inside[current[0]].append(time.perf_counter() - t0)
        return out

    def run(key):
        current[0] = key
        return run_experiment(runs[key])

    def rk45():
        return solve_ivp(Example().rhs, (0.0, HORIZON), X0, method="RK45", rtol=1e-8,
                         atol=1e-10, t_eval=t)

    with ExitStack() as stack:
        for kernel in kernels.values():
            stack.enter_context(mock.patch.object(kernel.integrator, "integrate", timed))
        *totals, (t_rk45, sol) = interleaved_median_times(
            [lambda k=key: run(k) for key in runs] + [rk45], REPS)
    total = dict(zip(runs, (1e3 * s for s, _ in totals), strict=True))
    ms = {key: 1e3 * float(np.median(v)) for key, v in inside.items()}
    split = {m: {"total": total[m, grids[0]], "integrate": ms[m, grids[0]],
                 "per_output_ns": 1e6 * (ms[m, grids[1]] - ms[m, grids[0]]) / 60000,
                 "grid": ms[m, grids[0]] - ms[m, grids[2]]} for m in SETTINGS}
    return split, t_rk45, sol


def _counts(method: str, rtol: float) -> dict:
    """Evaluations, trial and rejected steps of hgo's own loop (plain-Python kernel)."""
    exp = _experiment(HORIZON, method, rtol)
    module = load_kernel(exp.system, compiled=False, method=method)
    n = {"nfev": 0, "trials": 0, "rejected": 0}
    rhs, trial = module.composition.system_rhs, module.integrator._trial

    def counted_rhs(*args):
        n["nfev"] += 1
        return rhs(*args)

    def counted_trial(*args):
        err = trial(*args)
        n["trials"] += 1
        n["rejected"] += not err <= 1.0
        return err

    with ExitStack() as stack:
        # (before the kernel's first call: it takes the composition's functions then)
        stack.enter_context(mock.patch.object(module.composition, "system_rhs", counted_rhs))
        stack.enter_context(mock.patch.object(module.integrator, "_trial", counted_trial))
        stack.enter_context(mock.patch.object(engine, "_kernel",
                                              lambda s, m, noisy=True: module))
        run_experiment(exp)
    return n


def _stability_limit(A: np.ndarray, b: np.ndarray) -> float:
    """The largest x with |R(-s)| <= 1 on [0, x], R the explicit tableau's stability function."""
    s = len(b)
    A = np.pad(A[:s, :s], ((0, 0), (0, s - A[:s, :s].shape[1])))
    for x in np.arange(0.001, 10.0, 0.001):
        z = -x
        if abs(1.0 + z * b @ np.linalg.solve(np.eye(s) - z * A, np.ones(s))) > 1.0:
            return float(x)
    return np.inf


def _jacobian(t: float, w: np.ndarray) -> np.ndarray:
    f0, jac = np.array(Example().rhs(t, w)), np.zeros((8, 8))
    for j in range(8):
        dw = np.array(w, float)
        dw[j] += 1e-7 * max(1.0, abs(w[j]))
        jac[:, j] = (np.array(Example().rhs(t, dw)) - f0) / (dw[j] - w[j])
    return jac


def _ideal_hgo_rhs(t: float, w) -> list[float]:
    """The cascade with z_h := x (the HGO's limit eps -> 0): the slow part alone."""
    w = list(w)
    w[2], w[3] = w[0], w[1]
    f = Example().rhs(t, w)
    f[2] = f[3] = 0.0
    return f


def main() -> None:
    t = np.arange(int(round(HORIZON / 1e-3)) + 1) * 1e-3
    ref = _ivp(t, "DOP853", 1e-13, 1e-13)
    print("1-2. hgo (compiled, 1 ms grid) and solve_ivp RK45 rtol 1e-8")
    splits, t_rk45, sol = _timings(t)
    counts = {method: _counts(method, rtol) for method, rtol in SETTINGS.items()}
    for method, rtol in SETTINGS.items():
        split, n = splits[method], counts[method]
        outside = split["total"] - split["integrate"]
        print(f"  hgo {method} rtol {rtol:g}: run_experiment {split['total']:.2f} ms, "
              f"integrate {split['integrate']:.2f} ms (outside {outside:.2f} ms), output grid "
              f"{split['grid']:.2f} ms ({split['per_output_ns']:.0f} ns per sample); "
              f"nfev {n['nfev']}, trials {n['trials']}, rejected {n['rejected']}; "
              f"{1e3 * split['integrate'] / n['nfev']:.3f} us per evaluation (integrate / nfev)")
    print(f"  solve_ivp RK45 rtol 1e-8: {t_rk45:.3f} s, nfev {sol.nfev}, error "
          f"{_err(sol.y.T, ref):.2e}, {1e6 * t_rk45 / sol.nfev:.2f} us per evaluation")
    print(f"3. stability limits (real axis), step bound at the HGO pole -{FAST_POLE:.0f} 1/s")
    for name, A, b, stages in (("dop853", dop853_coefficients.A, dop853_coefficients.B, 12),
                               ("dopri5", RK45.A, RK45.B, 6)):
        x = _stability_limit(A, b)
        steps = HORIZON * FAST_POLE / x
        print(f"  {name}: |h lambda| <= {x:.2f}, h <= {1e3 * x / FAST_POLE:.2f} ms: >= {steps:.0f} "
              f"steps, {stages * steps:.0f} evaluations (+ dense output) at the limit")
    print("4. slow part")
    eig = [np.linalg.eigvals(_jacobian(tk, wk)) for tk, wk in zip(t[::50], ref[::50], strict=True)]
    slow = [e for ev in eig for e in ev if abs(e) < FAST_POLE / 4]  # (HGO: -333, -667)
    print(f"  largest |eigenvalue| besides the HGO's: {max(abs(e) for e in slow):.1f} 1/s "
          f"(max |Im| {max(abs(e.imag) for e in slow):.1f})")
    rad = solve_ivp(Example().rhs, (0.0, HORIZON), X0, method="Radau", rtol=1e-9, atol=1e-11,
                    t_eval=t, jac=_jacobian)
    print(f"  Radau rtol 1e-9 on the full system: {rad.nlu} LU factorisations (~steps), nfev "
          f"{rad.nfev}, error {_err(rad.y.T, ref):.2e}")
    ref_ideal = _ivp(t, "DOP853", 1e-13, 1e-13, rhs=_ideal_hgo_rhs)
    for rtol in (1e-8, 1e-9, 1e-10):
        ideal = solve_ivp(_ideal_hgo_rhs, (0.0, HORIZON), X0, method="DOP853", rtol=rtol,
                          atol=rtol / 100, t_eval=t)
        print(f"  ideal HGO, DOP853 rtol {rtol:g}: nfev {ideal.nfev} (~{ideal.nfev // 12} steps), "
              f"error {_err(ideal.y.T, ref_ideal):.2e} against its own reference")
    split = splits["dopri5"]
    per_evaluation = split["integrate"] / counts["dopri5"]["nfev"]
    budget = 1e3 * t_rk45 / 300
    floor = split["total"] - split["integrate"] + 20001 * split["per_output_ns"] * 1e-6
    left = max(0.0, budget - floor) / per_evaluation
    print(f"5. 300x: hgo within t_RK45 / 300 = {budget:.2f} ms; outside integrate + 20,001 "
          f"output samples = {floor:.2f} ms, leaving {left:.0f} evaluations "
          f"({1e3 * per_evaluation:.3f} us each, dopri5) for the integration")


if __name__ == "__main__":
    main()
