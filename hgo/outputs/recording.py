"""Bulk Rerun logging of one simulation run, and reading a recording back.

Entity-path convention (one entity per signal, one column per component):

========================== ===================================================
``/plant/x``               plant state, columns ``x1 .. xn``
``/observer/<name>/xhat``  estimate of observer ``<name>`` (e.g. ``sp6``)
``/observer/<name>/r``     internal/auxiliary state of observer ``<name>``
``/error/<name>``          estimation error ``xhat - x`` of observer ``<name>``
``/measurement/y``         measured output (noise included)
``/measurement/noise``     measurement noise alone
``/input/u``               plant input
``/run/...``               static text documents (e.g. ``/run/status``)
========================== ===================================================

All scalars sit on the timeline ``"sim_time"`` (simulated seconds, sent as
``timedelta64[ns]``). Logging is columnar: each :class:`Series` goes to Rerun in
``send_columns`` calls of up to ``CHUNK_ROWS`` samples each, never sample by sample
(per-sample ``rr.log`` is several hundred times slower).

Notes
-----
* With ``RERUN=off`` in the environment Rerun disables every stream:
  :func:`write_recording` then writes no file (an existing file at ``path`` is left
  untouched) and only emits a :class:`RuntimeWarning`.
* The ``.rrd`` file is complete only once the stream is closed:
  :func:`write_recording` writes ``<name>.partial``, logs the marker ``/run/complete``
  last, closes the stream and only then renames the file to ``<name>``. An interrupted
  or failed write (Ctrl-C, SIGKILL, a full disk) leaves only the ``.partial``, and
  :func:`read_recording` refuses a file without the marker.
* Reading back needs ``rerun-sdk[catalog]`` (``rerun.chunk.RrdReader``).
"""

from __future__ import annotations

import errno
import functools
import os
import re
import select
import shutil
import signal
import sys
import time as time_module
import warnings
from collections.abc import Callable, Iterator, Mapping, Sequence
from contextlib import contextmanager
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np
import pandas as pd

if TYPE_CHECKING:  # imported where used: a run without a recording never loads Rerun
    import rerun as rr
    import rerun.blueprint as rrb

__all__ = [
    "TIMELINE",
    "Computed",
    "Derived",
    "Difference",
    "Series",
    "materialized",
    "read_arrays",
    "read_recording",
    "read_static",
    "time_series_blueprint",
    "time_series_views",
    "write_recording",
]

TIMELINE = "sim_time"
#: Static entity logged last: a recording without it did not finish writing.
COMPLETE = "/run/complete"
"""Name of the Rerun timeline holding simulated time."""

PALETTE: tuple[tuple[int, int, int], ...] = (
    (31, 119, 180),
    (255, 127, 14),
    (44, 160, 44),
    (214, 39, 40),
    (148, 103, 189),
    (140, 86, 75),
    (227, 119, 194),
    (127, 127, 127),
    (188, 189, 34),
    (23, 190, 207),
)
"""Fixed colour cycle (matplotlib ``tab10``): column ``k`` gets ``PALETTE[k % 10]``."""

_RECORDING_ID_RE = re.compile(r"[A-Za-z0-9_-]+")
_SCALARS_SUFFIX = ":Scalars:scalars"
_NAMES_SUFFIX = ":SeriesLines:names"


@dataclass(frozen=True)
class Series:
    """A multi-column scalar signal sampled on the run's time grid.

    Attributes
    ----------
    entity : str
        Rerun entity path, e.g. ``"/plant/x"`` or ``"/observer/sp6/xhat"``.
    names : list of str
        One display name per column, e.g. ``["x1", "x2"]``.
    values : numpy.ndarray or Computed
        Shape ``(N, len(names))``, float64, one row per time sample; a
        :class:`Computed` (a :class:`Difference`, a :class:`Derived`) computes its rows when
        they are read.
    color, width : optional
        One colour (RGB) for every column and a line width; by default column ``k`` gets
        ``PALETTE[k % 10]``. (The runner gives a plant's states one colour and each
        observer its own, so x and x^ differ in the viewer.)
    """

    entity: str
    names: list[str]
    values: np.ndarray | Computed
    #: one RGB colour for every column, and a line width (None: the palette by column)
    color: tuple[int, int, int] | None = None
    width: float | None = None


