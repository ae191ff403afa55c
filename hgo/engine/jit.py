"""Compilation helpers shared by components and generated kernels.

``kernel_helper``: compile a helper that component functions call (``record_helper``: one
that takes their parameter record). Component functions
(``f``, ``h``, ``update``, ...) are compiled by the engine; a helper they call must be
compiled on its own, in its module, so numba can type the call. A compiled helper is
still callable from plain Python (the pure-Python fallback).

``view(a, start, stop)``: ``a[start:stop]`` of a 1-D C-contiguous array as a *borrowed*
view, used by generated kernels to hand each component its part of the flat state,
parameter and output vectors. A normal numba slice carries the parent's reference count
and costs two atomic operations (and defeats inlining) on every call of every component,
which made a composed right-hand side ~10x slower than a hand-written one; a borrowed view
is a plain pointer + length. It is only valid while the parent array is alive, which the
kernel guarantees (the parents are the integrator's own work arrays).
"""

from __future__ import annotations

import time
import warnings
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path

import numba
import numpy as np
from llvmlite import ir
from numba.core import cgutils, types
from numba.core.datamodel import models
from numba.core.imputils import lower_constant
from numba.extending import (
    intrinsic,
    overload,
    register_jitable,
    register_model,
    typeof_impl,
)
from numba.np import arrayobj

kernel_helper = numba.njit(cache=True, error_model="numpy")

_WARNED_DAMAGED: list[bool] = []


def _remove_entry(index_path: str) -> None:
    index = Path(index_path)
    stem = index.name.removesuffix(".nbi")
    for entry in index.parent.glob(f"{stem}*"):
        if entry.suffix in (".nbi", ".nbc"):
            entry.unlink(missing_ok=True)


def _tolerant(read, missing):
    """numba's cache read ``read``, where a damaged file (garbage, truncated) is a cache miss:
    the entry is deleted (one warning per process) and the function recompiled. Without
    this, garbage in hgo's own cache (``hgo/**/__pycache__/*.nbi|nbc`` of its
    ``kernel_helper`` functions called from Python, e.g. the decimated recording) failed the
    run after the simulation, losing its metrics; kernels were already repaired."""
    def wrapper(self, *args):
        try:
            return read(self, *args)
        except Exception as err:  # noqa: BLE001 - any error reading a cache file: damaged
            if not _WARNED_DAMAGED:
                warnings.warn(f"hgo: a numba cache entry is damaged ({Path(self._index_path).name}"
                              f": {type(err).__name__}); deleting it and recompiling",
                              RuntimeWarning, stacklevel=2)
                _WARNED_DAMAGED.append(True)
            _remove_entry(self._index_path)
            return missing
    wrapper.hgo_tolerant = True
    return wrapper


def tolerate_damaged_cache() -> None:
    """Install :func:`_tolerant` on numba's cache file reader (idempotent)."""
    from numba.core.caching import IndexDataCacheFile

    if not getattr(IndexDataCacheFile._load_index, "hgo_tolerant", False):
        IndexDataCacheFile._load_index = _tolerant(IndexDataCacheFile._load_index, {})
        IndexDataCacheFile.load = _tolerant(IndexDataCacheFile.load, None)


tolerate_damaged_cache()


def record_helper(fn):
    """A helper that component functions call with their parameter record (``p``).

    In a kernel it is compiled into the calling component (a numba overload: nothing is
    cached apart from the kernel, so no cache entry names a record type); from plain
    Python it is the function itself, reading the same names from ``component.p`` (a
    :class:`hgo.core.components.ParamVector`). ``fn.py_func`` is ``fn`` (as for a compiled
    helper), which also puts its file into the kernel's cache key."""
    register_jitable(error_model="numpy")(fn)
    fn.py_func = fn
    return fn


def _array_data(context, builder, aty, value):
    """The data pointer of the array ``value`` of type ``aty``."""
    return builder.extract_value(value, context.data_model_manager[aty].get_field_position("data"))


