"""The default figure of a run: every plant state with its estimates, and the estimation
errors on a log scale (``hgo plot <run>``, for a run whose preset draws no figure).

One row per plant state: on the left $x_i$ (black, solid) and each observer's $\\hat x_i$
(a colour and a dashed line style each); on the right $|\\hat x_i - x_i|$ of each observer,
logarithmic. Read back from the run's ``recording.rrd`` (``/plant/x/<state>``,
``/observer/<name>/xhat/<state>_hat``, ``/error/<name>/e_<state>``).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd

from hgo.core.errors import ConfigError

ESTIMATE_STYLES = ("--", "-.", ":", (0, (5, 1, 1, 1)))


def signals_by_state(frame: pd.DataFrame) -> dict[str, dict[str, dict[str, str]]]:
    """State -> {"x": column, "xhat": {observer: column}, "error": {observer: column}}."""
    states: dict[str, dict] = {}
    for column in frame.columns:
        parts = column.strip("/").split("/")
        if parts[:2] == ["plant", "x"]:
            states.setdefault(parts[2], {"xhat": {}, "error": {}})["x"] = column
    for column in frame.columns:
        parts = column.strip("/").split("/")
        if len(parts) == 4 and parts[0] == "observer" and parts[2] == "xhat":
            state = parts[3].removesuffix("_hat")
            if state in states:
                states[state]["xhat"][parts[1]] = column
        elif len(parts) == 3 and parts[0] == "error" and parts[2].startswith("e_"):
            state = parts[2].removeprefix("e_")
            if state in states:
                states[state]["error"][parts[1]] = column
    return states


def draw(frame: pd.DataFrame, title: str = ""):
    """The figure (not saved) of a recording read with
    :func:`hgo.outputs.recording.read_recording`."""
    import matplotlib.pyplot as plt

    from hgo.outputs.figures import CYCLE, PALETTE, hat, symbol

    states = signals_by_state(frame)
    if not states:
        raise ConfigError("run", "its recording has no plant states (/plant/x/...)")
    observers = sorted({o for s in states.values() for o in (*s["xhat"], *s["error"])})
    colour = {o: CYCLE[k % len(CYCLE)] for k, o in enumerate(observers)}
    line = {o: ESTIMATE_STYLES[k % len(ESTIMATE_STYLES)] for k, o in enumerate(observers)}
    fig, axes = plt.subplots(len(states), 2, squeeze=False, sharex=True,
                             figsize=(10.0, 2.4 * len(states) + 0.6))
    t = frame.index.to_numpy(float)
    for row, (state, cols) in enumerate(states.items()):
        left, right = axes[row]
        left.plot(t, frame[cols["x"]], color=PALETTE["black"], lw=1.4, label=f"${symbol(state)}$")
        for obs, column in cols["xhat"].items():
            left.plot(t, frame[column], color=colour[obs], ls=line[obs],
                      label=f"{hat(state)} ({obs})")
        left.set_ylabel(f"${symbol(state)}$")
        left.legend(fontsize=7, loc="upper right")
        for obs, column in cols["error"].items():
            err = np.abs(frame[column].to_numpy(float))
            right.plot(t, np.where(err > 0, err, np.nan), color=colour[obs], label=obs)
        right.set_yscale("log")
        right.set_ylabel(f"$|{hat(state).strip('$')} - {symbol(state)}|$")
        if cols["error"]:
            right.legend(fontsize=7, loc="upper right")
    for ax in axes[-1]:
        ax.set_xlabel("t (s)")
    axes[0][0].set_title("state (black) and estimates (dashed)")
    axes[0][1].set_title("estimation error, log scale")
    if title:
        fig.suptitle(title)
    return fig


def states_figure(run_dir: str | Path, out: str | Path | None = None) -> list[Path]:
    """Write the default figure of the run in ``run_dir`` (``<run_dir>/states.png`` and
    ``.pdf``, or ``out`` + each suffix); the files written."""
    from hgo.outputs.figures import save_png_and_pdf
    from hgo.outputs.recording import read_recording

    run_dir = Path(run_dir)
    recording = run_dir / "recording.rrd"
    if not recording.is_file():
        raise ConfigError("run", f"{run_dir} has no recording.rrd (recording=off?)")
    fig = draw(read_recording(recording), title=run_dir.resolve().name)
    return save_png_and_pdf(fig, Path(out) if out is not None else run_dir / "states")