class Computed:
    """A series' values computed when read: ``values[i:j]`` (any row index, with column
    indices after it) computes those rows, ``np.asarray(values)`` all of them (subclasses
    say how: :meth:`rows`). The recording is written a block of rows at a time and the
    figures get the pixel-reduced view (:func:`hgo.running.figure_worker.drawing_view`), so
    a derived series costs no copy of the run's length in the run's process."""

    ndim = 2
    dtype = np.dtype(np.float64)

    @property
    def shape(self) -> tuple[int, int]:
        raise NotImplementedError

    def rows(self, rows) -> np.ndarray:
        """The values at ``rows`` (a slice, an index array or an int)."""
        raise NotImplementedError

    def __len__(self) -> int:
        return self.shape[0]

    def __getitem__(self, key):
        rows, rest = (key[0], key[1:]) if isinstance(key, tuple) else (key, ())
        if rows is Ellipsis or rows is None:
            return np.asarray(self)[key]
        block = self.rows(rows)
        if not rest:
            return block
        return block[rest] if block.ndim == 1 else block[(slice(None), *rest)]

    def __array__(self, dtype=None, copy=None) -> np.ndarray:
        out = self[:]
        return out if dtype is None else out.astype(dtype, copy=False)

    def __getattr__(self, name: str):
        # any other array attribute (min, max, mean, T, ...): of the computed array
        if name.startswith("_") or name in getattr(self, "__dataclass_fields__", ()):
            raise AttributeError(name)  # (pickle, copy)
        return getattr(np.asarray(self), name)


@dataclass(frozen=True)
class Difference(Computed):
    """``a - b[:, columns]``, computed when read (:class:`Computed`): the estimation errors
    ``/error/<name>``. For S&P Fig. 1 at 1e7 samples the two error series were 320 MB held
    for the whole run.
    """

    a: np.ndarray  # (N, S)
    b: np.ndarray  # (N, >= S)
    columns: tuple[int, ...]  # of b, one per column of a

    @property
    def shape(self) -> tuple[int, int]:
        return self.a.shape

    def rows(self, rows) -> np.ndarray:
        return self.a[rows] - self.b[rows][..., list(self.columns)]


@dataclass(frozen=True)
class Derived(Computed):
    """``fn(*(x[rows] for x in arrays))`` with ``columns`` columns, computed when read
    (:class:`Computed`); ``fn`` row by row alike (each row's values from that row's), and
    picklable (the figure process receives a short run's series as they are)."""

    fn: Callable[..., np.ndarray]
    arrays: tuple[np.ndarray, ...]  # (N, ...) each
    columns: int

    @property
    def shape(self) -> tuple[int, int]:
        return len(self.arrays[0]), self.columns

    def rows(self, rows) -> np.ndarray:
        return self.fn(*(x[rows] for x in self.arrays))


def materialized(series: Sequence[Series]) -> list[Series]:
    """``series`` with every :class:`Computed` one computed into an array (for code that
    expects arrays: figure functions, a DataFrame of the signals)."""
    return [s if isinstance(s.values, np.ndarray)
            else Series(s.entity, s.names, np.asarray(s.values)) for s in series]


def _validate_recording_id(recording_id: str) -> None:
    if not isinstance(recording_id, str) or not _RECORDING_ID_RE.fullmatch(recording_id):
        raise ValueError(
            f"invalid recording_id {recording_id!r}: use only letters, digits, '_' and '-'"
        )


def _time_column(t: np.ndarray) -> np.ndarray:
    """Validate the time grid and convert seconds to ``timedelta64[ns]``."""
    t = np.asarray(t, dtype=np.float64)
    if t.ndim != 1:
        raise ValueError(f"t must be 1-D, got shape {t.shape}")
    if not np.all(np.isfinite(t)):
        raise ValueError("t contains non-finite times")
    # in place, and compared without np.diff: one int64 copy of t stays (80 MB for 1e7
    # samples), against four temporaries of that size before
    t_ns = t * 1e9
    np.rint(t_ns, out=t_ns)
    t_ns = t_ns.astype(np.int64)
    if np.any(t_ns[1:] <= t_ns[:-1]):
        raise ValueError("t must be strictly increasing at 1 ns resolution")
    return t_ns.view("timedelta64[ns]")


