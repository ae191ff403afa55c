"""Metrics of every paper preset (conf/experiment/*.yaml), stored once and compared later.

Issue 24 changes how components read their parameters (by name instead of by position in
the flat vector); the numbers must not move. ``python tests/preset_metrics.py --write``
runs every case below with the code of the moment and stores its metric rows in
``tests/preset_metrics.json``; ``--check`` runs them again and compares every value to
1e-9 relative (the slow cases too); tests/test_preset_metrics.py checks the quick ones.

A case is a preset's single job (``experiment=<name>``, the config a plain ``hgo run``
composes; a sweep's base job), or an ensemble preset through the ensemble runner, plus a
few overrides that reach the branches the presets do not take by default (other laws,
inputs, readings). Nothing is shortened: the stored values are the presets' own.
"""

from __future__ import annotations

import argparse
import json
import math
import sys
import tempfile
import time
from pathlib import Path

STORE = Path(__file__).with_name("preset_metrics.json")
EXACT_STORE = Path(__file__).with_name("preset_exact.json")
RTOL = 1e-9

#: runs of the restructured observers (cascade, APA, circle criterion) compared bit for bit
#: without FMA contraction (``--write-exact``, ``exact_case``)
EXACT_CASES: dict[str, tuple[str, ...]] = {
    "dhlm_example": ("experiment=dhlm_example", "solver.t_end=4.0", "metrics.window=1.0",
                     "postprocess=none"),
    "apa_fig1": ("experiment=apa_fig1", "solver.t_end=10.0", "metrics.window=1.0",
                 "solver.split_observers=false", "postprocess=none"),
    "moreno_fig1": ("experiment=moreno_fig1", "postprocess=none"),
}

#: case name -> overrides; every preset of conf/experiment, then branch-covering variants
CASES: dict[str, tuple[str, ...]] = {
    **{name: (f"experiment={name}",) for name in (
        "ak_fig1", "ak_fig2", "ak_fig3", "ak_tradeoff", "ak_tradeoff_grid",
        "apa_fig1", "apa_fig2", "apa_model", "apa_noise", "apa_nominal", "apa_readings",
        "apa_seeds", "dhlm_delta", "dhlm_eps", "dhlm_example", "dhlm_sigma",
        "moreno_fig1", "moreno_pe", "moreno_sector", "sp_ensemble", "sp_example", "sp_fig1",
        "sp_fig2", "sp_fig3", "sp_fig3_grid", "sp_fig4", "sp_fig5", "sp_oscillation")},
    "ak_fig2_fixed_eps1": ("experiment=ak_fig2", "controller.observer=fixed_eps1"),
    "apa_readings_linear": ("experiment=apa_readings", "readings.c3=linear"),
    "dhlm_psi_at_xhat": ("experiment=dhlm_example", "observer.cascade.psi_at=xhat"),
    "dhlm_omega_law": ("experiment=dhlm_example", "observer.cascade.omega_law=true"),
    "dhlm_ideal": ("experiment=dhlm_example", "plant.outputs=Hx", "observer.cascade.hgo=ideal"),
    "moreno_sin": ("experiment=moreno_fig1", "controller=moreno_sin"),
    "moreno_bad_a1": ("experiment=moreno_fig1", "controller=moreno_bad", "plant.a=1.0"),
}


def _rows(table) -> dict[str, float]:
    """Metric rows as 'run|member|observer|quantity' -> value (NaN kept as None)."""
    out = {}
    for rec in table.to_dict("records"):
        key = "|".join(str(rec.get(k, "")) for k in ("member", "observer", "quantity"))
        value = rec.get("empirical")
        if isinstance(value, (int, float)):
            out[key] = None if math.isnan(float(value)) else float(value)
    return out


def run_case(overrides: tuple[str, ...]) -> dict[str, float]:
    """The metric rows of one case, computed with the code of the moment."""
    from hgo.running.ensemble_runner import is_ensemble, run_ensemble
    from hgo.running.in_memory import compose_cached
    from hgo.running.runner import simulate_config

    cfg = compose_cached(overrides)
    if is_ensemble(cfg):
        with tempfile.TemporaryDirectory() as tmp:
            return _rows(run_ensemble(cfg, tmp).metrics)
    return _rows(simulate_config(cfg).metrics)


def exact_case(overrides: tuple[str, ...]) -> dict[str, list[float]]:
    """The state at mid-run and at the end, and the window metrics, of one run whose kernel
    is compiled without fast-math flags (no fused multiply-adds: every operation rounds
    as written, so the result depends on the arithmetic of the source, not on how LLVM
    schedules the fusions of the inlined kernel)."""
    import hgo.engine.codegen as codegen
    from hgo.running.in_memory import compose_cached
    from hgo.running.runner import build, run_experiment

    saved, codegen.FASTMATH = codegen.FASTMATH, ()
    try:
        traj = run_experiment(build(compose_cached(overrides)))
    finally:
        codegen.FASTMATH = saved
    return {"z_mid": traj.z[len(traj.z) // 2].tolist(), "z_end": traj.z[-1].tolist(),
            "acc": traj.acc.tolist(), "status": int(traj.status)}


def compare(stored: dict[str, float | None], now: dict[str, float | None],
            rtol: float = RTOL) -> list[str]:
    """Lines naming every row that differs (missing, extra or beyond ``rtol``)."""
    bad = [f"missing row {k}" for k in stored if k not in now]
    bad += [f"new row {k}" for k in now if k not in stored]
    for k in stored.keys() & now.keys():
        a, b = stored[k], now[k]
        if (a is None) != (b is None):
            bad.append(f"{k}: stored {a}, now {b}")
        elif a is not None and not math.isclose(a, b, rel_tol=rtol, abs_tol=0.0) \
                and not (a == b):
            bad.append(f"{k}: stored {a!r}, now {b!r} (rel {abs(a - b) / max(abs(a), 1e-300):.2e})")
    return bad


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    mode = parser.add_mutually_exclusive_group(required=True)
    mode.add_argument("--write", action="store_true", help="store the values of the moment")
    mode.add_argument("--check", action="store_true", help="compare with the stored values")
    mode.add_argument("--write-exact", action="store_true",
                      help="store the runs of EXACT_CASES without FMA contraction")
    parser.add_argument("cases", nargs="*", help="case names (default: all)")
    args = parser.parse_args(argv)
    if args.write_exact:
        EXACT_STORE.write_text(json.dumps({k: exact_case(v) for k, v in EXACT_CASES.items()},
                                          indent=1) + "\n")
        return 0
    names = args.cases or list(CASES)
    stored = json.loads(STORE.read_text()) if STORE.exists() else {"cases": {}}
    failures = 0
    for name in names:
        start = time.perf_counter()
        rows = run_case(CASES[name])
        seconds = time.perf_counter() - start
        if args.write:
            stored["cases"][name] = {"overrides": list(CASES[name]), "seconds": round(seconds, 1),
                                     "rows": rows}
            print(f"{name}: {len(rows)} rows, {seconds:.1f} s", flush=True)
        else:
            bad = compare(stored["cases"][name]["rows"], rows)
            failures += bool(bad)
            print(f"{name}: {'OK' if not bad else 'DIFFERS'} ({seconds:.1f} s)", flush=True)
            for line in bad[:20]:
                print("   ", line)
    if args.write:
        stored["rtol"] = RTOL
        STORE.write_text(json.dumps(stored, indent=1, sort_keys=True) + "\n")
    return 1 if failures else 0


if __name__ == "__main__":
    sys.exit(main())
