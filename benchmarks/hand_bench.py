"""hgo against hand-written numba kernels of the same method (issue 24, item 5).

    python benchmarks/run.py --only hand          # or: python benchmarks/hand_bench.py
    python benchmarks/hand_bench.py --outputs     # DHLM, Moreno: outputs against steps
    python benchmarks/hand_bench.py --signals     # Moreno: the cost of recording u, y, x^
    python benchmarks/hand_bench.py --only=DHLM,Moreno   # those ratios alone
    python benchmarks/hand_bench.py --composition  # DHLM, Moreno: boundary, integrator, components
    python benchmarks/hand_bench.py --processes=5 [--only=...] [--pin]  # 5 fresh processes

For each problem, hgo's whole in-process call as a user's script makes it (the system or
experiment built once; then ``simulate(system, solver, noise)`` or
``run_experiment(experiment)``: its Python set-up, the Ctrl-C watch (``hgo.engine.interrupt``), the
compiled integration, the output arrays) against a hand-written numba kernel of the same
method, tolerances and steps, checked to give the same trajectory (max |difference| over
the grid, relative to max(1, max |state|) per state, printed). Times: CPU seconds of the
process (all its threads), medians of interleaved calls (``REPS``).

* A: switched DC motor (``problems.a_system``), RK4, against ``baselines.a_kernel``;
* B: Sanfelice & Praly (20) (``problems.b_system``), DOPRI5 rtol 1e-8, against
  ``hand_unrolled``'s DOPRI5 kernel of B (hgo's 5 states, plant and observer; 1.2x faster
  than ``baselines.b_kernel``, the loop-over-arrays kernel that was the yardstick before);
* APA: ``experiment=apa_fig2`` (T = 50, noise held 0.01, three observers integrated apart),
  DOP853 rtol 1e-8, against ``hand_unrolled.apa_unrolled`` (one per observer). The df2max
  observer's x^2 crosses its saturation bounds ~2.3 times per noise sample; its steps
  there depend on round-off, so its x^2 differs by up to ~1e-5 and its eta^2 (through the
  saturation) by up to ~2e-4 (the same arithmetic in another order; hgo's own kernel moves
  as much between builds: tests/test_preset_metrics); every other column to ~3e-7;
* DHLM: ``experiment=dhlm_example``, DOP853 rtol 1e-10, against
  ``hand_unrolled.dhlm_unrolled``;
* Moreno: ``experiment=moreno_pe`` (x2 = 2 sin t, a = 0.5, l2 = 120), DOP853 rtol 1e-10,
  against ``hand_unrolled.moreno_unrolled``.

The adaptive kernels (B, APA, DHLM, Moreno) are ``hand_unrolled``'s (issue 41): DOPRI5 or
DOP853 written out stage by stage with scalar locals and the problem's right-hand side
inlined, hgo's fast-math flags; on DHLM 1.4-1.55x faster than ``hand_dop853``'s
loop-over-arrays kernel (``dop853_kernel`` of ``dhlm_f``: ``hand_papers.dhlm_kernel``
until 07cc137), the yardstick of DHLM before 2026-12-01 and of APA and Moreno until
2026-12-01 evening.

Then the build time per ensemble member of a 10,000-member grid (``sp_ensemble`` with a
100 x 100 grid over p2 and x^1(0): ``hgo.ensemble_runner.prepare_ensemble``, i.e. planning,
building every member's system, stacking the parameters and sampling the noise; no
integration), and the compile time of a new kernel (problem B, DOP853 rtol 1e-7, in fresh
processes: empty caches, and a new kernel with numba's cache of the component helpers
kept), and a new composition's compile of ``sp_fig1`` and ``dhlm_example``
(``compile_bench.py``: CPU of a fresh run with an empty kernel cache minus the same run
cached; issue 41's target <= 0.6 s). The last line:
``hgo_over_hand: A=<x> B=<x> APA=<x> DHLM=<x> Moreno=<x>``.

Every hand kernel computes and records what hgo's call computes and records (issue 41,
item 4), checked against it (the difference column: the largest over the record's columns
and the window metrics, relative to max(1, max |column|)): at each output the state z,
the discrete state d, y, m, u, x^ and t (A: d of the switched HGO, its switching scheme
run after every substep; B: no d, no u; APA: d = L set; DHLM's d, two step-end times,
left out of the difference: they move with the steps' round-off), and hgo's window
metrics as hgo computes them: by 3-point Gauss-Legendre on each step's continuous
extension (B, APA, DHLM, Moreno), by the trapezoid on the RK4 step ends (A). Before
2026-12-01 evening A's, B's and APA's recorded the state only, B integrated the 3-state
error system from h0 = 1e-3, and APA computed no window metrics. The column "without its
window metrics" times the same hand kernels with no window. What a hand kernel does not
do that hgo's does: the state bound and finiteness checks after every step and the Ctrl-C
flag. (APA's input jumps at t = 10, 20, 35: its kernels end a step there, evaluate the
stages just below the jump and restart the step size after it, as hgo.)
"""