def _checked_values(s: Series, n: int) -> np.ndarray | Computed:
    """Return ``s.values`` (as float64; a :class:`Computed` as it is, read a block at a
    time when sent) after checking it is ``(n, len(s.names))``."""
    values = s.values if isinstance(s.values, Computed) else np.asarray(s.values,
                                                                        dtype=np.float64)
    expected = (n, len(s.names))
    if values.shape != expected:
        hint = ""
        if values.ndim == 2 and values.shape[0] < n:
            hint = " (a run that stopped early: slice t to the samples actually computed)"
        raise ValueError(
            f"series {s.entity!r}: values have shape {values.shape}, expected {expected} "
            f"(len(t), len(names)){hint}"
        )
    return values


def _checked_series(series: Sequence[Series], n: int) -> list[tuple[Series, np.ndarray]]:
    seen: set[str] = set()
    out = []
    for s in series:
        key = "/" + s.entity.strip("/")
        if key in seen:
            raise ValueError(f"series {s.entity!r}: entity logged twice")
        seen.add(key)
        out.append((s, _checked_values(s, n)))
    return out


CHUNK_ROWS = 1 << 16
"""Rows per ``send_columns`` call: longer series go out in blocks of this many samples.

Measured (Rerun 0.41, problem B with 1,000,001 samples, 9 scalars in 6 entities, 2-core
machine with a second CPU-bound process running, medians of 9 interleaved runs): most of
the cost is Rerun's ``file_writer`` thread (LZ4 compression and copies of ~240 MB of
Arrow data, 0.45-0.55 s CPU), which runs beside the sending thread and is still busy when
the stream is closed. Blocks of 2^15-2^16 rows need the least of it (0.48 s CPU) against
0.56 s for 2^18 and 0.96 s for 2^19; one call per entity took 1.6-1.8 s; 2^14 rows costs
more on both threads (every block stays its own chunk in the file). Batcher settings
(``ChunkBatcherConfig`` NEVER, LOW_LATENCY, zero or huge thresholds), a memory or
binary-stream sink written to disk afterwards (~1.5x slower), and sending entities from
two threads did not help.
"""

def _time_blocks(time: np.ndarray) -> list[tuple[int, int, rr.TimeColumn]]:
    """``(start, stop, TimeColumn)`` per block of ``CHUNK_ROWS``, shared by every series.

    Built once per recording instead of once per series (each ``TimeColumn`` copies its
    block into Arrow). A run without samples gives one empty block.
    """
    import rerun as rr

    n = len(time)
    return [
        (a, min(n, a + CHUNK_ROWS), rr.TimeColumn(TIMELINE, duration=time[a : a + CHUNK_ROWS]))
        for a in range(0, max(n, 1), CHUNK_ROWS)
    ]


def _scalar_column(block: np.ndarray, offsets: np.ndarray) -> rr.ComponentColumn:
    """``(rows, S)`` block -> the column ``rr.Scalars.columns(scalars=block)`` builds.

    Same descriptor and Arrow ``list<double>`` array, without that helper's per-call
    flatten/cumsum/partition (measured: main-thread CPU 0.29 -> 0.22 s for the run above).
    """
    import rerun as rr

    rows = block.shape[0]
    return rr.ComponentColumn(rr.Scalars.descriptor_scalars(),
                              rr.components.ScalarBatch(block.reshape(-1)),
                              offsets=offsets[: rows + 1])


FLUSH_BYTES = 16 << 20
"""Scalar bytes sent between two blocking flushes of the stream.

Rerun 0.41's file sink queues every chunk sent until its writer thread has compressed and
written it, and sending is faster than that thread: without a flush the whole recording
was held in memory once more (S&P Fig. 1 with 1e7 samples x 14 columns: the writing
process grew by 1.9 GB, to 3.8 GB). Measured with 1e6 samples x 14 columns (growth of the
writing process over its parent, best of 3 writes, load 1.3-1.6): no flush 170 MB 0.73 s;
flushing every 64 MB 105 MB, 32 MB 93 MB, 16 MB 49 MB 0.76 s, 8 MB 34 MB 0.75 s.
"""


