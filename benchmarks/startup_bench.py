"""Whole-process start-up of the ``hgo`` command, and the run index.

    python benchmarks/startup_bench.py [--reps N]

* ``hgo --help`` (target < 1 s) and a cached ``hgo run experiment=sp_fig1`` (target < 1.5 s),
  medians of ``--reps`` whole processes (wall clock; the run's kernel is compiled first);
* ``hgo.outputs.runs.load`` over 1,000 run directories (target < 2 s), median of 3;
* ``--presets``: a cached ``hgo run`` of every paper preset that draws figures (one run,
  not a sweep; target < 1.5 s each, issue 27), one line each with the load average and
  the last run's own seconds from its ``run.json`` (the rest is imports, Hydra, exit);
* ``--floor``: what any run pays before hgo's own work, on this machine: a bare Python
  process importing numpy, Hydra, OmegaConf, pandas and numba and calling one
  ``@njit(cache=True)`` function loaded from its cache, then ending without the
  interpreter's teardown (whole process, and its imports and numba's first load as the
  process measures them), ``--reps`` processes.

The last line is ``startup: help=<s> run=<s> index_1000=<s>``.
"""

from __future__ import annotations

import argparse
import json
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


def figure_presets() -> list[str]:
    """The presets of the papers' figures that are single runs (``PAPER_FIGURES``)."""
    from hgo.core.registry import paper_names
    from hgo.reproduce.run import paper_figures

    return [f.preset for p in paper_names() for f in paper_figures(p) if not f.sweep]


def preset_times(reps: int) -> None:
    """One line per figure preset: median whole-process time of a cached run."""
    with tempfile.TemporaryDirectory() as tmp:
        cwd = Path(tmp)
        for preset in figure_presets():
            run = ["run", f"experiment={preset}", f"hydra.run.dir={cwd / preset}"]
            subprocess.run([*HGO.split(), *run], cwd=cwd, check=True, capture_output=True)
            t = whole_process(run, cwd, reps)
            load1 = os.getloadavg()[0]
            parts = json.loads((cwd / preset / "run.json").read_text())["seconds"]
            inside = ", ".join(f"{k} {v:.2f}" for k, v in parts.items())
            print(f"cached hgo run experiment={preset}: {t:.2f} s (target 1.5), "
                  f"load {load1:.1f}; last run's run.json: {inside} s", flush=True)


FLOOR = """\
import os
import time
t0 = time.perf_counter()
import numpy, hydra, omegaconf, pandas, numba
t1 = time.perf_counter()
@numba.njit(cache=True)
def one(x):
    return x + 1.0
one(1.0)
print(t1 - t0, time.perf_counter() - t1, flush=True)
os._exit(0)  # (no interpreter teardown: 0.4-0.7 s here, which hgo's run mostly avoids)
"""


def floor_times(reps: int) -> None:
    """The bare process of ``FLOOR``, from a file in a fresh folder (its numba cache
    written by a first, untimed process): whole-process wall time, its imports and numba's
    first load of the cached function, one line a process, then the medians."""
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        script = Path(tmp) / "floor.py"
        script.write_text(FLOOR)
        subprocess.run([sys.executable, str(script)], check=True, capture_output=True)
        for _ in range(reps):
            t0 = time.perf_counter()
            out = subprocess.run([sys.executable, str(script)], check=True,
                                 capture_output=True, text=True).stdout
            rows.append((time.perf_counter() - t0, *map(float, out.split())))
            print(f"floor: whole process {rows[-1][0]:.2f} s (imports {rows[-1][1]:.2f} s, "
                  f"numba's first load of a cached function {rows[-1][2]:.2f} s), load "
                  f"{os.getloadavg()[0]:.1f}", flush=True)
    wall, imports, first = (statistics.median(c) for c in zip(*rows, strict=True))
    print(f"floor (medians of {reps}): whole process {wall:.2f} s, imports {imports:.2f} s, "
          f"numba's first load {first:.2f} s (a cached hgo run's target: 1.5 s)", flush=True)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--reps", type=int, default=5)
    parser.add_argument("--presets", action="store_true",
                        help="also time a cached run of every paper figure preset")
    parser.add_argument("--floor", action="store_true",
                        help="also time a bare process of hgo's libraries (FLOOR)")
    args = parser.parse_args()
    if args.floor:
        floor_times(args.reps)
    if args.presets:
        preset_times(args.reps)
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