def _array_value(context, builder, aty, data, shape, strides):
    """A borrowed array of type ``aty`` on ``data`` (no meminfo, no parent), built as a
    value field by field: numba's ``populate_array`` goes through a copy on the stack,
    the same code once LLVM has promoted it to registers but several times the Python
    work per view while lowering (a composition's entry points make dozens of views)."""
    model = context.data_model_manager[aty]
    intp = context.get_value_type(types.intp)
    nitems = shape[0]
    for extent in shape[1:]:
        nitems = builder.mul(nitems, extent, flags=["nsw"])
    itemsize = context.get_abi_sizeof(context.get_data_type(aty.dtype))
    fields = {"nitems": nitems, "itemsize": ir.Constant(intp, itemsize), "data": data,
              "shape": cgutils.pack_array(builder, shape, intp),
              "strides": cgutils.pack_array(builder, strides, intp)}
    value = ir.Constant(context.get_value_type(aty), ir.Undefined)
    for k, name in enumerate(model._fields):
        field = fields.get(name)
        if field is None:  # meminfo, parent: null (borrowed)
            field = ir.Constant(value.type.elements[k], None)
        value = builder.insert_value(value, field, k)
    return value


@intrinsic
def _borrowed_view(typingctx, arr, start, stop):
    if not (isinstance(arr, types.Array) and arr.ndim == 1 and arr.layout == "C"):
        return None
    ret = types.Array(arr.dtype, 1, "C")

    def codegen(context, builder, signature, args):
        aty, sty, ety = signature.args
        s = context.cast(builder, args[1], sty, types.intp)
        e = context.cast(builder, args[2], ety, types.intp)
        size = context.get_abi_sizeof(context.get_data_type(aty.dtype))
        data = builder.gep(_array_data(context, builder, aty, args[0]), [s])
        return _array_value(context, builder, ret, data, [builder.sub(e, s)],
                            [ir.Constant(e.type, size)])

    return ret(arr, start, stop), codegen


@intrinsic
def _borrowed_view2(typingctx, arr, start, rows, cols):
    """``arr[start:start + rows * cols].reshape(rows, cols)`` of a 1-D C-contiguous array,
    borrowed as :func:`_borrowed_view` (a matrix parameter of a component, by name)."""
    if not (isinstance(arr, types.Array) and arr.ndim == 1 and arr.layout == "C"):
        return None
    ret = types.Array(arr.dtype, 2, "C")

    def codegen(context, builder, signature, args):
        aty = signature.args[0]
        s, r, c = (context.cast(builder, v, t, types.intp)
                   for v, t in zip(args[1:], signature.args[1:], strict=True))
        size = ir.Constant(s.type, context.get_abi_sizeof(context.get_data_type(aty.dtype)))
        data = builder.gep(_array_data(context, builder, aty, args[0]), [s])
        return _array_value(context, builder, ret, data, [r, c], [builder.mul(c, size), size])

    return ret(arr, start, rows, cols), codegen


@intrinsic
def _stack_array(typingctx, size):
    """A float64 array of ``size`` (a literal) entries on the calling function's stack:
    scratch space for a component (its parameter ``scratch``), valid while the kernel
    function that builds the component's record runs. No heap: an ``np.empty`` in a
    component's right-hand side, called millions of times from inlined, GIL-free code,
    corrupted the heap (dhlm_example: double free after a few runs) and cost ~40 % of
    the run."""
    if not isinstance(size, types.IntegerLiteral):
        return None
    ret = types.Array(types.float64, 1, "C")
    n = size.literal_value

    def codegen(context, builder, signature, args):
        dtype = context.get_data_type(types.float64)
        count = context.get_constant(types.intp, n)
        data = cgutils.alloca_once(builder, dtype, size=count)
        itemsize = context.get_constant(types.intp, context.get_abi_sizeof(dtype))
        return _array_value(context, builder, ret, data, [count], [itemsize])

    return ret(size), codegen


def matrix_view(a, start, rows, cols):
    """``a[start:start + rows * cols]`` as a (rows, cols) matrix sharing ``a``'s memory, for
    a component's scratch space (``p.scratch``). In a kernel it is a borrowed view: numba's
    ``reshape`` calls a C function on every evaluation, which LLVM cannot see through (it
    then assumes any memory may have changed: no common subexpressions across it)."""
    return a[start:start + rows * cols].reshape(rows, cols)


@overload(matrix_view, jit_options={"error_model": "numpy"})
def _matrix_view_kernel(a, start, rows, cols):
    def impl(a, start, rows, cols):
        return _borrowed_view2(a, start, rows, cols)

    return impl


def _py_stack_array(size):
    return np.empty(size)


