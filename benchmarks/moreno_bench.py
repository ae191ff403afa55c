"""Moreno ``moreno_pe`` sweep: hgo against solve_ivp at equal or better accuracy.

    python benchmarks/moreno_bench.py [--quick]

The jobs of ``conf/experiment/moreno_pe.yaml`` (a in {0, 0.5, 1} x l2 in {120, 20} x five
inputs, 40 s each, e0 = (70, -50): a stiff start, Jacobian ~2e5) are built through hgo's
normal path (Hydra compose -> build) and run by ``hgo.running.runner.run_experiment`` (DOP853,
rtol 1e-10, atol 1e-12, h_max 0.01 s, output grid 1 ms: every signal recorded), after one
compiling run; hgo's time is the sum over jobs of the median of ``reps`` runs. The baseline
integrates the same ODE (plant in original coordinates + observer (3), 4 states,
``hgo.papers.moreno.reference``) with ``scipy.integrate.solve_ivp`` on the same grid,
restarted at the input's corners (atol = rtol / 100 throughout). Its right-hand side is
``plain_rhs``, written in Python floats as the Dimassi baseline's (1.7 us a call);
``joint_rhs``, the same equations in small-array numpy (7.5 us, ``np.polynomial`` for psi),
made solve_ivp 2.2x slower and is kept as one more DOP853 row for comparison. Settings:

* DOP853, hgo's method and settings (rtol 1e-10, max_step = h_max = 0.01 s: without the
  cap both pairs run at their stability boundary after the stiff start and lose 3-5
  digits). The loosest DOP853 as accurate as hgo: at rtol 1e-9 its error over the 30 jobs
  is 6.4e-8 against hgo's 4.8e-8;
* LSODA (stiff/non-stiff switching, no step cap), scipy's fastest here, at rtol 1e-11 and
  1e-12 (at 1e-10 its error is 2.2e-7). Measured once with the numpy right-hand side, not
  repeated here (wall times of one loaded run): RK45 (max_step 0.01) needs rtol 1e-10 on
  the 30 jobs (error 8.6e-9; at 1e-9 1.0e-7) and took 66 s against 25.5 s for DOP853 at
  rtol 1e-9; on the quick jobs BDF and Radau took 1.4-5x and 5-11x LSODA's time at the
  same rtol (1e-10 .. 1e-12).

Times are CPU seconds of the process (hgo's worker thread included; ``process_time``), the
ratios those of CPU times: on this shared 2-core machine the wall time of a 3 ms run
depends on the other processes (the wall times and their ratios are printed too; on an
idle machine both agree). ``ratio_dop853`` (same method and settings, plain right-hand
side) is the row's speedup: the issue names no method for Moreno and a fixed explicit
one (RK45) for the other papers, and DOP853 is the faster of solve_ivp's explicit pairs
here. ``ratio_fastest`` is against the fastest setting above whose error is <= hgo's
(LSODA at rtol 1e-11). Errors: max |[x, x^] - reference| over the grid and the jobs, the
reference being hgo's DOP853 at rtol 1e-12 / atol 1e-14 (within 3e-10 of Radau at rtol
1e-13 on Fig. 1, ``tests/test_moreno_numerics.py``; at rtol 1e-13 the engine stops with a
step-size underflow at the pulse's corner t = 5 s, which it does not cut). hgo's largest
errors are on the pulse input (up to 4.8e-8: its corners at 5 and 5.5 s, which solve_ivp
restarts at and hgo steps over) and on x2 = 5 sin t (up to 1.3e-8); 6e-10 on the others.

Where hgo's time goes (one job, x2 = 2 sin t, in-process CPU medians): 2.55 ms for the
compiled integration, of which ~40 % in libm's sincos (the input's sin and cos at every
stage and output: ~105k calls), 4,300 steps of 12 evaluations (h_max-bound: 40 s /
0.01 s) plus 3 more per step for DOP853's dense output, and ~10 % in evaluating it at the
40,000 outputs; plus ~0.15 ms of Python and the worker thread. Up to 2026-11-24 every
run also mapped its ~3 MB of fresh record arrays page by page (~770 page faults,
~1.2 ms); ``simulate`` now allocates them as one block, which the next run reuses.
``--quick``: 7 of the 30 jobs.
"""