def _send_series(
    rec: rr.RecordingStream,
    s: Series,
    values: np.ndarray,
    blocks: Sequence[tuple[int, int, rr.TimeColumn]],
    unflushed: int = 0,
) -> int:
    """Send ``s`` block by block; returns the bytes sent since the last flush (the
    stream is flushed whenever they reach :data:`FLUSH_BYTES`)."""
    import rerun as rr

    colors = [s.color or PALETTE[k % len(PALETTE)] for k in range(len(s.names))]
    widths = None if s.width is None else [s.width] * len(s.names)
    rec.log(s.entity, rr.SeriesLines(names=list(s.names), colors=colors, widths=widths),
            static=True)
    offsets = np.arange(CHUNK_ROWS + 1, dtype=np.int32) * np.int32(values.shape[1])
    for a, b, time_column in blocks:
        block = np.asarray(values[a:b], dtype=np.float64)
        rec.send_columns(
            s.entity,
            indexes=[time_column],
            columns=[_scalar_column(block, offsets)],
        )
        unflushed += block.nbytes
        if unflushed >= FLUSH_BYTES:
            rec.flush()
            unflushed = 0
    return unflushed


def write_recording(
    path: str | Path,
    t: np.ndarray,
    series: Sequence[Series],
    *,
    application_id: str = "hgo",
    recording_id: str,
    blueprint: rrb.Blueprint | None = None,
    text: Mapping[str, str] | None = None,
    recording_name: str | None = None,
) -> Path:
    """Write one run to an ``.rrd`` file, columnar (``send_columns`` per series).

    Parameters
    ----------
    path : str or Path
        Output file; parent directories are created, an existing file is replaced.
    t : numpy.ndarray
        Time grid in simulated seconds, shape ``(N,)``, strictly increasing. For a run
        that stopped early, pass ``t`` sliced to the computed samples.
    series : sequence of Series
        Signals to log; each must have values of shape ``(N, len(names))``.
    application_id : str
        Rerun application id.
    recording_id : str
        Unique id of this run, only ``[A-Za-z0-9_-]``. Two files with the same id merge
        into one recording in the viewer.
    blueprint : rerun.blueprint.Blueprint, optional
        Saved as the file's default blueprint (see :func:`time_series_blueprint`).
    text : mapping of str to str, optional
        Entity path -> text, logged as static ``rr.TextDocument`` entries,
        e.g. ``{"/run/status": "failed at t=3.2 s: non-finite state"}``.
    recording_name : str, optional
        The name the viewer lists the recording by (a sweep's job: its overrides,
        ``eps=0.01 noise.std=0.001``).

    Returns
    -------
    Path
        ``path``. The file is complete (stream closed) on return. With ``RERUN=off`` no
        file is written.

    Raises
    ------
    ValueError
        On an invalid ``recording_id``, a bad time grid, a duplicated entity, or a series
        whose shape does not match ``(len(t), len(names))`` (the message names the entity).
    OSError
        ``errno.ENOSPC`` naming the ``.partial`` file when the disk fills (within about a
        second, see :func:`bounded_write`); ``TimeoutError`` when the write stalls.
    KeyboardInterrupt
        Ctrl-C during the write (the ``.partial`` is left).
    """
    _validate_recording_id(recording_id)
    path = Path(path)
    time = _time_column(t)
    checked = _checked_series(series, len(time))
    partial = partial_path(path)
    stream = functools.partial(_stream_to_file, partial, time, checked, application_id,
                               recording_id, blueprint, text, recording_name)
    if not bounded_write(partial, stream):
        warnings.warn(
            f"Rerun is disabled (RERUN=off?): no recording written to {path}",
            RuntimeWarning,
            stacklevel=2,
        )
        return path
    os.replace(partial, path)  # only a complete file gets the final name
    return path


def _stream_to_file(partial: Path, time: np.ndarray, checked: list[tuple[Series, np.ndarray]],
                    application_id: str, recording_id: str, blueprint: rrb.Blueprint | None,
                    text: Mapping[str, str] | None, recording_name: str | None = None) -> bool:
    """Rerun's part of :func:`write_recording`: the stream saved to ``partial`` and closed;
    False when Rerun is disabled (nothing written)."""
    import rerun as rr

    with rr.RecordingStream(application_id, recording_id=recording_id) as rec:
        if not rec.is_enabled():
            return False
        partial.parent.mkdir(parents=True, exist_ok=True)
        _save(rec, partial, blueprint)
        if recording_name:
            rec.send_recording_name(recording_name)
        blocks = _time_blocks(time)
        unflushed = 0
        for s, values in checked:
            unflushed = _send_series(rec, s, values, blocks, unflushed)
        for entity, doc in (text or {}).items():
            rec.log(entity, rr.TextDocument(doc), static=True)
        rec.log(COMPLETE, rr.TextDocument(f"{len(time)} samples"), static=True)
    del rec
    _release_closed_streams()
    return True


