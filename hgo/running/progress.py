"""Progress bars (tqdm) for long work: compiling a new kernel, ensembles, reproduce.

Bars go to stderr and are shown on a terminal only (tqdm's ``disable=None``), so logs and
tests stay clean. Compiling shows an ETA from the last compile of the same part on this
machine (``compile_seconds.json`` in the kernel cache): a composition (seconds) and an
integrator (once per method and layout: ~10x longer) each have their own.
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

# a part's compile shorter than this (a small helper's, ~0.05 s) leaves its ETA as it was
MIN_RECORDED_S = 0.25


def bar(total: int | float | None, desc: str, unit: str = "it") -> tqdm:
    """A tqdm bar on stderr, shown on terminals only."""
    return tqdm(total=total, desc=desc, unit=unit, disable=None, leave=False,
                dynamic_ncols=True)


def _history() -> tuple[Path | None, dict]:
    from hgo.engine.codegen import cache_dir

    try:
        path = cache_dir() / "compile_seconds.json"
        return path, json.loads(path.read_text()) if path.exists() else {}
    except (OSError, ValueError):
        return None, {}


def _part(event) -> tuple[str, str]:
    """What a compile event compiles, as (kind, words): the integrator (a function of a
    generated ``hgo_integrator_*`` module: once per method and layout, shared by every
    composition of that layout) or the composition (its entry point, components and bound
    functions: once per composition). Their times differ by ~10x, so each has its ETA."""
    fn = getattr((getattr(event, "data", None) or {}).get("dispatcher"), "py_func", None)
    module = getattr(fn, "__globals__", {})
    if str(module.get("__name__", "")).startswith("hgo_integrator"):
        return "integrator", f"the integrator for {module.get('NZ', '?')} states"
    return "composition", ""


class _CompileBar(Listener):
    """While numba compiles (outermost compile event), a bar filling over the time the same
    part (:func:`_part`) took last time; the first compile of each part says what it
    compiles (a log line)."""

    def __init__(self, method: str, what: str = "") -> None:
        self.method, self.what, self.depth = method, what, 0
        self.part_seconds: dict[str, float] = {}  # history key -> seconds compiled
        self._last = _history()[1]  # (read once: the seconds of each part last time)
        self.interrupted = False  # a compile ended by Ctrl-C (KeyboardInterrupt)
        self._stop = threading.Event()
        self._thread: threading.Thread | None = None
        self._key = ""

    def on_start(self, event) -> None:
        self.depth += 1
        if self.depth != 1:
            return
        kind, words = _part(event)
        self._key = f"{self.method} {kind}"
        expected = self._last.get(self._key)
        if self._key not in self.part_seconds:
            self.part_seconds[self._key] = 0.0
            what = words or self.what or "a new kernel"
            log.info("compiling %s with %s (once: later runs load it from the kernel cache%s)",
                     what, self.method, f"; about {expected:.1f} s last time" if expected else "")
        self._t0 = time.perf_counter()
        self._stop.clear()
        self._thread = threading.Thread(target=self._show, args=(kind, expected), daemon=True)
        self._thread.start()

    def on_end(self, event) -> None:
        self.depth -= 1
        kind = (getattr(event, "_exc_details", None) or (None,))[0]  # (numba keeps it private)
        self.interrupted |= isinstance(kind, type) and issubclass(kind, KeyboardInterrupt)
        if self.depth == 0:
            self.part_seconds[self._key] += time.perf_counter() - self._t0
            self._stop.set()
            if self._thread is not None:
                self._thread.join()

    def _show(self, kind: str, expected: float | None) -> None:
        # (no history: numba's typical times on a 2-core machine, issue 41's measurements)
        expected = expected or (10.0 if kind == "integrator" else 1.0)
        label = (f"compiling the {self.method} integrator (once per layout)"
                 if kind == "integrator" else "compiling the composition (once)")
        with bar(round(expected, 1), label, "s") as b:
            while not self._stop.wait(0.25):
                b.n = round(min(time.perf_counter() - self._t0, 0.99 * expected), 1)
                b.refresh()


@contextmanager
def compile_progress(method: str, what: str = ""):
    """Show a bar while numba compiles inside the block, and say once per part (the
    composition, the integrator) what it compiles (``what``: "the kernel of plant vdp with
    observers standard", the composition); remember how long each part took."""
    listener = _CompileBar(method, what)
    with install_listener("numba:compile", listener):
        yield listener
    took = {k: s for k, s in listener.part_seconds.items() if s >= MIN_RECORDED_S}
    if took:
        path, history = _history()
        if path is not None:
            try:
                path.write_text(json.dumps({**history, **took}))
            except OSError:
                pass  # a read-only cache: no ETA next time, nothing else lost
