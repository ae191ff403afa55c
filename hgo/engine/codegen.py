"""Compile a :class:`~hgo.engine.system.System`: its integrator and its composition, apart.

Two generated modules make a kernel (:class:`Kernel`):

* the **integrator** (:mod:`hgo.engine.kernel_template` with the method's stages from
  :mod:`hgo.engine.tableau`, after a header of the layout's sizes): the same text, so the
  same numba cache entry, for every composition of one method and layout; compiled once;
* the **composition** (:mod:`hgo.engine.composition`): the components' functions on their
  slices of the flat vectors, compiled per experiment into C entry points (numba
  ``cfunc``) whose addresses the integrator gets as its argument ``S``; the components'
  own functions compiled once and cached apart (:mod:`hgo.engine.component_cache`).

Each is written to a cache folder under a name that hashes its text (the composition's
text also names every component function with a hash of its source files), so numba's
on-disk cache (``cache=True``) is reused by later processes and never goes stale.

If numba cannot compile a component (a user's plant written with Python objects, say),
the same modules are loaded with ``jit`` as the identity: a pure-Python path, slower, with
one warning saying why.
"""

from __future__ import annotations

import errno
import functools
import hashlib
import importlib.util
import inspect
import os
import pickle
import shutil
import sys
import tempfile
import types
import warnings
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path
from types import ModuleType

import numpy as np

from hgo.engine import tableau
from hgo.engine.composition import (
    ARRAYS,
    ENTRY_POINTS,
    RETURNS_FLOAT,
    Bound,
    _components,
    _functions,
    composition_text,
    integrator_constants,
    scalars_of,
    selector_constants,
)
from hgo.engine.jit import (
    address_function,
    borrow_function,
    c_call_functions,
    carray_function,
    pointer_function,
    stack_function,
    view2_function,
    view_function,
)
from hgo.engine.system import System
from hgo.engine.tableau import ADAPTIVE, method_source, scipy_tableau_files

_TEMPLATE = Path(__file__).with_name("kernel_template.py")
FASTMATH = ("contract", "arcp")
"""LLVM fast-math flags of the compiled kernel: fused multiply-adds and multiplication by
reciprocals, both exact to an ulp per operation; 13-15 % off problem B (benchmarks/).
Never ``nnan``/``ninf``: the kernel detects non-finite states."""


def cache_dir() -> Path:
    """Folder of generated kernels: ``$HGO_CACHE_DIR`` or ``~/.cache/hgo/kernels``; a
    private temporary folder (one warning) when that one cannot be created or written, or
    once a write into it failed (a full disk: :func:`_cache_write`)."""
    root = os.environ.get("HGO_CACHE_DIR") or Path.home() / ".cache" / "hgo" / "kernels"
    path = Path(root)
    if path in _PRIVATE:
        return _PRIVATE[path]
    try:
        path.mkdir(parents=True, exist_ok=True)
        if os.access(path, os.W_OK | os.X_OK):
            return path
    except OSError:
        pass
    return _fallback_dir(path, "is not writable")


_PRIVATE: dict[Path, Path] = {}  # kernel cache wanted -> the private folder used instead
# a write into the cache that a private folder can do instead of failing the run
UNWRITABLE = (errno.ENOSPC, errno.EDQUOT, errno.EROFS, errno.EACCES, errno.EPERM)


def _fallback_dir(wanted: Path, why: str) -> Path:
    if wanted not in _PRIVATE:
        _PRIVATE[wanted] = path = Path(tempfile.mkdtemp(prefix="hgo-kernels-"))
        warnings.warn(f"hgo: the kernel cache {wanted} {why}; compiling into {path} for "
                      "this process only (set HGO_CACHE_DIR to a writable folder)",
                      RuntimeWarning, stacklevel=3)
    return _PRIVATE[wanted]


