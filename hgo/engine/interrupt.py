"""Ctrl-C, SIGTERM and SIGHUP during a compiled integration: the kernel stops within one step.

The kernel runs in the calling thread with the GIL released (numba ``nogil``). Python runs
a signal handler only between bytecodes of the main thread, so not while the kernel runs;
the signals that would raise ``KeyboardInterrupt`` (handler ``signal.default_int_handler``:
SIGINT, and SIGTERM under ``hgo``'s command line) are therefore watched from a helper
thread: Python's C-level handler writes the signal number to the wakeup fd
(:func:`signal.set_wakeup_fd`), the watcher reads it and sets ``ctl[0]``, which the kernel
checks after every step. It then returns (status 6) and its outputs up to then are kept.

For the call, those signals' Python-level handlers are replaced by one that only counts:
the first signal must not raise once the kernel has returned (its outputs would be lost).
A second signal while Python code runs (numba compiling, the pure-Python kernel) raises
``KeyboardInterrupt`` at once. A call still running ``STOP_NOTICE_S`` after the first is
either compiling (numba's compiler lock is held) or a kernel that does not check the flag
(user code looping): the watcher says which. A second signal to a busy kernel cannot reach
the main thread, so the watcher itself ends the process (exit 130) within
``BUSY_GRACE_S``, after the run's :data:`LAST_WORDS` (``run.json`` marked interrupted).

Why not a worker thread with the main thread waiting for Ctrl-C (hgo <= 0.x): the hand-off
cost 0.3-0.45 ms a call, 10-20 % of a short run (``benchmarks/hand_bench.py``). Outside the
main thread no signal reaches Python code at all: the kernel is simply called.
"""

from __future__ import annotations

import _signal
import os
import signal
import socket
import sys
import threading
from collections.abc import Callable

STOP_NOTICE_S = 0.5  # a kernel that has not stopped this long after Ctrl-C is compiling
NOTICE = "interrupted: stopping once numba has compiled the kernel (Ctrl-C again to stop at once)\n"
BUSY_NOTICE = ("interrupted: the kernel is busy and has not stopped (not compiling: user code "
               "that does not return, e.g. a loop, never checks the stop flag); Ctrl-C again "
               "to stop at once\n")
BUSY_STOP = ("error: interrupted while integrating: the kernel was busy (user code that does "
             "not return); stopped at once, without the trajectory\n")
BUSY_GRACE_S = 1.0  # after a second signal, time for a kernel to return before the exit
EXIT_INTERRUPTED = 130
WATCHED = tuple(s for s in (getattr(signal, "SIGINT", None), getattr(signal, "SIGTERM", None),
                            getattr(signal, "SIGHUP", None)) if s is not None)
LAST_WORDS: list[Callable[[], None]] = []  # run before a busy kernel's process exits


def compiling() -> bool:
    """Whether another thread (the main one) holds numba's compiler lock: compiling or
    loading a kernel, Python code that a second Ctrl-C interrupts by itself."""
    from numba.core.compiler_lock import global_compiler_lock

    lock = global_compiler_lock._lock
    if lock.acquire(blocking=False):
        lock.release()
        return False
    return True


def _say(text: str) -> None:
    try:
        sys.stderr.write(text)
        sys.stderr.flush()
    except (OSError, ValueError):  # a closed terminal (SIGHUP): nothing to tell
        pass


class _Watcher:
    """The wakeup socket pair and the thread that turns a watched signal into ``ctl[0] = 1``
    for the call in progress (one per process: a forked child makes its own)."""

    def __init__(self) -> None:
        self.pid = os.getpid()
        self.read, self.write = socket.socketpair()
        self.write.setblocking(False)  # set_wakeup_fd requires it
        self.ctl = None  # the control vector of the call in progress
        self.signals: set[int] = set()  # the signals watched in that call
        self.count = 0  # watched signals received during that call
        self.done = threading.Event()
        threading.Thread(target=self._watch, name="hgo-signals", daemon=True).start()

    def _watch(self) -> None:
        while True:
            data = self.read.recv(64)
            ctl = self.ctl
            if ctl is None or not self.signals.intersection(data):
                continue
            ctl[0] = 1
            self.count += sum(1 for b in data if b in self.signals)
            if self.count == 1 and not self.done.wait(STOP_NOTICE_S):
                _say(NOTICE if compiling() else BUSY_NOTICE)
            elif self.count > 1 and not self.done.wait(BUSY_GRACE_S) and not compiling():
                self._stop_busy()

    @staticmethod
    def _stop_busy() -> None:
        """End the process whose kernel ignores the stop flag, after the run's last words."""
        for last in list(LAST_WORDS):
            try:
                last()
            except Exception:  # noqa: BLE001 - the exit must happen; the line says why
                pass
        _say(BUSY_STOP)
        os._exit(EXIT_INTERRUPTED)


_WATCHER: _Watcher | None = None


def _watcher() -> _Watcher:
    global _WATCHER
    if _WATCHER is None or _WATCHER.pid != os.getpid():
        _WATCHER = _Watcher()
    return _WATCHER


def interruptible(fn: Callable, args: tuple, ctl):
    """``fn(*args)``, a kernel call that stops (status 6) when ``ctl[0]`` becomes nonzero;
    Ctrl-C (and any signal handled by ``signal.default_int_handler``) sets it."""
    if threading.current_thread() is not threading.main_thread():
        return fn(*args)
    # (``_signal``: the C functions ``signal`` wraps; its wrappers turn every handler into
    # an enum member, ~5 us a call, 6 calls a run)
    watched = [s for s in WATCHED if _signal.getsignal(s) is signal.default_int_handler]
    if not watched:
        return fn(*args)
    w = _watcher()
    count = [0]

    def counted(signum, frame):
        ctl[0] = 1
        count[0] += 1
        if count[0] > 1:
            raise KeyboardInterrupt

    w.ctl, w.signals, w.count = ctl, set(watched), 0
    w.done.clear()
    previous_fd = signal.set_wakeup_fd(w.write.fileno(), warn_on_full_buffer=False)
    for s in watched:
        _signal.signal(s, counted)
    try:
        return fn(*args)
    finally:
        w.done.set()
        w.ctl = None
        for s in watched:
            _signal.signal(s, signal.default_int_handler)
        signal.set_wakeup_fd(previous_fd)
