"""Recordings that fit: ``recording.mode`` full | decimated | off, and the min/max envelope.

* ``full`` (default for single runs): every output sample of every series.
* ``decimated``: at most ``recording.max_rows`` rows. The N samples are cut into
  ``max_rows // 2`` buckets of consecutive samples; bucket k gives two rows, the minimum
  of every column stamped with the bucket's first sample time and the maximum stamped
  with its last, so every peak and trough of every column stays visible (to within one
  bucket in time). A run with N <= max_rows is written in full.
* ``off``: no recording file.

Metrics never see this: they are computed from the full-rate trajectory (in the kernel
and by the post-processors) before anything is written.
"""

from __future__ import annotations

import logging
from collections.abc import Sequence
from pathlib import Path

import numpy as np

from hgo.engine.jit import kernel_helper
from hgo.outputs.recording import Computed, Series, write_recording

log = logging.getLogger(__name__)
MODES = ("full", "decimated", "off")


def bucket_edges(n: int, max_rows: int) -> np.ndarray:
    """Start indices of the ``max_rows // 2`` buckets of ``n`` samples, and ``n``."""
    return np.linspace(0, n, max_rows // 2 + 1).astype(np.int64)


def envelope(t: np.ndarray, series: Sequence[Series], max_rows: int
             ) -> tuple[np.ndarray, list[Series]]:
    """(t, series) decimated to the min/max envelope per bucket (module docstring);
    unchanged when ``len(t) <= max_rows``."""
    n = len(t)
    if n <= max_rows:
        return t, list(series)
    edges = bucket_edges(n, max_rows)
    starts, stops = edges[:-1], edges[1:] - 1
    t_out = np.empty(2 * len(starts))
    t_out[0::2], t_out[1::2] = t[starts], t[stops]
    out = [Series(s.entity, s.names, bucket_min_max(s.values, edges)) for s in series]
    return t_out, out


PASS_ROWS = 1 << 20  # rows bucket_min_max reads at a time (a Computed computes them)


def bucket_min_max(values: np.ndarray | Computed, edges: np.ndarray) -> np.ndarray:
    """Rows 2k and 2k + 1: the minimum and the maximum of every column of ``values``
    (2-d, finite; an array or a :class:`~hgo.outputs.recording.Computed`) over the rows
    ``edges[k]:edges[k + 1]`` (:func:`bucket_edges`, increasing row indices of ``values``).
    Read whole buckets of at most :data:`PASS_ROWS` rows at a time (or one bucket): a
    derived series is never computed over the run's whole length."""
    if not isinstance(values, Computed):
        values = np.asarray(values, float)
    out = np.empty((2 * (len(edges) - 1), values.shape[1]))
    k = 0
    while k < len(edges) - 1:
        # the buckets k .. j - 1 whose rows fit in one pass
        j = max(k + 1, int(np.searchsorted(edges, edges[k] + PASS_ROWS, "right")) - 1)
        block = np.asarray(values[edges[k]:edges[j]], float)
        _bucket_min_max(block, edges[k:j + 1] - edges[k], out[2 * k:2 * j])
        k = j
    return out


def check_recording(mode: str, max_rows: int) -> None:
    """ValueError naming the key and the allowed values."""
    if mode not in MODES:
        raise ValueError(f"recording.mode must be one of {', '.join(MODES)}, got {mode!r}")
    if not (isinstance(max_rows, int) and max_rows >= 2):
        raise ValueError(f"recording.max_rows must be an integer >= 2, got {max_rows!r}")


def recording_mode(recording) -> str:
    """``recording.mode`` of a config node (None: ``full``)."""
    return "full" if recording is None else getattr(recording.mode, "name", recording.mode)


def write_run_recording(recording, path: Path, t: np.ndarray, series: Sequence[Series],
                        *, text: dict[str, str], **kwargs) -> Path | None:
    """:func:`hgo.outputs.recording.write_recording` in ``recording.mode`` (a config node with
    ``mode`` and ``max_rows``; None: full). The ``/run/config`` text starts with a line
    saying how the file was reduced. Returns the path, or None when ``mode`` is off."""
    mode = recording_mode(recording)
    max_rows = 0 if recording is None else int(recording.max_rows)
    if recording is not None:
        check_recording(mode, max_rows)
    if mode == "off":
        log.info("recording.mode=off: no %s", path.name)
        return None
    n = len(t)
    if mode == "decimated" and n > max_rows:
        t, series = envelope(t, series, max_rows)
        note = (f"# recording.mode=decimated: min/max envelope of {n} samples in "
                f"{len(t) // 2} buckets ({len(t)} rows); metrics computed at full rate\n")
    else:
        note = f"# recording.mode={mode}: all {n} samples\n"
    text = dict(text)
    text["/run/config"] = note + text.get("/run/config", "")
    return write_recording(path, t, series, text=text, **kwargs)


@kernel_helper
def _bucket_min_max(values, edges, out):
    """out[2k] = min, out[2k + 1] = max of every column over rows edges[k]:edges[k + 1]
    in one pass (the recorded samples are finite: the kernel stops before recording a
    non-finite state). Several times faster than np.minimum/maximum.reduceat."""
    for k in range(edges.shape[0] - 1):
        a, b = edges[k], edges[k + 1]
        for j in range(values.shape[1]):
            lo = values[a, j]
            hi = lo
            for i in range(a + 1, b):
                v = values[i, j]
                lo = v if v < lo else lo
                hi = v if v > hi else hi
            out[2 * k, j] = lo
            out[2 * k + 1, j] = hi