def _sections() -> dict[str, str]:
    """The template cut at its ``# --- section: <name> ---`` markers."""
    parts: dict[str, str] = {}
    name = "preamble"
    for line in _TEMPLATE.read_text().splitlines(keepends=True):
        if line.startswith("# --- section: "):
            name = line.split(":", 1)[1].strip(" -\n")
            parts[name] = ""
            continue
        parts[name] = parts.get(name, "") + line
    return parts


def _source_files(fn: object) -> set[str]:
    """The file defining ``fn`` and the files of the compiled helpers it calls.

    numba's on-disk cache of the kernel only checks the kernel's own file, so the kernel's
    name must change whenever a component *or a helper it calls* changes: hashing whole
    files (not only the function's source) covers helpers in the same module and in the
    modules of the ``kernel_helper`` functions it references.
    """
    files = set()
    for obj in [fn] + [v for v in getattr(fn, "__globals__", {}).values()
                       if hasattr(v, "py_func")]:
        target = getattr(obj, "py_func", obj)
        try:
            files.add(inspect.getsourcefile(target) or "")
        except TypeError:
            continue
    return {f for f in files if f}


def _identity(fn: object) -> str:
    """Module, name and source hash of a component function (part of the kernel's name),
    with a hash of a closure's values; ending in ``@<id>`` where the source does not
    determine the function (no source file, a closure value pickle cannot write): then
    the name holds for this process only (:func:`determined`)."""
    digest = hashlib.sha256()
    files = sorted(_source_files(fn))
    for path in files:
        digest.update(Path(path).read_bytes())
    unique = not files
    for cell in getattr(fn, "__closure__", None) or ():
        try:  # two closures of one source differ in their values only
            digest.update(pickle.dumps(cell.cell_contents))
        except Exception:  # noqa: BLE001 - anything pickle refuses: this process only
            unique = True
    name = f"{getattr(fn, '__module__', '?')}.{getattr(fn, '__qualname__', '?')}"
    return f"# {name} {digest.hexdigest()[:16]}" + (f" @{id(fn)}" if unique else "")


def determined(identity: str) -> bool:
    """Whether :func:`_identity` ``identity`` names the same function in every process."""
    return "@" not in identity


def composition_source(system: System, noisy: bool = True) -> tuple[str, dict[str, object]]:
    """The composition's module text (:mod:`hgo.engine.composition`) and the functions it
    calls by injected name (components without a record, and the
    :class:`~hgo.engine.composition.Bound` functions of those with one); ``noisy=False``:
    for runs whose measurement noise is zero (y = h(x), m ignored). Its first lines name
    every function it calls with a hash of its source files (a bound function: of its
    module's text, which names its component's), so the text (and the cache entry named
    by its hash) changes when a component or a helper it calls does."""
    functions, calls = _functions(system)
    text, called = composition_text(system, functions, calls, noisy)
    ids = "\n".join(f"# bound {_digest(bound_source(fn))} -> {name}" if isinstance(fn, Bound)
                    else f"{_identity(fn)} -> {name}" for name, fn in called.items())
    text = ("# Generated by hgo.engine.codegen; do not edit.\n" + ids + "\n"
            + f"# composition; numba fastmath {FASTMATH}, noalias, components cached apart; "
              "C entry points\n" + text)
    return text, called


def bound_source(bound: Bound, ids: dict[str, str] | None = None) -> str:
    """The module text of a :class:`~hgo.engine.composition.Bound` function: a header
    naming the functions it is given with a hash of their sources (``ids``: their
    :func:`_identity`, if known), then its text."""
    ids = ids or {name: _identity(fn) for name, fn in bound.functions.items()}
    return ("# Generated by hgo.engine.codegen; do not edit.\n"
            + "\n".join(f"{identity} -> {name}" for name, identity in ids.items()) + "\n"
            + f"# a component's function on its parameter slice; numba fastmath {FASTMATH}, "
              "noalias, cached with the components\n" + bound.text)


