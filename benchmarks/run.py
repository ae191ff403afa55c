"""Benchmark of the hgo engine against solve_ivp and hand-written numba kernels (issue 5).

    python benchmarks/run.py           # full run (~2 min here, < 10 min on 2 cores)
    python benchmarks/run.py --quick   # reduced run (< 60 s after compilation)
    python benchmarks/run.py --only grid,recording,memory   # a subset (see --help)
    python benchmarks/run.py --only apa,dhlm,moreno         # the papers' rows against solve_ivp
    python benchmarks/run.py --only reproduce,startup       # whole-process rows
    python benchmarks/run.py --only hand    # hgo over hand-written kernels (hand_bench.py)

Times are medians of >= 3 runs after compilation (CPU-bound; wall clock), ratios are
taken inside the same run. Prints the tables and ends with one line
``speedup_vs_solve_ivp: A=<x> B=<y> ensemble=<z>``.
"""

from __future__ import annotations

import argparse
import importlib
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
import baselines as bl  # noqa: E402
from problems import (  # noqa: E402
    A_DT_OUT,
    A_NOISE,
    A_NOISE_DT,
    A_SWITCH,
    A_T,
    ATOL_B,
    B_DT,
    B_T,
    FAST_B,
    RTOL_B,
    WP_RTOLS_HGO,
    WP_RTOLS_IVP,
    a_noise,
    a_solver,
    a_system,
    b_errors,
    b_solver,
    b_system,
    compile_times,
    ensemble_inputs,
    ensemble_members,
    fast_label,
)
from timing import interleaved_median_times, median_time, table  # noqa: E402

from hgo.engine.simulate import Noise, SolverSettings, no_noise, simulate, simulate_ensemble  # noqa: E402,E501
from hgo.engine.system import System  # noqa: E402

ROOT = Path(__file__).resolve().parent.parent
SWEEP_ROWS = ("grid", "recording", "memory", "joblib")  # sections of sweeps_bench.py
# repetitions of the millisecond runs of hgo and the hand kernels (medians): their
# distribution here has a long tail (8-13 ms for one 8 ms run), 5 samples are not enough
FAST_REPS = 15
# the papers' benchmark modules (benchmarks/<name>_bench.py) and the key of their speedup
PAPER_ROWS = {"apa": "ratio", "dhlm": "ratio", "moreno": "ratio_dop853"}


# ---------------------------------------------------------------------- main
def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--quick", action="store_true", help="reduced run (< 60 s)")
    ap.add_argument("--only", help="comma-separated subset: core (the issue-5 tables), "
                    "sweeps (all of sweeps_bench.py) or its rows grid, recording, memory, "
                    "joblib; the papers' rows apa, dhlm, moreno; reproduce, startup (whole "
                    "processes); hand (hgo over hand-written kernels, issue 24); default: core, "
                    "sweeps, apa, dhlm, moreno")
    args = ap.parse_args()
    quick = args.quick
    only = set(args.only.split(",")) if args.only else {"core", "sweeps", *PAPER_ROWS}
    rows = only & set(SWEEP_ROWS)
    if "sweeps" in only or rows:  # its own process: sweeps_bench.py imports this module's cases
        subprocess.run([sys.executable, str(Path(__file__).with_name("sweeps_bench.py")),
                        *(["--quick"] if quick else []),
                        *([] if "sweeps" in only else ["--only", ",".join(sorted(rows))])],
                       check=True)
    for name in sorted(only & set(PAPER_ROWS)):
        row = importlib.import_module(f"{name}_bench").bench(quick)
        print(f"\n{name}: {row}\n{name}: speedup_vs_solve_ivp={row[PAPER_ROWS[name]]:.0f}")
    for name in sorted(only & {"reproduce", "startup"}):
        subprocess.run([sys.executable, str(Path(__file__).with_name(f"{name}_bench.py"))],
                       check=True)
    if "core" in only:
        core(quick)
    if "hand" in only:  # last: its final line is hgo_over_hand
        import hand_bench

        hand_bench.bench(quick)


