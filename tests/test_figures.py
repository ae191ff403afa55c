"""The shared figure style: format and dpi settings, mathtext labels for sweeps."""

from __future__ import annotations

import pytest

from hgo.core.config import compose
from hgo.outputs.figures import hat, math_label
from hgo.running.aggregate import figure_label
from hgo.running.runner import run


def test_figures_format_svg_writes_svg(tmp_path):
    cfg = compose(["experiment=sp_fig1", "solver.t_end=5", "metrics.window=1",
                   "figures.format=svg"], tmp_path)
    run(cfg, tmp_path)
    assert (tmp_path / "fig1.svg").read_text().lstrip().startswith("<?xml")
    assert not (tmp_path / "fig1.png").exists()


@pytest.mark.parametrize("override, message", [
    ("figures.format=jpg", "figures.format: 'jpg' not in ['png', 'pdf', 'svg']"),
    ("figures.dpi=0", "figures.dpi must be a number in [10, 1200], got 0"),
])
def test_bad_figure_settings_fail_before_integration(tmp_path, override, message):
    cfg = compose(["experiment=sp_fig1", override], tmp_path)
    with pytest.raises(ValueError, match=message.replace("[", r"\[").replace("(", r"\(")):
        run(cfg, tmp_path)
    assert not (tmp_path / "recording.rrd").exists()


def test_sweep_labels_are_mathematical():
    assert math_label("observer.sign_indefinite.p2", 3) == "$p_{2} = 3$"
    assert math_label("observer.fixed.eps1", 0.001) == r"$\varepsilon_{1} = 0.001$"
    assert math_label("noise.amplitude", 1e-4) == r"$\mathrm{amplitude} = 0.0001$"
    assert figure_label("observer.sign_indefinite.p2=1.5, controller.observer=switched") == (
        "$p_{2} = 1.5$, observer = switched")
    assert hat("x2") == r"$\hat{x}_{2}$"