def integrator_source(system: System, method: str) -> str:
    """The integrator module text for ``method`` and the layout of ``system``
    (:func:`hgo.engine.composition.integrator_constants`): the same text, so the same
    cache entry and compiled code, for every composition of that layout."""
    sections = _sections()
    if method in ADAPTIVE:
        integrator = _integrator_source(method) + sections["adaptive"]
    elif method == "rk4":
        integrator = sections["rk4"]
    else:
        raise ValueError(f"solver.method: '{method}' not in {sorted(ADAPTIVE + ('rk4',))}")
    return ("# Generated by hgo.engine.codegen; do not edit.\n"
            + f"# integrator: {method}; numba fastmath {FASTMATH}, noalias\n"
            + "import math\n\nimport numpy as np\n\n"
            + integrator_constants(system) + selector_constants()
            + "# --- common ---\n" + sections["common"]
            + f"# --- {method} ---\n" + integrator)


def _digest(text: str) -> str:
    return hashlib.sha256(text.encode()).hexdigest()[:20]


@functools.cache
def _integrator_source(method: str) -> str:
    """:func:`~hgo.engine.tableau.method_source`, kept in the cache folder under a hash of
    what it is made from (``tableau.py`` and scipy's coefficient files), so that a cached
    kernel is found without importing scipy. An entry whose text does not match the hash
    on its first line is made anew."""
    made_from = [Path(tableau.__file__), *scipy_tableau_files()]
    key = _digest(method + "".join(path.read_text() for path in made_from))
    path = cache_dir() / f"hgo_tableau_{method}_{key}.txt"
    try:
        head, text = path.read_text().split("\n", 1)
        if head == f"# {_digest(text)}":
            return text
    except (OSError, UnicodeDecodeError, ValueError):
        pass
    text = method_source(method)
    _cache_write(path.name, f"# {_digest(text)}\n{text}")
    return text


def _atomic_write(path: Path, text: str) -> None:
    """``text`` into ``path`` through a temporary file and a rename: jobs may race. A folder
    where the entry belongs is removed first; a failed write leaves no temporary file."""
    fd, tmp = tempfile.mkstemp(dir=path.parent, suffix=".tmp")
    try:
        with os.fdopen(fd, "w") as fh:
            fh.write(text)
        if path.is_dir() and not path.is_symlink():
            shutil.rmtree(path)
        os.replace(tmp, path)
    except BaseException:
        Path(tmp).unlink(missing_ok=True)
        raise


def _cache_write(name: str, text: str) -> Path:
    """``text`` as the cache entry ``name``; where the cache cannot take it (full, read-only
    since it was checked), in the private folder instead, with one warning."""
    folder = cache_dir()
    try:
        _atomic_write(folder / name, text)
        return folder / name
    except OSError as err:
        if err.errno not in UNWRITABLE:
            raise
        why = f"cannot be written ({os.strerror(err.errno)})"
    folder = _fallback_dir(folder, why)
    _atomic_write(folder / name, text)
    return folder / name


def _write_once(text: str, prefix: str = "hgo_kernel") -> Path:
    """The cache entry of ``text``, named ``<prefix>_<hash>.py``; an existing entry is
    verified (hash of its text) and a corrupted one (a folder in its place too) rewritten,
    with its numba cache, after one warning."""
    digest = _digest(text)
    path = cache_dir() / f"{prefix}_{digest}.py"
    if path.exists():
        try:
            intact = _digest(path.read_text()) == digest
        except (OSError, UnicodeDecodeError):
            intact = False
        if intact:
            return path
        what = "is a folder" if path.is_dir() else "is corrupted (its text does not match its hash)"
        warnings.warn(f"hgo: kernel-cache entry {path.name} {what}; rebuilding it",
                      RuntimeWarning, stacklevel=3)
        purge_numba_cache(path)
    return _cache_write(path.name, text)


def numba_cache_dirs(path: Path) -> list[Path]:
    """Where numba may keep the compiled cache of the module file ``path``."""
    dirs = [path.parent / "__pycache__"]
    if config_dir := os.environ.get("NUMBA_CACHE_DIR"):
        dirs += [p.parent for p in Path(config_dir).rglob(f"{path.stem}.*.nbi")]
    return dirs


