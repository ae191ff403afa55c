"""numba's on-disk cache of a component function, compiled once for every composition
that calls it (issue 41, item 2).

A component's function (a plant's ``f``, an observer's ``update``) is compiled for the
types of its arguments: float arrays, numbers and its parameter record
(:mod:`hgo.core.records`). Those types are the same in every composition of that
component, so the compiled function is too: a new composition links it (LLVM then
inlines it into the entry points, as before) instead of typing it again.

The entries live in hgo's kernel cache, in a folder named by a hash of

* the function's source file and the files of the compiled helpers it calls
  (:func:`hgo.engine.codegen._identity`): numba itself checks only the function's own
  file, so an edited helper in another module would otherwise load stale code;
* the compile options (fast-math flags, error model, ``noalias``) and numba's version:
  numba's key ignores the options, so an entry compiled under others would be reused.

Only signatures another process rebuilds equal are saved or loaded: numbers, arrays,
data pointers (a bound function's arguments, :mod:`hgo.engine.composition`), tuples,
functions named by their source (:class:`hgo.engine.jit.KernelFunction`) and hgo's
record classes of those. A function its source and closure values do not determine
(no source file, a closure value pickle cannot write), or a record holding one: compiled
per process (still once for all the compositions of that process).
"""

from __future__ import annotations

import functools
import hashlib
import inspect
import sys
from pathlib import Path

from numba.core import types
from numba.core.caching import (
    CompileResultCacheImpl,
    FunctionCache,
    _CacheLocator,
    _SourceFileBackedLocatorMixin,
)

from hgo.core import records
from hgo.engine.jit import KernelFunctionType


class _Locator(_SourceFileBackedLocatorMixin, _CacheLocator):
    """The folder given, and the freshness stamp of the function's own file."""

    def __init__(self, py_func, folder: Path):
        self._py_file = inspect.getfile(py_func)
        self._lineno = py_func.__code__.co_firstlineno
        self._cache_path = str(folder)

    def get_cache_path(self) -> str:
        return self._cache_path


class _Impl(CompileResultCacheImpl):
    def __init__(self, py_func, folder: Path):  # (the base class searches numba's locators)
        self._lineno = py_func.__code__.co_firstlineno
        self._locator = _Locator(py_func, folder)
        module = Path(inspect.getfile(py_func)).stem
        abiflags = getattr(sys, "abiflags", "")
        self._filename_base = self.get_filename_base(f"{module}.{py_func.__qualname__}",
                                                     abiflags)


class ComponentCache(FunctionCache):
    """numba's function cache in ``folder``, for signatures of stable types only."""

    def __init__(self, py_func, folder: Path):
        self._impl_class = functools.partial(_Impl, folder=folder)
        super().__init__(py_func)

    def load_overload(self, sig, target_context):
        if not stable(sig):
            return None
        return super().load_overload(sig, target_context)

    def save_overload(self, sig, data) -> None:
        if stable(sig):
            super().save_overload(sig, data)


def stable(sig) -> bool:
    """Whether every argument type of ``sig`` (a tuple of types or a signature) is one a
    later process rebuilds equal from numba's index: numbers, booleans, arrays and data
    pointers of those, functions named by their source, tuples of those and hgo's record
    classes (importable by name) of those."""
    args = getattr(sig, "args", sig)
    return all(_stable_type(ty) for ty in args)


def _stable_type(ty) -> bool:
    if isinstance(ty, (types.Number, types.Boolean)):
        return True
    if isinstance(ty, KernelFunctionType):
        return ty.stable
    if isinstance(ty, (types.Array, types.CPointer)):
        return isinstance(ty.dtype, (types.Number, types.Boolean))
    if isinstance(ty, types.BaseNamedTuple):
        cls = ty.instance_class
        if cls.__module__ != records.__name__:
            return False
    if isinstance(ty, types.BaseTuple):
        return all(_stable_type(t) for t in ty.types)
    return False


def folder_of(root: Path, identity: str, options: str) -> Path:
    """The cache folder of a component whose sources hash to ``identity``, compiled with
    ``options``: ``root/components/<hash>``."""
    import numba

    key = "\n".join([identity, options, numba.__version__])
    return root / "components" / hashlib.sha256(key.encode()).hexdigest()[:20]
