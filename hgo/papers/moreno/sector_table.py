"""Sector table of Moreno (7)-(8): K1^a and eps_max by LMI and by the exact SPR test side by
side, for a list of gain sets (k, l1, l2, a) of the example, eps_max(rho) along rho, and
the sector maximisation (8) over all gains (notes 6.3).

A post-processor (``postprocess.sector``; the run's trajectory is not used): its rows go to
``metrics.csv`` (observer = the gain set, e.g. ``k=2 l1=200 l2=120 a=0``) and the figure
function :func:`sector_figure` writes them as ``sector_table.csv`` (one row per gain set,
methods side by side) and a PNG.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
import pandas as pd

from hgo.engine.simulate import Trajectory
from hgo.engine.system import System
from hgo.papers.moreno.theory import (
    ErrorSystem,
    eps_max_fd,
    eps_max_lmi,
    k1a_closed,
    k1a_fd,
    k1a_over_gains,
    k1a_sdp,
)
from hgo.postprocess import PostOutput

K1_EXAMPLE = -2.0  # the example's sector [-2, inf] over all sigma (Section 5)
DELTA = 0.1  # margin of K~1 = max(K1, K1^a + delta/2) in the table (A5, R2)


def example_error_system(k: float, l1: float, l2: float, a: float) -> ErrorSystem:
    """(A_L, G, H_N) of the example for gains L = (l1, l2), N = k and plant parameter a."""
    return ErrorSystem.from_gains([[-1.0, 1.0], [0.0, -a]], [1.0, 0.0], [1.0, 0.0],
                                  [0.0, 1.0], [l1, l2], k)


def label(k: float, l1: float, l2: float, a: float) -> str:
    return f"k={k:g} l1={l1:g} l2={l2:g} a={a:g}"


def gain_row(k: float, l1: float, l2: float, a: float) -> dict[str, float]:
    """K1^a (SDP, exact FD, closed form), eps_max at K1 = -2 and at K~1 (LMI and FD)."""
    es = example_error_system(k, l1, l2, a)
    sdp, fd, closed = k1a_sdp(es), k1a_fd(es), k1a_closed(k, l1, l2, a)
    K1t = max(K1_EXAMPLE, sdp + DELTA / 2)
    return {"K1a_sdp": sdp, "K1a_fd": fd, "K1a_closed": closed,
            "strong": float(fd < K1_EXAMPLE), "kyp_ok": float(es.check_kyp()),
            "eps_max_lmi_K1=-2": eps_max_lmi(es, K1_EXAMPLE),
            "eps_max_fd_K1=-2": eps_max_fd(es, K1_EXAMPLE), "K1t": K1t,
            "eps_max_lmi_K1t": eps_max_lmi(es, K1t), "eps_max_fd_K1t": eps_max_fd(es, K1t)}


@dataclass
class SectorTable:
    gains: list[list[float]] = field(default_factory=list)
    rho_gains: list[float] = field(default_factory=list)
    rhos: list[float] = field(default_factory=list)
    over_gains_a: list[float] = field(default_factory=list)
    rho_lo: float = -50.0

    def rows(self) -> list[dict]:
        out = []
        for g in self.gains:
            out += [{"observer": label(*g), "quantity": q, "empirical": v}
                    for q, v in gain_row(*g).items()]
        if self.rhos:
            es = example_error_system(*self.rho_gains)
            for rho in self.rhos:
                out += [{"observer": label(*self.rho_gains), "quantity": f"eps_max_lmi_rho={rho:g}",
                         "empirical": eps_max_lmi(es, rho)},
                        {"observer": label(*self.rho_gains), "quantity": f"eps_max_fd_rho={rho:g}",
                         "empirical": eps_max_fd(es, rho)}]
        for a in self.over_gains_a:
            A = [[-1.0, 1.0], [0.0, -a]]
            rho, L, N = k1a_over_gains(A, [1.0, 0.0], [1.0, 0.0], [0.0, 1.0], self.rho_lo)
            name = f"over all gains a={a:g}"
            out.append({"observer": name, "quantity": "K1a_min_lmi", "empirical": rho})
            if L is not None:
                out.append({"observer": name, "quantity": "K1a_closed_at_found_gains",
                            "empirical": k1a_closed(N, L[0], L[1], a)})
                out += [{"observer": name, "quantity": q, "empirical": v}
                        for q, v in (("k", N), ("l1", L[0]), ("l2", L[1]))]
        return out

    def apply(self, system: System, traj: Trajectory) -> PostOutput:  # noqa: ARG002
        return PostOutput(rows=self.rows())


def sector_table(gains: list[list[float]], rho_gains: list[float], rhos: list[float],
                 over_gains_a: list[float], rho_lo: float = -50.0) -> SectorTable:
    """Factory of the ``postprocess`` option ``moreno_sector``."""
    for g in gains + [rho_gains]:
        if len(g) != 4:
            raise ValueError(f"postprocess.sector.gains: each entry is [k, l1, l2, a], got {g}")
    if not rho_lo < 0:
        raise ValueError(f"postprocess.sector.rho_lo must be < 0, got {rho_lo}")
    return SectorTable([list(map(float, g)) for g in gains], list(map(float, rho_gains)),
                       list(map(float, rhos)), list(map(float, over_gains_a)), float(rho_lo))


def wide_table(metrics: pd.DataFrame) -> pd.DataFrame:
    """The sector rows of ``metrics.csv`` as one row per gain set, methods side by side."""
    rows = metrics[metrics["postprocess"] == "sector"]
    return rows.pivot_table(index="observer", columns="quantity", values="empirical",
                            aggfunc="first", sort=False)


METHOD_LABELS = {"K1a_sdp": "LMI (7a), by SDP", "K1a_fd": "exact SPR test (frequency domain)",
                 "K1a_closed": "closed form"}


def gains_label(name: str, sep: str = "\n") -> str:
    """``k=2 l1=200 l2=120 a=0`` (:func:`label`) in the paper's notation, one per line."""
    symbols = {"k": "k", "l1": "l_1", "l2": "l_2", "a": "a"}
    parts = [p.split("=", 1) for p in name.split()]
    return sep.join(f"${symbols.get(k, k)} = {v}$" for k, v in parts)