def purge_numba_cache(path: Path) -> int:
    """Delete numba's cache files (index and data) of the kernel module ``path``; returns
    how many were removed."""
    removed = 0
    for folder in numba_cache_dirs(path):
        for entry in folder.glob(f"{path.stem}.*"):
            if entry.suffix in (".nbi", ".nbc"):
                entry.unlink(missing_ok=True)
                removed += 1
    return removed


def damaged_cache_file(err: BaseException) -> Path | None:
    """The numba cache index whose reading raised ``err`` (from numba's frames), if any."""
    found, tb = None, err.__traceback__
    while tb is not None:
        index = getattr(tb.tb_frame.f_locals.get("self"), "_index_path", None)
        if index:
            found = Path(index)
        tb = tb.tb_next
    return found


def remove_cache_entry(index: Path) -> None:
    """Delete a numba cache index and its data files (``<name>.nbi``, ``<name>.<k>.nbc``)."""
    stem = index.name.removesuffix(".nbi")
    for entry in index.parent.glob(f"{stem}*"):
        if entry.suffix in (".nbi", ".nbc"):
            entry.unlink(missing_ok=True)


@contextmanager
def entry_lock(path: Path) -> Iterator[None]:
    """An exclusive lock on the kernel-cache entry ``path`` (``<entry>.lock``, ``flock``):
    of the processes that need the kernel at once, one compiles it and the others wait,
    then load numba's cache of it. No lock where there is no ``fcntl`` or the cache
    directory is read-only (each process compiles, as before)."""
    try:
        import fcntl

        handle = open(path.with_suffix(".lock"), "a")  # noqa: SIM115 (held while compiling)
    except (ImportError, OSError):
        yield
        return
    with handle:
        fcntl.flock(handle, fcntl.LOCK_EX)
        try:
            yield
        finally:
            fcntl.flock(handle, fcntl.LOCK_UN)


def compiled_first(fn, path: Path | str):
    """``fn`` (a kernel function) that, on its first call in this process, compiles or
    loads it from numba's cache under :func:`entry_lock` before running it: the lock is
    held while compiling, never while integrating."""
    if not hasattr(fn, "compile") or fn in _COMPILED:  # pure Python, or ready
        return fn

    def call(*args):
        # (a caller may keep this wrapper, as StepRecord.at does: once compiled, its calls
        # skip ``signatures``, 12.6 us a call, ~20000 calls in Moreno's K~1 searches)
        if fn not in _COMPILED:
            if not fn.signatures:
                with entry_lock(Path(path)):
                    compile_unsaved(fn, tuple(fn.typeof_pyval(a) for a in args))
            _COMPILED.add(fn)
        return fn(*args)

    return call


def compile_unsaved(fn, signature: tuple) -> None:
    """``fn.compile(signature)``, kept for this process when numba cannot save it into its
    cache (a full disk): numba adds a function's compiled code before it saves it, so each
    retry goes past one more function (the kernel or a helper it calls) whose save failed;
    one warning."""
    warned = False
    for _ in range(MAX_UNSAVED):
        try:
            fn.compile(signature)
            return
        except OSError as err:
            if err.errno not in UNWRITABLE:
                raise
            if not warned:
                _warn_unsaved(err)
                warned = True
            if fn.signatures:  # compiled; only the save failed
                return
    fn.compile(signature)


def _warn_unsaved(err: OSError) -> None:
    warnings.warn(f"hgo: numba cannot save the compiled kernel into its cache "
                  f"({os.strerror(err.errno)}); it is compiled for this process only",
                  RuntimeWarning, stacklevel=5)


MAX_UNSAVED = 64  # functions (the kernel and its helpers) whose save may fail in one compile


# kernel functions compiled or loaded in this process (their later calls go straight in:
# reading ``signatures`` cost ~30 us a call)
_COMPILED: set = set()


