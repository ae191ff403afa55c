"""Sweeps at scale (issue 17): grid ensembles, recording modes, sweep memory, joblib.

    python benchmarks/sweeps_bench.py [--quick] [--only grid,recording,memory,joblib]
    python benchmarks/run.py --only sweeps [--quick]      # the same rows from run.py

Rows (ratios are taken inside the same run; the machine may be shared):

* grid: the 52-point ``ak_tradeoff_grid`` (one compiled ensemble call + the trade-off
  report) warm in-process (median of 3) and as a whole process (``experiments/run.py``,
  caches warm: median of 5 after one warm-up run); the multirun ``-m experiment=ak_tradeoff`` it
  replaces (full run only); a 10,000-point grid over the Sanfelice & Praly oscillation
  (``sp_ensemble`` with ``ensemble.grid`` of 100 p2 x 100 x^1(0), 200 s, DOP853), warm
  in-process and whole process.
* recording: problems A and B of ``run.py`` with 1,000,001 output samples: simulation,
  ``write_recording`` of every series (full) and the decimated recording (min/max
  envelope into 2^14 rows, :mod:`hgo.outputs.decimate`, envelope included), against the
  simulation.
* memory: a Hydra sweep of 1,000,001-sample runs (S-P ``sp_example``, 100 s output every
  0.1 ms, full recordings) and, full run only, the same number of tiny jobs (what Hydra
  and hgo keep per job): each job's own peak resident size (the process's peak is reset
  at every job start) and the resident size after it, with their trends over the jobs
  after the warm-up. Flat: the trend of the job peaks is zero within its 95 % interval
  (the sweep's peak is then the largest of equally distributed job peaks, not a growth)
  and what stays resident grows by no more than the tiny jobs' (Hydra's) per-job amount.
* joblib: 4-job multiruns of ``sp_example`` (t_end 20,000 s and 40,000 s: jobs of >= 1 s;
  one job's logged simulation time is printed), sequential against
  ``hydra/launcher=joblib`` with 2 workers, whole multirun wall time.
"""

from __future__ import annotations

import argparse
import gc
import itertools
import json
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np
from hydra.experimental.callback import Callback

BENCH = Path(__file__).resolve().parent
ROOT = BENCH.parent
sys.path.insert(0, str(BENCH))
RUN = [sys.executable, str(ROOT / "experiments" / "run.py")]
DECIMATED_ROWS = 2**14
SP_GRID_N = 100  # 100 x 100 points


def _env() -> dict:
    paths = [str(ROOT), str(BENCH), os.environ.get("PYTHONPATH", "")]
    return dict(os.environ, PYTHONPATH=os.pathsep.join(p for p in paths if p))


def _wall(args: list[str]) -> float:
    """Wall time of a subprocess (it must succeed)."""
    t0 = time.perf_counter()
    subprocess.run(args, cwd=ROOT, env=_env(), check=True, capture_output=True, text=True)
    return time.perf_counter() - t0


def sp_grid_override(n: int = SP_GRID_N) -> str:
    p2 = ", ".join(f"{v:.6g}" for v in np.linspace(0.5, 3.0, n))
    e0 = ", ".join(f"[{v:.6g}, 1.0]" for v in np.linspace(-3.0, 3.0, n))
    return ("++ensemble.grid={observer.sign_indefinite.p2: [" + p2 + "], "
            "observer.sign_indefinite.xhat0: [" + e0 + "]}")


def _in_process(overrides: list[str], reps: int) -> tuple[float, object]:
    """Median wall time of run_ensemble (compose excluded) after one warm-up run."""
    from hgo.core.config import compose
    from hgo.running.ensemble_runner import run_ensemble

    with tempfile.TemporaryDirectory() as tmp:
        cfg = compose(overrides, Path(tmp))
        result = run_ensemble(cfg, tmp)
        times = []
        for _ in range(reps):
            t0 = time.perf_counter()
            result = run_ensemble(cfg, tmp)
            times.append(time.perf_counter() - t0)
    return float(np.median(times)), result