from __future__ import annotations

import functools
import os
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
import baselines as bl  # noqa: E402
import compile_bench  # noqa: E402
import problems as pb  # noqa: E402
from hand_papers import (  # noqa: E402
    APA_OBSERVERS,
    DHLM_Z0,
    MORENO_Z0,
    apa_start,
    moreno_kernel,
    moreno_kernel_signals,
)
from hand_unrolled import (  # noqa: E402
    APA_REC,
    MORENO_REC,
    N_REC,
    apa_unrolled,
    b_problem,
    compile_kernel,
    dhlm_unrolled,
    moreno_unrolled,
)
from timing import interleaved_median_cpu  # noqa: E402

REPS = 21
APA = ["experiment=apa_fig2", "postprocess=none", "figures={}"]
DHLM = ["experiment=dhlm_example", "postprocess=none"]
MORENO = ["experiment=moreno_pe", "postprocess=none", "controller=moreno_sin", "plant.a=0.5",
          "observer.circle.L=[200.0,120.0]"]
GRID_N = 100  # 100 x 100 members
NO_NOISE = np.zeros(1)
NO_BREAKS = np.zeros(0)
B_P2 = 1.5  # problems.b_system's p2


def _rel_diff(a: np.ndarray, b: np.ndarray) -> float:
    """max |a - b| over the grid, per state relative to max(1, max |b|)."""
    scale = np.maximum(1.0, np.abs(b).max(axis=0))
    return float((np.abs(a - b) / scale).max())


def _record(tr) -> np.ndarray:
    """What hgo's call records, one row per output: z, d, y, m, u, x^, t (the hand kernels'
    record layout; empty signals take no columns)."""
    return np.column_stack([tr.z, tr.d, tr.y, tr.m, tr.u, tr.xh, tr.t])


def case_a() -> tuple:
    """(hgo call, hand call, difference of the records and window metrics, hand call
    without its window metrics) of problem A; the hand kernel records z, d, y, m, u, x^, t."""
    system, solver, noise = pb.a_system(), pb.a_solver(), pb.a_noise()
    s0 = np.concatenate([system.plant.x0, system.observers[0].z0])
    stab = solver.stability_safety * 2.785
    every = int(round(pb.A_DT_OUT / pb.A_NOISE_DT))
    rec = np.zeros((int(round(pb.A_T / pb.A_DT_OUT)) + 1, bl.A_REC))
    v = noise.samples[:, 0].copy()

    acc = np.zeros(system.n_acc())

    def hand(window: float = solver.t_window):
        return bl.a_kernel(s0, v, pb.A_NOISE_DT, pb.A_T, pb.A_SWITCH, stab, every, rec, window,
                           acc)

    def hgo():
        return pb.simulate(system, solver, noise)

    hand()
    tr = hgo()
    diff = max(_rel_diff(rec, _record(tr)), _rel_diff(acc[None], tr.acc[None]))
    return hgo, hand, diff, lambda: hand(0.0)


def case_b() -> tuple:
    """(hgo call, hand call, difference of the records and window metrics, hand call
    without its window metrics) of problem B; the hand kernel (``hand_unrolled``'s DOPRI5)
    integrates hgo's 5 states and records z, y, m, x^, t (B has no d, no u)."""
    system, solver = pb.b_system(), pb.b_solver()
    rec = np.zeros((int(round(pb.B_T / pb.B_DT)) + 1, bl.B_REC))
    acc = np.zeros(system.n_acc())
    kernel, z0 = compile_kernel(b_problem(B_P2)), system.z0()

    def hand(window: float = solver.t_window):
        return kernel(z0.copy(), NO_NOISE, np.inf, NO_BREAKS, pb.B_T, pb.B_DT, solver.h_max,
                      pb.RTOL_B, pb.ATOL_B, rec, window, acc)

    def hgo():
        return pb.simulate(system, solver, pb.no_noise(1))

    hand()
    tr = hgo()
    diff = max(_rel_diff(rec, _record(tr)), _rel_diff(acc[None], tr.acc[None]))
    return hgo, hand, diff, lambda: hand(0.0)