def forget_kernel(kernel: Kernel) -> None:
    """Drop a loaded kernel (its composition and integrator modules, and their numba
    caches) so that the next load recompiles both."""
    for key in [k for k, known in _LOADED.items() if known is kernel]:
        del _LOADED[key]
    for module in (kernel.composition, kernel.integrator):
        for key in [k for k, m in _MODULES.items() if m is module]:
            del _MODULES[key]
        sys.modules.pop(module.__name__, None)
        _COMPILED.difference_update([f for f in _COMPILED
                                     if f.py_func.__module__ == module.__name__])
        purge_numba_cache(Path(module.__file__))


class Kernel:
    """A composition bound to its integrator: :meth:`function` gives the integrator's
    ``integrate``, ``integrate_ensemble`` and ``dense_signals`` with the composition's
    entry points as their first argument ``S`` (:mod:`hgo.engine.kernel_template`)."""

    def __init__(self, composition: ModuleType, integrator: ModuleType, compiled: bool,
                 method: str):
        self.composition, self.integrator, self.compiled = composition, integrator, compiled
        # the entry points the integrator calls (the RK4 step: RK4's only)
        self.names = ENTRY_POINTS if method == "rk4" else ENTRY_POINTS[:-1]
        self.__name__, self.__file__ = composition.__name__, composition.__file__
        self._entry_points: tuple | np.ndarray | None = None

    def entry_points(self) -> tuple | np.ndarray:
        """``S``: the composition's entry points in the order of ``ENTRY_POINTS``, the
        first four one function (``c_system``, its selector picks: :data:`SELECT`);
        compiled (numba ``cfunc``, or loaded from numba's cache) on the first call, under
        the entry's lock."""
        if self._entry_points is None:
            module = self.composition
            if not self.compiled:
                self._entry_points = tuple(module.system_rk4 if name == "rk4" else
                                           module.system_call for name in self.names)
            else:
                with entry_lock(Path(module.__file__)):
                    system = _entry_point(module.c_system, "system")
                    rk4 = _entry_point(module.c_rk4, "rk4") if "rk4" in self.names else None
                # the addresses are valid while the cfunc objects (their machine code) live:
                # for the process, since a step record may call them after a repair has
                # dropped this kernel (forget_kernel)
                _ENTRY_POINTS_ALIVE.append([system, rk4])
                self._entry_points = np.array(
                    [rk4.address if name == "rk4" else system.address if self._called(name)
                     else 0 for name in self.names], np.int64)
        return self._entry_points

    def _called(self, name: str) -> bool:
        """Whether the integrator calls entry point ``name`` (not an update without discrete
        logic, nor a stiffness no component declares: ``c_system`` has no branch for them,
        address 0)."""
        return ((name != "update" or self.composition.HAS_UPDATE)
                and (name != "stiffness" or self.composition.HAS_STIFFNESS))

    def function(self, fname: str):
        """The integrator's function ``fname`` with ``S`` bound: compiled under the
        integrator's lock on its first call (:func:`compiled_first`)."""
        fn = compiled_first(getattr(self.integrator, fname), self.integrator.__file__)
        return functools.partial(fn, self.entry_points())

    def __getattr__(self, name: str):
        # the integrator's functions by name (integrate.stats, _trial, _step_of, ...); not
        # its own attributes or dunders (copy and pickle look for those before __init__)
        if name.startswith("__") or name in ("integrator", "composition"):
            raise AttributeError(name)
        return getattr(self.integrator, name)


def _c_signature(name: str):
    """The C signature of entry point ``name``: its floats (``system``: t and the selector;
    the RK4 step: t, h, t_lim, t_new), then the data of the arrays it takes."""
    from numba.core import types

    n_scalars, n_arrays = len(scalars_of(name).split(",")), len(ARRAYS[name].split())
    result = types.float64 if name in RETURNS_FLOAT else types.void
    return result(*[types.float64] * n_scalars, *[types.CPointer(types.float64)] * n_arrays)