def core(quick: bool) -> None:
    """The issue-5 tables (problems A and B against solve_ivp and the hand kernels)."""
    reps = 3 if quick else 5
    t_start = time.perf_counter()
    print(f"# hgo benchmark ({'quick' if quick else 'full'}), {os.cpu_count()} cores, "
          f"numba threads {__import__('numba').get_num_threads()}")

    # ---------------- problem B, single run
    sysB, solB, solF = b_system(), b_solver(), b_solver(**FAST_B)
    simulate(sysB, solB, no_noise(1))  # compile / load
    simulate(sysB, solF, no_noise(1))
    n_out = int(round(B_T / B_DT)) + 1
    rec = np.zeros((n_out, bl.B_REC))  # what hgo's call records
    acc = np.zeros(sysB.n_acc())  # the window metrics hgo's run computes

    def hand_b():
        return bl.b_kernel(3.0, 3.0, 1.5, B_T, B_DT, RTOL_B, ATOL_B, B_T, B_T / 4, rec, acc)

    hand_b()
    t_ref, ref_b = bl.b_solve_ivp((3.0, 3.0), 1.5, B_T, B_DT, 1e-12, 1e-14, "DOP853",
                                  full=False)
    (tb_fast, tr_f), (tb_hgo, tr), (tb_hand, n_steps) = interleaved_median_times(
        [lambda: simulate(sysB, solF, no_noise(1)), lambda: simulate(sysB, solB, no_noise(1)),
         hand_b], FAST_REPS)
    tb_ivp, (_, y_ivp) = median_time(
        lambda: bl.b_solve_ivp((3.0, 3.0), 1.5, B_T, B_DT, RTOL_B, ATOL_B, full=False), 3)
    tb_ivp5, (_, y_ivp5) = median_time(
        lambda: bl.b_solve_ivp((3.0, 3.0), 1.5, B_T, B_DT, RTOL_B, ATOL_B), 3)
    err_b = {"fast": np.abs(b_errors(tr_f) - ref_b).max(),
             "hgo": np.abs(b_errors(tr) - ref_b).max(),
             "hand": np.abs(bl.b_record_errors(rec) - ref_b).max(),
             "ivp": np.abs(y_ivp - ref_b).max(), "ivp5": np.abs(y_ivp5 - ref_b).max()}
    tol_b = f"rtol {RTOL_B:g} atol {ATOL_B:g}"
    rows_b = [[f"hgo simulate, {fast_label(**FAST_B)}", tb_fast, tb_ivp / tb_fast,
               tb_ivp5 / tb_fast, err_b["fast"]],
              [f"hgo simulate, DOPRI5 {tol_b}", tb_hgo, tb_ivp / tb_hgo, tb_ivp5 / tb_hgo,
               err_b["hgo"]],
              [f"hand-written numba DOPRI5 {tol_b} ({n_steps} steps)", tb_hand,
               tb_ivp / tb_hand, tb_ivp5 / tb_hand, err_b["hand"]],
              [f"solve_ivp RK45 {tol_b}, Python RHS of the error system (20), 3 states",
               tb_ivp, 1.0, tb_ivp5 / tb_ivp, err_b["ivp"]],
              [f"solve_ivp RK45 {tol_b}, Python RHS of plant + observer, 5 states (the ODE "
               "hgo integrates)", tb_ivp5, tb_ivp / tb_ivp5, 1.0, err_b["ivp5"]]]
    table(f"Problem B: S-P error system (20), horizon {B_T:g} s, output every {B_DT} s",
          ["method", "time (s)", "speedup vs solve_ivp (20)", "speedup vs solve_ivp 5 states",
           "max error vs DOP853 1e-12"], rows_b)
    print(f"\nhgo DOPRI5 / hand-written DOPRI5 (same tolerances): {tb_hgo / tb_hand:.2f}x; "
          f"hgo {FAST_B['method']} error <= both solve_ivp errors: "
          f"{'yes' if err_b['fast'] <= min(err_b['ivp'], err_b['ivp5']) else 'NO'}")

    rows_wp, tb_equal = b_work_precision(sysB, ref_b, (tb_ivp, min(err_b["ivp"], err_b["ivp5"])),
                                        quick)
    table("Problem B, work-precision: time against max error (the same grid and reference); "
          "target 1 compares solve_ivp RK45 rtol 1e-8 with the fastest hgo setting at equal "
          "or better accuracy",
          ["method", "time (s)", "max error", "error <= solve_ivp RK45 rtol 1e-8 (20)",
           "speedup vs solve_ivp RK45 rtol 1e-8 (20)"], rows_wp)
    print(f"\nB at equal or better accuracy: {tb_ivp / tb_equal:.0f}x")

    # ---------------- problem B, ensemble
    n_ens = 1000
    p2, e0 = ensemble_members(n_ens)
    params, z0 = ensemble_inputs(sysB, p2, e0)
    acc_h = np.zeros((n_ens, sysB.n_acc()))
    runs = [lambda: simulate_ensemble(sysB, solF, no_noise(1), params, z0),
            lambda: simulate_ensemble(sysB, solB, no_noise(1), params, z0),
            lambda: bl.b_ensemble(e0, p2, B_T, B_DT, RTOL_B, ATOL_B, B_T, B_T / 4, acc_h)]
    for fn in runs:  # compile / load
        fn()
    ens = dict(zip(("fast", "hgo", "hand"), interleaved_median_times(runs, reps),
                   strict=True))
    te_hand = ens["hand"][0]
    tight = simulate_ensemble(sysB, b_solver(method="dop853", rtol=1e-11, atol=1e-13),
                              no_noise(1), params, z0)["acc"][:, :2]
    n_sample = 5 if quick else 20
    t0 = time.perf_counter()
    acc_ivp = np.array([ivp_window_integrals(e0[i], p2[i]) for i in range(n_sample)])
    te_ivp = (time.perf_counter() - t0) / n_sample * n_ens

    def rel_err(a: np.ndarray, n: int) -> float:
        """Largest error of members 0..n-1 relative to the largest tight integral."""
        return float(np.abs(a[:n] - tight[:n]).max() / np.abs(tight[:n]).max())

    def errs(a: np.ndarray) -> list[float | str]:
        return [rel_err(a, n_sample), rel_err(a, n_ens) if len(a) == n_ens else "-"]

    (te_fast, res_f), (te_hgo, res) = ens["fast"], ens["hgo"]
    table(f"Problem B ensemble: {n_ens} members, p2 ~ U[0.5, 3], e(0) ~ U[-3, 3]^2, "
          "window integrals of (x^ - x)^2 over the last 50 s",
          ["method", "wall time (s)", "speedup vs solve_ivp loop",
           f"window integrals: relative error vs DOP853 rtol 1e-11, members 0-{n_sample - 1}",
           "same, all members"],
          [[f"hgo simulate_ensemble (prange), {fast_label(**FAST_B)}", te_fast,
            te_ivp / te_fast, *errs(res_f["acc"][:, :2])],
           [f"hgo simulate_ensemble (prange), DOPRI5 {tol_b}", te_hgo, te_ivp / te_hgo,
            *errs(res["acc"][:, :2])],
           [f"hand-written numba DOPRI5 (prange) {tol_b}", te_hand, te_ivp / te_hand,
            *errs(acc_h[:, :2])],
           [f"solve_ivp RK45 {tol_b} loop over (20) (extrapolated from {n_sample} members)",
            te_ivp, 1.0, *errs(acc_ivp)]])
    print(f"\nhgo DOPRI5 / hand-written DOPRI5: {te_hgo / te_hand:.2f}x; members with "
          f"status != 0: {int((res_f['status'] != 0).sum())} ({FAST_B['method']}), "
          f"{int((res['status'] != 0).sum())} (dopri5)")

    # ---------------- problem A
    sysA, solA, noiseA = a_system(), a_solver(), a_noise()
    simulate(sysA, solA, noiseA)
    s0 = np.concatenate([sysA.plant.x0, sysA.observers[0].z0])
    stab = solA.stability_safety * 2.785
    every = int(round(A_DT_OUT / A_NOISE_DT))
    n_rec = int(round(A_T / A_DT_OUT)) + 1
    rec_a = np.zeros((n_rec, bl.A_REC))  # what hgo's call records
    rec_ref = np.zeros((n_rec, bl.A_REC))
    acc_a = np.zeros(sysA.n_acc())  # the window metrics hgo's run computes
    vA = noiseA.samples[:, 0].copy()

    def hand_a():
        return bl.a_kernel(s0, vA, A_NOISE_DT, A_T, A_SWITCH, stab, every, rec_a,
                           solA.t_window, acc_a)

    hand_a()
    bl.a_kernel(s0, vA, A_NOISE_DT, A_T, A_SWITCH, stab / 8, every, rec_ref, 0.0,
                np.zeros(5))  # reference
    (ta_hgo, trA), (ta_hand, n_steps_a) = interleaved_median_times(
        [lambda: simulate(sysA, solA, noiseA), hand_a], FAST_REPS)
    hgo_a = np.c_[trA.z[:, :3], trA.z[:, 3:5]]
    # solve_ivp: segment by segment; a sample of segments before and after the switch,
    # extrapolated (the full run takes ~15-30 s per repetition)
    n_seg = int(round(A_T / A_NOISE_DT))
    n_before = int(round(A_SWITCH / A_NOISE_DT))
    n_smp = 60 if quick else 250
    t0 = time.perf_counter()
    out_ivp = bl.a_solve_ivp(s0, vA, A_NOISE_DT, A_T, A_SWITCH, 1e-6, 1e-9,
                             n_segments=n_smp)
    t_first = time.perf_counter() - t0
    # second sample: after the switch, started from the reference state at a noise instant
    start = n_before + 500
    s_start = bl_state_at(s0, vA, stab / 8, start)
    t0 = time.perf_counter()
    bl_a_segments(s_start, vA, start, n_smp)
    t_after = time.perf_counter() - t0
    ta_ivp = t_first / n_smp * n_before + t_after / n_smp * (n_seg - n_before)
    ta_ivp_measured = None
    err_ivp_a = np.abs(out_ivp[::every][: n_smp // every + 1]
                       - rec_ref[: n_smp // every + 1, :5]).max()
    if not quick:  # one full solve_ivp run: measured time and error over the horizon
        t0 = time.perf_counter()
        out_full = bl.a_solve_ivp(s0, vA, A_NOISE_DT, A_T, A_SWITCH, 1e-6, 1e-9)
        ta_ivp_measured = time.perf_counter() - t0
        err_ivp_a = np.abs(out_full[::every] - rec_ref[:, :5]).max()
        ta_ivp = ta_ivp_measured
    err_a = {"hgo": np.abs(hgo_a - rec_ref[:, :5]).max(),
             "hand": np.abs(rec_a[:, :5] - rec_ref[:, :5]).max()}
    rows_a = [["hgo simulate (RK4, step from the active gain's margin)", ta_hgo,
               ta_ivp / ta_hgo, err_a["hgo"]],
              ["hand-written numba RK4", ta_hand, ta_ivp / ta_hand, err_a["hand"]],
              ["solve_ivp RK45 (rtol 1e-6, atol 1e-9), Python RHS, per noise segment"
               + (" (extrapolated)" if ta_ivp_measured is None else " (1 full run)"),
               ta_ivp, 1.0, err_ivp_a]]
    table(f"Problem A: DC motor + switched HGO (eps 5e-4 -> 0.01 at t = {A_SWITCH:g} s), "
          f"noise +-{A_NOISE} held {A_NOISE_DT * 1e3:g} ms, horizon {A_T:g} s, output "
          f"every {A_DT_OUT} s ({n_steps_a} RK4 steps)",
          ["method", "time (s)", "speedup vs solve_ivp", "max error vs RK4 h/8"], rows_a)
    print(f"\nhgo / hand-written: {ta_hgo / ta_hand:.2f}x; hgo status {trA.status}; "
          f"gain switches {int(trA.d[-1, 4])} at t = {trA.d[-1, 5]:.4f} s")

    # ---------------- compile times
    rows_c = []
    labels = {"B": "B, DOPRI5", "B853": f"B, {fast_label(**FAST_B)}", "A": "A, RK4"}
    for prob in (("B853",) if quick else ("B", "B853", "A")):
        rows_c.append([labels[prob], *compile_times(prob)])
    table("Compilation (fresh process): time of the first simulate() minus a steady run",
          ["problem", "empty caches (s)", "new kernel, helpers cached (s)",
           "later process, all cached (s)"], rows_c)

    # ---------------- logging
    n_log = 10**6
    rows_l = [logging_row(f"B: {B_T:g} s, output every {B_T / n_log * 1e3:g} ms, "
                          f"{fast_label(**FAST_B)}", sysB,
                          b_solver(dt_out=B_T / n_log, **FAST_B), no_noise(1), reps, quick)]
    if not quick:  # A over 800 s, output at every noise sample (0.8 ms)
        t_a = n_log * A_NOISE_DT
        rows_l.append(logging_row(
            f"A: {t_a:g} s, output every {A_NOISE_DT * 1e3:g} ms (each noise sample), RK4",
            sysA, SolverSettings(t_end=t_a, dt_out=A_NOISE_DT, method="rk4", h_max=1.0),
            a_noise(t_end=t_a), 3, quick))
    table("Logging: runs of 1,000,001 output samples (write_recording of every series "
          "the runner logs)",
          ["run", "columns", "simulate (s)", "write_recording (s)", "logging / simulation",
           "file (MB)", "floor: same columns as uncompressed Arrow IPC (s)",
           "floor / simulation"], rows_l)

    # ---------------- scaling
    rows_h = []
    for k in ([1, 10] if quick else [1, 10, 100]):
        sol = b_solver(t_end=B_T * k, **FAST_B)
        simulate(sysB, sol, no_noise(1))
        th, _ = median_time(lambda sol=sol: simulate(sysB, sol, no_noise(1)),
                            FAST_REPS if k < 100 else 5)  # the 1.5 ms run has a long tail
        rows_h.append([f"{B_T * k:g} s ({k}x)", th, th / k, th / k / rows_h[0][1]
                       if rows_h else 1.0])
    table(f"Scaling with the horizon (problem B, single run, output every 0.01 s, "
          f"{fast_label(**FAST_B)})",
          ["horizon", "time (s)", "time / k", "relative cost per unit horizon"], rows_h)
    rows_e = []
    sizes = [10, 100, 1000] if quick else [10, 100, 1000, 10000]
    for n in sizes:
        p2n, e0n = ensemble_members(n, seed=1)
        pn, zn = ensemble_inputs(sysB, p2n, e0n)
        tn, _ = median_time(lambda pn=pn, zn=zn: simulate_ensemble(sysB, solF, no_noise(1),
                                                                      pn, zn),
                            3 if n < (1000 if quick else 10000) else 1)
        rows_e.append([n, tn, tn / n * 1e3])
    per = [r[2] for r in rows_e]
    table(f"Scaling with the ensemble size (problem B, 200 s, {fast_label(**FAST_B)})",
          ["members", "wall time (s)", "ms per member"], rows_e)
    print(f"\nper-member cost at {sizes[-1]} vs {sizes[1]}: {per[-1] / per[1]:.2f}x")
    print(f"\ntotal benchmark time {time.perf_counter() - t_start:.0f} s")
    print(f"more: B_equal_accuracy={tb_ivp / tb_equal:.0f} B_same_ode={tb_ivp5 / tb_fast:.0f} "
          f"ensemble_wall_s={te_fast:.2f}")
    # the last line, numbers only, as the issue asks (tracked over time)
    print(f"speedup_vs_solve_ivp: A={ta_ivp / ta_hgo:.0f} B={tb_ivp / tb_fast:.0f} "
          f"ensemble={te_ivp / te_fast:.0f}")


def b_work_precision(system: System, ref: np.ndarray, ivp: tuple[float, float],
                     quick: bool) -> tuple[list[list], float]:
    """Rows (method, time, error, error <= solve_ivp's, speedup) of hgo DOP853 over
    ``WP_RTOLS_HGO`` (timed interleaved) and of solve_ivp RK45 on (20) over
    ``WP_RTOLS_IVP``; and the time of the fastest hgo setting at least as accurate as
    solve_ivp RK45 at rtol 1e-8 (``ivp`` = its time and error)."""
    t_ivp, err_ivp = ivp
    sols = [b_solver(method="dop853", rtol=r, atol=r / 100) for r in WP_RTOLS_HGO]
    for sol in sols:
        simulate(system, sol, no_noise(1))
    timed = interleaved_median_times([lambda sol=sol: simulate(system, sol, no_noise(1))
                                      for sol in sols], FAST_REPS)
    runs = [(f"hgo simulate, {fast_label(sol.method, sol.rtol, sol.atol)}", t,
             float(np.abs(b_errors(tr) - ref).max())) for sol, (t, tr) in zip(sols, timed,
                                                                              strict=True)]
    t_equal = min(t for _, t, err in runs if err <= err_ivp)
    for r in () if quick else WP_RTOLS_IVP:
        t, (_, y) = median_time(lambda r=r: bl.b_solve_ivp((3.0, 3.0), 1.5, B_T, B_DT, r,
                                                            r / 100, full=False), 1)
        runs.append((f"solve_ivp RK45 rtol {r:g} atol {r / 100:g} (20)", t,
                     float(np.abs(y - ref).max())))
    runs.append((f"solve_ivp RK45 rtol {RTOL_B:g} atol {ATOL_B:g} (20)", t_ivp, err_ivp))
    rows = [[label, t, err, "yes" if err <= err_ivp else "no", t_ivp / t]
            for label, t, err in sorted(runs, key=lambda row: row[2])]
    return rows, t_equal


def logging_row(label: str, system: System, solver: SolverSettings, noise: Noise, reps: int,
                quick: bool) -> list:
    """Simulate one run and write its recording: both times, their ratio, the file size."""
    from hgo.outputs.recording import write_recording
    from hgo.running.runner import signals

    simulate(system, solver, noise)
    t_sim, tr = median_time(lambda: simulate(system, solver, noise), reps)
    series = signals(system, tr)
    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / "run.rrd"
        t_log, _ = median_time(lambda: write_recording(path, tr.t, series,
                                                       recording_id="bench"),
                               1 if quick else 3)
        size = path.stat().st_size
        t_raw, _ = median_time(lambda: raw_columns(Path(tmp) / "run.arrow", tr.t, series),
                               1 if quick else 3)
    columns = sum(len(s.names) for s in series)
    return [label, f"{columns} in {len(series)} entities", t_sim, t_log, t_log / t_sim,
            size / 1e6, t_raw, t_raw / t_sim]


def raw_columns(path: Path, t: np.ndarray, series) -> None:
    """The cheapest full-rate columnar file of a run: its columns as one uncompressed
    Arrow IPC (Feather v2) file, no Rerun. A lower bound for any full-rate recording."""
    import pyarrow as pa
    import pyarrow.feather as feather

    columns = {"t": t}
    for s in series:
        columns.update({f"{s.entity}/{n}": s.values[:, j] for j, n in enumerate(s.names)})
    feather.write_feather(pa.table(columns), path, compression="uncompressed")


def ivp_window_integrals(e0, p2) -> np.ndarray:
    """solve_ivp on (20) for one member: trapezoid integrals of e1^2, e2^2 over the window
    (the last quarter of the horizon, as hgo's metrics)."""
    t, y = bl.b_solve_ivp(e0, p2, B_T, B_DT, RTOL_B, ATOL_B, full=False)
    w = t >= B_T * 3 / 4 - 1e-9
    return np.array([np.trapezoid(y[w, j] ** 2, t[w]) for j in (0, 1)])


def bl_state_at(s0, v, stab, k):
    """Reference state at noise instant k (hand RK4 with a small step)."""
    rec = np.zeros((k + 1, bl.A_REC))
    bl.a_kernel(s0, v[: k + 1].copy(), A_NOISE_DT, k * A_NOISE_DT, A_SWITCH, stab, 1, rec, 0.0,
                np.zeros(5))
    return rec[-1, :5]


def bl_a_segments(s, v, start, n):
    """solve_ivp RK45 over noise segments start .. start + n (timing sample)."""
    for k in range(start, start + n):
        t0, t1 = k * A_NOISE_DT, (k + 1) * A_NOISE_DT
        eps, a1, a2 = bl.a_gains(t0, A_SWITCH)
        sol = bl.solve_ivp(bl.a_rhs_py, (t0, t1), s, method="RK45", rtol=1e-6, atol=1e-9,
                           args=(eps, a1, a2, v[k]))
        s = sol.y[:, -1]
    return s


if __name__ == "__main__":
    main()
