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
* **new**: with a new kernel cache holding the integrators (``hgo_integrator_*``, the
  tableau texts and numba's cache of them) and the compiled components
  (``components/``, :mod:`hgo.engine.component_cache`, with the texts of the bound
  functions, ``hgo_bound_*``, that call them on their parameter slices), copied from the
  empty run's folder: the composition is new, its integrator and hgo's components known, as after
  a change of an experiment's structure (another observer, noise on or off). The
  results of theory computations (``theory/``: DHLM's LMIs, ~1.5 s of cvxpy, not a
  compile) are copied too: measured before 2026-12-01 without them, dhlm_example's
  "new composition" held that second and a half;
* **new+comp**: as **new** without the components: every component compiles too, as
  for a plant not met before (the measure of "new" before components were cached);
* **cached**: the run again with the empty run's folder (everything loaded from it).

Each process reports its CPU seconds (``time.process_time``: all its threads) from just
before building the experiment to the end of the run, and the seconds numba's compile
events took inside (``hgo.engine.jit.run_seconds``). A new composition costs
``new - cached`` CPU (``new+comp - cached`` with its components), a first use of an
integrator ``empty - new+comp`` (medians of ``--reps`` rounds, interleaved across
presets). Every line carries the load average: the machine is shared.

The last three lines are ``compile_new_integrator: <preset>=<CPU s> ...``,
``compile_new_composition_and_components: ...`` and ``compile_new_composition: ...``.
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


def known_only(cache: str, target: str, components: bool) -> None:
    """Copy the integrators of kernel cache ``cache`` (module texts, tableau texts, numba's
    cache files of the integrator modules), its theory results and, if ``components``,
    its compiled components (and bound functions' texts) into the empty folder
    ``target``."""
    for path in Path(cache).rglob("*"):
        folder = path.relative_to(cache).parts[0]
        component = folder == "theory" or (components and (
            folder == "components" or path.name.startswith("hgo_bound_")))
        if path.is_file() and (component or path.name.startswith(("hgo_integrator_",
                                                                    "hgo_tableau_"))):
            dest = Path(target) / path.relative_to(cache)
            dest.parent.mkdir(parents=True, exist_ok=True)
            shutil.copy2(path, dest)


def bench(presets: list[str], reps: int) -> dict[str, tuple[float, float, float]]:
    """Median CPU seconds of (new - cached, new+comp - cached, empty - new+comp), per
    preset (table lines printed)."""
    rows: dict[str, list[tuple[dict, dict, dict, dict]]] = {p: [] for p in presets}
    print("| preset | round | empty: CPU s (numba's compile events) | new: CPU s (numba) | "
          "new+comp: CPU s (numba) | cached: CPU s (numba) | new - cached | "
          "new+comp - cached | empty - new+comp | load 1/5/15 min |")
    print("|---|---|---|---|---|---|---|---|---|---|")
    for k in range(reps):
        for preset in presets:
            with (tempfile.TemporaryDirectory(prefix="hgo-compile-bench-") as cache,
                  tempfile.TemporaryDirectory(prefix="hgo-compile-bench-") as fresh,
                  tempfile.TemporaryDirectory(prefix="hgo-compile-bench-") as bare):
                empty = one_run(preset, cache)
                known_only(cache, fresh, components=True)
                known_only(cache, bare, components=False)
                new = one_run(preset, fresh)
                new_comp = one_run(preset, bare)
                cached = one_run(preset, cache)
            rows[preset].append((empty, new, new_comp, cached))
            cells = " | ".join(f"{r['cpu']:.2f} ({r['numba']:.2f})"
                               for r in (empty, new, new_comp, cached))
            print(f"| {preset} | {k + 1} | {cells} | {new['cpu'] - cached['cpu']:.2f} | "
                  f"{new_comp['cpu'] - cached['cpu']:.2f} | "
                  f"{empty['cpu'] - new_comp['cpu']:.2f} | {load()} |", flush=True)
    return {p: (statistics.median(n["cpu"] - c["cpu"] for _, n, _, c in rounds),
                statistics.median(nc["cpu"] - c["cpu"] for _, _, nc, c in rounds),
                statistics.median(e["cpu"] - nc["cpu"] for e, _, nc, _ in rounds))
            for p, rounds in rows.items()}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--reps", type=int, default=3)
    parser.add_argument("--presets", default=",".join(PRESETS))
    args = parser.parse_args()
    print(f"# compile of a new composition (CPU s; start load {load()})\n")
    medians = bench([p for p in args.presets.split(",") if p], args.reps)
    print()
    print_medians(medians)


def print_medians(medians: dict[str, tuple[float, float, float]]) -> None:
    """The three summary lines of :func:`bench`'s medians (module doc)."""
    for name, k in (("compile_new_integrator", 2),
                    ("compile_new_composition_and_components", 1),
                    ("compile_new_composition", 0)):
        print(f"{name}: " + " ".join(f"{p}={v[k]:.2f}" for p, v in medians.items()))


if __name__ == "__main__":
    main()
