r"""The trade-off figure of a sweep: a metric against one swept key, one line per value of
another (``hgo plot``, :func:`hgo.plot`).

The figure every high-gain paper has: the error of an observer against its gain parameter
$\varepsilon$, one line per noise level $\sigma$. Axes are logarithmic where every value
is positive; the minimum of each line is marked; with three or more lines (values of the
second key) the minimisers are fitted by a power law

$$\varepsilon^* = c\,\sigma^k \quad (\log \varepsilon^* = k \log \sigma + \log c,
\text{ least squares})$$

printed and drawn in a panel of its own, per observer. The minimiser of a line is the
swept value with the smallest metric (a grid minimum: its resolution is the grid's).

The table is that of :func:`hgo.outputs.runs.load` (one row per run, ``config.<key>`` and
``metric.<observer>/<quantity>`` columns): the swept keys are the config keys whose value
differs between the runs.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import pandas as pd

from hgo.core.errors import ConfigError

#: config keys that vary between runs without being a swept parameter
NOT_SWEPT = ("config.hydra", "config.run_name")


@dataclass
class PowerLaw:
    """``x* = c by^k`` fitted to the minimisers of one observer's lines."""

    observer: str
    k: float
    c: float
    k_se: float  # standard error of k (0 for 2 points, where the line is exact)
    points: int

    def text(self, x: str, by: str) -> str:
        se = f" ± {self.k_se:.2g}" if self.k_se > 1e-9 * abs(self.k) else ""
        return (f"{self.observer}: {x}* ∝ {by}^k, k = {self.k:.3g}{se} "
                f"({self.points} minima, c = {self.c:.3g})")


@dataclass
class Tradeoff:
    """What :func:`plot` drew: the keys, the minima of each line, the fits, the files."""

    metric: str
    x: str
    by: str | None
    minima: pd.DataFrame  # observer, <by>, <x>*, metric at the minimum
    fits: list[PowerLaw] = field(default_factory=list)
    files: list[Path] = field(default_factory=list)


def swept_keys(table: pd.DataFrame) -> list[str]:
    """The config keys (without ``config.``) whose value differs between the runs, in
    column order."""
    keys = []
    for column in table.columns:
        if not column.startswith("config.") or column.startswith(NOT_SWEPT):
            continue
        values = table[column].dropna().map(repr)
        if values.nunique() > 1:
            keys.append(column.removeprefix("config."))
    return keys


def metric_columns(table: pd.DataFrame, metric: str | None) -> dict[str, str]:
    """Observer -> the ``metric.<observer>/<quantity>`` column of ``metric`` (a quantity,
    ``observer/quantity``, or None: the first quantity of the table)."""
    columns = [c for c in table.columns if c.startswith("metric.")]
    quantities = list(dict.fromkeys(c.split("/", 1)[1] for c in columns if "/" in c))
    if not quantities:
        raise ConfigError("metric", "the runs have no metrics")
    metric = metric or quantities[0]
    chosen = {c.removeprefix("metric.").split("/", 1)[0]: c for c in columns
              if c == f"metric.{metric}" or c.split("/", 1)[-1] == metric}
    if not chosen:
        raise ConfigError("metric", f"'{metric}' is not a metric of these runs",
                          ", ".join(quantities))
    return chosen


def _numeric(table: pd.DataFrame, key: str) -> pd.Series:
    values = pd.to_numeric(table[f"config.{key}"], errors="coerce")
    if values.isna().any():
        raise ConfigError("x", f"'{key}' has values that are not numbers: "
                          f"{sorted(set(table[f'config.{key}'].map(str)))[:5]}")
    return values


def minima(table: pd.DataFrame, column: str, x: str, by: str | None) -> pd.DataFrame:
    """Per value of ``by``: the ``x`` of the smallest finite metric and that metric."""
    data = pd.DataFrame({"x": _numeric(table, x), "y": pd.to_numeric(table[column]),
                         "by": _numeric(table, by) if by else 0.0})
    data = data[np.isfinite(data.y)]
    best = data.loc[data.groupby("by").y.idxmin()]
    return best.rename(columns={"x": f"{x}*", "y": "metric", "by": by or "by"})