from __future__ import annotations

import argparse
import itertools
import os
import time

import numpy as np

from hgo.core.config import compose
from hgo.papers.moreno.reference import reference_run
from hgo.running.runner import build, run_experiment

INPUTS = ("moreno_bad", "moreno_pulse", "moreno_sin", "moreno_sin5", "moreno_sin1")
# solve_ivp settings (method, rtol, max_step, right-hand side; atol = rtol / 100, max_step
# None: hgo's h_max; "plain": plain_rhs in Python floats, "numpy": joint_rhs): DOP853 as hgo's
# preset (with numpy: the earlier baseline, kept for comparison), and LSODA, scipy's
# fastest here (stiff/non-stiff switching), at the rtol around the accuracy of hgo (at
# 1e-10 its error over the 30 jobs is 2.2e-7)
BASELINES = {"dop853": ("DOP853", 1e-10, None, "plain"),
             "dop853_numpy": ("DOP853", 1e-10, None, "numpy"),
             "lsoda_1e-11": ("LSODA", 1e-11, np.inf, "plain"),
             "lsoda_1e-12": ("LSODA", 1e-12, np.inf, "plain")}
JOBS = [(f"observer.circle.L=[200.0,{l2}]", f"plant.a={a}", f"controller={c}")
        for l2, a, c in itertools.product((120.0, 20.0), (0.0, 0.5, 1.0), INPUTS)]


def _states(traj) -> np.ndarray:
    return np.hstack([traj.z[:, :2], traj.xh])


def _times(fn) -> tuple[float, float]:
    """(CPU, wall) seconds of one call of ``fn``: CPU of the whole process, the worker
    thread hgo integrates in included."""
    c0, w0 = time.process_time(), time.perf_counter()
    fn()
    return time.process_time() - c0, time.perf_counter() - w0


def _median_times(fn, reps: int) -> np.ndarray:
    """(CPU, wall) medians of ``reps`` calls of ``fn``."""
    return np.median([_times(fn) for _ in range(reps)], axis=0)


def _baseline(exp, method: str, rtol: float, max_step: float, rhs: str
              ) -> tuple[np.ndarray, np.ndarray]:
    """(CPU, wall) seconds and states [x, x^] on the grid of solve_ivp on one job."""
    sysm, s = exp.system, exp.solver
    a = -float(sysm.plant.A[1, 1])
    out = {}

    def run():
        out["w"] = reference_run(sysm.observers[0], sysm.controller, a, s.t_end, s.dt_out,
                                 method, rtol, rtol / 100, with_error=False,
                                 max_step=max_step, plain=rhs == "plain")[1]

    return np.array(_times(run)), out["w"]