def _entry_point(fn, name: str):
    """The composition's function ``fn`` as a numba ``cfunc`` (cached on disk); where numba
    cannot save it into its cache (a full disk), compiled for this process, one warning."""
    from numba.core.caching import NullCache
    from numba.core.ccallback import CFunc
    from numba.core.sigutils import normalize_signature

    # (numba.cfunc without its compile at decoration: a save that fails is handled here)
    cfunc = CFunc(fn, normalize_signature(_c_signature(name)), locals={},
                  options={"error_model": "numpy", "fastmath": set(FASTMATH)})
    # noalias on the data pointers, as on the integrator's arrays (:func:`_noalias`): the
    # integrator never passes overlapping arrays to one call
    customize = cfunc._compiler._customize_flags
    cfunc._compiler._customize_flags = lambda flags: _set_noalias(customize(flags))
    cfunc._compile_uncached = _announced(cfunc)
    cfunc.enable_caching()
    try:
        cfunc.compile()
    except OSError as err:
        if err.errno not in UNWRITABLE:
            raise
        _warn_unsaved(err)
        cfunc._cache = NullCache()
        cfunc.compile()
    return cfunc


def _announced(cfunc):
    """``cfunc``'s compile (not its load from numba's cache) as a ``numba:compile`` event,
    as a dispatcher's compile is: what listens to those (the run's compile seconds in
    ``run.json``, the compile progress bar) sees the composition's compile too, not only
    the integrator's and the components'."""
    from numba.core import event

    uncached = cfunc._compile_uncached

    def compile_uncached():
        data = {"dispatcher": cfunc, "args": cfunc._sig.args,
                "return_type": cfunc._sig.return_type}
        with event.trigger_event("numba:compile", data=data):
            return uncached()

    return compile_uncached


def load_kernel(system: System, compiled: bool = True, method: str = "dopri5",
                noisy: bool = True) -> Kernel:
    """The kernel of ``system`` with integrator ``method``: its composition module (written
    once per composition) and its integrator module (once per method and layout), imported.

    ``compiled=False`` gives the pure-Python kernel (same code, ``jit`` = identity);
    ``noisy=False`` the composition of runs without measurement noise
    (:func:`composition_source`).
    """
    key = _layout_key(system, method, compiled, noisy)
    if key in _LOADED:  # no source hashing on every run of a sweep
        return _LOADED[key]
    text, functions = composition_source(system, noisy)
    composition = _import(_write_once(text), compiled, functions)
    integrator = _import(_write_once(integrator_source(system, method), "hgo_integrator"),
                         compiled)
    _LOADED[key] = Kernel(composition, integrator, compiled, method)
    return _LOADED[key]


def _import(path: Path, compiled: bool, functions: dict | None = None) -> ModuleType:
    """The generated module ``path`` (once per process and mode), with the decorators of
    ``compiled`` and the ``functions`` it calls injected."""
    name = path.stem + ("" if compiled else "_py")
    if name in _MODULES:
        return _MODULES[name]
    spec = importlib.util.spec_from_file_location(name, path)
    module = importlib.util.module_from_spec(spec)
    module.__dict__.update(_decorators(compiled))
    module.__dict__.update({k: _injected(k, fn, compiled)
                            for k, fn in (functions or {}).items()})
    sys.modules[name] = module
    spec.loader.exec_module(module)
    _MODULES[name] = module
    return module


def _injected(name: str, fn: object, compiled: bool) -> object:
    """A function as a generated module calls it: a bound function's own (its module
    imported), a function constant as :func:`_function_constant` makes it (compiled), a
    component function as :func:`_component` does."""
    if isinstance(fn, Bound):
        return _bound(fn, compiled)
    if name.startswith("c_const") and compiled:
        return _function_constant(fn)
    return _component(fn, compiled)


def _bound(bound: Bound, compiled: bool):
    """The function ``bound`` of a :class:`~hgo.engine.composition.Bound` function's module
    (written once in the cache folder under a hash of its text, imported once), compiled
    as a component is: once, on the disk cache, unless a function it is given is not
    determined by its source (then once per process)."""
    ids = {name: _identity(fn) for name, fn in bound.functions.items()}
    module = _import(_write_once(bound_source(bound, ids), "hgo_bound"), compiled,
                     bound.functions)
    return _component(module.bound, compiled, all(map(determined, ids.values())))