def power_law(observer: str, by_values: np.ndarray, x_star: np.ndarray) -> PowerLaw | None:
    """Least squares of log x* on log by (>= 3 positive points), else None."""
    ok = (by_values > 0) & (x_star > 0)
    if ok.sum() < 3:
        return None
    lb, lx = np.log(by_values[ok]), np.log(x_star[ok])
    (k, logc), residuals, *_ = np.polyfit(lb, lx, 1, full=True)
    n = int(ok.sum())
    dof = n - 2
    sigma2 = float(residuals[0]) / dof if residuals.size and dof > 0 else 0.0
    k_se = math.sqrt(sigma2 / float(np.sum((lb - lb.mean()) ** 2)))
    return PowerLaw(observer, float(k), float(math.exp(logc)), k_se, n)


def _label(key: str, value: float) -> str:
    from hgo.outputs.figures import math_label

    return math_label(key, value)


def _axis_label(key: str) -> str:
    from hgo.outputs.figures import symbol

    return f"${symbol(key.rsplit('.', 1)[-1])}$  ({key})"


def draw(table: pd.DataFrame, metric: str | None = None, x: str | None = None,
         by: str | None = None) -> tuple[object, Tradeoff]:
    """The figure (not saved) and what it shows; keys default to the first two swept."""
    import matplotlib.pyplot as plt
    from matplotlib.ticker import NullFormatter

    from hgo.outputs.figures import RUN_STYLES

    keys = swept_keys(table)
    if not keys:
        raise ConfigError("x", "the runs differ in no config key: not a sweep")
    x = x or keys[0]
    by = by if by is not None else next((k for k in keys if k != x), None)
    for name, key in (("x", x), ("by", by)):
        if key is not None and key not in keys:
            raise ConfigError(name, f"'{key}' is not a swept key of these runs",
                              ", ".join(keys))
    columns = metric_columns(table, metric)
    quantity = next(iter(columns.values())).split("/", 1)[1]
    all_minima, fits = [], []
    for observer, column in columns.items():
        best = minima(table, column, x, by)
        best.insert(0, "observer", observer)
        all_minima.append(best)
        fit = power_law(observer, best[by].to_numpy(float), best[f"{x}*"].to_numpy(float)) \
            if by else None
        if fit:
            fits.append(fit)
    n_obs, with_fit = len(columns), bool(fits)
    fig, axes = plt.subplots(n_obs, 2 if with_fit else 1, squeeze=False,
                             figsize=(10.0 if with_fit else 6.0, 3.6 * n_obs))
    for row, (observer, column) in enumerate(columns.items()):
        ax = axes[row][0]
        xs, ys = _numeric(table, x), pd.to_numeric(table[column])
        groups = [(None, table.index)] if by is None else \
            sorted(table.groupby(_numeric(table, by)).groups.items())
        for g, (value, index) in enumerate(groups):
            order = xs[index].sort_values().index
            style = RUN_STYLES[g % len(RUN_STYLES)]
            label = _label(by, value) if by else None
            ax.plot(xs[order], ys[order], marker="o", ms=3, label=label, **style)
            finite = ys[order][np.isfinite(ys[order])]
            if finite.size:
                i = finite.idxmin()
                ax.plot([xs[i]], [ys[i]], marker="*", ms=13, color=style["color"],
                        markeredgecolor="black", ls="none",
                        label="minimum of each line" if g == 0 else None)
        if (xs > 0).all():
            ax.set_xscale("log")
            ax.xaxis.set_minor_formatter(NullFormatter())  # (overlapping under a decade)
        if (ys[np.isfinite(ys)] > 0).all():
            ax.set_yscale("log")
        ax.set_xlabel(_axis_label(x))
        ax.set_ylabel(quantity)
        ax.set_title(observer)
        ax.legend(fontsize=7)
        fit = next((f for f in fits if f.observer == observer), None)
        if fit:
            _draw_fit(axes[row][1], all_minima[row], fit, x, by)
    fig.suptitle(f"{quantity} against {x}" + (f", one line per {by}" if by else ""))
    return fig, Tradeoff(quantity, x, by, pd.concat(all_minima, ignore_index=True), fits)