def bench(quick: bool) -> dict:
    """CPU and wall times (s) and max errors of hgo and of the solve_ivp settings over the
    jobs; ratios of CPU times (``ratio_dop853`` the same-settings one, ``ratio_fastest``
    against the fastest solve_ivp setting at least as accurate as hgo) and of wall times."""
    jobs = JOBS[::5] + JOBS[2:3] if quick else JOBS
    reps = 3 if quick else 5
    hgo_t, hgo_err = np.zeros(2), 0.0
    base_t = {key: np.zeros(2) for key in BASELINES}
    base_err = dict.fromkeys(BASELINES, 0.0)
    by_input = {c: np.zeros(2) for c in INPUTS}  # CPU s of hgo, of same-settings DOP853
    for job in jobs:
        cfg = compose(["experiment=moreno_pe", "postprocess=none", *job])
        exp = build(cfg)
        tight = run_experiment(build(compose(["experiment=moreno_pe", "postprocess=none",
                                              "solver.rtol=1e-12", "solver.atol=1e-14",
                                              *job])))
        if not tight.ok:
            raise RuntimeError(f"reference run {job} stopped: {tight.message}")
        ref = _states(tight)
        traj = run_experiment(exp)  # compiles once (then cached)
        hgo_job = _median_times(lambda e=exp: run_experiment(e), reps)
        hgo_t += hgo_job
        by_input[job[2].split("=")[1]][0] += hgo_job[0]
        hgo_err = max(hgo_err, float(np.max(np.abs(_states(traj) - ref))))
        for key, (method, rtol, max_step, rhs) in BASELINES.items():
            times, w = _baseline(exp, method, rtol, max_step or exp.solver.h_max, rhs)
            base_t[key] += times
            if key == "dop853":
                by_input[job[2].split("=")[1]][1] += times[0]
            base_err[key] = max(base_err[key], float(np.max(np.abs(w - ref))))
    accurate = [key for key in BASELINES if base_err[key] <= hgo_err]
    if not accurate:
        raise RuntimeError(f"no solve_ivp setting is as accurate as hgo ({hgo_err:.2e}): "
                           f"{base_err}")
    fastest = min(accurate, key=lambda key: base_t[key][0])
    out = {"jobs": len(jobs), "hgo_cpu_s": hgo_t[0], "hgo_wall_s": hgo_t[1],
           "hgo_err": hgo_err, "fastest": fastest}
    for key in BASELINES:
        out |= {f"{key}_cpu_s": base_t[key][0], f"{key}_wall_s": base_t[key][1],
                f"{key}_err": base_err[key]}
    out["ratio_dop853"] = base_t["dop853"][0] / hgo_t[0]
    out["ratio_dop853_wall"] = base_t["dop853"][1] / hgo_t[1]
    out["ratio_dop853_numpy"] = base_t["dop853_numpy"][0] / hgo_t[0]
    out["ratio_fastest"] = base_t[fastest][0] / hgo_t[0]
    out["ratio_fastest_wall"] = base_t[fastest][1] / hgo_t[1]
    out["ratio_dop853_by_input"] = {c: b / h for c, (h, b) in by_input.items() if h > 0}
    return out


def _report(r: dict) -> None:
    print(f"moreno_pe ({r['jobs']} jobs x 40 s), CPU s (wall s), max error; "
          f"load average {os.getloadavg()[0]:.2f}")
    print(f"  hgo DOP853 rtol 1e-10: {r['hgo_cpu_s']:.4f} ({r['hgo_wall_s']:.4f}), "
          f"{r['hgo_err']:.2e}")
    for key, (method, rtol, max_step, rhs) in BASELINES.items():
        cap = f"{' max_step h_max' if max_step is None else ''}, {rhs} right-hand side"
        worse = "" if r[f"{key}_err"] <= r["hgo_err"] else "  (less accurate than hgo)"
        print(f"  solve_ivp {method} rtol {rtol:g}{cap}: {r[f'{key}_cpu_s']:.2f} "
              f"({r[f'{key}_wall_s']:.2f}), {r[f'{key}_err']:.2e}{worse}")
    print(f"  ratio, same settings (DOP853, plain): {r['ratio_dop853']:.0f}x CPU "
          f"({r['ratio_dop853_wall']:.0f}x wall; numpy right-hand side "
          f"{r['ratio_dop853_numpy']:.0f}x CPU); fastest as accurate ({r['fastest']}): "
          f"{r['ratio_fastest']:.0f}x CPU ({r['ratio_fastest_wall']:.0f}x wall)")
    print("  same-settings ratio by input (bad and pulse: no sine to evaluate): " + ", ".join(
        f"{c.removeprefix('moreno_')} {x:.0f}x" for c, x in r["ratio_dop853_by_input"].items()))


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true", help="7 of the 30 jobs")
    _report(bench(ap.parse_args().quick))


if __name__ == "__main__":
    main()
