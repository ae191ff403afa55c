"""Cost of the Ahrens & Khalil closed loop per simulated second (issue 4, numerics).

    python benchmarks/ak_closed_loop.py [--horizon 20] [--log-samples N]

Runs the ``ak_fig1`` preset (DC motor, switched-gain HGO, speed controller, encoder noise
held 0.8 ms, RK4 at half the stability cap of eps1 = 5e-4) through hgo's normal path
(Hydra compose -> build -> simulate) for the given horizon, after one compiling run, and
prints the median wall time of 3 runs per simulated second, the number of RK4 substeps
and of gain switches. ``--log-samples N`` records N + 1 output samples over the horizon
and also times ``write_recording`` of every series the runner logs (issue 5, logging).
"""

from __future__ import annotations

import argparse
import tempfile
import time
from pathlib import Path

import numpy as np
from hydra import compose, initialize_config_dir

from hgo.core.config import register_configs
from hgo.outputs.recording import write_recording
from hgo.running.runner import build, run_experiment, signals

CONF = str(Path(__file__).resolve().parent.parent / "conf")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--horizon", type=float, default=20.0, help="simulated seconds")
    parser.add_argument("--log-samples", type=int, default=0,
                        help="output samples to record and time the writing of (0: no)")
    args = parser.parse_args()
    register_configs()
    overrides = ["experiment=ak_fig1", f"solver.t_end={args.horizon}"]
    if args.log_samples:
        overrides.append(f"solver.dt_out={args.horizon / args.log_samples!r}")
    with initialize_config_dir(version_base="1.3", config_dir=CONF):
        cfg = compose("config", overrides=overrides)
    exp = build(cfg)
    run_experiment(exp)  # compile (or load the cached kernel)
    times = []
    for _ in range(3):
        t0 = time.perf_counter()
        traj = run_experiment(exp)
        times.append(time.perf_counter() - t0)
    wall = float(np.median(times))
    switches = traj.d[-1, exp.system.observers[0].disc_names.index("n_switches")]
    h = exp.solver.effective_h_max(exp.system.spectral_radius())
    print(f"ak_fig1 closed loop, horizon {args.horizon:g} s, RK4 substep <= {h:.3g} s "
          f"({args.horizon / h:.3g} substeps), status {traj.message}, "
          f"gain switches {switches:g}")
    print(f"wall {wall:.3f} s (median of 3) = {wall / args.horizon:.4f} s per simulated second")
    if args.log_samples:
        series = signals(exp.system, traj)
        with tempfile.TemporaryDirectory() as tmp:
            t0 = time.perf_counter()
            write_recording(Path(tmp) / "run.rrd", traj.t, series, recording_id="bench")
            t_log = time.perf_counter() - t0
        print(f"write_recording of {len(traj.t):,} samples x "
              f"{sum(len(s.names) for s in series)} columns: {t_log:.3f} s = "
              f"{t_log / wall:.2f} x the simulation")


if __name__ == "__main__":
    main()
