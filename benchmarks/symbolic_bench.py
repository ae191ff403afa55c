"""The plant given by its equations (``plant=symbolic``, issue 42) against the same plant
written by hand: one kernel each, the same observer, DOP853; target <= 1.1x.

    python benchmarks/symbolic_bench.py [--reps 15]

Plants: Lotka-Volterra (n = 2) and Rossler (n = 3), each with hgo's standard high-gain
observer (n states, eps = 0.05, phi0 = 0: the same observer object in both systems, so the
plant's functions are the only difference), no noise, t = 0 .. 2000 s, outputs every 0.1 s,
rtol 1e-10 / atol 1e-12. Times: medians of interleaved calls in CPU seconds of the process
(robust on a shared machine), after compilation. Also printed: the largest difference of
the plant states between the two runs (the generated code groups terms its own way:
round-off only).
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from timing import interleaved_median_cpu, table  # noqa: E402

from hgo.core.components import Params, Plant  # noqa: E402
from hgo.engine.simulate import SolverSettings, no_noise, simulate  # noqa: E402
from hgo.engine.system import System  # noqa: E402
from hgo.observers.normal_form import standard_hgo  # noqa: E402
from hgo.plants.symbolic import symbolic_plant  # noqa: E402


def lv_f(t, x, u, p, dx):
    dx[0] = p.a * x[0] - p.b * x[0] * x[1]
    dx[1] = p.c * x[0] * x[1] - p.d * x[1]


def rossler_f(t, x, u, p, dx):
    dx[0] = -x[1] - x[2]
    dx[1] = x[0] + p.a * x[1]
    dx[2] = p.b + x[2] * (x[0] - p.c)


def h_first(t, x, p, y):
    y[0] = x[0]


def h_second(t, x, p, y):
    y[0] = x[1]


CASES = {
    "lotka_volterra": (dict(states=["x1", "x2"], params={"a": 1.0, "b": 0.5, "c": 0.5, "d": 1.0},
                            f={"x1": "a*x1 - b*x1*x2", "x2": "c*x1*x2 - d*x2"},
                            h={"y": "x1"}, x0=[2.0, 1.0]), lv_f, h_first, 0),
    "rossler": (dict(states=["x", "y", "z"], params={"a": 0.2, "b": 0.2, "c": 5.7},
                     f={"x": "-y - z", "y": "x + a*y", "z": "b + z*(x - c)"},
                     h={"out": "y"}, x0=[1.0, 1.0, 0.0]), rossler_f, h_second, 1),
}


def systems(name: str) -> tuple[System, System]:
    spec, f, h, out = CASES[name]
    sym = symbolic_plant(name=name, **spec)
    hand = Plant(name=name, state_names=list(spec["states"]), output_names=["y"],
                 input_names=[], x0=np.asarray(spec["x0"], float), p=Params(**spec["params"]),
                 f=f, h=h, output_state=out)
    obs = standard_hgo("standard", len(spec["states"]), eps=0.05)
    return System(sym, [obs]), System(hand, [obs])


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--reps", type=int, default=15)
    args = parser.parse_args(argv)
    solver = SolverSettings(t_end=2000.0, dt_out=0.1, method="dop853", h_max=2000.0,
                            rtol=1e-10, atol=1e-12)
    rows = []
    for name in CASES:
        sym, hand = systems(name)
        runs = [lambda s=s: simulate(s, solver, no_noise(1)) for s in (sym, hand)]
        for run in runs:
            run()  # compile or load
        (t_sym, a), (t_hand, b) = interleaved_median_cpu(runs, args.reps)
        diff = float(np.abs(a.z[:, :sym.plant.nx] - b.z[:, :sym.plant.nx]).max())
        rows.append([name, t_sym * 1e3, t_hand * 1e3, t_sym / t_hand, diff])
    table("symbolic plant against the same plant by hand (DOP853, 2000 s)",
          ["plant", "symbolic (ms CPU)", "by hand (ms CPU)", "ratio", "max |x diff|"], rows)
    print("symbolic_over_hand: " + " ".join(f"{r[0]}={r[3]:.3f}" for r in rows))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