def case_paper(overrides: list[str], kernel, z0: np.ndarray) -> tuple:
    from hgo.core.config import compose
    from hgo.running.runner import build, run_experiment

    exp = build(compose(overrides))
    s = exp.solver
    rec = np.zeros((int(round(s.t_end / s.dt_out)) + 1, z0.size))
    p = np.zeros(1)
    acc = np.zeros(exp.system.n_acc())

    def hand(window: float = s.t_window):
        z = z0.copy()
        return kernel(z, p, NO_NOISE, np.inf, s.t_end, s.dt_out, s.h_max, s.rtol, s.atol,
                      rec, window, acc)

    def hgo():
        return run_experiment(exp)

    hand()
    run = hgo()
    diff = max(_rel_diff(rec, run.z[:, :z0.size]), _rel_diff(acc[None], run.acc[None]))
    return hgo, hand, diff, lambda: hand(0.0)


def case_signals(overrides: list[str], kernel, z0: np.ndarray, width: int,
                 compared: list[int] | None = None) -> tuple:
    """(hgo call, hand call, difference, hand call without its window metrics) of a noiseless
    paper run whose ``hand_unrolled`` kernel records what hgo's call records: ``width``
    columns a row (``compared`` of them: all if None) against :func:`_record`, and hgo's
    window metrics."""
    from hgo.core.config import compose
    from hgo.running.runner import build, run_experiment

    exp = build(compose(overrides))
    s = exp.solver
    rec = np.zeros((int(round(s.t_end / s.dt_out)) + 1, width))
    acc = np.zeros(exp.system.n_acc())

    def hand(window: float = s.t_window):
        return kernel(z0.copy(), NO_NOISE, np.inf, NO_BREAKS, s.t_end, s.dt_out, s.h_max,
                      s.rtol, s.atol, rec, window, acc)

    def hgo():
        return run_experiment(exp)

    hand()
    run = hgo()
    mine, ours = (rec, _record(run)) if compared is None else (rec[:, compared],
                                                               _record(run)[:, compared])
    diff = max(_rel_diff(mine, ours), _rel_diff(acc[None], run.acc[None]))
    return hgo, hand, diff, lambda: hand(0.0)


def case_moreno() -> tuple:
    """Moreno against ``hand_unrolled.moreno_unrolled`` (recording z, y, m, u, x^, t)."""
    return case_signals(MORENO, moreno_unrolled, MORENO_Z0, MORENO_REC)


def case_dhlm() -> tuple:
    """DHLM against ``hand_unrolled.dhlm_unrolled`` (recording z, d, y, m, u, x^, t). The
    difference is over every column but d, which holds step-end times (the first and the
    last step end with the HGO saturated): they move with the steps' round-off (t_sat_last
    by 2.7e-4 relative against hgo's, measured; every other column <= 3.1e-8)."""
    nz = DHLM_Z0.size
    return case_signals(DHLM, dhlm_unrolled, DHLM_Z0, N_REC, [*range(nz), *range(nz + 2, N_REC)])


