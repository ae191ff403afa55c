"""A single run's figures drawn in a forked process, beside the run.

A cached single run spends most of its time importing libraries and drawing:
``matplotlib.pyplot`` takes ~0.25 s to import and a paper figure ~0.3 s to lay out and
save, against milliseconds of integration. ``hgo run`` forks the :class:`FigureWorker`
at start-up (:func:`prestart`), before it imports its Hydra app; the child imports
matplotlib and what the result and the figures use (:func:`_prepare`) while the parent
imports, composes, loads the kernel and simulates. It then draws the figures of the config
and result it receives (pickled through a pipe, 1-36 MB for the paper presets,
milliseconds) while the parent writes the recording and ``metrics.csv``; with several
figures it forks once more and the two draw every other figure each
(:func:`_draw_on_two_cores`; dhlm_example's six: 1.7 -> 0.9 s waited at load ~1). Forked
after the composition instead (as before 2026-11-28), the child was still preparing when
the result came, and loaded numba's registries while drawing (for its pixel-column
reduction, now numpy's): sp_fig1's figure took 1.7-1.8 s there against 1.1-1.3 s now. A
run that does not take the prestarted process (a sweep, an ensemble, a configuration
error) ends it (:func:`discard_prestarted`). The parent waits for the figures before it
writes ``run.json`` and marks the run complete, so the outputs, statuses and errors are
those of drawing in the run's own process: an exception raised by a figure is raised
again in the parent; a child that dies without replying fails the run with a
:class:`ChildProcessError`.

The child receives what the figures draw (:func:`drawing_view`): a run of more than
~60,000 samples travels with its first and last 20,000 samples at full rate (transients,
last periods) and the samples between as the min/max of 10,000 buckets, which is what a
line of them looks like at any figure's pixel width; a 1e7-sample run sends ~0.5 MB a column
instead of 80 MB, and nothing is copied for the figures in the parent. Metrics never see
this view (they are computed from the full-rate run before).

Used by ``hgo run`` for single runs (not sweeps, whose jobs share one process and so
import matplotlib once, nor ensembles) on Linux, where ``fork`` is the start method
every library here supports. The child ignores Ctrl-C (the parent ends it) and ends with
``os._exit``: no exit handler of the parent's libraries runs twice.
"""

from __future__ import annotations

import gc
import os
import pickle
import signal
import sys
import threading
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import Any

import numpy as np
from omegaconf import DictConfig

from hgo.core.errors import one_line

FULL_RATE = 20_000  # samples kept at full rate at each end of a run (drawing_view)
BUCKETS = 10_000  # min/max buckets of the samples between them


def _min_max_rows(values, edges: np.ndarray) -> np.ndarray:
    """Two rows a bucket of ``values`` (2-d: an array or a
    :class:`~hgo.outputs.recording.Computed`; ``edges``: row indices): min then max, or
    max then min where the bucket falls (its first value above its last), so a smooth
    curve stays smooth."""
    from hgo.outputs.decimate import bucket_min_max

    mm = bucket_min_max(values, edges)
    lo, hi = mm[0::2], mm[1::2]
    falling = np.asarray(values[edges[:-1]]) > np.asarray(values[edges[1:] - 1])
    mm[0::2], mm[1::2] = np.where(falling, hi, lo), np.where(falling, lo, hi)
    return mm


def _reduced(values, edges: np.ndarray) -> np.ndarray:
    """The first and last ``FULL_RATE`` rows of ``values`` and the min/max rows of the
    buckets ``edges`` (row indices of ``values``) between them; read a pass of rows at a
    time (:func:`hgo.outputs.decimate.bucket_min_max`), nothing of the run's length copied."""
    if values.ndim == 1:
        return _reduced(values[:, None], edges)[:, 0]
    if values.shape[1] == 0:
        return np.asarray(values[:2 * FULL_RATE + 2 * (len(edges) - 1)])
    n = len(values)
    return np.concatenate([np.asarray(values[:FULL_RATE]), _min_max_rows(values, edges),
                           np.asarray(values[n - FULL_RATE:])])


