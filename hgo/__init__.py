"""hgo: a research harness for high-gain observer experiments.

The Python API (see :mod:`hgo.api`)::

    import hgo
    result = hgo.run(["experiment=sp_fig1", "solver.t_end=5"])
    result.metrics, result.signals          # DataFrames
    table = hgo.sweep(["experiment=sp_fig1"], grid={"observer.sign_indefinite.p2": [1, 2]})

Names are imported on first use (module ``__getattr__``), so ``import hgo`` and the ``hgo``
command start without loading Hydra, numba or Rerun.
"""

from __future__ import annotations

import importlib

TYPE_CHECKING = False  # (typing.TYPE_CHECKING without importing typing: ~2 ms at start-up)
if TYPE_CHECKING:  # what the lazy names are, for type checkers and readers
    from hgo.api import HgoError, Result, compose, run, sweep
    from hgo.outputs import runs
    from hgo.outputs.recording import read_recording
    from hgo.outputs.tradeoff import plot

# public name -> (module, attribute; None: the module itself)
_LAZY: dict[str, tuple[str, str | None]] = {
    "compose": ("hgo.api", "compose"),
    "run": ("hgo.api", "run"),
    "sweep": ("hgo.api", "sweep"),
    "Result": ("hgo.api", "Result"),
    "HgoError": ("hgo.core.errors", "HgoError"),
    "read_recording": ("hgo.outputs.recording", "read_recording"),
    "runs": ("hgo.outputs.runs", None),
    "plot": ("hgo.outputs.tradeoff", "plot"),
}

__all__ = ["HgoError", "Result", "__version__", "compose", "plot", "read_recording", "run",
           "runs", "sweep"]


def _version() -> str:
    from importlib.metadata import PackageNotFoundError, version

    try:
        return version("hgo")
    except PackageNotFoundError:  # a checkout on PYTHONPATH, not installed
        return "0+unknown"


def __getattr__(name: str) -> object:
    if name == "__version__":
        value = _version()
    elif name in _LAZY:
        module, attribute = _LAZY[name]
        value = importlib.import_module(module)
        value = value if attribute is None else getattr(value, attribute)
    else:
        raise AttributeError(f"module 'hgo' has no attribute {name!r}")
    globals()[name] = value  # later look-ups skip this function
    return value


def __dir__() -> list[str]:
    return sorted([*globals(), *_LAZY, "__version__"])