def grid_rows(quick: bool) -> list[list]:
    rows = []
    t_ak, res = _in_process(["experiment=ak_tradeoff_grid"], 3)
    n_ak = len(res.status)
    with tempfile.TemporaryDirectory() as tmp:
        cmd = [*RUN, "experiment=ak_tradeoff_grid", f"hydra.run.dir={tmp}/g"]
        _wall(cmd)
        w_ak = float(np.median([_wall(cmd) for _ in range(5)]))  # whole warm processes
        w_multi = None if quick else _wall([*RUN, "-m", "experiment=ak_tradeoff",
                                            f"hydra.sweep.dir={tmp}/m"])
    rows.append([f"AK trade-off grid, {n_ak} points (ak_tradeoff_grid)", t_ak, w_ak,
                 "-" if w_multi is None else f"{w_multi:.3g}",
                 "-" if w_multi is None else f"{w_multi / w_ak:.1f}x"])
    sp = ["experiment=sp_ensemble", "ensemble.size=0", sp_grid_override()]
    t_sp, res = _in_process(sp, 1)
    with tempfile.TemporaryDirectory() as tmp:
        w_sp = _wall([*RUN, *sp, f"hydra.run.dir={tmp}/s"])
    rows.append([f"S-P grid, {len(res.status)} points (sp_ensemble, 200 s, DOP853)", t_sp,
                 w_sp, "-", "-"])
    return rows