#: A write whose file has not grown for this long while the disk has less than
#: ``LOW_SPACE`` bytes free is ended as a full disk; one that has not grown for
#: ``STALL_SECONDS`` (``HGO_WRITE_STALL_SECONDS``) whatever the free space, as stalled.
FULL_DISK_SECONDS = 1.0
LOW_SPACE = 1 << 20
STALL_SECONDS = float(os.environ.get("HGO_WRITE_STALL_SECONDS", "120"))
_DISABLED = 3  # the writing process's exit code when Rerun is disabled


def bounded_write(partial: Path, stream: Callable[[], bool]) -> bool:
    """Run ``stream()`` (which writes ``partial`` through Rerun) in a forked process that
    the caller watches, and return its result.

    Why: when the disk fills, Rerun 0.41's file-writer thread dies and the stream's flush
    (on closing it, on dropping it, on any later cleanup) can wait forever in native code,
    where neither Ctrl-C nor a timeout reaches it (4 hangs in 15 tries measured; the rest
    end in "File-writer thread shut down prematurely"). Watched from here, a full disk
    ends the write within ~``FULL_DISK_SECONDS`` with ``OSError(ENOSPC)`` naming the
    file, Ctrl-C and SIGTERM end it at once (the child is killed), and a Rerun stream
    that cannot be closed never lives in this process. The child shares the data by fork
    (copy-on-write, nothing is pickled) and dies with its parent. Without ``fork`` (or
    with ``HGO_WRITE_IN_PROCESS=1``) ``stream`` runs here, unbounded."""
    if not hasattr(os, "fork") or os.environ.get("HGO_WRITE_IN_PROCESS") == "1":
        return stream()
    import rerun  # noqa: F401  (once in this process, not in every child)

    read_fd, write_fd = os.pipe()
    sys.stdout.flush()
    sys.stderr.flush()
    pid = os.fork()
    if pid == 0:  # the child: never returns
        os.close(read_fd)
        _write_in_child(stream, write_fd)
    os.close(write_fd)
    try:
        code, said = _watch(pid, read_fd, partial)
    except BaseException:
        _end_child(pid)
        raise
    finally:
        os.close(read_fd)
    if code == 0:
        return True
    if code == _DISABLED:
        return False
    if code in (130, -signal.SIGINT):
        raise KeyboardInterrupt(f"interrupted (Ctrl-C) while writing {partial}")
    if "No space left" in said or _free_bytes(partial.parent) < LOW_SPACE:
        raise _disk_full(partial)
    lines = [ln for ln in said.splitlines() if ln.strip()]
    raise OSError(f"writing {partial} failed: {lines[-1] if lines else f'exit {code}'}")


def _write_in_child(stream: Callable[[], bool], fd: int) -> None:
    """The writing process: default Ctrl-C and SIGTERM (they end it at once), killed with
    its parent, its stderr (Rerun's log lines) sent to the parent, its result as the exit
    code; never returns."""
    code = 1
    try:
        signal.signal(signal.SIGINT, signal.SIG_DFL)
        signal.signal(signal.SIGTERM, signal.SIG_DFL)
        _die_with_parent()
        os.dup2(fd, 2)
        code = 0 if stream() else _DISABLED
    except BaseException as err:  # noqa: BLE001  (reported to the parent as one line)
        code = 130 if isinstance(err, KeyboardInterrupt) else 1
        try:
            os.write(fd, f"\n{type(err).__name__}: {err}\n".encode(errors="replace"))
        except OSError:
            pass
    finally:
        os._exit(code)


def _die_with_parent() -> None:
    """Linux: SIGKILL this process when its parent dies (a killed run leaves no writer)."""
    try:
        import ctypes

        ctypes.CDLL(None, use_errno=True).prctl(1, signal.SIGKILL)  # PR_SET_PDEATHSIG
    except (OSError, AttributeError):
        pass


