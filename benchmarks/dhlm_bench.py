"""Dimassi et al. example (robot arm + HGO/adaptive cascade): hgo against solve_ivp.

    python benchmarks/dhlm_bench.py [--quick]

The problem: the ``dhlm_example`` preset (1 ms output grid, 8 states [x, z_h, x^, theta^]).
hgo runs through its normal path (compose -> build -> ``run_experiment`` =
``hgo.engine.simulate.simulate``, DOP853), after one compiling run, median of 5 runs, no
post-processing (it is not integration). The baseline is ``scipy.integrate.solve_ivp``
RK45 with the plain-Python right-hand side of :mod:`hgo.papers.dimassi.reference` on the
same grid (RK45 is usable: the HGO poles, -333 and -667 s^-1, only cap its step at ~5 ms).
Errors: max over the grid and the 8 states of |w - w_ref| / max(1, max |w_ref|), against
solve_ivp DOP853 rtol = atol = 1e-13.

Two rows, both at equal or better accuracy for hgo (as in benchmarks/README.md, problem B):

* ``baseline``: solve_ivp RK45 at a user's usual rtol 1e-8 (atol 1e-10) against the fastest
  hgo DOP853 rtol in (1e-6, 3e-7, ..., 1e-10) (atol = rtol/100) whose error is <= RK45's;
* ``preset``: hgo at the preset's rtol 1e-10 against the loosest RK45 rtol in
  (1e-8, 3e-9, ..., 1e-12) whose error is <= hgo's (solve_ivp at equal or better accuracy).

Horizon 20 s (quick: 5 s).
"""

from __future__ import annotations

import argparse
import statistics
import time

import numpy as np
from scipy.integrate import solve_ivp

from hgo.config import compose
from hgo.papers.dimassi.reference import X0, Example
from hgo.runner import build, run_experiment

RTOLS_HGO = (1e-6, 3e-7, 1e-7, 3e-8, 1e-8, 3e-9, 1e-9, 3e-10, 1e-10)
RTOLS_IVP = (1e-8, 3e-9, 1e-9, 3e-10, 1e-10, 3e-11, 1e-11, 3e-12, 1e-12)


def _err(w: np.ndarray, ref: np.ndarray) -> float:
    scale = np.maximum(1.0, np.max(np.abs(ref), axis=0))
    return float(np.max(np.abs(w - ref) / scale))


def _ivp(t_eval: np.ndarray, method: str, rtol: float, atol: float):
    t0 = time.perf_counter()
    sol = solve_ivp(Example().rhs, (0.0, t_eval[-1]), X0, method=method, rtol=rtol, atol=atol,
                    t_eval=t_eval)
    return sol.y.T, time.perf_counter() - t0


def _hgo(horizon: float, rtol: float):
    """(samples of the 8 states, median wall time of 5 runs) at this DOP853 rtol."""
    cfg = compose(["experiment=dhlm_example", f"solver.t_end={horizon}",
                   f"metrics.window={horizon / 2}", "postprocess=none",
                   f"solver.rtol={rtol}", f"solver.atol={rtol / 100}"])
    exp = build(cfg)
    run_experiment(exp)  # compile (or load the cached kernel)
    times = []
    for _ in range(5):
        t0 = time.perf_counter()
        traj = run_experiment(exp)
        times.append(time.perf_counter() - t0)
    return traj.t, traj.z[:, :8], statistics.median(times)


def bench(quick: bool = False) -> dict:
    """Both rows (see the module docstring): times, errors, ratios."""
    horizon = 5.0 if quick else 20.0
    t, _, _ = _hgo(horizon, 1e-10)
    ref, _ = _ivp(t, "DOP853", 1e-13, 1e-13)
    ivp8, t_ivp8 = _ivp(t, "RK45", 1e-8, 1e-10)
    err_ivp8 = _err(ivp8, ref)
    for rtol in RTOLS_HGO:  # fastest hgo setting at least as accurate as RK45 rtol 1e-8
        _, w, t_h = _hgo(horizon, rtol)
        if _err(w, ref) <= err_ivp8:
            break
    base = {"rtol_hgo": rtol, "t_hgo": t_h, "err_hgo": _err(w, ref), "rtol_ivp": 1e-8,
            "t_ivp": t_ivp8, "err_ivp": err_ivp8}
    _, w, t_h = _hgo(horizon, 1e-10)
    err_h = _err(w, ref)
    for rtol in RTOLS_IVP:  # loosest RK45 at least as accurate as hgo's preset
        v, t_i = _ivp(t, "RK45", rtol, rtol * 1e-2)
        if _err(v, ref) <= err_h:
            break
    preset = {"rtol_hgo": 1e-10, "t_hgo": t_h, "err_hgo": err_h, "rtol_ivp": rtol,
              "t_ivp": t_i, "err_ivp": _err(v, ref)}
    for row in (base, preset):
        row["equal_or_better"] = row["err_hgo"] <= row["err_ivp"]
        row["ratio"] = row["t_ivp"] / row["t_hgo"]
    return {"problem": f"dhlm_example ({horizon:g} s)", "baseline": base, "preset": preset,
            "ratio": base["ratio"]}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="5 s horizon")
    r = bench(parser.parse_args().quick)
    for name in ("baseline", "preset"):
        row = r[name]
        print(f"{r['problem']} [{name}]: hgo DOP853 rtol {row['rtol_hgo']:g} "
              f"{row['t_hgo'] * 1e3:.2f} ms (err {row['err_hgo']:.2e}) | solve_ivp RK45 rtol "
              f"{row['rtol_ivp']:g} {row['t_ivp']:.3f} s (err {row['err_ivp']:.2e}) | hgo error "
              f"<= solve_ivp's: {row['equal_or_better']} | ratio {row['ratio']:.0f}x")


if __name__ == "__main__":
    main()