def stack_function(compiled: bool):
    """``stack(n)`` for generated kernels: n floats of scratch space (module doc)."""
    return _stack_array if compiled else _py_stack_array


@intrinsic
def _borrowed(typingctx, arr):
    if not isinstance(arr, types.Array):
        return None
    ret = arr

    def codegen(context, builder, signature, args):
        aty = signature.args[0]
        src = arrayobj.make_array(aty)(context, builder, args[0])
        out = arrayobj.make_array(ret)(context, builder)
        arrayobj.populate_array(out, data=src.data, shape=src.shape, strides=src.strides,
                                itemsize=src.itemsize, meminfo=None)
        return out._getvalue()

    return ret(arr), codegen


def _py_view(a, start, stop):
    return a[start:stop]


def _py_view2(a, start, rows, cols):
    return a[start:start + rows * cols].reshape(rows, cols)


def view2_function(compiled: bool):
    """``view2`` for generated kernels: a (rows, cols) matrix parameter, borrowed."""
    return _borrowed_view2 if compiled else _py_view2


def _py_borrowed(a):
    return a


def view_function(compiled: bool):
    """``view`` for generated kernels: the intrinsic, or plain slicing in pure Python."""
    return _borrowed_view if compiled else _py_view


def borrow_function(compiled: bool):
    """``borrow(a)``: the same array without its reference count (identity in Python).

    The integrators borrow every array they pass around in the hot loop, so calls between
    compiled functions never touch a shared atomic counter (which also made the threads
    of an ensemble fight over the parent arrays' counters).
    """
    return _borrowed if compiled else _py_borrowed


@intrinsic
def _data_pointer(typingctx, arr):
    """The data pointer of an array: how the integrator hands its arrays to the
    composition's C entry points (:mod:`hgo.engine.composition`)."""
    if not isinstance(arr, types.Array):
        return None

    def codegen(context, builder, signature, args):
        return _array_data(context, builder, signature.args[0], args[0])

    return types.CPointer(arr.dtype)(arr), codegen


def _c_call(result):
    """An intrinsic calling the C function at address ``addr`` (an int64) with a float (or a
    tuple of floats) and a tuple of data pointers, returning ``result`` (void or float64):
    how the integrator calls the composition's entry points (numba ``cfunc``). A plain
    call through an address:
    no first-class function object to unbox on every call of the integrator from Python
    (numba's ``FunctionType`` arguments cost 20-170 us a call there)."""

    @intrinsic
    def call(typingctx, addr, scalars, pointers):
        if not (isinstance(addr, types.Integer) and isinstance(pointers, types.UniTuple)):
            return None
        n_scalars = len(scalars) if isinstance(scalars, types.UniTuple) else 1

        def codegen(context, builder, signature, args):
            from llvmlite import ir

            address, values, data = args
            if isinstance(signature.args[1], types.UniTuple):
                values = [builder.extract_value(values, i) for i in range(n_scalars)]
            else:
                values = [values]
            n = len(signature.args[2])
            pointer = context.get_value_type(signature.args[2].dtype)
            ret = ir.VoidType() if result is types.void else context.get_value_type(result)
            fnty = ir.FunctionType(ret, [ir.DoubleType()] * n_scalars + [pointer] * n)
            fn = builder.inttoptr(address, fnty.as_pointer())
            value = builder.call(fn, values + [builder.extract_value(data, i)
                                               for i in range(n)])
            return context.get_dummy_value() if result is types.void else value

        scalar_types = (types.UniTuple(types.float64, n_scalars)
                        if isinstance(scalars, types.UniTuple) else types.float64)
        return result(addr, scalar_types, pointers), codegen

    return call


_call_void = _c_call(types.void)
_call_float = _c_call(types.float64)


def _py_call(fn, scalars, arrays):
    return fn(*(scalars if isinstance(scalars, tuple) else (scalars,)), *arrays)


def c_call_functions(compiled: bool) -> dict:
    """``call_void`` and ``call_float`` for generated integrators: a call of the C entry
    point at an address, or of the Python function itself in pure Python."""
    if compiled:
        return {"call_void": _call_void, "call_float": _call_float}
    return {"call_void": _py_call, "call_float": _py_call}


