"""Results of pure, slow computations (LMI solves of the papers' theory) cached on disk by
their inputs, as the kernels are by their source.

:func:`disk_cached` keys a call by the function's module source and its arguments (arrays
by dtype, shape and bytes; numbers by ``repr``; dataclasses field by field), so a changed
input or a changed theory file computes again. Entries are pickles in ``theory/`` of the
kernel cache (``$HGO_CACHE_DIR``, default ``~/.cache/hgo/kernels``); a cache that cannot
be read or written only costs the computation.
"""

from __future__ import annotations

import dataclasses
import functools
import hashlib
import inspect
import os
import pickle
import tempfile
from collections.abc import Callable
from pathlib import Path
from typing import Any, TypeVar

T = TypeVar("T")


def cache_root() -> Path:
    """``theory/`` in the kernel cache (``$HGO_CACHE_DIR`` or ``~/.cache/hgo/kernels``)."""
    kernels = os.environ.get("HGO_CACHE_DIR") or Path.home() / ".cache" / "hgo" / "kernels"
    return Path(kernels) / "theory"


def _feed(h: Any, value: Any) -> None:
    """Hash ``value`` canonically (type-tagged, recursive)."""
    import numpy as np

    if isinstance(value, np.ndarray):
        h.update(f"a{value.dtype.str}{value.shape}".encode())
        h.update(np.ascontiguousarray(value).tobytes())
    elif isinstance(value, (list, tuple)):
        h.update(f"l{len(value)}".encode())
        for v in value:
            _feed(h, v)
    elif isinstance(value, dict):
        h.update(f"d{len(value)}".encode())
        for k in sorted(value, key=repr):
            _feed(h, k)
            _feed(h, value[k])
    elif dataclasses.is_dataclass(value) and not isinstance(value, type):
        h.update(f"c{type(value).__module__}.{type(value).__qualname__}".encode())
        _feed(h, {f.name: getattr(value, f.name) for f in dataclasses.fields(value)})
    elif value is None or isinstance(value, (bool, int, float, str, np.generic)):
        h.update(f"s{type(value).__name__}:{value!r}".encode())
    else:
        raise TypeError(f"disk_cached: cannot key an argument of type {type(value).__name__}")


def disk_cached(fn: Callable[..., T]) -> Callable[..., T]:
    """``fn`` with its results cached on disk by its module's source and its arguments
    (module docstring); a call with an argument it cannot key is computed."""
    source = Path(inspect.getsourcefile(fn) or "")
    name = f"{fn.__module__}.{fn.__qualname__}"

    @functools.wraps(fn)
    def cached(*args: Any, **kwargs: Any) -> T:
        h = hashlib.sha256(name.encode())
        try:
            h.update(source.read_bytes())
            _feed(h, (args, kwargs))
        except (OSError, TypeError):
            return fn(*args, **kwargs)
        path = cache_root() / f"{name}-{h.hexdigest()[:24]}.pkl"
        try:
            return pickle.loads(path.read_bytes())
        except (OSError, pickle.UnpicklingError, EOFError, AttributeError, ImportError):
            pass
        result = fn(*args, **kwargs)
        _store(path, result)
        return result

    return cached


def _store(path: Path, result: Any) -> None:
    """Write atomically (a temporary file renamed): a reader never sees half an entry."""
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        with tempfile.NamedTemporaryFile(dir=path.parent, delete=False, suffix=".tmp") as fh:
            pickle.dump(result, fh, protocol=pickle.HIGHEST_PROTOCOL)
        os.replace(fh.name, path)
    except (OSError, pickle.PicklingError, TypeError, AttributeError):
        pass