def _watch(pid: int, fd: int, partial: Path) -> tuple[int, str]:
    """Wait for the writing process; its exit code and what it wrote to stderr. Raises
    ``OSError(ENOSPC)`` or ``TimeoutError`` when ``partial`` stops growing (see
    :data:`FULL_DISK_SECONDS`, :data:`STALL_SECONDS`)."""
    said: list[bytes] = []
    size, changed = -1, time_module.monotonic()
    while True:
        ready, _, _ = select.select([fd], [], [], 0.05)
        if ready:
            chunk = os.read(fd, 1 << 16)
            said.append(chunk)
            if not chunk:  # the child closed its end: it is exiting
                _, status = os.waitpid(pid, 0)
                return os.waitstatus_to_exitcode(status), b"".join(said).decode("utf-8",
                                                                               "replace")
        done, status = os.waitpid(pid, os.WNOHANG)
        if done:
            rest = _read_available(fd)
            return os.waitstatus_to_exitcode(status), b"".join([*said, rest]).decode(
                "utf-8", "replace")
        now = time_module.monotonic()
        current = partial.stat().st_size if partial.exists() else -1
        if current != size:
            size, changed = current, now
        elif now - changed > FULL_DISK_SECONDS and _free_bytes(partial.parent) < LOW_SPACE:
            raise _disk_full(partial)
        elif now - changed > STALL_SECONDS:
            raise TimeoutError(f"writing {partial} made no progress for {STALL_SECONDS:g} s "
                               "(HGO_WRITE_STALL_SECONDS); stopped")


def _read_available(fd: int) -> bytes:
    out = []
    while select.select([fd], [], [], 0)[0]:
        chunk = os.read(fd, 1 << 16)
        if not chunk:
            break
        out.append(chunk)
    return b"".join(out)


def _end_child(pid: int) -> None:
    try:
        os.kill(pid, signal.SIGKILL)
        os.waitpid(pid, 0)
    except (ProcessLookupError, ChildProcessError):
        pass


def _free_bytes(folder: Path) -> int:
    try:
        return shutil.disk_usage(folder).free
    except OSError:
        return 1 << 62


def _disk_full(path: Path) -> OSError:
    """ENOSPC naming ``path`` and the space left (:func:`hgo.core.errors.one_line` shows it as
    ``no space left on <path> (...)``)."""
    return OSError(errno.ENOSPC, f"No space left on device, {_free_bytes(path.parent) / 2**20:.3g} "
                   "MiB free", str(path))


def partial_path(path: Path) -> Path:
    """Where a file is written before it is complete: ``<name>.partial``."""
    return path.with_name(path.name + ".partial")


@contextmanager
def atomic_output(path: str | Path) -> Iterator[Path]:
    """Write to ``<path>.partial`` inside the block; renamed to ``path`` when it ends
    without an error (an interrupted or failed write leaves only the ``.partial``)."""
    path = Path(path)
    partial = partial_path(path)
    try:
        yield partial
    except OSError as err:  # name the file (a full disk: see hgo.core.errors.one_line)
        if err.errno == errno.ENOSPC and not err.filename:
            raise _disk_full(partial) from err
        raise
    os.replace(partial, path)


class RecordingIncomplete(ValueError):
    """A recording whose writing did not finish (truncated, ``.partial``, unreadable)."""


def _save(rec: rr.RecordingStream, path: Path, blueprint: rrb.Blueprint | None) -> None:
    """``rec.save(path, default_blueprint=blueprint)``, with the blueprint's own stream
    disconnected afterwards: Rerun 0.41 builds that stream in ``save`` and never ends its
    two threads (2 threads and ~2 MB per recording in a sweep process). Mirrors
    ``rerun.sinks.create_in_memory_blueprint``."""
    if blueprint is None:
        rec.save(path)
        return
    import rerun as rr
    import rerun_bindings as bindings

    stream = rr.RecordingStream._from_native(bindings.new_blueprint(
        application_id=rec.get_application_id(), make_default=False,
        make_thread_default=False, default_enabled=True))
    stream.set_time("blueprint", sequence=0)
    blueprint.to_blueprint()._log_to_stream(stream)
    storage = stream.memory_recording().storage
    bindings.save(path=str(path), default_blueprint=storage, recording=rec.to_native(),
                  write_footer=True)
    stream.disconnect()


def _release_closed_streams() -> None:
    """End the threads of closed streams now.

    Rerun 0.41 keeps the two threads of a closed stream (``RecordingStream``,
    ``ChunkBatcher``) and their memory until a sweep of orphaned streams, which its own
    ``__del__`` does not trigger: a sweep process writing one recording per job grew by
    ~1.6 MB per job (``benchmarks/sweeps_bench.py``, memory row; tests/test_sweeps.py)."""
    from rerun_bindings import flush_and_cleanup_orphaned_recordings

    flush_and_cleanup_orphaned_recordings()