def drawing_view(result: Any) -> Any:
    """``result`` (:class:`hgo.running.runner.RunResult`) as the figures draw it: unchanged up to
    ``2 * (FULL_RATE + BUCKETS)`` samples; else each per-sample array keeps its first and
    last ``FULL_RATE`` rows and reduces the rows between to the min/max of ``BUCKETS``
    buckets (time stamped with each bucket's first and last sample), reading the run a
    pass of rows at a time: what it sends does not grow with the run, nor does what it
    costs here. Never the run's steps (``trajectory.dense``, kept for post-processors):
    figures draw the output grid."""
    import dataclasses

    from hgo.outputs.decimate import bucket_edges
    from hgo.outputs.recording import Computed, materialized

    traj = result.trajectory
    if traj.dense is not None:
        traj = dataclasses.replace(traj, dense=None)
        result = dataclasses.replace(result, trajectory=traj)
    n = len(traj.t)
    if n <= 2 * (FULL_RATE + BUCKETS) or not traj.ok:
        return result
    edges = bucket_edges(n - 2 * FULL_RATE, 2 * BUCKETS)
    middle_t = traj.t[FULL_RATE:n - FULL_RATE]
    t_mid = np.empty(2 * BUCKETS)
    t_mid[0::2], t_mid[1::2] = middle_t[edges[:-1]], middle_t[edges[1:] - 1]
    t = np.concatenate([traj.t[:FULL_RATE], t_mid, traj.t[n - FULL_RATE:]])
    edges = edges + FULL_RATE  # as rows of the whole run
    per_sample = {f.name: _reduced(getattr(traj, f.name), edges)
                  for f in dataclasses.fields(traj)
                  if f.name != "t" and isinstance(getattr(traj, f.name), np.ndarray)
                  and getattr(traj, f.name).shape[:1] == (n,)}
    series = [dataclasses.replace(s, values=_reduced(
        s.values if isinstance(s.values, Computed) else np.asarray(s.values), edges))
        if len(s.values) == n else s for s in result.series]
    return dataclasses.replace(result, trajectory=dataclasses.replace(traj, t=t, **per_sample),
                               series=materialized(series))


def _read_all(fd: int) -> bytes:
    chunks = []
    while chunk := os.read(fd, 1 << 20):
        chunks.append(chunk)
    return b"".join(chunks)


def _write_all(fd: int, data: bytes) -> None:
    view = memoryview(data)
    while view:
        view = view[os.write(fd, view):]


def _send_and_close(fd: int, data: bytes) -> None:
    """(In a thread: the pipe takes 64 KB at a time, as fast as the child reads it, and the
    child may still be importing.)"""
    try:
        _write_all(fd, data)
    except BrokenPipeError:  # the child ended: collect() says so
        pass
    finally:
        os.close(fd)


def _picklable(err: BaseException) -> BaseException:
    """``err`` itself if it survives a pickle round trip, else its one line."""
    try:
        pickle.loads(pickle.dumps(err))
        return err
    except Exception:
        return RuntimeError(one_line(err))


def _warm_up() -> None:
    """Lay out and render a small figure with mathtext and a legend, thrown away: builds
    matplotlib's mathtext parser and loads its fonts (~0.04 s of the first figure) while
    the parent still simulates."""
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(2, 2))
    ax.plot([0.0, 1.0], [0.0, 1.0], label=r"$\hat{x}_{1}$")
    ax.set_xlabel(r"$t$ (s)")
    ax.legend()
    fig.tight_layout()
    fig.canvas.draw()
    plt.close(fig)


def _reply_of(draw) -> tuple[str, Any]:
    """``("ok", draw())`` or ``("error", the exception)`` (picklable)."""
    try:
        return "ok", draw()
    except BaseException as err:  # noqa: BLE001  (the parent raises it again)
        return "error", _picklable(err)


