"""DHLM's and Moreno's compositions written by hand, for hgo's own integrator (issue 41).

hgo's integrator calls the composition through C entry points (``S``: one function,
``c_system``, for the right-hand side, the discrete update and the outputs, which a
selector picks; ``hgo.engine.composition.SELECT``, ``hgo.engine.kernel_template``). Here
is the same entry point written the way the hand kernels write the problem
(``hand_unrolled``): the right-hand side of ``hand_papers`` (``dhlm_f``, ``moreno_f``:
scalars, the constants as literals), the
discrete update and the outputs, as a numba ``cfunc`` with hgo's fast-math flags and hgo's
C signature. hgo's call run with them (:func:`hand_entry_points`) is hgo's whole call path
and integrator with the components' cost taken out: what separates it from hgo's own
call is the generic components (records of parameters, matrices read at run time), what
separates it from the hand kernel is the integrator (``hand_bench.py --composition``).

The other way round, :func:`behind_pointer` gives a hand kernel whose right-hand side is
called through a C function pointer, as hgo's integrator calls its composition: what the
call boundary alone costs. The pointer is this process's address of a ``cfunc``, a
constant in the kernel's code: compile it with ``compile_kernel(..., cache=False)``.

Both problems run without noise (y = x1; ``m`` is 0 and is not read).
"""

from __future__ import annotations

import dataclasses
import hashlib
import math
from pathlib import Path

import numba
import numpy as np
from hand_papers import DHLM_S, dhlm_f, moreno_f, moreno_u
from hand_unrolled import DHLM, MORENO, Problem
from numba import types

from hgo.engine.codegen import FASTMATH, Kernel, _c_signature
from hgo.engine.composition import SELECT
from hgo.engine.jit import c_call_functions, pointer_function

_OPTIONS = {"fastmath": set(FASTMATH), "error_model": "numpy"}


def _cfunc(name: str):
    """numba ``cfunc`` with the C signature of hgo's entry point ``name``."""
    return numba.cfunc(_c_signature(name), **_OPTIONS)


RHS, UPDATE, OUTPUTS = SELECT["rhs"], SELECT["update"], SELECT["outputs"]


# ---------------------------------------------------------------------- DHLM
@_cfunc("system")
def dhlm_system(t, sel, z, d, m, p, a, b, c):
    """DHLM's right-hand side (a = dz), discrete update (the first and the last step end
    with the HGO saturated, ``hand_unrolled.DHLM``) and outputs (a, b, c = y, u, x^)."""
    if sel == RHS:
        f = dhlm_f(t, z[0], z[1], z[2], z[3], z[4], z[5], z[6], z[7], z[8])
        for i in range(9):
            a[i] = f[i]
    elif sel == UPDATE:
        if abs(z[2]) > DHLM_S or abs(z[3]) > DHLM_S:
            if d[0] < 0.0:
                d[0] = t
            d[1] = t
    else:
        a[0] = z[0]
        if sel != OUTPUTS:  # with_u
            b[0] = 5.0 * (math.sin(2.0 * t) + math.cos(3.0 * t))
        c[0] = z[4]
        c[1] = z[5]
    return 0.0


# ---------------------------------------------------------------------- Moreno
@_cfunc("system")
def moreno_system(t, sel, z, d, m, p, a, b, c):
    """Moreno's right-hand side (a = dz) and outputs (a, b, c = y, u, x^)."""
    if sel == RHS:
        f = moreno_f(t, 0.0, z[0], z[1], z[2], z[3])
        for i in range(4):
            a[i] = f[i]
    else:
        a[0] = z[0]
        if sel != OUTPUTS:  # with_u
            b[0] = moreno_u(t)
        c[0] = z[2]
        c[1] = z[3]
    return 0.0


HAND = {"DHLM": dhlm_system, "Moreno": moreno_system}


def hand_entry_points(kernel: Kernel, problem: str) -> np.ndarray:
    """``kernel``'s entry points with ``problem``'s ``c_system`` written by hand in the
    places of hgo's (the integrator's ``S[0]`` .. ``S[3]``, those it calls)."""
    S = np.array(kernel.entry_points(), np.int64)
    for k in range(4):
        if S[k]:
            S[k] = HAND[problem].address
    return S


# ---------------------------------------------------------------------- behind a pointer
_call_void = c_call_functions(True)["call_void"]
_ptr = pointer_function(True)
_POINTER = types.CPointer(types.float64)


@numba.cfunc(types.void(types.float64, _POINTER, _POINTER), **_OPTIONS)
def _dhlm_c(t, y, out):
    f = dhlm_f(t, y[0], y[1], y[2], y[3], y[4], y[5], y[6], y[7], y[8])
    for i in range(9):
        out[i] = f[i]


@numba.cfunc(types.void(types.float64, types.float64, _POINTER, _POINTER), **_OPTIONS)
def _moreno_c(t, m, y, out):
    f = moreno_f(t, m, y[0], y[1], y[2], y[3])
    for i in range(4):
        out[i] = f[i]


DHLM_C, MORENO_C = _dhlm_c.address, _moreno_c.address  # (constants for the kernels)


@numba.njit(inline="always", **_OPTIONS)
def dhlm_behind_pointer(t, y, out, y0, y1, y2, y3, y4, y5, y6, y7, y8):
    """``dhlm_f`` through the address ``DHLM_C``: the stage into ``y``, f out of ``out``."""
    y[0], y[1], y[2], y[3], y[4], y[5], y[6], y[7], y[8] = y0, y1, y2, y3, y4, y5, y6, y7, y8
    _call_void(DHLM_C, t, (_ptr(y), _ptr(out)))
    return out[0], out[1], out[2], out[3], out[4], out[5], out[6], out[7], out[8]


@numba.njit(inline="always", **_OPTIONS)
def moreno_behind_pointer(t, m, y, out, y0, y1, y2, y3):
    """``moreno_f`` through the address ``MORENO_C``."""
    y[0], y[1], y[2], y[3] = y0, y1, y2, y3
    _call_void(MORENO_C, (t, m), (_ptr(y), _ptr(out)))
    return out[0], out[1], out[2], out[3]


def behind_pointer(problem: str) -> Problem:
    """``hand_unrolled``'s ``problem`` with its right-hand side called through a C function
    pointer: the stage written into an array, f read back from another (two arrays made
    once at the kernel's start)."""
    pb, fn = {"DHLM": (DHLM, "dhlm_behind_pointer"),
              "Moreno": (MORENO, "moreno_behind_pointer")}[problem]
    noise = "" if problem == "DHLM" else "m, "
    # (this file's hash in the kernel's text: hand_unrolled's cache name covers the text)
    digest = hashlib.sha256(Path(__file__).read_bytes()).hexdigest()[:16]
    return dataclasses.replace(
        pb, tag=f"{pb.tag}_pointer",
        header=pb.header + f"import numpy as np\n\nfrom hand_composition import {fn}  "
                           f"# {digest}\n",
        rhs=lambda t, states: f"{fn}({t}, {noise}y_c, f_c, {states})",
        start=(f"y_c = np.empty({pb.nz})", f"f_c = np.empty({pb.nz})", *pb.start))
