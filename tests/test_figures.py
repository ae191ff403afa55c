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


def test_figures_vector_writes_a_vector_copy_beside_each_png(tmp_path):
    cfg = compose(["experiment=sp_fig1", "solver.t_end=5", "metrics.window=1",
                   "figures.vector=pdf"], tmp_path)
    run(cfg, tmp_path)
    assert (tmp_path / "fig1.png").read_bytes().startswith(b"\x89PNG")
    assert (tmp_path / "fig1.pdf").read_bytes().startswith(b"%PDF")


@pytest.mark.parametrize("override, message", [
    ("figures.vector=eps", "figures.vector: 'eps' not in ['pdf', 'svg'] or null"),
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


def _axes(width_in: float = 6.0):
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(width_in, 3))
    return fig, ax


def test_drawn_is_pixel_width_and_keeps_every_extreme():
    """1e4 or 1e6 samples draw as the same number of points (2 per pixel column), and
    the global extremes (a one-sample spike included) are among them."""
    import numpy as np

    from hgo.outputs.figures import drawn

    for n in (10_000, 1_000_000):
        t = np.linspace(0.0, 10.0, n)
        y = np.sin(t)
        y[n // 3] = 5.0  # a one-sample spike
        td, yd = drawn(t, y, 500)
        assert len(td) == len(yd) == 1000
        assert yd.max() == 5.0 and yd.min() == y.min()
        assert np.all(np.diff(td) >= 0)
    short = np.linspace(0.0, 1.0, 1500)
    assert len(drawn(short, short, 500)[0]) == 1500  # <= 4 samples a pixel: unchanged


def test_drawn_keeps_a_falling_curve_falling():
    """A smooth falling curve reduced to pixel columns is still monotone (no zigzag)."""
    import numpy as np

    from hgo.outputs.figures import drawn

    t = np.linspace(0.0, 1.0, 100_000)
    _, yd = drawn(t, np.cos(3 * t), 300)
    assert np.all(np.diff(yd) <= 0)


def test_plot_line_draws_dense_noise_as_a_band_and_a_smooth_curve_as_a_line():
    import matplotlib.pyplot as plt
    import numpy as np

    from hgo.outputs.figures import noisy, pixel_columns, plot_line

    rng = np.random.default_rng(0)
    t = np.linspace(0.0, 50.0, 200_000)
    fig, ax = _axes()
    plot_line(ax, t, 0.5 + 0.4 * rng.uniform(-1, 1, t.size), color="k", label="noisy")
    plot_line(ax, t, np.sin(t), color="k", label="smooth")
    assert len(ax.collections) == 1  # one min/max band: the noisy signal's
    noisy_line, smooth_line = ax.lines
    assert len(noisy_line.get_xdata()) <= pixel_columns(ax)  # the column means
    assert len(smooth_line.get_xdata()) == 2 * pixel_columns(ax)
    assert not noisy(np.sin(t[:-1:400]), np.sin(t[1::400]))
    plt.close(fig)


def _mathtext_png(own_parser: bool) -> tuple[bytes, object]:
    """A small figure with mathtext labels as png bytes, and the parser its renderer used
    (``own_parser``: a new one, as matplotlib gives each renderer)."""
    import io

    import matplotlib.pyplot as plt
    from matplotlib.mathtext import MathTextParser

    fig, ax = plt.subplots(figsize=(3, 2))
    ax.plot([0.0, 1.0], [0.0, 1.0], label=r"$\hat{x}_{1}$")
    ax.set_xlabel(r"$\varepsilon$ (s)")
    ax.legend()
    renderer = fig.canvas.get_renderer()
    if own_parser:
        renderer.mathtext_parser = MathTextParser("path")
    buf = io.BytesIO()
    fig.savefig(buf, format="png")
    assert fig.canvas.get_renderer() is renderer  # (savefig drew with it)
    plt.close(fig)
    return buf.getvalue(), renderer.mathtext_parser


def test_agg_renderers_share_one_mathtext_parser_and_draw_the_same_pixels() -> None:
    """With hgo's figure module loaded, two figures' renderers share one mathtext parser
    (its cache of parsed labels serves every figure of the process), and a figure drawn
    through the shared cache is byte-identical to the same figure drawn by a renderer with
    its own new parser."""
    import hgo.outputs.figures  # noqa: F401  (shares the parser)

    first, shared = _mathtext_png(own_parser=False)
    second, shared_again = _mathtext_png(own_parser=False)
    own, own_parser = _mathtext_png(own_parser=True)
    assert shared is shared_again and own_parser is not shared
    assert first == second == own


def test_a_forked_process_parses_mathtext_again_and_draws_the_same_pixels() -> None:
    """After this process drew mathtext labels, a fork of it (as the figure process forks
    to draw on two cores) draws the same figure with a parser of its own, byte-identical:
    the parent's parses hold its FreeType fonts, which a forked process must not draw with
    (FreeType failed: 'too many hints', 'invalid outline')."""
    import os

    import hgo.outputs.figures  # noqa: F401  (shares the parser)

    png, parser = _mathtext_png(own_parser=False)
    read, write = os.pipe()
    pid = os.fork()
    if pid == 0:  # the child: its png, or a note that it drew with the parent's parser
        try:
            child_png, child_parser = _mathtext_png(own_parser=False)
            os.write(write, b"parent's parser" if child_parser is parser else child_png)
        finally:
            os._exit(0)
    os.close(write)
    with os.fdopen(read, "rb") as pipe:
        drawn = pipe.read()
    os.waitpid(pid, 0)
    assert drawn == png
