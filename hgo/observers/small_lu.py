"""Small dense linear solves inside a kernel: Gaussian elimination with partial pivoting.

For the n x n Jacobian dPhi/dx of the observers of :mod:`hgo.observers.symbolic_hgo`
(n a few states): no heap, no LAPACK call, compiled into the calling component
(:func:`hgo.engine.jit.record_helper`).
"""

from __future__ import annotations

import math

from hgo.engine.jit import record_helper


@record_helper
def lu_solve(A, b, n):
    """Solve A v = b in place (b becomes v; A is overwritten by its factors) and return
    det A (0.0, b left partly eliminated, where a pivot is exactly 0)."""
    det = 1.0
    for k in range(n):
        piv = k
        for i in range(k + 1, n):
            if abs(A[i, k]) > abs(A[piv, k]):
                piv = i
        if A[piv, k] == 0.0:
            return 0.0
        if piv != k:
            det = -det
            for j in range(n):
                A[k, j], A[piv, j] = A[piv, j], A[k, j]
            b[k], b[piv] = b[piv], b[k]
        det *= A[k, k]
        for i in range(k + 1, n):
            m = A[i, k] / A[k, k]
            for j in range(k + 1, n):
                A[i, j] -= m * A[k, j]
            b[i] -= m * b[k]
    for k in range(n - 1, -1, -1):
        s = b[k]
        for j in range(k + 1, n):
            s -= A[k, j] * b[j]
        b[k] = s / A[k, k]
    return det


@record_helper
def max_abs(v, n):
    """max |v_i| over the first n entries (NaN propagates as inf)."""
    m = 0.0
    for i in range(n):
        a = abs(v[i])
        if not a <= m:
            m = math.inf if math.isnan(a) else a
    return m