def _is_plain(expr: str) -> bool:
    """True if Rerun's query language handles ``expr`` itself (``*`` only as a ``/**`` suffix)."""
    return "*" not in expr.removesuffix("/**")


def _glob_regex(pattern: str) -> re.Pattern[str]:
    """``**`` matches any number of path segments, ``*`` part of one segment."""
    parts = []
    for seg in pattern.strip("/").split("/"):
        if seg == "**":
            parts.append("(?:/[^/]+)*")
        else:
            parts.append("/" + "[^/]*".join(re.escape(p) for p in seg.split("*")))
    return re.compile("".join(parts))


def _view_contents(
    patterns: Sequence[str], entities: Sequence[str] | None, title: str
) -> list[str]:
    """Entity paths/patterns -> query expressions understood by the viewer."""
    out: list[str] = []
    for raw in patterns:
        sign, expr = ("-", raw[1:]) if raw.startswith("-") else ("+", raw.removeprefix("+"))
        expr = expr.strip()
        if _is_plain(expr):
            out.append(f"{sign} {expr}")
            continue
        if entities is None:
            raise ValueError(
                f"view {title!r}: pattern {expr!r} has '*' other than a trailing '/**', which "
                "Rerun 0.41 does not support; pass entities=... to expand it"
            )
        regex = _glob_regex(expr)
        out.extend(f"{sign} {e}" for e in entities if regex.fullmatch("/" + e.strip("/")))
    return out


def time_series_blueprint(
    groups: Mapping[str, Sequence[str]], *, entities: Sequence[str] | None = None
) -> rrb.Blueprint:
    """Build a grid of time-series views, one per group.

    Parameters
    ----------
    groups : mapping of str to sequence of str
        View title -> entity paths or patterns. ``"/plant/x"`` and subtrees such as
        ``"/observer/**"`` are passed to the viewer as they are; a leading ``-`` excludes.
        Rerun 0.41 supports ``*`` only as a trailing ``/**``, so other wildcards
        (``"/observer/**/r"``, ``"/error/sp*"``) are expanded against ``entities``.
    entities : sequence of str, optional
        Entity paths of the run (e.g. ``[s.entity for s in series]``), needed only for
        patterns with inner wildcards.

    Returns
    -------
    rerun.blueprint.Blueprint
        ``Blueprint(Grid(TimeSeriesView(...), ...), auto_views=False)``.

    Raises
    ------
    ValueError
        If a pattern has an inner wildcard and ``entities`` is not given.
    """
    import rerun.blueprint as rrb

    return rrb.Blueprint(rrb.Grid(*time_series_views(groups, entities=entities)),
                         auto_views=False)


def time_series_views(
    groups: Mapping[str, Sequence[str]], *, entities: Sequence[str] | None = None
) -> list:
    """The views of :func:`time_series_blueprint`, one per group, for a layout of one's
    own."""
    import rerun.blueprint as rrb

    return [
        rrb.TimeSeriesView(
            name=title, origin="/", contents=_view_contents(patterns, entities, title)
        )
        for title, patterns in groups.items()
    ]


def _column_values(column: object, n: int) -> np.ndarray:
    """Arrow ``list<double>`` column -> ``(n, S)`` float64, null rows as NaN."""
    import pyarrow as pa
    import pyarrow.compute as pc

    column = column.combine_chunks() if isinstance(column, pa.ChunkedArray) else column
    lengths = pc.list_value_length(column).drop_null().to_numpy()
    width = int(lengths.max()) if lengths.size else 0
    if np.any(lengths != width):
        raise ValueError("scalar rows of differing lengths")
    out = np.full((n, width), np.nan)
    valid = column.is_valid().to_numpy(zero_copy_only=False)
    flat = pc.list_flatten(column).to_numpy(zero_copy_only=False)
    out[valid] = flat.astype(np.float64).reshape(-1, width)
    return out


def _read_store(path: str | Path, allow_incomplete: bool):
    """The first recording store of ``path``, refused (:class:`RecordingIncomplete`) when
    unreadable or without the ``/run/complete`` marker unless ``allow_incomplete``."""
    from rerun.chunk import RrdReader

    try:
        store = RrdReader(Path(path)).stream().collect()
    except Exception as err:  # noqa: BLE001 - rerun's errors for a damaged file vary
        raise RecordingIncomplete(f"recording {path} is unreadable (incomplete write?): "
                                  f"{' '.join(str(err).split())[:200]}") from err
    if COMPLETE not in store.schema().entity_paths():
        if not allow_incomplete:
            raise RecordingIncomplete(f"recording {path} is truncated: its writing did not "
                                      f"finish (no {COMPLETE} marker); pass "
                                      "allow_incomplete=True to read what it holds")
        warnings.warn(f"recording {path} is truncated (no {COMPLETE} marker)",
                      RuntimeWarning, stacklevel=3)
    return store


