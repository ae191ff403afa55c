"""Long runs linear (issue 41, item 5): post-processing time and peak memory of
``dhlm_example`` at ``solver.t_end=200`` and ``2000`` (targets: the 2000 s run's peak
memory <= 1 GB, its post-processing <= 12x that of the 200 s run).

    python benchmarks/long_run_bench.py                # both horizons, ~2 min at load ~1
    python benchmarks/long_run_bench.py --reps 3       # the in-process part 3 times each

Per horizon, in a fresh process each (cached kernel):

* in process: build, simulate, post-process (the experiment's post-processors, as
  ``hgo run`` does): the CPU (``time.process_time``) and wall seconds of the
  post-processing, and the process's peak resident size (``VmHWM``) after the simulation
  and after the post-processing;
* the whole ``hgo run`` (recording in full, figures): the peak RSS of its largest process
  (what ``/usr/bin/time -v`` prints), of the run's own process, and the post-processing
  seconds it logged in ``run.json`` (wall), through ``memory_bench.sample``.

The load average is printed before and after each measurement: on this 2-core machine
the times move with it (the CPU seconds less than the wall).
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
from memory_bench import sample  # noqa: E402

EXPERIMENT = "dhlm_example"
HORIZONS = (200, 2000)


def _hwm_gb() -> float:
    for line in Path("/proc/self/status").read_text().splitlines():
        if line.startswith("VmHWM:"):
            return int(line.split()[1]) / 1e6
    return float("nan")


def child(t_end: float) -> None:
    """Simulate and post-process one run; print a JSON line of what was measured."""
    from hgo.core.config import compose
    from hgo.running.runner import build, postprocess, run_experiment

    cfg = compose([f"experiment={EXPERIMENT}", f"solver.t_end={t_end}"])
    exp = build(cfg)
    traj = run_experiment(exp)
    sim_peak = _hwm_gb()
    cpu, wall = time.process_time(), time.perf_counter()
    post = postprocess(cfg, exp, traj)
    cpu, wall = time.process_time() - cpu, time.perf_counter() - wall
    print(json.dumps({"samples": len(traj.t), "steps": len(traj.dense.records[0].rows),
                      "rows": len(post.rows), "post_cpu": cpu, "post_wall": wall,
                      "sim_peak": sim_peak, "peak": _hwm_gb()}))


def in_process(t_end: float) -> dict:
    out = subprocess.run([sys.executable, __file__, "--child", str(t_end)], check=True,
                         capture_output=True, text=True).stdout
    return json.loads(out.strip().splitlines()[-1])


def whole_run(t_end: float) -> dict:
    """``hgo run`` sampled by memory_bench from a process of its own (whose children's
    largest max RSS is that run's alone)."""
    out = subprocess.run([sys.executable, __file__, "--whole", str(t_end)], check=True,
                         capture_output=True, text=True).stdout
    return json.loads(out.strip().splitlines()[-1])


def whole(t_end: float) -> None:
    with tempfile.TemporaryDirectory() as out:
        got = sample([sys.executable, "-m", "hgo.cli", "run", f"experiment={EXPERIMENT}",
                      f"solver.t_end={t_end}", f"hydra.run.dir={out}"], 0.01)
        got["post_wall"] = json.loads((Path(out) / "run.json").read_text())["seconds"][
            "postprocess"] if got["rc"] == 0 else float("nan")
    print(json.dumps(got))


def _load() -> str:
    return f"{os.getloadavg()[0]:.2f}"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--reps", type=int, default=1, help="in-process runs per horizon")
    parser.add_argument("--child", type=float, help=argparse.SUPPRESS)
    parser.add_argument("--whole", type=float, help=argparse.SUPPRESS)
    args = parser.parse_args()
    if args.child is not None or args.whole is not None:
        child(args.child) if args.whole is None else whole(args.whole)
        return
    cpu: dict[int, float] = {}
    for t_end in HORIZONS:
        for _ in range(args.reps):
            before = _load()
            r = in_process(t_end)
            cpu[t_end] = min(cpu.get(t_end, float("inf")), r["post_cpu"])
            print(f"t_end={t_end}: {r['samples']} samples, {r['steps']} steps, {r['rows']} rows;"
                  f" post-processing {r['post_cpu']:.2f} s CPU ({r['post_wall']:.2f} s wall);"
                  f" peak RSS {r['sim_peak']:.2f} GB after the simulation, {r['peak']:.2f} GB "
                  f"after the post-processing (load {before} -> {_load()})", flush=True)
    ratio = cpu[HORIZONS[1]] / cpu[HORIZONS[0]]
    print(f"post-processing CPU {HORIZONS[1]} s / {HORIZONS[0]} s: {ratio:.1f}x "
          f"(best of {args.reps}; target <= 12x)", flush=True)
    for t_end in HORIZONS:
        before = _load()
        w = whole_run(t_end)
        print(f"hgo run experiment={EXPERIMENT} solver.t_end={t_end}: exit {w['rc']}, "
              f"{w['wall']:.1f} s; peak RSS: largest process {w['max_rss']:.2f} GB (target "
              f"<= 1 GB at 2000 s), the run's {w['run']:.2f} GB, its children "
              f"{', '.join(f'{c:.2f}' for c in w['children'])} GB; post-processing "
              f"{w['post_wall']:.2f} s wall (run.json) (load {before} -> {_load()})",
              flush=True)


if __name__ == "__main__":
    main()