def case_apa() -> tuple:
    """apa_fig2: hgo integrates the three observers apart (solver.split_observers), each
    with its own copy of the plant; the hand kernels (``hand_unrolled.apa_unrolled``) the
    same, one after the other, each recording its part of what hgo's call records (z, d, y,
    m, u, x^, t) and computing its part of hgo's window metrics. The difference is the
    largest over the parts."""
    from hgo.core.config import compose
    from hgo.running.runner import build, run_experiment

    exp = build(compose(APA))
    s = exp.solver
    noise = exp.noise.sample(s.t_end, 1, exp.seed)
    v = noise.samples[:, 0].copy()
    breaks = exp.system.breaks(exp.system.params(), s.t_end)  # the input's jumps, hgo's
    runs = [(apa_unrolled(name), apa_start(name, v[0]),
             np.zeros((int(round(s.t_end / s.dt_out)) + 1, APA_REC)), np.zeros(5))
            for name in APA_OBSERVERS]

    def hand(window: float = s.t_window):
        for kernel, z0, rec, acc in runs:
            kernel(z0.copy(), v, noise.dt, breaks, s.t_end, s.dt_out, s.h_max, s.rtol, s.atol,
                   rec, window, acc)

    def hgo():
        return run_experiment(exp)

    hand()
    r = hgo()
    n_xh, n_obs = r.xh.shape[1], len(runs)
    diff = 0.0
    for k, (_, _, rec, acc) in enumerate(runs):
        ours = np.column_stack([r.z[:, [0, 1, 2 + 3 * k, 3 + 3 * k, 4 + 3 * k]], r.d[:, k],
                                r.y, r.m, r.u, r.xh[:, 2 * k:2 * k + 2], r.t])
        metrics = r.acc[[2 * k, 2 * k + 1, n_xh + k, n_xh + n_obs + k, n_xh + 2 * n_obs]]
        diff = max(diff, _rel_diff(rec, ours), _rel_diff(acc[None], metrics[None]))
    return hgo, hand, diff, lambda: hand(0.0)


COARSE_DT = 0.04  # --outputs: the coarse output grid (s) against the presets' 1 ms


def outputs_split(reps: int = REPS) -> None:
    """``--outputs``: DHLM's and Moreno's calls with outputs every 1 ms (the presets) and every
    ``COARSE_DT``: what the extra outputs cost hgo and the hand kernel (the ratio line's:
    ``hand_unrolled``'s, recording what hgo's call records), and the ratio left at the
    coarse grid (the steps)."""
    print(f"\n## DHLM and Moreno: outputs against steps (CPU ms, medians of {reps} interleaved "
          f"calls; load average {os.getloadavg()[0]:.2f})\n")
    print(f"| problem | hgo 1 ms / {COARSE_DT * 1e3:g} ms | hand 1 ms / {COARSE_DT * 1e3:g} ms "
          "| cost of the extra outputs: hgo / hand | hgo / hand at the coarse grid |")
    print("|---|---|---|---|---|")
    nz = DHLM_Z0.size
    for name, overrides, args in (
            ("DHLM", DHLM, (dhlm_unrolled, DHLM_Z0, N_REC, [*range(nz), *range(nz + 2, N_REC)])),
            ("Moreno", MORENO, (moreno_unrolled, MORENO_Z0, MORENO_REC))):
        fine = case_signals(overrides, *args)
        coarse = case_signals([*overrides, f"solver.dt_out={COARSE_DT}"], *args)
        (g1, _), (h1, _), (g2, _), (h2, _) = interleaved_median_cpu(
            [fine[0], fine[1], coarse[0], coarse[1]], reps)
        ms = [1e3 * t for t in (g1, g2, h1, h2)]
        print(f"| {name} | {ms[0]:.2f} / {ms[1]:.2f} | {ms[2]:.2f} / {ms[3]:.2f} | "
              f"{ms[0] - ms[1]:.2f} / {ms[2] - ms[3]:.2f} | {g2 / h2:.2f} |")


def composition_split(reps: int = REPS) -> None:
    """``--composition``: where hgo / hand goes on DHLM and Moreno. Four calls, interleaved:
    the hand kernel; the same with its right-hand side behind a C function pointer (the
    call boundary hgo's integrator has); hgo's call with the composition written by hand
    (``hand_composition``: hgo's integrator and call path, the problem's own right-hand
    side, update and outputs); hgo's call. Each is checked against hgo's call (the
    difference as in the ratio table)."""
    from hand_composition import behind_pointer, hand_entry_points

    from hgo.core.config import compose
    from hgo.engine.codegen import load_kernel
    from hgo.running.runner import build, run_experiment

    print(f"\n## hgo / hand: the call boundary, the integrator, the components (CPU, "
          f"medians of {reps} interleaved calls, as ratios to the hand kernel; load average "
          f"{os.getloadavg()[0]:.2f})\n")
    print("| problem | hand (ms) | hand, f behind a C pointer | hgo, composition by hand "
          "| hgo | difference: pointer / composition by hand |")
    print("|---|---|---|---|---|---|")
    nz = DHLM_Z0.size
    for name, overrides, (kernel, z0, width, *cols) in (
            ("DHLM", DHLM, (dhlm_unrolled, DHLM_Z0, N_REC,
                            [*range(nz), *range(nz + 2, N_REC)])),
            ("Moreno", MORENO, (moreno_unrolled, MORENO_Z0, MORENO_REC))):
        hgo, hand, _, _ = case_signals(overrides, kernel, z0, width, *cols)
        pointer = case_signals(overrides, compile_kernel(behind_pointer(name), cache=False), z0,
                               width, *cols)
        exp = build(compose(overrides))
        own = load_kernel(exp.system, True, exp.solver.method, noisy=False)
        by_hand = hand_entry_points(own, name)

        def hgo_by_hand(exp=exp, own=own, S=by_hand):
            own.entry_points = lambda: S  # (the instance's, for this call: Kernel.function)
            try:
                return run_experiment(exp)
            finally:
                del own.entry_points

        ref, mine = run_experiment(exp), hgo_by_hand()
        ours, theirs = _record(ref), _record(mine)
        if cols:
            ours, theirs = ours[:, cols[0]], theirs[:, cols[0]]
        diff = max(_rel_diff(theirs, ours), _rel_diff(mine.acc[None], ref.acc[None]))
        times = [t for t, _ in interleaved_median_cpu([hand, pointer[1], hgo_by_hand, hgo],
                                                      reps)]
        print(f"| {name} | {times[0] * 1e3:.2f} | "
              + " | ".join(f"{t / times[0]:.2f}" for t in times[1:])
              + f" | {pointer[2]:.1e} / {diff:.1e} |")


