"""Progress bars (tqdm) for long work: compiling a new kernel, ensembles, reproduce.

Bars go to stderr and are shown on a terminal only (tqdm's ``disable=None``), so logs and
tests stay clean. Compiling shows an ETA from the last compile of a kernel with the same
integrator on this machine (``compile_seconds.json`` in the kernel cache).
"""

from __future__ import annotations

import json
import logging
import threading
import time
from contextlib import contextmanager
from pathlib import Path

from numba.core.event import Listener, install_listener
from tqdm import tqdm

log = logging.getLogger(__name__)


def bar(total: int | float | None, desc: str, unit: str = "it") -> tqdm:
    """A tqdm bar on stderr, shown on terminals only."""
    return tqdm(total=total, desc=desc, unit=unit, disable=None, leave=False,
                dynamic_ncols=True)


def _history(method: str) -> tuple[Path | None, dict]:
    from hgo.engine.codegen import cache_dir

    try:
        path = cache_dir() / "compile_seconds.json"
        return path, json.loads(path.read_text()) if path.exists() else {}
    except (OSError, ValueError):
        return None, {}


class _CompileBar(Listener):
    """While numba compiles (outermost compile event), a bar filling over the expected time;
    the first compile says what it compiles (a log line)."""

    def __init__(self, method: str, what: str = "") -> None:
        self.method, self.what, self.depth, self.seconds = method, what, 0, 0.0
        self.interrupted = False  # a compile ended by Ctrl-C (KeyboardInterrupt)
        self._stop = threading.Event()
        self._thread: threading.Thread | None = None
        self._said = False

    def on_start(self, event) -> None:
        self.depth += 1
        if self.depth == 1 and not self._said:
            self._said = True
            expected = _history(self.method)[1].get(self.method)
            log.info("compiling %s with %s (once: later runs load it from the kernel cache%s)",
                     self.what or "a new kernel", self.method,
                     f"; about {expected:.0f} s last time" if expected else "")
        if self.depth == 1:
            self._t0 = time.perf_counter()
            self._stop.clear()
            self._thread = threading.Thread(target=self._show, daemon=True)
            self._thread.start()

    def on_end(self, event) -> None:
        self.depth -= 1
        kind = (getattr(event, "_exc_details", None) or (None,))[0]  # (numba keeps it private)
        self.interrupted |= isinstance(kind, type) and issubclass(kind, KeyboardInterrupt)
        if self.depth == 0:
            self.seconds += time.perf_counter() - self._t0
            self._stop.set()
            if self._thread is not None:
                self._thread.join()

    def _show(self) -> None:
        expected = _history(self.method)[1].get(self.method, 10.0)
        with bar(round(expected, 1), f"compiling a new {self.method} kernel (once)", "s") as b:
            while not self._stop.wait(0.25):
                b.n = round(min(time.perf_counter() - self._t0, 0.99 * expected), 1)
                b.refresh()


@contextmanager
def compile_progress(method: str, what: str = ""):
    """Show a bar while numba compiles inside the block, and say once what it compiles
    (``what``: "the kernel of plant vdp with observers standard"); remember how long it
    took."""
    listener = _CompileBar(method, what)
    with install_listener("numba:compile", listener):
        yield listener
    if listener.seconds > 1.0:  # a real kernel compile, not a small helper
        path, history = _history(method)
        if path is not None:
            try:
                path.write_text(json.dumps({**history, method: listener.seconds}))
            except OSError:
                pass  # a read-only cache: no ETA next time, nothing else lost
