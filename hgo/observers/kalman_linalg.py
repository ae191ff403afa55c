"""Small dense linear algebra for the Kalman filters' kernel functions, without allocation.

Every function writes into arrays its caller provides (views of the component's scratch
space, :mod:`hgo.engine.jit`): a kernel function allocates nothing (an allocation per
evaluation hangs the parallel ensemble kernel, :mod:`hgo.observers.normal_form`). The
sizes are the filter's state and output dimensions (a few entries), so plain loops are
as fast as LAPACK here and compile into the kernel.

A symmetric n x n matrix is stored as its upper triangle, row by row (n (n + 1) / 2
entries: P_11, P_12, ..., P_1n, P_22, ...): the covariance states of the filters.
"""

from __future__ import annotations

import math

from hgo.engine.jit import record_helper


@record_helper
def unpack_symmetric(v, n, S):
    """S (n x n) from its upper triangle ``v`` (row by row), mirrored: S is symmetric."""
    k = 0
    for i in range(n):
        for j in range(i, n):
            S[i, j] = v[k]
            S[j, i] = v[k]
            k += 1


@record_helper
def pack_symmetric(S, n, v):
    """The upper triangle of S into ``v`` (row by row)."""
    k = 0
    for i in range(n):
        for j in range(i, n):
            v[k] = S[i, j]
            k += 1


@record_helper
def cholesky(S, n, L):
    """L lower triangular with L L^T = S (S symmetric, n x n); False (L undefined) when S is
    not positive definite (a pivot <= 0 or not finite)."""
    for j in range(n):
        s = S[j, j]
        for k in range(j):
            s -= L[j, k] * L[j, k]
        if not s > 0.0:  # (NaN fails too)
            return False
        L[j, j] = math.sqrt(s)
        for i in range(j + 1, n):
            v = S[i, j]
            for k in range(j):
                v -= L[i, k] * L[j, k]
            L[i, j] = v / L[j, j]
        for i in range(j):
            L[i, j] = 0.0
    return True


@record_helper
def solve_rows(L, m, B, rows):
    """Each row b of B (``rows`` x m) replaced by S^-1 b, S = L L^T (m x m, Cholesky factor
    L): B S^-1 for symmetric S, e.g. the gain K = P_xy S^-1."""
    for r in range(rows):
        for i in range(m):  # forward: L c = b
            v = B[r, i]
            for k in range(i):
                v -= L[i, k] * B[r, k]
            B[r, i] = v / L[i, i]
        for i in range(m - 1, -1, -1):  # back: L^T x = c
            v = B[r, i]
            for k in range(i + 1, m):
                v -= L[k, i] * B[r, k]
            B[r, i] = v / L[i, i]


@record_helper
def smallest_eigenvalue(S, n, W):
    """The smallest eigenvalue of the symmetric n x n matrix S (cyclic Jacobi rotations on
    the copy W; S unchanged). Off-diagonal entries are rotated to zero until they are below
    1e-15 of the diagonal's scale (at most 50 sweeps; a few suffice for n < 10)."""
    for i in range(n):
        for j in range(n):
            W[i, j] = S[i, j]
    for _ in range(50):
        off, scale = 0.0, 0.0
        for i in range(n):
            scale += W[i, i] * W[i, i]
            for j in range(i + 1, n):
                off += W[i, j] * W[i, j]
        if not off > 1e-30 * scale:  # (also stops on NaN)
            break
        for a in range(n - 1):
            for b in range(a + 1, n):
                if W[a, b] == 0.0:
                    continue
                theta = (W[b, b] - W[a, a]) / (2.0 * W[a, b])
                tan = math.copysign(1.0, theta) / (abs(theta) + math.sqrt(theta * theta + 1.0))
                cos = 1.0 / math.sqrt(tan * tan + 1.0)
                sin = tan * cos
                for k in range(n):  # W <- W G (columns a, b)
                    wa, wb = W[k, a], W[k, b]
                    W[k, a] = cos * wa - sin * wb
                    W[k, b] = sin * wa + cos * wb
                for k in range(n):  # W <- G^T W (rows a, b)
                    wa, wb = W[a, k], W[b, k]
                    W[a, k] = cos * wa - sin * wb
                    W[b, k] = sin * wa + cos * wb
    low = W[0, 0]
    for i in range(1, n):
        low = min(low, W[i, i])
    return low
