"""Whole-process start-up of the ``hgo`` command, and the run index.

    python benchmarks/startup_bench.py [--reps N]

* ``hgo --help`` (target < 1 s) and a cached ``hgo run experiment=sp_fig1`` (target < 1.5 s),
  medians of ``--reps`` whole processes (wall clock; the run's kernel is compiled first);
* ``hgo.outputs.runs.load`` over 1,000 run directories (target < 2 s), median of 3.

The last line is ``startup: help=<s> run=<s> index_1000=<s>``.
"""

from __future__ import annotations

import argparse
import os
import shutil
import statistics
import subprocess
import sys
import tempfile
import time
from datetime import datetime
from pathlib import Path

import pandas as pd

from hgo.outputs.runs import load, write_run_json

HGO = shutil.which("hgo") or f"{sys.executable} -m hgo.cli"


def whole_process(args: list[str], cwd: Path, reps: int) -> float:
    times = []
    for _ in range(reps):
        t0 = time.perf_counter()
        subprocess.run([*HGO.split(), *args], cwd=cwd, check=True, capture_output=True)
        times.append(time.perf_counter() - t0)
    return statistics.median(times)


def index_time(n: int, reps: int = 3) -> float:
    table = pd.DataFrame({"observer": ["a", "a"], "quantity": ["q1", "q2"],
                          "empirical": [1.0, 2.0]})
    config = {"run_name": "bench", "seed": 0,
              "observer": {"a": {f"k{i}": i for i in range(40)}}}
    with tempfile.TemporaryDirectory() as tmp:
        for k in range(n):
            d = Path(tmp) / f"sweep{k // 100}" / f"job{k % 100}"
            d.mkdir(parents=True)
            write_run_json(d, config, "ok", datetime.now(), {"simulate": 0.1}, table)
        times = []
        for _ in range(reps):
            t0 = time.perf_counter()
            assert len(load(tmp)) == n
            times.append(time.perf_counter() - t0)
    return statistics.median(times)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--reps", type=int, default=5)
    args = parser.parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        cwd = Path(tmp)
        run = ["run", "experiment=sp_fig1", f"hydra.run.dir={cwd / 'run'}"]
        subprocess.run([*HGO.split(), *run], cwd=cwd, check=True, capture_output=True,
                       env=os.environ)  # compile (or load) the kernel once
        t_help = whole_process(["--help"], cwd, args.reps)
        t_run = whole_process(run, cwd, args.reps)
    t_index = index_time(1000)
    print(f"hgo --help {t_help:.2f} s (target 1), cached hgo run experiment=sp_fig1 "
          f"{t_run:.2f} s (target 1.5), index of 1000 runs {t_index:.2f} s (target 2); "
          f"medians of {args.reps} whole processes")
    print(f"startup: help={t_help:.2f} run={t_run:.2f} index_1000={t_index:.2f}")


if __name__ == "__main__":
    main()