def _draw_fit(ax, best: pd.DataFrame, fit: PowerLaw, x: str, by: str) -> None:
    """The minimisers against ``by`` and the fitted power law, log-log."""
    b, xs = best[by].to_numpy(float), best[f"{x}*"].to_numpy(float)
    ax.plot(b, xs, "o", color="black", label="minimiser of each line")
    grid = np.geomspace(b[b > 0].min(), b.max(), 50)
    ax.plot(grid, fit.c * grid ** fit.k, color="#D55E00",
            label=f"fit: ${symbol_of(x)}^* \\propto {symbol_of(by)}^{{{fit.k:.2f}}}$")
    ax.set_xscale("log")
    ax.set_yscale("log")
    ax.set_xlabel(_axis_label(by))
    ax.set_ylabel(f"${symbol_of(x)}^*$ (minimiser)")
    ax.set_title(f"{fit.observer}: minimiser, k = {fit.k:.3g}")
    ax.legend(fontsize=7)


def symbol_of(key: str) -> str:
    from hgo.outputs.figures import symbol

    return symbol(key.rsplit(".", 1)[-1])


def plot(source: str | Path | pd.DataFrame, metric: str | None = None, x: str | None = None,
         by: str | None = None, out: str | Path | None = None) -> Tradeoff:
    """Draw the trade-off figure of a sweep and write it as ``png`` and ``pdf``.

    Args:
        source: a sweep directory (every ``run.json`` below it), or the table of
            :func:`hgo.outputs.runs.load`.
        metric: a quantity (``max_error``, ``mean_sq_error_x1``), or ``observer/quantity``
            for one observer; default the first quantity. One row of panels per observer.
        x: the swept key on the horizontal axis (default: the first swept key).
        by: the swept key with one line per value (default: the second; none for a
            one-key sweep).
        out: the files' path without suffix (default ``<source>/tradeoff_<metric>``): a
            ``.png`` and a ``.pdf`` are written.

    Returns:
        The keys, the minima of every line, the power-law fits (``Tradeoff.fits``, with
            three or more lines) and the files written.

    Example:
        ```python
        import tempfile
        from pathlib import Path

        import numpy as np
        import pandas as pd
        from hgo.outputs.tradeoff import plot

        # error ~ eps^2 + sigma / eps: smallest at eps* = (sigma / 2)^(1/3)
        rows = [{"config.eps": e, "config.sigma": s, "metric.std/max_error": e**2 + s / e}
                for e in np.geomspace(1e-3, 1.0, 61) for s in (1e-6, 1e-4, 1e-2)]
        t = plot(pd.DataFrame(rows), out=Path(tempfile.mkdtemp()) / "tradeoff")
        print(t.x, t.by, [f.name for f in t.files])  # eps sigma ['tradeoff.png', 'tradeoff.pdf']
        # k fitted to the grid's minima: 1/3 up to the grid's step
        print(f"{t.fits[0].k:.2f}")  # 0.34
        ```
    """
    from hgo.outputs.figures import save_png_and_pdf
    from hgo.outputs.runs import load

    table = source if isinstance(source, pd.DataFrame) else load(source)
    if table.empty:
        raise ConfigError("source", f"no run.json under {source}")
    fig, result = draw(table, metric, x, by)
    if out is None:
        if isinstance(source, pd.DataFrame):
            raise ConfigError("out", "a table has no folder: give out=<path without suffix>")
        out = Path(source) / f"tradeoff_{result.metric}"
    Path(out).parent.mkdir(parents=True, exist_ok=True)
    result.files = save_png_and_pdf(fig, out)
    return result
