"""``hgo plot`` / ``hgo.plot``: the trade-off figure of a sweep and the default figure of a
run, on synthetic run tables and recordings (no simulation: the Duffing tutorial,
docs/tutorials/duffing-tradeoff.md, runs the real sweep in tests/test_docs.py)."""

from __future__ import annotations

import json

import matplotlib
import numpy as np
import pandas as pd
import pytest

from hgo.cli import main
from hgo.core.errors import ConfigError
from hgo.outputs import states_figure, tradeoff

matplotlib.use("Agg")
EPS = np.geomspace(1e-3, 1.0, 61)
SIGMAS = (1e-6, 1e-4, 1e-2)


def error(eps, sigma):
    """A trade-off with a known minimiser: eps* = (sigma / 2)^(1/3)."""
    return eps ** 2 + sigma / eps


def table() -> pd.DataFrame:
    return pd.DataFrame([{"config.run_name": "t", "config.seed": 0,
                          "config.observer.std.eps": e, "config.noise.std": s,
                          "metric.std/max_error": error(e, s),
                          "metric.std/other": 1.0} for e in EPS for s in SIGMAS])


def test_swept_keys_are_the_config_keys_that_vary():
    assert tradeoff.swept_keys(table()) == ["observer.std.eps", "noise.std"]


def test_minima_and_power_law_of_the_minimisers(tmp_path):
    """Each line's minimum is the grid point nearest the analytic minimiser
    (sigma/2)^(1/3); the fitted exponent is 1/3 to the grid's step; png and pdf written."""
    result = tradeoff.plot(table(), metric="max_error", out=tmp_path / "t")
    assert (result.x, result.by) == ("observer.std.eps", "noise.std")
    step = np.log(EPS[1] / EPS[0])
    for _, row in result.minima.iterrows():
        exact = (row["noise.std"] / 2) ** (1 / 3)
        assert abs(np.log(row["observer.std.eps*"] / exact)) <= step
    (fit,) = result.fits
    assert abs(fit.k - 1 / 3) < step / np.log(SIGMAS[-1] / SIGMAS[0]) * 2
    assert [f.name for f in result.files] == ["t.png", "t.pdf"]
    assert all(f.stat().st_size > 5_000 for f in result.files)


def test_axes_are_log_only_where_positive():
    data = table()
    data["metric.std/max_error"] -= 0.05  # some values negative
    fig, _ = tradeoff.draw(data, "max_error")
    ax = fig.axes[0]
    assert ax.get_xscale() == "log" and ax.get_yscale() == "linear"
    fig2, _ = tradeoff.draw(table(), "max_error")
    assert fig2.axes[0].get_yscale() == "log"
    # one line per sigma, a star at each line's minimum
    stars = [ln for ln in fig2.axes[0].lines if ln.get_marker() == "*"]
    assert len(stars) == len(SIGMAS)


def test_fewer_than_three_lines_have_no_fit():
    data = table()
    data = data[data["config.noise.std"] < 1e-3]
    _, result = tradeoff.draw(data, "max_error")
    assert result.fits == [] and len(result.minima) == 2


def test_bad_keys_are_one_line():
    with pytest.raises(ConfigError, match=r"^metric: 'nope' is not a metric .*allowed: "
                                          r"max_error, other"):
        tradeoff.draw(table(), "nope")
    with pytest.raises(ConfigError, match=r"^x: 'seed' is not a swept key .*allowed: "
                                          r"observer.std.eps, noise.std"):
        tradeoff.draw(table(), "max_error", x="seed")


def _write_runs(folder, data: pd.DataFrame) -> None:
    for k, row in enumerate(data.to_dict("records")):
        job = folder / f"job{k}"
        job.mkdir(parents=True)
        config = {c.removeprefix("config."): v for c, v in row.items() if c.startswith("config.")}
        metrics = {c.removeprefix("metric."): v for c, v in row.items() if c.startswith("metric.")}
        (job / "run.json").write_text(json.dumps({"status": "ok", "config": config,
                                                  "metrics": metrics}))


def test_hgo_plot_on_a_sweep_directory(tmp_path, capsys):
    data = table()
    data = data[data["config.observer.std.eps"].isin(EPS[::6])]
    _write_runs(tmp_path / "sweep", data)
    assert main(["plot", str(tmp_path / "sweep"), "--metric", "max_error"]) == 0
    out = capsys.readouterr().out
    assert "std: observer.std.eps* ∝ noise.std^k, k = 0.3" in out
    assert (tmp_path / "sweep" / "tradeoff_max_error.png").is_file()
    assert (tmp_path / "sweep" / "tradeoff_max_error.pdf").is_file()
    assert main(["plot", str(tmp_path / "sweep"), "--metric", "nope"]) == 2
    err = capsys.readouterr().err.strip()
    assert err.startswith("error: metric: 'nope'") and "\n" not in err


def test_default_run_figure_groups_each_state_with_its_estimates_and_error():
    """One row per plant state: x black and solid, each observer's x^ its own colour and
    dashed; the errors on a log scale."""
    t = np.linspace(0, 1, 50)
    frame = pd.DataFrame({"/plant/x/x1": np.sin(t), "/plant/x/x2": np.cos(t),
                          "/observer/a/xhat/x1_hat": np.sin(t) + 0.1,
                          "/observer/a/xhat/x2_hat": np.cos(t) + 0.1,
                          "/observer/b/xhat/x1_hat": np.sin(t) - 0.1,
                          "/error/a/e_x1": 0.1 + 0 * t, "/error/a/e_x2": 0.1 + 0 * t,
                          "/error/b/e_x1": -0.1 + 0 * t}, index=pd.Index(t, name="sim_time"))
    fig = states_figure.draw(frame)
    axes = fig.axes
    assert len(axes) == 4
    x1_lines = axes[0].lines
    assert [ln.get_label() for ln in x1_lines] == ["$x_{1}$", "$\\hat{x}_{1}$ (a)",
                                                   "$\\hat{x}_{1}$ (b)"]
    assert x1_lines[0].get_linestyle() == "-" and x1_lines[0].get_color() == "#000000"
    assert all(ln.get_linestyle() != "-" for ln in x1_lines[1:])
    assert len({ln.get_color() for ln in x1_lines}) == 3
    assert axes[1].get_yscale() == "log" and len(axes[1].lines) == 2
    assert len(axes[3].lines) == 1  # x2: only observer a has its error