@intrinsic
def _data_pointer_at(typingctx, arr, start):
    """The address of ``arr[start]`` in a 1-D C-contiguous array: how a composition hands
    a component's slices to its bound function (:mod:`hgo.engine.composition`), one
    pointer an argument instead of an array's seven fields."""
    if not (isinstance(arr, types.Array) and arr.ndim == 1 and arr.layout == "C"):
        return None

    def codegen(context, builder, signature, args):
        aty, sty = signature.args
        start = context.cast(builder, args[1], sty, types.intp)
        return builder.gep(_array_data(context, builder, aty, args[0]), [start])

    return types.CPointer(arr.dtype)(arr, start), codegen


def _py_at(a, start):
    return a[start:]


def _py_carray(a, size):
    return a[:size]


def address_function(compiled: bool):
    """``at(a, start)``: the address of ``a[start]``, or the view ``a[start:]`` in pure
    Python (where ``carray``, :func:`carray_function`, cuts it to its length)."""
    return _data_pointer_at if compiled else _py_at


def carray_function(compiled: bool):
    """``carray(pointer, size)``: numba's array on a data pointer, or ``a[:size]``."""
    return numba.carray if compiled else _py_carray


def pointer_function(compiled: bool):
    """``ptr(a)`` for generated integrators: ``a``'s data pointer, or ``a`` itself in pure
    Python (where the composition's functions take the arrays)."""
    return _data_pointer if compiled else _py_borrowed


def compile_timer():
    """Context manager measuring the time numba spends compiling inside it: ``with
    compile_timer() as t: ...``, then ``t.duration`` (seconds) if ``t.done``."""
    from numba.core.event import TimingListener, install_listener

    return install_listener("numba:compile", TimingListener())


@contextmanager
def run_seconds() -> Iterator[dict[str, float]]:
    """``with run_seconds() as seconds: ...``: afterwards ``seconds["compile"]`` is the
    time numba spent compiling inside the block (0 when every kernel was cached) and
    ``seconds["simulate"]`` the rest of the block's wall time."""
    seconds = {"compile": 0.0, "simulate": 0.0}
    start = time.perf_counter()
    with compile_timer() as compiling:
        yield seconds
    seconds["compile"] = compiling.duration if compiling.done else 0.0
    seconds["simulate"] = time.perf_counter() - start - seconds["compile"]


class KernelFunction:
    """A function among a component's constants (a user's phi), as a compiled record holds
    it: a value of type :class:`KernelFunctionType`, named by ``key`` (the function's
    module, name and a hash of its source, closure values and compile options), that numba
    calls as ``function`` (a Python function registered with ``register_jitable``);
    ``stable``: whether ``key`` names the same function in every process (not where the
    source does not determine it, :func:`hgo.engine.codegen.determined`).

    Why not the function itself: its numba type (``Function`` of a template class numba
    makes on the fly) is rebuilt unequal in another process, so no component holding it
    could be found in the on-disk cache (:mod:`hgo.engine.component_cache`); this type is
    equal in every process that registers the same ``key``. The value carries nothing at
    run time (a null pointer): a call is resolved when the component compiles.
    """

    def __init__(self, key: str, function, stable: bool) -> None:
        self.key, self.stable = key, stable
        _KERNEL_FUNCTIONS[key] = function


_KERNEL_FUNCTIONS: dict[str, object] = {}  # key -> the registered function (this process)


class KernelFunctionType(types.Callable, types.Opaque):
    """numba's type of a :class:`KernelFunction`: equal (and pickled) by its key alone."""

    def __init__(self, key: str, stable: bool) -> None:
        self.function_key, self.stable = key, stable
        super().__init__(name=f"KernelFunction({key})")

    def _function_type(self, context):
        return context.resolve_value_type(_KERNEL_FUNCTIONS[self.function_key])

    def get_call_type(self, context, args, kws):
        return context.resolve_function_type(self._function_type(context), args, kws)

    def get_call_signatures(self):
        return [], True

    def get_impl_key(self, sig):
        from numba.core.registry import cpu_target

        return self._function_type(cpu_target.typing_context).get_impl_key(sig)


@typeof_impl.register(KernelFunction)
def _typeof_kernel_function(value, c):
    return KernelFunctionType(value.key, value.stable)


register_model(KernelFunctionType)(models.OpaqueModel)


@lower_constant(KernelFunctionType)
def _lower_kernel_function(context, builder, ty, value):
    return context.get_constant_null(ty)
