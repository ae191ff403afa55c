"""What a new composition costs to compile (issue 41's target: <= 0.6 s CPU), and a first
use of its integrator (target: <= 6 s once per method and layout).

    python benchmarks/compile_bench.py [--reps N] [--presets sp_fig1,dhlm_example]

For each preset, fresh processes build the experiment and run it once
(``hgo.running.runner.simulate_config``: build, simulate, post-process; no files, no
figures), in turn:

* **empty**: with an empty kernel cache (``HGO_CACHE_DIR``, a new temporary folder each
  time): neither the composition nor its integrator is in the cache; numba's cache of
  hgo's own helpers (next to their modules) is kept, as for a new combination of known
  components;
* **new**: with a new kernel cache holding only the integrators (``hgo_integrator_*``,
  the tableau texts and numba's cache of them, copied from the empty run's folder): the
  composition is new, its integrator known, as after an edit of a plant;
* **cached**: the run again with the empty run's folder (everything loaded from it).

Each process reports its CPU seconds (``time.process_time``: all its threads) from just
before building the experiment to the end of the run, and the seconds numba's compile
events took inside (``hgo.engine.jit.run_seconds``). A new composition costs
``new - cached`` CPU, a first use of an integrator ``empty - new`` (medians of ``--reps``
triples, interleaved across presets). Every line carries the load average: the machine
is shared.

The last line is ``compile_new_composition: <preset>=<CPU s> ...``, the one before it
``compile_new_integrator: <preset>=<CPU s> ...``.
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
from pathlib import Path

PRESETS = ("sp_fig1", "dhlm_example")

SNIPPET = """
import json, time
from hgo.core.config import compose
from hgo.engine.jit import run_seconds
from hgo.running.runner import simulate_config
cfg = compose(["experiment={preset}"])
t0 = time.process_time()
with run_seconds() as seconds:
    mem = simulate_config(cfg)
print(json.dumps({{"cpu": time.process_time() - t0, "numba": seconds["compile"],
                  "ok": bool(mem.trajectory.ok)}}))
"""


def one_run(preset: str, cache: str) -> dict:
    """CPU seconds of one fresh process's run of ``preset`` with kernel cache ``cache``."""
    env = dict(os.environ, HGO_CACHE_DIR=cache)
    out = subprocess.run([sys.executable, "-c", SNIPPET.format(preset=preset)], env=env,
                         check=True, capture_output=True, text=True)
    result = json.loads(out.stdout.strip().splitlines()[-1])
    if not result["ok"]:
        raise RuntimeError(f"{preset}: the run failed")
    return result


def load() -> str:
    return "/".join(f"{x:.1f}" for x in os.getloadavg())


def integrators_only(cache: str, target: str) -> None:
    """Copy the integrators of kernel cache ``cache`` (module texts, tableau texts, numba's
    cache files of the integrator modules) into the empty folder ``target``."""
    for path in Path(cache).rglob("*"):
        if path.is_file() and path.name.startswith(("hgo_integrator_", "hgo_tableau_")):
            dest = Path(target) / path.relative_to(cache)
            dest.parent.mkdir(parents=True, exist_ok=True)
            shutil.copy2(path, dest)


def bench(presets: list[str], reps: int) -> dict[str, tuple[float, float]]:
    """Median CPU seconds of (new - cached, empty - new), per preset (table lines printed)."""
    rows: dict[str, list[tuple[dict, dict, dict]]] = {p: [] for p in presets}
    print("| preset | triple | empty: CPU s (numba's compile events) | new: CPU s (numba) | "
          "cached: CPU s (numba) | new - cached | empty - new | load 1/5/15 min |")
    print("|---|---|---|---|---|---|---|---|")
    for k in range(reps):
        for preset in presets:
            with (tempfile.TemporaryDirectory(prefix="hgo-compile-bench-") as cache,
                  tempfile.TemporaryDirectory(prefix="hgo-compile-bench-") as fresh):
                empty = one_run(preset, cache)
                integrators_only(cache, fresh)
                new = one_run(preset, fresh)
                cached = one_run(preset, cache)
            rows[preset].append((empty, new, cached))
            print(f"| {preset} | {k + 1} | {empty['cpu']:.2f} ({empty['numba']:.2f}) | "
                  f"{new['cpu']:.2f} ({new['numba']:.2f}) | "
                  f"{cached['cpu']:.2f} ({cached['numba']:.2f}) | "
                  f"{new['cpu'] - cached['cpu']:.2f} | {empty['cpu'] - new['cpu']:.2f} | "
                  f"{load()} |", flush=True)
    return {p: (statistics.median(n["cpu"] - c["cpu"] for _, n, c in triples),
                statistics.median(e["cpu"] - n["cpu"] for e, n, _ in triples))
            for p, triples in rows.items()}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--reps", type=int, default=3)
    parser.add_argument("--presets", default=",".join(PRESETS))
    args = parser.parse_args()
    print(f"# compile of a new composition (CPU s; start load {load()})\n")
    medians = bench([p for p in args.presets.split(",") if p], args.reps)
    print("\ncompile_new_integrator: " + " ".join(f"{p}={v[1]:.2f}"
                                                  for p, v in medians.items()))
    print("compile_new_composition: " + " ".join(f"{p}={v[0]:.2f}"
                                                 for p, v in medians.items()))


if __name__ == "__main__":
    main()