def _draw_on_two_cores(cfg: DictConfig, result: Any) -> list[Path]:
    """The figures of ``cfg``, every other one drawn by a fork of this process (which has
    matplotlib and the result already): a preset with several figures (dhlm_example: six)
    draws on both cores. A figure's exception is raised here; a fork that dies ends this
    process with its exit code, as if this one had died drawing; SIGTERM ends both."""
    from hgo.running.figures import draw_figures, figure_nodes

    names = list(figure_nodes(cfg))
    if len(names) < 2 or (os.cpu_count() or 1) < 2:
        return draw_figures(cfg, result)
    mine, theirs = names[0::2], names[1::2]
    read_fd, write_fd = os.pipe()
    pid = os.fork()
    if pid == 0:  # the fork: draw its half, reply, end
        os.close(read_fd)
        try:
            _write_all(write_fd, pickle.dumps(_reply_of(lambda: draw_figures(cfg, result,
                                                                            theirs))))
        finally:
            os._exit(0)
    os.close(write_fd)
    signal.signal(signal.SIGTERM, lambda *_: (os.kill(pid, signal.SIGKILL), os._exit(1)))
    try:
        status, value = _reply_of(lambda: draw_figures(cfg, result, mine))
    finally:
        data = _read_all(read_fd)  # (EOF: the fork has replied or died)
        os.close(read_fd)
        signal.signal(signal.SIGTERM, signal.SIG_DFL)  # (before the fork is reaped)
        code = os.waitstatus_to_exitcode(os.waitpid(pid, 0)[1])
    if not data:
        os._exit(code if code > 0 else 1)
    if status == "error":
        raise value
    other_status, other = pickle.loads(data)
    if other_status == "error":
        raise other
    paths = dict(zip(mine, value, strict=True)) | dict(zip(theirs, other, strict=True))
    return [paths[name] for name in names]


def _prepare() -> None:
    """What the figures use, loaded before the result comes: the modules of the result and
    the figures (matplotlib with hgo's style), and a figure laid out and rendered
    (:func:`_warm_up`). Nothing compiled: the figures reduce their lines with numpy
    (:func:`hgo.outputs.figures.drawn`), as numba's first load of a compiled function in
    a process costs 0.6-1 s on a 2-core VM."""
    import hgo.outputs.figures  # noqa: F401
    import hgo.running.figures  # noqa: F401
    import hgo.running.results  # noqa: F401  (the result's classes, which unpickling imports)

    gc.freeze()  # the collector skips the modules' objects while drawing (0.1 s a figure)
    _warm_up()


def _serve(request_fd: int, reply_fd: int) -> None:
    """The child: prepare, wait for the request (the figures' config and the result),
    draw, reply ``("ok", paths)`` or ``("error", exception)``. EOF instead of a request
    (the run stopped, or needs no figures): draw nothing."""
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    signal.signal(signal.SIGTERM, signal.SIG_DFL)  # (the parent's SIGTERM handler raises)
    _prepare()
    data = _read_all(request_fd)
    if not data:
        return
    reply = _reply_of(lambda: _draw_on_two_cores(*pickle.loads(data)))
    _write_all(reply_fd, pickle.dumps(reply, protocol=pickle.HIGHEST_PROTOCOL))


