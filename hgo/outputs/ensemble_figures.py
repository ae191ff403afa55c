"""Distribution of the trailing-window metrics over the members of an ensemble."""

from __future__ import annotations

from pathlib import Path

import matplotlib.pyplot as plt
import numpy as np
import pandas as pd

from hgo.outputs.figures import PALETTE, save_figure


def metric_histograms(members: pd.DataFrame, path: Path) -> Path:
    """One histogram (log10 of the value) per (observer, quantity) with a finite value,
    bound marked if any."""
    ok = members[(members.status == "ok") & np.isfinite(members.empirical.astype(float))]
    groups = list(ok.groupby(["observer", "quantity"], sort=False))
    n = max(1, len(groups))
    fig, axes = plt.subplots(n, 1, figsize=(7, 2.2 * n), squeeze=False)
    for ax, ((obs, quantity), grp) in zip(axes[:, 0], groups, strict=False):
        values = grp.empirical.to_numpy(float)
        logs = np.log10(np.clip(values, 1e-300, None))
        ax.hist(logs, bins=40, color=PALETTE["blue"], alpha=0.8)
        bounds = grp.bound.to_numpy(float)
        if np.isfinite(bounds).any():
            ax.axvline(np.log10(np.nanmax(bounds)), color=PALETTE["vermillion"], ls="--",
                       label="largest bound")
            ax.legend(loc="upper right", fontsize=8)
        ax.set_title(f"{obs}: {quantity} ({len(values)} members)", fontsize=9)
        ax.set_xlabel("log10(value)")
    save_figure(fig, path)
    return path
