"""Moreno ``moreno_pe`` sweep: hgo against solve_ivp at equal or better accuracy.

    python benchmarks/moreno_bench.py [--quick]

The jobs of ``conf/experiment/moreno_pe.yaml`` (a in {0, 0.5, 1} x l2 in {120, 20} x five
inputs, 40 s each, e0 = (70, -50): a stiff start, Jacobian ~2e5) are built through hgo's
normal path (Hydra compose -> build) and integrated by ``hgo.engine.simulate.simulate``
(DOP853, rtol 1e-10, atol 1e-12, output grid 1 ms), after one compiling run; the time is
the sum over jobs of the median of ``reps`` runs. The baseline integrates the same ODE
(plant in original coordinates + observer (3), 4 states, Python right-hand side,
``hgo.papers.moreno.reference``) with ``scipy.integrate.solve_ivp`` on the same grid,
restarted at the input's corners: with DOP853, the same method and settings as hgo's
(rtol 1e-10, atol 1e-12, max_step = h_max = 0.01 s: without the cap both pairs run at
their stability boundary after the stiff start and lose 3-5 digits), and with LSODA
(scipy's fastest here, stiff/non-stiff switching) at rtol 1e-12 / atol 1e-14, the
loosest setting whose error comes near hgo's (at rtol 1e-10 LSODA is 100x less accurate).
Errors: max |[x, x^] - reference| over the grid and the jobs, the reference being hgo's
DOP853 at rtol 1e-12 / atol 1e-14 (within 3e-10 of Radau at rtol 1e-13 on Fig. 1,
``tests/test_moreno_numerics.py``; at rtol 1e-13 the engine stops with a step-size
underflow at the pulse's corner t = 5 s, which it does not cut). ``--quick``: 6 of the 30 jobs.
"""

from __future__ import annotations

import argparse
import itertools
import time

import numpy as np

from hgo.config import compose
from hgo.papers.moreno.reference import reference_run
from hgo.runner import build, run_experiment

INPUTS = ("moreno_bad", "moreno_pulse", "moreno_sin", "moreno_sin5", "moreno_sin1")
JOBS = [(f"observer.circle.L=[200.0,{l2}]", f"plant.a={a}", f"controller={c}")
        for l2, a, c in itertools.product((120.0, 20.0), (0.0, 0.5, 1.0), INPUTS)]


def _states(traj) -> np.ndarray:
    return np.hstack([traj.z[:, :2], traj.xh])


def _median_time(fn, reps: int) -> float:
    times = []
    for _ in range(reps):
        t0 = time.perf_counter()
        fn()
        times.append(time.perf_counter() - t0)
    return float(np.median(times))


def bench(quick: bool) -> dict:
    """Times (s) and max errors of hgo and solve_ivp (DOP853, LSODA) over the jobs."""
    jobs = JOBS[::5] + JOBS[2:3] if quick else JOBS
    reps = 3 if quick else 5
    out = {"jobs": len(jobs), "hgo_s": 0.0, "dop853_s": 0.0, "lsoda_s": 0.0,
           "hgo_err": 0.0, "dop853_err": 0.0, "lsoda_err": 0.0}
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
        out["hgo_s"] += _median_time(lambda e=exp: run_experiment(e), reps)
        out["hgo_err"] = max(out["hgo_err"], float(np.max(np.abs(_states(traj) - ref))))
        sysm, s = exp.system, exp.solver
        a = -float(sysm.plant.A[1, 1])
        for method, rtol, atol, max_step in (("DOP853", s.rtol, s.atol, s.h_max),
                                             ("LSODA", 1e-12, 1e-14, np.inf)):
            t0 = time.perf_counter()
            _, w, _ = reference_run(sysm.observers[0], sysm.controller, a, s.t_end, s.dt_out,
                                    method, rtol, atol, with_error=False, max_step=max_step)
            key = method.lower()
            out[f"{key}_s"] += time.perf_counter() - t0
            out[f"{key}_err"] = max(out[f"{key}_err"], float(np.max(np.abs(w - ref))))
    out["ratio_dop853"] = out["dop853_s"] / out["hgo_s"]
    out["ratio_lsoda"] = out["lsoda_s"] / out["hgo_s"]
    return out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true", help="6 of the 30 jobs")
    r = bench(ap.parse_args().quick)
    print(f"moreno_pe ({r['jobs']} jobs x 40 s): hgo {r['hgo_s']:.4f} s (err {r['hgo_err']:.2e}) | "
          f"solve_ivp DOP853 {r['dop853_s']:.2f} s (err {r['dop853_err']:.2e}) ratio "
          f"{r['ratio_dop853']:.0f}x | solve_ivp LSODA {r['lsoda_s']:.2f} s "
          f"(err {r['lsoda_err']:.2e}) ratio {r['ratio_lsoda']:.0f}x")


if __name__ == "__main__":
    main()