def signals_split(reps: int = REPS) -> None:
    """``--signals``: Moreno's call against ``hand_dop853``'s loop-over-arrays hand kernel
    recording the state only (the ratio line's yardstick before issue 41) and against the
    same hand kernel also recording what hgo's call records at each output (t, y, m, u, x^:
    ``hand_papers.moreno_signals``), checked equal to hgo's. (The ratio line's yardstick is
    now ``hand_unrolled.moreno_unrolled``.)"""
    from hgo.core.config import compose
    from hgo.running.runner import build, run_experiment

    hgo, hand, _, _ = case_paper(MORENO, moreno_kernel, MORENO_Z0)
    exp = build(compose(MORENO))
    s = exp.solver
    rec = np.zeros((int(round(s.t_end / s.dt_out)) + 1, 10))
    acc = np.zeros(exp.system.n_acc())

    def hand_signals():
        return moreno_kernel_signals(MORENO_Z0.copy(), np.zeros(1), NO_NOISE, np.inf, s.t_end,
                                     s.dt_out, s.h_max, s.rtol, s.atol, rec, s.t_window, acc)

    hand_signals()
    run = run_experiment(exp)
    ours = np.column_stack([run.z, run.t, run.y, run.m, run.u, run.xh])
    diff = _rel_diff(rec, ours)
    (g, _), (h, _), (hs, _) = interleaved_median_cpu([hgo, hand, hand_signals], reps)
    print(f"\n## Moreno: what recording the signals costs (CPU ms, medians of {reps} "
          f"interleaved calls; load average {os.getloadavg()[0]:.2f})\n")
    print("| hgo | hand, state only | hand, also t, y, m, u, x^ | hgo / hand, state only | "
          "hgo / hand, also t, y, m, u, x^ | max difference of the signals |")
    print("|---|---|---|---|---|---|")
    print(f"| {g * 1e3:.3f} | {h * 1e3:.3f} | {hs * 1e3:.3f} | {g / h:.2f} | {g / hs:.2f} | "
          f"{diff:.1e} |")


def member_build_ms(n: int = GRID_N) -> tuple[float, int]:
    """CPU ms per member of preparing the ``n`` x ``n`` grid ensemble (median of 3)."""
    from sweeps_bench import sp_grid_override

    from hgo.core.config import compose
    from hgo.running.ensemble_runner import prepare_ensemble

    with tempfile.TemporaryDirectory() as tmp:
        cfg = compose(["experiment=sp_ensemble", "ensemble.size=0", sp_grid_override(n)],
                      Path(tmp))
        prepare_ensemble(cfg)
        (t, plan), = interleaved_median_cpu([lambda: prepare_ensemble(cfg)], 3)
    size = len(plan.systems)
    return t / size * 1e3, size


CASES = {"A": case_a, "B": case_b, "APA": case_apa, "DHLM": case_dhlm, "Moreno": case_moreno}