class FigureWorker:
    """A forked process that draws a config's figures for one
    :class:`hgo.running.runner.RunResult` (:meth:`submit`, then :meth:`collect`). It may be
    forked before the config is known (:func:`prestart`): it prepares meanwhile."""

    def __init__(self) -> None:
        request_r, self._request_w = os.pipe()
        self._sender: threading.Thread | None = None
        self._reply_r, reply_w = os.pipe()
        sys.stdout.flush()
        sys.stderr.flush()
        gc.freeze()  # neither process's collector walks (or copies) what exists now
        self.pid = os.fork()
        if self.pid == 0:  # the child
            os.close(self._request_w)
            os.close(self._reply_r)
            code = 0
            try:
                _serve(request_r, reply_w)
            except BaseException as err:  # noqa: BLE001  (a broken pipe: the parent ended)
                sys.stderr.write(f"figure process: {one_line(err)}\n")
                code = 1
            finally:
                sys.stderr.flush()
                os._exit(code)
        os.close(request_r)
        os.close(reply_w)

    @staticmethod
    def available() -> bool:
        """Whether figures can be drawn in a forked process here (Linux)."""
        return sys.platform == "linux" and hasattr(os, "fork")

    def submit(self, cfg: DictConfig, result: Any) -> None:
        """Send ``cfg``'s figures (the ``figures`` node, resolved) and the run's result as
        they draw it (:func:`drawing_view`; in the background): the child starts drawing."""
        from omegaconf import OmegaConf

        figures = OmegaConf.create({"figures": OmegaConf.to_container(cfg.figures,
                                                                      resolve=True)})
        data = pickle.dumps((figures, drawing_view(result)),
                            protocol=pickle.HIGHEST_PROTOCOL)
        fd, self._request_w = self._request_w, -1
        self._sender = threading.Thread(target=_send_and_close, args=(fd, data), daemon=True)
        self._sender.start()

    def collect(self) -> list[Path]:
        """Wait for the figures; their paths, or the exception a figure raised
        (:class:`ChildProcessError` if the process ended without replying)."""
        data = _read_all(self._reply_r)
        if not data:
            _, status = os.waitpid(self.pid, 0)
            self.pid = -1
            self.close()
            raise ChildProcessError("the figure process ended (exit code "
                                    f"{os.waitstatus_to_exitcode(status)}) without drawing "
                                    "the figures")
        self.close()
        status, value = pickle.loads(data)
        if status == "error":
            raise value
        return value

    def close(self) -> None:
        """End the child (if it is still there) and release the pipes; idempotent."""
        for fd in (self._request_w, self._reply_r):
            if fd >= 0:
                os.close(fd)
        self._request_w = self._reply_r = -1
        if self.pid > 0:
            try:
                os.kill(self.pid, signal.SIGTERM)
            except ProcessLookupError:
                pass
            os.waitpid(self.pid, 0)
            self.pid = -1
        if self._sender is not None:  # its pipe is broken now, if it was not done
            self._sender.join()


_PRESTARTED: FigureWorker | None = None  # forked at start-up, no config yet (prestart)


def prestart() -> None:
    """Fork the figure process now, before the run's config is composed: it imports and
    prepares (:func:`_prepare`, ~2-3 s of one core on a 2-core VM) while this process
    imports, composes and simulates, so the figures are drawn as soon as the result is
    there. :func:`figures_aside` takes it; :func:`discard_prestarted` ends it unused."""
    global _PRESTARTED
    if _PRESTARTED is None and FigureWorker.available():
        _PRESTARTED = FigureWorker()


def discard_prestarted() -> None:
    """End the process :func:`prestart` forked if no run took it (a sweep, a config
    error, a run without figures); idempotent."""
    global _PRESTARTED
    worker, _PRESTARTED = _PRESTARTED, None
    if worker is not None:
        worker.close()


@contextmanager
def figures_aside(cfg: DictConfig) -> Iterator[FigureWorker | None]:
    """A :class:`FigureWorker` for ``cfg``'s figures (the one :func:`prestart` forked, if
    any), ended on leaving; None where there are no figures or no ``fork``."""
    global _PRESTARTED
    from hgo.running.figures import figure_nodes

    if not (FigureWorker.available() and figure_nodes(cfg)):
        discard_prestarted()
        yield None
        return
    worker, _PRESTARTED = _PRESTARTED or FigureWorker(), None
    try:
        yield worker
    finally:
        worker.close()
