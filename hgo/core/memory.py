"""Memory between the jobs of a sweep, and a quick exit.

:func:`release_freed_memory`: a job allocates and frees hundreds of MB (trajectories,
series, Rerun's Arrow buffers). glibc keeps much of it in its heaps after it is freed:
its mmap threshold rises to the size of the largest block freed (up to 32 MB), so later
arrays of a few MB come from the heap and the heap's free pages stay resident. In a
40-job sweep of 1e6-sample runs (``benchmarks/sweeps_bench.py``, memory row) the process
kept ~543 MB resident between jobs and peaked at 838-953 MB per job; with
``malloc_trim`` after every job, ~446 MB and 821-893 MB.

:func:`skip_exit_collection`: at exit the interpreter's garbage collector walks every
object still alive (hundreds of thousands once numba, pandas, matplotlib and Rerun are
imported): 1.2-1.7 s of a process that ran one job, paid again by every worker of a
joblib sweep when the pool shuts down.

:func:`collection_paused`: the collector off while a block makes many lasting objects and
little garbage (the members of an ensemble).
"""

from __future__ import annotations

import atexit
import contextlib
import ctypes
import ctypes.util
import functools
import gc
from collections.abc import Iterator


@functools.cache
def _malloc_trim():
    """glibc's ``malloc_trim``, or None (another C library: nothing to do)."""
    name = ctypes.util.find_library("c")
    try:
        return ctypes.CDLL(name).malloc_trim if name else None
    except (OSError, AttributeError):
        return None


def release_freed_memory() -> None:
    """Return the free pages of the C heaps to the OS (``malloc_trim(0)``); a no-op where
    the C library has no such call. Costs milliseconds: call it between jobs."""
    trim = _malloc_trim()
    if trim is not None:
        trim(0)


@functools.cache
def skip_exit_collection() -> None:
    """At exit, after the other exit handlers registered after this call, move every
    object to the collector's permanent generation (``gc.freeze``), so that the
    interpreter's final collections skip them; the process's memory goes back to the OS
    as it ends. Exit handlers (``atexit``: logging's flush, Rerun's) still run; objects
    kept alive only by reference cycles are not finalized, which Python never promises
    at exit anyway. Once per process."""
    atexit.register(gc.freeze)


@contextlib.contextmanager
def collection_paused() -> Iterator[None]:
    """No cyclic garbage collection inside the block; back as it was after it. For blocks
    that make many objects that last (the 10,000 members of a grid ensemble: the
    collector's passes over them were ~40 % of building them) and little cyclic garbage,
    which the first collection after the block frees."""
    enabled = gc.isenabled()
    gc.disable()
    try:
        yield
    finally:
        if enabled:
            gc.enable()
