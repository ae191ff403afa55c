"""Summary of the ``moreno_pe`` sweep: one row per job (a, L, input) with the error norms,
the time to ||e|| < 1e-3 and the certificate columns of Moreno (12)-(14).

Hydra callback (``hydra.callbacks.moreno_pe``) or ``python -m hgo.papers.moreno.sweep <dir>``;
writes ``pe_summary.csv`` in the sweep directory.
"""

from __future__ import annotations

import sys
from pathlib import Path

import pandas as pd
import yaml
from hydra.experimental.callback import Callback

COLUMNS = ["norm_e_t1", "norm_e_t5", "norm_e_t10", "norm_e_t20", "norm_e_t40",
           "t_norm_below_1e-3", "K1a_sdp", "K1t", "eps", "c", "strong", "alpha1", "holds14",
           "gamma", "eta_end", "eta_tail_slope", "c_need", "max_ratio_ii"]


def summarise(sweep: str | Path, observer: str = "circle") -> pd.DataFrame:
    """The summary table of the sweep directory (jobs without metrics.csv are skipped)."""
    rows = []
    for job in sorted(Path(sweep).glob("job*"), key=lambda p: int(p.name[3:] or 0)):
        csv = job / "metrics.csv"
        if not csv.exists():
            continue
        ov = yaml.safe_load((job / ".hydra" / "overrides.yaml").read_text()) or []
        m = pd.read_csv(csv)
        m = m[m["observer"] == observer].set_index("quantity")["empirical"]
        rows.append({"job": job.name, "overrides": " ".join(map(str, ov)),
                     **{c: m.get(c) for c in COLUMNS}})
    table = pd.DataFrame(rows)
    table.to_csv(Path(sweep) / "pe_summary.csv", index=False)
    return table


class PeSummary(Callback):
    """Writes ``pe_summary.csv`` at the end of the multirun."""

    def __init__(self, observer: str = "circle") -> None:
        self.observer = observer

    def on_multirun_end(self, config, **kwargs) -> None:
        summarise(config.hydra.sweep.dir, self.observer)


if __name__ == "__main__":
    print(summarise(sys.argv[1]).to_string(index=False))
