"""Dimassi et al. sweeps over eps, delta or sigma: combined table and a metrics-vs-value figure.

``SweepCallback`` (Hydra ``on_multirun_end``, set by ``conf/experiment/dhlm_{eps,delta,
sigma}.yaml``) writes, in the sweep directory, ``metrics_all.csv``/``.md`` (via
``experiments/aggregate.py``) and ``sweep.png``: the residuals on W, the parameter bias and
R^2 (23) against the swept value, one panel each. After a failed job (Hydra then skips the
callback): ``python -m hgo.papers.dimassi.sweep <sweep dir>``.
"""

from __future__ import annotations

import sys
from pathlib import Path

import matplotlib.pyplot as plt
import pandas as pd
from hydra.experimental.callback import Callback

from hgo.outputs.figures import save_figure

PANELS = (("max_abs_e2_W", "max |e2| on W [rad/s]"),
          ("rms_rel_theta_err1_W", "RMS theta~1/theta1 on W"),
          ("rms_rel_theta_err2_W", "RMS theta~2/theta2 on W"),
          ("R2", "R^2 of (23) (beta measured)"))


def swept_values(rows: pd.DataFrame) -> tuple[str, dict[str, float]]:
    """(key, job -> value) of the ``observer.cascade.*`` override that varies across jobs."""
    per_job = rows.drop_duplicates("job").set_index("job")["overrides"]
    found: dict[str, dict[str, float]] = {}
    for job, text in per_job.items():
        for item in str(text).split():
            key, _, value = item.partition("=")
            if key.startswith("observer.cascade."):
                found.setdefault(key, {})[job] = float(value)
    key = next(k for k, v in found.items() if len(set(v.values())) > 1)
    return key, found[key]


def sweep_figure(metrics_all: Path, path: Path) -> Path:
    """The PANELS metrics of the cascade observer against the swept value (log axes)."""
    rows = pd.read_csv(metrics_all)
    key, values = swept_values(rows)
    rows = rows[rows.observer == "cascade"]
    fig, axes = plt.subplots(1, len(PANELS), figsize=(4 * len(PANELS), 3.4))
    for ax, (quantity, label) in zip(axes, PANELS, strict=True):
        sel = rows[rows.quantity == quantity].set_index("job")["empirical"]
        pts = sorted((values[j], v) for j, v in sel.items() if j in values)
        xs = [p[0] for p in pts]
        ax.plot(xs, [p[1] for p in pts], "o-")
        ax.set_xscale("symlog", linthresh=min(x for x in xs if x > 0))
        ax.set_yscale("log")
        ax.set_xlabel(key.split(".")[-1])
        ax.set_title(label, fontsize=9)
        ax.grid(alpha=0.3)
    fig.suptitle(f"Dimassi et al. sweep of {key} (W = [10, 20] s)", fontsize=10)
    save_figure(fig, path)
    return path


def report(sweep: str | Path) -> Path:
    """metrics_all.csv/.md (:func:`hgo.running.aggregate.aggregate`, no comparison panel)
    and sweep.png."""
    from hgo.running.aggregate import aggregate

    paths = aggregate(sweep, observer="cascade", figure=False)
    return sweep_figure(paths["csv"], Path(sweep) / "sweep.png")


class SweepCallback(Callback):
    """Hydra callback: :func:`report` at the end of the multirun."""

    def on_multirun_end(self, config, **kwargs) -> None:
        try:
            print(f"sweep figure: {report(config.hydra.sweep.dir)}")
        except Exception as err:  # never turn a finished sweep into a failure
            print(f"sweep report failed ({err}); run python -m hgo.papers.dimassi.sweep "
                  f"{config.hydra.sweep.dir}", file=sys.stderr)


if __name__ == "__main__":
    print(report(sys.argv[1]))