def bench(quick: bool = False, only: list[str] | None = None) -> dict:
    """The ratio table and line; ``only``: those problems alone (no member build, no
    compile times: for comparing two checkouts process by process)."""
    cases = {k: CASES[k] for k in only} if only else CASES
    load = os.getloadavg()[0]
    print(f"\n## hgo over hand-written kernels (CPU s, medians of {REPS} interleaved calls; "
          f"load average {load:.2f})\n")
    print("| problem | hgo (s) | hand (s) | hgo / hand | hgo / hand without its window "
          "metrics | max difference |")
    print("|---|---|---|---|---|---|")
    ratios = {}
    for name, make in cases.items():
        hgo, hand, diff, *bare = make()
        (t_hgo, _), (t_hand, _), *t_bare = interleaved_median_cpu([hgo, hand, *bare],
                                                                   7 if quick else REPS)
        ratios[name] = t_hgo / t_hand
        without = f"{t_hgo / t_bare[0][0]:.2f}" if t_bare else "(none)"
        print(f"| {name} | {t_hgo:.5f} | {t_hand:.5f} | {ratios[name]:.2f} | {without} | "
              f"{diff:.1e} |")
    if only:
        print("hgo_over_hand: " + " ".join(f"{k}={v:.2f}" for k, v in ratios.items()))
        return ratios
    ms, size = member_build_ms(30 if quick else GRID_N)
    print(f"\nmember build: {ms:.3f} ms CPU per member ({size} members, prepare_ensemble; "
          f"load {os.getloadavg()[0]:.2f})")
    if not quick:
        empty, new_kernel, cached = pb.compile_times("B853")
        print(f"compile, B DOP853: empty caches {empty:.2f} s, new kernel {new_kernel:.2f} s, "
              f"cached {cached:.2f} s (load {os.getloadavg()[0]:.2f})")
        print("\nA new composition and a new integrator (compile_bench.py, one round "
              "each):\n")
        compile_bench.print_medians(compile_bench.bench(list(compile_bench.PRESETS), 1))
    print("hgo_over_hand: " + " ".join(f"{k}={v:.2f}" for k, v in ratios.items()))
    return ratios


def across_processes(n: int, only: list[str], pin: bool = False) -> None:
    """``--processes=N``: the ratio line of ``N`` fresh processes one after the other (each
    its own interleaved medians, ``--only`` those problems), then per problem the median
    and the range over the processes. On a shared machine one process's ratios move by up
    to ~0.3 against another's of the same code (benchmarks/README, 2026-12-02). ``--pin``:
    each process on one CPU (process k on CPU k mod the CPUs this one may use)."""
    cpus = sorted(os.sched_getaffinity(0)) if pin else []
    runs = []
    for k in range(n):
        cpu = cpus[k % len(cpus)] if pin else None
        where = {"preexec_fn": functools.partial(os.sched_setaffinity, 0, {cpu})} if pin else {}
        out = subprocess.run([sys.executable, __file__, f"--only={','.join(only)}"],
                             capture_output=True, text=True, check=True, **where).stdout
        line = next(ln for ln in out.splitlines() if ln.startswith("hgo_over_hand:"))
        on = f", CPU {cpu}" if pin else ""
        print(f"process {k + 1} (load {os.getloadavg()[0]:.2f}{on}): {line}")
        runs.append({kv.split("=")[0]: float(kv.split("=")[1]) for kv in line.split()[1:]})
    spread = {p: sorted(r[p] for r in runs) for p in only}
    print("range: " + " ".join(f"{p}={v[0]:.2f}-{v[-1]:.2f}" for p, v in spread.items()))
    print(f"hgo_over_hand (median of {n} processes{', pinned' if pin else ''}): "
          + " ".join(f"{p}={statistics.median(v):.2f}" for p, v in spread.items()))

if __name__ == "__main__":
    t0 = time.perf_counter()
    if "--outputs" in sys.argv:
        outputs_split()
    elif "--signals" in sys.argv:
        signals_split()
    elif "--composition" in sys.argv:
        composition_split()
    else:  # --only A,B,...: some problems alone
        picked = next((a.split("=", 1)[1] for a in sys.argv if a.startswith("--only=")), "")
        only = [k for k in picked.split(",") if k] or None
        processes = next((int(a.split("=", 1)[1]) for a in sys.argv
                          if a.startswith("--processes=")), 0)
        if processes:
            across_processes(processes, only or list(CASES), "--pin" in sys.argv)
        else:
            bench("--quick" in sys.argv, only)