def sector_figure(result, path) -> None:
    """``sector_table.csv`` beside ``path`` and a figure: K1^a by SDP / exact SPR / closed
    form per gain set, and eps_max(rho) by LMI and by the SPR test."""
    import matplotlib.pyplot as plt  # (only when drawing: a claims task draws nothing)

    from hgo.outputs.figures import PALETTE, save_figure

    table = wide_table(result.metrics)
    table.to_csv(path.with_suffix(".csv"))
    sets = table.dropna(subset=["K1a_sdp"])
    fig, axes = plt.subplots(1, 2, figsize=(12, 4.8), gridspec_kw={"width_ratios": [3, 2]})
    x = np.arange(len(sets))
    for off, col, mk in ((-0.2, "K1a_sdp", "o"), (0.0, "K1a_fd", "s"), (0.2, "K1a_closed", "^")):
        axes[0].plot(x + off, sets[col], mk, label=METHOD_LABELS[col])
    axes[0].axhline(K1_EXAMPLE, color="k", lw=0.8, ls="--",
                    label=r"$K_1 = -2$ (the example's nonlinearity)")
    axes[0].set_xticks(x, [gains_label(name) for name in sets.index], fontsize=7)
    axes[0].set_ylabel(r"$K_1^a$ of the stability sector $(K_1^a, \infty]$ (–)")
    axes[0].set_xlabel("gain set (the notes' table)")
    axes[0].legend(fontsize=8, loc="lower left")
    cols = [c for c in table.columns if c.startswith("eps_max_lmi_rho=")]
    if cols:
        rho = [float(c.split("=")[1]) for c in cols]
        row = table.loc[table[cols].notna().all(axis=1)].iloc[0]
        axes[1].plot(rho, [row[c] for c in cols], "o-", color=PALETTE["blue"], lw=2.5,
                     alpha=0.6, label="LMI (7a)")
        axes[1].plot(rho, [row[c.replace("lmi", "fd")] for c in cols], "x--", color="k",
                     label="exact SPR test")
        axes[1].set_xlabel(r"$\rho$ of the sector $[\rho, \infty]$ (–)")
        axes[1].set_ylabel(r"$\varepsilon_{\max}(\rho)$ (–)")
        axes[1].set_title(gains_label(row.name, ", "), fontsize=9)
        axes[1].legend(fontsize=8)
    for ax in axes:
        ax.grid(alpha=0.3)
    save_figure(fig, path)