def _component(fn, compiled: bool, cached: bool = True):
    """Component function ``fn`` as the compositions call it: itself (the pure-Python
    path), or its one dispatcher of this process, cached on disk
    (:mod:`hgo.engine.component_cache`) for the signatures that can be (``cached``
    False: never, compiled per process)."""
    if not compiled:
        return fn
    import numba

    from hgo.engine.component_cache import ComponentCache, folder_of

    key = (fn, FASTMATH)
    if key not in _COMPONENTS:
        options = _component_options()
        dispatcher = _noalias(numba.njit(**options))(fn)
        identity = _identity(fn)
        if cached and determined(identity):  # (else compiled per process)
            dispatcher._cache = ComponentCache(
                fn, folder_of(cache_dir(), identity, _described(options) + " noalias"))
        _COMPONENTS[key] = dispatcher
    return _COMPONENTS[key]


def _described(options: dict) -> str:
    """numba options as text, the same in every process (a set's order is not)."""
    return repr(sorted((k, sorted(v) if isinstance(v, set) else v)
                       for k, v in options.items()))


_COMPONENTS: dict[tuple, object] = {}  # (function, fast-math flags) -> its dispatcher
_LOADED: dict[tuple, Kernel] = {}
_ENTRY_POINTS_ALIVE: list[list] = []  # every compiled entry point of this process
_MODULES: dict[str, ModuleType] = {}  # generated modules imported in this process, by name


_CONSTANT_FUNCTIONS: dict[tuple, object] = {}


def _function_constant(fn: object) -> object:
    """A function among a component's constants, as the kernel's record holds it: a
    :class:`hgo.engine.jit.KernelFunction` of a copy of the Python function registered
    with numba (``register_jitable``), whose type carries no run-time value and is named
    by the function's source (so that a component holding it is found in the on-disk
    cache by another process). A numba dispatcher in the record would be stored as the
    address of a Python object, which the on-disk cache would carry into the next
    process (measured: a kernel loaded from the cache ran from garbage, then
    ``free(): corrupted unsorted chunks``). A compiled helper (``kernel_helper``) keeps
    its own options (no fast-math); a user's function gets the components' options."""
    from numba.extending import register_jitable

    from hgo.engine.jit import KernelFunction

    src = getattr(fn, "py_func", fn)
    options = {"error_model": "numpy"}
    if src is fn:
        options["fastmath"] = set(FASTMATH)
    key = (src, tuple(sorted(FASTMATH)) if src is fn else ())
    if key not in _CONSTANT_FUNCTIONS:
        copy = types.FunctionType(src.__code__, src.__globals__, src.__name__,
                                  src.__defaults__, src.__closure__)
        copy.__qualname__, copy.__module__ = src.__qualname__, src.__module__
        register_jitable(**options)(copy)
        identity = _identity(src)
        _CONSTANT_FUNCTIONS[key] = KernelFunction(f"{identity[2:]} {_described(options)}",
                                                  copy, determined(identity))
    return _CONSTANT_FUNCTIONS[key]


def _layout_key(system: System, method: str, compiled: bool, noisy: bool) -> tuple:
    """What the generated text depends on: the component functions (by identity), the
    layout and the noise flag, not the parameter values (computed once per system)."""
    key = system.kernel_keys.get((method, compiled, noisy))
    if key is None:
        key = system.kernel_keys[method, compiled, noisy] = _new_layout_key(
            system, method, compiled, noisy)
    return key


def _new_layout_key(system: System, method: str, compiled: bool, noisy: bool) -> tuple:
    functions, _ = _functions(system)
    plant = system.plant
    layout = (plant.nx, len(plant.output_names), len(plant.input_names),
              tuple(system.z_slices), tuple(system.d_slices), tuple(system.p_slices),
              tuple(system.xh_slices), tuple(system.estimate_map().tolist()),
              tuple(system.yhat_columns().tolist()), system.controlled_observer(),
              tuple(None if c.params is None else c.params.layout()
                    for c in _components(system)))
    return (method, compiled, noisy, FASTMATH, tuple(functions.items()), layout)


