"""``hgo reproduce`` of every paper as a whole process: cold, warm and reused.

    python benchmarks/reproduce_bench.py [--reps N] [--jobs J]

* cold: empty kernel caches (a fresh ``HGO_CACHE_DIR`` and ``NUMBA_CACHE_DIR``) and a
  fresh output root: every kernel is compiled, every run and claim computed;
* warm: the kernel caches of the cold run, a fresh output root: every run and claim
  computed, nothing compiled;
* reused: the output root of the warm run: every result read back from disk.

Medians over ``--reps`` whole-process runs (wall clock). Targets (issue 18): cold <= 60 s,
warm <= 20 s for all papers on a 2-core machine. The last line is
``reproduce: cold=<s> warm=<s> reused=<s>``.
"""

from __future__ import annotations

import argparse
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


def bench(reps: int = 3, jobs: int = 2) -> dict[str, float]:
    times: dict[str, list[float]] = {"cold": [], "warm": [], "reused": []}
    for _ in range(reps):
        with tempfile.TemporaryDirectory() as tmp:
            tmp = Path(tmp)
            env = {**os.environ, "HGO_CACHE_DIR": str(tmp / "kernels"),
                   "NUMBA_CACHE_DIR": str(tmp / "numba")}
            times["cold"].append(timed(tmp / "cold", env, jobs))
            times["warm"].append(timed(tmp / "warm", env, jobs))
            times["reused"].append(timed(tmp / "warm", env, jobs))
    return {k: statistics.median(v) for k, v in times.items()}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--reps", type=int, default=3)
    parser.add_argument("--jobs", type=int, default=2)
    args = parser.parse_args()
    r = bench(args.reps, args.jobs)
    print(f"reproduce (all papers, --jobs {args.jobs}, medians of {args.reps} whole-process "
          f"runs): cold {r['cold']:.1f} s (target 60), warm {r['warm']:.1f} s (target 20), "
          f"reused {r['reused']:.1f} s")
    print(f"reproduce: cold={r['cold']:.1f} warm={r['warm']:.1f} reused={r['reused']:.1f}")


if __name__ == "__main__":
    main()
