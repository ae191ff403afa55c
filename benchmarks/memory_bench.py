"""Peak memory of one ``hgo run`` and of every process it starts (issue 27: a 1e7-sample
``hgo run experiment=sp_fig1 solver.t_end=1e5`` with its figure within 2 GB).

    .venv/bin/python benchmarks/memory_bench.py                      # that run
    .venv/bin/python benchmarks/memory_bench.py experiment=sp_fig1 solver.t_end=1e4

The run's process tree (the run, its figure process, the process writing the recording)
is sampled every ``--every`` seconds from /proc (Linux): the peak RSS of each process,
the peak of the tree's summed RSS (shared copy-on-write pages counted in every process
that maps them: an overcount) and of its summed PSS (each shared page divided among the
processes sharing it: the tree's physical memory). The run's ``max RSS`` from
``getrusage(RUSAGE_CHILDREN)`` (what ``/usr/bin/time -v`` prints: the largest single
process) is printed too, with the load average before and after.
"""

from __future__ import annotations

import argparse
import os
import resource
import subprocess
import sys
import time
from pathlib import Path

DEFAULT = ["experiment=sp_fig1", "solver.t_end=1e5"]


def _children(pid: int) -> list[int]:
    """The pids of every descendant of ``pid`` (from /proc/<pid>/task/*/children)."""
    out, todo = [], [pid]
    while todo:
        for task in Path(f"/proc/{todo.pop()}/task").glob("*"):
            try:
                kids = [int(k) for k in (task / "children").read_text().split()]
            except OSError:
                continue
            out += kids
            todo += kids
    return out


def _kb(path: str, key: str) -> int:
    try:
        for line in Path(path).read_text().splitlines():
            if line.startswith(key):
                return int(line.split()[1])
    except OSError:
        pass
    return 0


def sample(cmd: list[str], every: float) -> dict:
    """Run ``cmd``; the peaks of its process tree (GB) and its wall time (s)."""
    start = time.perf_counter()
    proc = subprocess.Popen(cmd, stdout=subprocess.DEVNULL)
    peaks: dict[int, float] = {}
    rss_sum = pss_sum = 0.0
    while proc.poll() is None:
        rss_now = pss_now = 0.0
        for pid in [proc.pid, *_children(proc.pid)]:
            rss = _kb(f"/proc/{pid}/status", "VmRSS:") / 1e6
            rss_now += rss
            pss_now += _kb(f"/proc/{pid}/smaps_rollup", "Pss:") / 1e6
            peaks[pid] = max(peaks.get(pid, 0.0), rss)
        rss_sum, pss_sum = max(rss_sum, rss_now), max(pss_sum, pss_now)
        time.sleep(every)
    return {"rc": proc.wait(), "wall": time.perf_counter() - start, "run": peaks.pop(proc.pid, 0.0),
            "children": list(peaks.values()), "rss_sum": rss_sum, "pss_sum": pss_sum,
            "max_rss": resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss / 1e6}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("overrides", nargs="*", default=DEFAULT)
    parser.add_argument("--every", type=float, default=0.01, help="seconds between samples")
    parser.add_argument("--out", default="/tmp/hgo-memory-bench", help="run directory")
    args = parser.parse_args()
    cmd = [sys.executable, "-m", "hgo.cli", "run", *args.overrides, f"hydra.run.dir={args.out}"]
    load = os.getloadavg()
    got = sample(cmd, args.every)
    print(f"hgo run {' '.join(args.overrides)}: exit {got['rc']}, {got['wall']:.1f} s; "
          f"load {load[0]:.2f} before, {os.getloadavg()[0]:.2f} after")
    print(f"  peak RSS: run {got['run']:.2f} GB; its processes (figures, recording writer, "
          f"in start order) {', '.join(f'{c:.2f}' for c in got['children'])} GB")
    print(f"  tree: peak summed PSS {got['pss_sum']:.2f} GB, summed RSS {got['rss_sum']:.2f} "
          f"GB (overcount); largest process max RSS {got['max_rss']:.2f} GB")


if __name__ == "__main__":
    main()
