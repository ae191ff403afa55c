"""A plant's vector field f(t, x, u) at many samples, for post-processors.

A post-processor that needs x' at the samples of a long run (Dimassi et al.'s |h_i| of
(12) at every scan point: 4.2 M calls of ``plant.f`` over 2000 s, half of its CPU time)
calls :func:`vector_field`. Above :data:`COMPILE_ROWS` samples the loop over the samples is
compiled with numba (the plant's own ``f``, compiled as written, without fast-math: the
same arithmetic as the Python call, so the same bits); below, or when numba cannot compile
the plant, it is the Python loop.
"""

from __future__ import annotations

import functools

import numpy as np

from hgo.core.components import Plant

# samples from which the compiled loop pays for its compilation (~0.7 s CPU once a process:
# it takes the plant's function as an argument, which numba does not cache on disk; the
# Python loop costs ~3 us a sample)
COMPILE_ROWS = 500_000


def vector_field(plant: Plant, t: np.ndarray, x: np.ndarray, u: np.ndarray,
                 compiled: bool | None = None) -> np.ndarray:
    """``dx[j] = f(t[j], x[j], u[j])`` of ``plant`` (its parameters read once); compiled
    (``compiled``, by default: from :data:`COMPILE_ROWS` samples) or the Python loop. A
    caller asking for many samples a chunk at a time says ``compiled`` from their total."""
    p = plant.p.record() if plant.params else plant.p
    dx = np.empty((len(t), x.shape[1]))
    if (len(t) >= COMPILE_ROWS) if compiled is None else compiled:
        try:
            _rows()(_compiled(plant.f), np.ascontiguousarray(t, float),
                    np.ascontiguousarray(x, float), np.ascontiguousarray(u, float), p, dx)
            return dx
        except Exception as err:  # a plant numba cannot compile: the Python loop
            if type(err).__module__.split(".")[0] != "numba":
                raise
    for j in range(len(t)):
        plant.f(t[j], x[j], u[j], p, dx[j])
    return dx


@functools.cache
def _compiled(f):
    import numba

    return numba.njit(getattr(f, "py_func", f))


@functools.cache
def _rows():
    import numba

    @numba.njit
    def rows(f, t, x, u, p, dx):
        for j in range(t.shape[0]):
            f(t[j], x[j], u[j], p, dx[j])

    return rows