def _store_arrays(store) -> dict[str, np.ndarray]:
    if TIMELINE not in [c.name for c in store.schema().index_columns()]:
        return {TIMELINE: np.empty(0)}  # a run with no samples has no timeline at all
    table = store.reader(index=TIMELINE).to_arrow_table()
    table = table.sort_by(TIMELINE)
    time_ns = table.column(TIMELINE).cast("int64").to_numpy()
    out: dict[str, np.ndarray] = {TIMELINE: time_ns / 1e9}
    for name in table.column_names:
        if name.endswith(_SCALARS_SUFFIX):
            entity = name[: -len(_SCALARS_SUFFIX)]
            out[entity] = _column_values(table.column(name), table.num_rows)
    return out


def read_arrays(path: str | Path, allow_incomplete: bool = False) -> dict[str, np.ndarray]:
    """The scalar series of a recording written by :func:`write_recording`, one array per
    entity (what figures and aggregations of several runs use).

    A file whose writing did not finish (no ``/run/complete`` marker: interrupted,
    killed, a full disk) raises :class:`RecordingIncomplete`; with ``allow_incomplete``
    what it holds is returned, with a warning.

    Parameters
    ----------
    path : str or Path
        ``.rrd`` file; the first recording store in it is read.

    Returns
    -------
    dict of str to numpy.ndarray
        ``"sim_time"``: float seconds, shape ``(N,)``, sorted; and for every scalar
        entity (key with leading ``/``, e.g. ``"/plant/x"``) an ``(N, S)`` float64 array.
        Rows where an entity has no sample are NaN. A recording without samples gives
        only an empty ``"sim_time"``.
    """
    return _store_arrays(_read_store(path, allow_incomplete))


def read_static(path: str | Path, entity: str, component: str) -> list | None:
    """The static value of ``entity``'s ``component`` (``"SeriesLines:colors"``,
    ``"RecordingInfo:name"`` of ``/__properties``) in a recording, or None."""
    from rerun.chunk import RrdReader

    for chunk in RrdReader(Path(path)).stream().to_chunks():
        if str(chunk.entity_path) == entity and chunk.is_static:
            batch = chunk.to_record_batch()
            if component in batch.schema.names:
                return batch.column(component).to_pylist()[-1]
    return None


def read_recording(path: str | Path, allow_incomplete: bool = False) -> pd.DataFrame:
    """The scalar series of a recording as a DataFrame indexed by ``sim_time`` (seconds),
    one column per series named ``<entity>/<series name>`` as logged, e.g.
    ``/plant/x/x1``, ``/observer/sign_indefinite/xhat/x1_hat``, ``/error/…/e_x1``; rows
    where a series has no sample are NaN. Incomplete files: as :func:`read_arrays`."""
    store = _read_store(path, allow_incomplete)
    data = _store_arrays(store)
    static = store.reader(index=None).to_arrow_table().to_pylist()
    names = {}
    for column, value in (static[0] if static else {}).items():
        if column.endswith(_NAMES_SUFFIX) and value is not None:
            names[column[: -len(_NAMES_SUFFIX)]] = list(value)
    columns = {}
    for entity, values in data.items():
        if entity == TIMELINE:
            continue
        labels = names.get(entity) or [str(i) for i in range(values.shape[1])]
        for j, label in enumerate(labels[: values.shape[1]]):
            columns[f"{entity}/{label}"] = values[:, j]
    return pd.DataFrame(columns, index=pd.Index(data[TIMELINE], name=TIMELINE))


def read_texts(path: str | Path) -> dict[str, str]:
    """The static text documents of a recording (e.g. ``/run/status``), entity -> text."""
    from rerun.chunk import RrdReader

    table = RrdReader(Path(path)).stream().collect().reader(index=None).to_arrow_table()
    suffix = ":TextDocument:text"
    out = {}
    for name in table.column_names:
        if name.endswith(suffix):
            values = [v for v in table.column(name).to_pylist() if v]
            if values:
                out[name[: -len(suffix)]] = str(values[0][0])
    return out
