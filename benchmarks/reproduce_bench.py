"""``hgo reproduce`` of every paper as a whole process: cold, warm and reused.

    python benchmarks/reproduce_bench.py [--reps N] [--jobs J]

* cold: empty kernel caches (a fresh ``HGO_CACHE_DIR`` and ``NUMBA_CACHE_DIR``) and a
  fresh output root: every kernel is compiled, every run and claim computed;
* warm: the kernel caches of the cold run, a fresh output root: every run and claim
  computed, nothing compiled;
* reused: the output root of the warm run: every result read back from disk.

Medians over ``--reps`` whole-process runs (wall clock). Targets (issue 18): cold <= 60 s,
warm <= 20 s for all papers on a 2-core machine (issue 27: 40 s and 10 s). Also printed,
from the last repetition: the integrators (by method) and compositions the cold run
compiled (the modules in its fresh cache), and the seconds the warm run's figures took
(the sum of its runs' ``run.json``), two of the floors under those targets. The last line is
``reproduce: cold=<s> warm=<s> reused=<s>``.
"""

from __future__ import annotations

import argparse
import collections
import json
import os
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


def timed(out: Path, env: dict[str, str], jobs: int) -> float:
    t0 = time.perf_counter()
    subprocess.run([sys.executable, "-m", "hgo.cli", "reproduce", "--jobs", str(jobs),
                    "--out", str(out)], cwd=ROOT, env=env, check=True,
                   stdout=subprocess.DEVNULL)
    return time.perf_counter() - t0


def kernels_by_integrator(cache: Path) -> dict[str, int]:
    """The generated modules in a kernel cache: the integrators, counted by the method their
    header names (``# integrator: <method>; ...``), and the compositions (issue 41: one
    integrator per method and layout, one composition per experiment)."""
    counts: collections.Counter[str] = collections.Counter()
    for path in cache.glob("hgo_integrator_*.py"):
        line = next(ln for ln in path.read_text().splitlines() if ln.startswith("# integrator:"))
        counts["integrator " + line.split(":", 1)[1].split(";")[0].strip()] += 1
    counts["composition"] = len(list(cache.glob("hgo_kernel_*.py")))
    return dict(sorted(counts.items()))


def figure_seconds(out: Path) -> tuple[float, int]:
    """The seconds of every run's figures under a reproduce output root, and the runs."""
    seconds = [json.loads(p.read_text())["seconds"].get("figures", 0.0)
               for p in out.glob("runs/**/run.json")]
    return sum(seconds), len(seconds)


def bench(reps: int = 3, jobs: int = 2) -> dict[str, float]:
    times: dict[str, list[float]] = {"cold": [], "warm": [], "reused": []}
    for _ in range(reps):
        with tempfile.TemporaryDirectory() as tmp:
            tmp = Path(tmp)
            env = {**os.environ, "HGO_CACHE_DIR": str(tmp / "kernels"),
                   "NUMBA_CACHE_DIR": str(tmp / "numba")}
            times["cold"].append(timed(tmp / "cold", env, jobs))
            kernels = kernels_by_integrator(tmp / "kernels")
            times["warm"].append(timed(tmp / "warm", env, jobs))
            figures, runs = figure_seconds(tmp / "warm")
            times["reused"].append(timed(tmp / "warm", env, jobs))
    print("the cold run compiled "
          + ", ".join(f"{k} {n}" for k, n in kernels.items())
          + f"); the warm run's figures took {figures:.1f} s ({runs} runs' run.json)")
    return {k: statistics.median(v) for k, v in times.items()}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--reps", type=int, default=3)
    parser.add_argument("--jobs", type=int, default=2)
    args = parser.parse_args()
    r = bench(args.reps, args.jobs)
    print(f"reproduce (all papers, --jobs {args.jobs}, medians of {args.reps} whole-process "
          f"runs): cold {r['cold']:.1f} s (targets: issue 18 60, issue 27 40), warm "
          f"{r['warm']:.1f} s (20, 10), "
          f"reused {r['reused']:.1f} s")
    print(f"reproduce: cold={r['cold']:.1f} warm={r['warm']:.1f} reused={r['reused']:.1f}")


if __name__ == "__main__":
    main()
