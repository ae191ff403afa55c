"""PNG figures of a run, one function per paper figure with signature ``f(result, path)``.

``result`` is :class:`hgo.runner.RunResult` (``.experiment.system``, ``.trajectory``,
``.series`` including post-processed series, ``.metrics``); the runner calls each entry of
the ``figures`` config mapping and writes ``<name>.png`` in the run directory. Matplotlib
runs on its non-interactive Agg backend (no display needed).
"""

from __future__ import annotations

from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402


def save_figure(fig, path: str | Path) -> None:
    """Lay out ``fig``, write it to ``path`` (PNG, 110 dpi) and close it. The file is
    written as ``<path>.partial`` and renamed when complete
    (:func:`hgo.recording.atomic_output`)."""
    from hgo.recording import atomic_output

    fig.tight_layout()
    try:
        with atomic_output(path) as partial:
            fig.savefig(partial, dpi=110, format=Path(path).suffix.lstrip(".") or "png")
    finally:
        plt.close(fig)
