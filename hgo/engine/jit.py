"""``kernel_helper``: compile a helper that component functions call.

Component functions (``f``, ``h``, ``update``, ...) are compiled by the engine; a helper
they call must be compiled on its own, in its module, so numba can type the call.
A compiled helper is still callable from plain Python (the pure-Python fallback).
"""

from __future__ import annotations

import numba

kernel_helper = numba.njit(cache=True)