def recording_rows(quick: bool) -> list[list]:
    import problems as b

    from hgo.engine.simulate import SolverSettings, no_noise, simulate
    from hgo.outputs.decimate import envelope
    from hgo.outputs.recording import write_recording
    from hgo.running.runner import signals

    n_log = 10**6
    cases = [(f"B: {b.B_T:g} s, output every {b.B_T / n_log * 1e3:g} ms, "
              f"{b.fast_label(**b.FAST_B)}", b.b_system(),
              b.b_solver(dt_out=b.B_T / n_log, **b.FAST_B), no_noise(1))]
    t_a = n_log * b.A_NOISE_DT
    cases.append((f"A: {t_a:g} s, output every {b.A_NOISE_DT * 1e3:g} ms, RK4", b.a_system(),
                  SolverSettings(t_end=t_a, dt_out=b.A_NOISE_DT, method="rk4", h_max=1.0),
                  b.a_noise(t_end=t_a)))
    reps = 1 if quick else 3
    rows = []
    for label, system, solver, noise in cases:
        simulate(system, solver, noise)
        tr = simulate(system, solver, noise)
        series = signals(system, tr)
        with tempfile.TemporaryDirectory() as tmp:
            path = Path(tmp) / "run.rrd"

            def full(path=path, tr=tr, series=series):
                write_recording(path, tr.t, series, recording_id="bench")

            fresh = itertools.count()

            def decimated(tmp=tmp, tr=tr, series=series, fresh=fresh):
                # a new file each time, as a run writes (replacing the last one would add
                # its unlinking, 1-2 ms here, to a write that takes a few ms)
                t_d, s_d = envelope(tr.t, series, DECIMATED_ROWS)
                return write_recording(Path(tmp) / f"dec{next(fresh)}.rrd", t_d, s_d,
                                       recording_id="bench")

            # the cheap pair interleaved (same conditions), the full write apart: its
            # release of ~240 MB of Arrow buffers would land in the next timing
            (t_sim, _), (t_dec, dec_path) = b.interleaved_median_times(
                [lambda s=system, so=solver, n=noise: simulate(s, so, n), decimated],
                3 * b.FAST_REPS // 5 if quick else b.FAST_REPS)
            size_dec = dec_path.stat().st_size
            (t_full, _), = b.interleaved_median_times([full], reps)
        rows.append([label, t_sim, t_full, t_full / t_sim, t_dec, t_dec / t_sim,
                     size_dec / 1e6])
    return rows


def _proc_status_kb(key: str) -> int:
    """A ``kB`` field of /proc/self/status (``VmHWM``: peak resident, ``VmRSS``: resident)."""
    with open("/proc/self/status") as fh:
        return next(int(line.split()[1]) for line in fh if line.startswith(key + ":"))


class PeakRSS(Callback):
    """Hydra callback: appends ``job_number job_peak_kB resident_after_kB`` at each job end.

    The job's own peak: the process's peak resident size is reset when the job starts
    (``5`` to /proc/self/clear_refs, Linux), so each job's peak is measured on its own
    and a trend over the jobs shows; the sweep's peak is the largest of them. Resident
    after the job: after the job's arrays are freed and a garbage collection, what the
    process keeps from one job to the next."""

    def __init__(self, path: str) -> None:
        self.path = path

    def on_job_start(self, config, **kwargs) -> None:
        with open("/proc/self/clear_refs", "w") as fh:
            fh.write("5")

    def on_job_end(self, config, job_return, **kwargs) -> None:
        peak = _proc_status_kb("VmHWM")
        gc.collect()
        with open(self.path, "a") as fh:
            fh.write(f"{config.hydra.job.num} {peak} {_proc_status_kb('VmRSS')}\n")


def _trend(y: np.ndarray) -> tuple[float, float]:
    """Least-squares slope of y over its index, and its 95 % half-width (normal)."""
    x = np.arange(len(y), dtype=float)
    slope, intercept = np.polyfit(x, y, 1)
    residuals = y - (slope * x + intercept)
    se = np.sqrt(residuals @ residuals / (len(y) - 2) / ((x - x.mean()) @ (x - x.mean())))
    return float(slope), float(1.96 * se)


def _sweep_memory(tmp: str, name: str, n_jobs: int, overrides: list[str]) -> tuple:
    """(wall s, job peaks MB, resident after each job MB, first job's recording MB)."""
    log = Path(tmp) / f"{name}.txt"
    t0 = time.perf_counter()
    subprocess.run([*RUN, "-m", *overrides, f"seed=range({n_jobs})",
                    f"hydra.sweep.dir={tmp}/{name}",
                    "+hydra.callbacks.rss._target_=sweeps_bench.PeakRSS",
                    f"+hydra.callbacks.rss.path={log}"],
                   cwd=ROOT, env=_env(), check=True, capture_output=True, text=True)
    wall = time.perf_counter() - t0
    rows = np.loadtxt(log, dtype=np.int64).reshape(-1, 3)
    rows = rows[np.argsort(rows[:, 0])]
    rrd = Path(tmp) / name / "job0" / "recording.rrd"
    return wall, rows[:, 1] / 1024, rows[:, 2] / 1024, rrd.stat().st_size / 1e6 if \
        rrd.exists() else 0.0


WARM_UP = 10  # jobs before the trends are fitted (imports, caches, the first kernels)


def memory_rows(quick: bool) -> list[list]:
    """A sweep of 1e6-sample runs, and (full run only) the same number of tiny jobs: the
    per-job peaks and what stays resident between jobs, with their trends after
    :data:`WARM_UP` jobs."""
    n_jobs = 20 if quick else 100
    sweeps = [("big", "1,000,001 samples (sp_example, full recordings)",
               ["experiment=sp_example", "solver.t_end=100", "solver.dt_out=0.0001",
                "metrics.window=25"])]
    if not quick:
        sweeps.append(("tiny", "tiny jobs (sp_example, 1 s, no recording)",
                       ["experiment=sp_example", "solver.t_end=1", "metrics.window=0",
                        "recording=off", "figures=null"]))
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        for name, label, overrides in sweeps:
            wall, peaks, resident, rrd_mb = _sweep_memory(tmp, name, n_jobs, overrides)
            slope, half = _trend(peaks[WARM_UP:])
            r_slope, r_half = _trend(resident[WARM_UP:])
            marks = [0, WARM_UP - 1, n_jobs // 2 - 1, n_jobs - 1]
            rows.append([f"{n_jobs} jobs of {label}" + (f", {rrd_mb:.0f} MB .rrd each"
                                                         if rrd_mb else ""), wall,
                         " / ".join(f"{peaks[m]:.0f}" for m in marks), float(peaks.max()),
                         f"{100 * slope:+.1f} ± {100 * half:.1f}",
                         " / ".join(f"{resident[m]:.0f}" for m in marks),
                         f"{1024 * r_slope:+.0f} ± {1024 * r_half:.0f}",
                         "yes" if abs(slope) <= half else "no"])
    return rows


def joblib_rows(quick: bool) -> list[list]:
    """Sequential against joblib (2 workers): 4 jobs of sp_example, t_end 20,000 s (one
    job ~1 s on an idle machine) and, full run only, 40,000 s; whole multirun wall times,
    sequential and joblib interleaved, median of 3 pairs (1 with --quick)."""
    rows = []
    reps = 1 if quick else 3
    for t_end in ([20000.0] if quick else [20000.0, 40000.0]):
        args = ["-m", "experiment=sp_example", f"solver.t_end={t_end:g}",
                "solver.dt_out=0.1", "recording=off", "seed=0,1,2,3"]
        with tempfile.TemporaryDirectory() as tmp:
            _wall([*RUN, *args[:-1], "seed=0", f"hydra.sweep.dir={tmp}/w"])  # compile
            job = _job_seconds([*RUN, *args[:-1], "seed=0", f"hydra.sweep.dir={tmp}/j"],
                               Path(tmp) / "j")
            seq, par = [], []
            for k in range(reps):
                seq.append(_wall([*RUN, *args, f"hydra.sweep.dir={tmp}/s{k}"]))
                par.append(_wall([*RUN, *args, "hydra/launcher=joblib",
                                  "hydra.launcher.n_jobs=2", f"hydra.sweep.dir={tmp}/p{k}"]))
        seq_s, par_s = float(np.median(seq)), float(np.median(par))
        rows.append([f"4 jobs of sp_example t_end={t_end:g} s", job, seq_s, par_s,
                     seq_s / par_s, _load()])
    return rows


def _load() -> str:
    """The 1-minute load average now (the machine may be shared)."""
    return f"{os.getloadavg()[0]:.1f}"


def _job_seconds(cmd: list[str], sweep: Path) -> float:
    """The simulation seconds a job records in its run.json (one job of the sweep)."""
    subprocess.run(cmd, cwd=ROOT, env=_env(), check=True, capture_output=True, text=True)
    info = json.loads(next(sweep.glob("*/run.json")).read_text())
    return float(info["seconds"]["simulate"])


def bench(quick: bool, only: set[str] | None = None) -> dict:
    """Print the tables; returns the headline numbers."""
    from timing import table

    out: dict = {}
    if only is None or "grid" in only:
        rows = grid_rows(quick)
        table("Grid ensembles: one compiled call (in-process: run_ensemble after a warm-up; "
              "whole process: experiments/run.py, caches warm)",
              ["grid", "in-process warm (s)", "whole process (s)",
               "multirun -m of the same points (s)", "multirun / whole process"], rows)
        out.update(ak_grid_s=rows[0][2], sp_grid_s=rows[1][2])
    if only is None or "recording" in only:
        rows = recording_rows(quick)
        table(f"Recording modes: 1,000,001 samples, full against decimated "
              f"({DECIMATED_ROWS} rows, min/max envelope)",
              ["run", "simulate (s)", "write full (s)", "full / simulation",
               "write decimated (s)", "decimated / simulation", "decimated file (MB)"], rows)
        out.update(decimated_over_sim_B=rows[0][5], decimated_over_sim_A=rows[1][5])
    if only is None or "memory" in only:
        rows = memory_rows(quick)
        table(f"Sweep memory (MB): each job's own peak resident size and the resident size "
              f"after it, at jobs 1 / {WARM_UP} / half / last; trends fitted over jobs "
              f"{WARM_UP + 1}..N (least squares, ± 95 %)",
              ["sweep", "wall (s)", "job peak", "sweep peak", "job peak trend (MB per 100 "
               "jobs)", "resident after job", "resident trend (KB per job)",
               "flat: no job-peak trend (0 within ± 95 %)"], rows)
        out.update(sweep_peak_mb=rows[0][3])
    if only is None or "joblib" in only:
        rows = joblib_rows(quick)
        table("Local parallelism: 4-job multirun, sequential against joblib (2 workers)",
              ["sweep", "one job's simulation (s)", "sequential (s)", "joblib n_jobs=2 (s)",
               "speedup", "load average"], rows)
        out.update(joblib_speedup=rows[0][-2])
    return out


if __name__ == "__main__":
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true")
    ap.add_argument("--only", help="comma-separated: grid, recording, memory, joblib")
    args = ap.parse_args()
    result = bench(args.quick, set(args.only.split(",")) if args.only else None)
    print("\nsweeps: " + " ".join(f"{k}={v:.3g}" for k, v in result.items()))
