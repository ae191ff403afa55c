"""Figures of a run, one function per paper figure with signature ``f(result, path)``.

``result`` is :class:`hgo.running.runner.RunResult` (``.experiment.system``, ``.trajectory``,
``.series`` including post-processed series, ``.metrics``); the runner calls each entry of
the ``figures`` config mapping and writes ``<name>.<figures.format>`` in the run directory
(``png`` by default; ``pdf``, ``svg``) at ``figures.dpi``. Matplotlib runs on its
non-interactive Agg backend (no display needed).

One style for every paper (:data:`STYLE`): mathematical labels in mathtext
(:func:`hat`, :func:`math_label`), units on every axis, panel letters from
:func:`panel_letters`, legends placed where they hide the least data.
"""

from __future__ import annotations

import re
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402

STYLE = {
    "font.size": 10, "axes.titlesize": 10, "axes.labelsize": 10, "legend.fontsize": 8,
    "figure.titlesize": 11, "axes.grid": True, "grid.alpha": 0.3, "lines.linewidth": 1.2,
    "legend.loc": "best", "legend.framealpha": 0.85, "savefig.dpi": 110,
    "mathtext.fontset": "dejavusans",
    # figures made at the dpi they are saved at: savefig reuses the text measurements of
    # the layout (tight_layout) instead of measuring every label again (-0.06 s a figure)
    "figure.dpi": 110,
}
plt.rcParams.update(STYLE)

# symbols of config keys and signal names, as mathtext
_GREEK = {"eps": r"\varepsilon", "mu": r"\mu", "sigma": r"\sigma", "delta": r"\delta",
          "theta": r"\theta", "gamma": r"\gamma", "kappa": r"\kappa", "omega": r"\Omega",
          "eta": r"\eta", "alpha": r"\alpha", "nu": r"\nu", "phi": r"\varphi"}


def symbol(name: str) -> str:
    """``p2`` -> ``p_{2}``, ``eps1`` -> ``\\varepsilon_{1}``, ``x1`` -> ``x_{1}`` (mathtext
    body, no dollars); an unknown name is returned in roman."""
    m = re.fullmatch(r"([A-Za-z]+?)_?(\d*)", name)
    if not m:
        return rf"\mathrm{{{name}}}".replace("_", r"\_")
    base, index = m.groups()
    base = _GREEK.get(base, base if len(base) == 1 else rf"\mathrm{{{base}}}")
    return f"{base}_{{{index}}}" if index else base


def hat(name: str) -> str:
    """Estimate of a state: ``x1`` -> ``$\\hat{x}_{1}$``."""
    m = re.fullmatch(r"([A-Za-z]+?)_?(\d*)", name)
    if not m:
        return rf"$\hat{{{symbol(name)}}}$"
    base, index = m.groups()
    base = _GREEK.get(base, base)
    return rf"$\hat{{{base}}}_{{{index}}}$" if index else rf"$\hat{{{base}}}$"


def math_label(key: str, value: object) -> str:
    """A sweep label: ``observer.sign_indefinite.p2``, 3 -> ``$p_{2} = 3$``."""
    text = value if isinstance(value, str) else f"{value:g}"
    leaf = key.rsplit(".", 1)[-1]
    if isinstance(value, str) and not re.fullmatch(r"[-+.\deE]+", value):
        return f"{leaf} = {text}"
    return f"${symbol(leaf)} = {text}$"


def panel_letters(axes) -> None:
    """Mark each axes (in order) with a unique letter (a), (b), ... in its upper left."""
    for k, ax in enumerate(axes):
        ax.text(-0.02, 1.02, f"({chr(ord('a') + k)})", transform=ax.transAxes,
                ha="right", va="bottom", fontweight="bold")


def legend_outside(ax, below: bool = False) -> None:
    """The legend to the right of the axes (or below them), where it hides no data."""
    if below:
        ax.legend(loc="upper center", bbox_to_anchor=(0.5, -0.12), borderaxespad=0.0)
    else:
        ax.legend(loc="upper left", bbox_to_anchor=(1.01, 1.0), borderaxespad=0.0)


def save_figure(fig, path: str | Path) -> None:
    """Lay out ``fig``, write it to ``path`` (format from its suffix, dpi from
    ``savefig.dpi``) and close it. The file is written as ``<path>.partial`` and renamed
    when complete (:func:`hgo.outputs.recording.atomic_output`)."""
    from hgo.outputs.recording import atomic_output

    fig.tight_layout()
    try:
        with atomic_output(path) as partial:
            fig.savefig(partial, format=Path(path).suffix.lstrip(".") or "png")
    finally:
        plt.close(fig)