def _decorators(compiled: bool) -> dict[str, object]:
    if not compiled:
        return {"jit": lambda fn: fn, "pjit": lambda fn: fn, "prange": range,
                "view": view_function(False), "borrow": borrow_function(False),
                "view2": view2_function(False), "stack": stack_function(False),
                "ijit": lambda fn: fn,
                "ptr": pointer_function(False),
                "at": address_function(False), "carray": carray_function(False),
                **c_call_functions(False)}
    import numba

    opts = _options()
    # Inlined helpers are never called from Python: they skip the CPython wrapper numba
    # would otherwise compile through LLVM too (measured: ~15 % of a fresh compile of
    # problem B). ``jit`` functions keep theirs.
    internal = {**opts, "no_cpython_wrapper": True}
    return {
        "jit": _noalias(numba.njit(**opts)),
        # every function a kernel function calls (helpers, the step functions): inlined
        # into it by LLVM. A callee compiled apart (``jit``) is also linked into its
        # caller's cached code, optimised there in another context: the compiling process
        # ran the separate copy, a process loading the cache the caller's own, and runs
        # of DOP853 moved in their last bits and then their steps with the cache's state
        # (tests/test_kernel_cache.py). ``jit``: the functions Python calls (integrate,
        # dense_signals); integrate_ensemble calls integrate too, and its members equal
        # single runs bit for bit (checked for B, apa_fig2, moreno_fig1, dhlm_example).
        "ijit": _noalias(numba.njit(**internal, forceinline=True)),
        "pjit": _noalias(numba.njit(**opts, parallel=True)),
        "prange": numba.prange,
        "view": view_function(True),
        "view2": view2_function(True),
        "stack": stack_function(True),
        "borrow": borrow_function(True),
        "ptr": pointer_function(True),
        **c_call_functions(True),
        "at": address_function(True),
        "carray": carray_function(True),
    }


def _options() -> dict:
    """numba's options of the kernel's functions."""
    # error_model="numpy": a division by zero gives inf/nan (caught as status 1) instead of
    # raising, and drops a branch from every division of the hot loop.
    # nogil: while the integration runs, the thread that turns Ctrl-C into its stop flag
    # (hgo.engine.interrupt) needs the GIL; the kernel holds no Python object, so releasing
    # it is free.
    return {"cache": True, "error_model": "numpy", "fastmath": set(FASTMATH), "nogil": True}


def _component_options() -> dict:
    """numba's options of a component function: inlined into the entry points, no CPython
    wrapper, cached by :mod:`hgo.engine.component_cache` (not by numba's own locator:
    numba's cache key ignores compile options, so an entry written under other options,
    an older hgo's, would be reused. Measured: problem A's kernel built on such entries
    ran 9.5-10.5 ms instead of 5.5 ms)."""
    return {**_options(), "no_cpython_wrapper": True, "cache": False, "forceinline": True}


def _set_noalias(flags):
    flags.noalias = True
    return flags


def _noalias(decorator):
    """``decorator`` whose functions compile with LLVM ``noalias`` on their array arguments.

    Sound for kernel functions: the engine never passes overlapping arrays to one call
    (each argument is a run's own array, a parameter slice, or a disjoint view of the work
    vector), so LLVM may keep parameters and states in registers across the components'
    stores instead of reloading them (problem A, in-process A/B: see ``benchmarks/``).
    numba has the flag but no decorator option for it: it is set on each dispatcher's
    compiler, and left off (slower, same results) if a numba version lacks that hook.
    """

    def wrap(fn):
        dispatcher = decorator(fn)
        compiler = getattr(dispatcher, "_compiler", None)
        if hasattr(compiler, "_customize_flags"):
            compiler._customize_flags = _set_noalias
        return dispatcher

    return wrap
