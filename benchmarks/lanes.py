"""How much two ensemble members interleaved in one thread would gain (issue 5, ensemble).

    python benchmarks/lanes.py

A hand-written fixed-step DOPRI5 step of the S-P error system (20) (the right-hand side of
``baselines.py``, with r^(1-2b) as exp/log as in hgo), for one member, and for two
independent members whose stages are computed side by side in the same loop body. Each
stage waits for the previous one (exp, log, division on the critical path), so a second
member's stages fill the idle cycles. Prints the cost per step and member of both.

Measured here: 1.5-1.9x. The full engine kernel doing the same for ensembles (two members
in lockstep, each with its own step control) gained 8-18 % with one thread and nothing
measurable with two in an interleaved A/B, and was reverted (see benchmarks/README.md).
"""

from __future__ import annotations

import math
import time

import numba
import numpy as np
from baselines import _A as A
from baselines import _B as B

FM = {"contract", "arcp"}  # the flags hgo's kernels use


@numba.njit(fastmath=FM, inline="always")
def _f(s0, s1, s2, p2, out, j):
    out[j, 0] = s1 + 3.0 * s0 - 2.0 * s2 * s0
    out[j, 1] = -2.0 * s2 * s2 * s0
    out[j, 2] = 4 / 3 * ((s0 * s0 - p2) * math.exp(0.44 * math.log(s2)) + p2 / s2 ** 4)


@numba.njit(fastmath=FM, inline="always")
def _stage(s, k, st, row, j, h):
    """st = s + h * sum_i A_row[i] k_i (row = the tableau's stage j - 1), then k_j = f."""
    for i in range(3):
        acc = 0.0
        for m in range(j):
            acc += row[m] * k[m, i]
        st[i] = s[i] + h * acc


@numba.njit(fastmath=FM)
def _rows():
    rows = np.zeros((7, 6))
    rows[1, :1] = A[0:1]
    rows[2, :2] = A[1:3]
    rows[3, :3] = A[3:6]
    rows[4, :4] = A[6:10]
    rows[5, :5] = A[10:15]
    rows[6, :6] = np.array([B[0], 0.0, B[1], B[2], B[3], B[4]])
    return rows


@numba.njit(fastmath=FM)
def one(n, h, p2):
    rows = _rows()
    s = np.array([3.0, 3.0, 1.0])
    k = np.zeros((7, 3))
    st = np.zeros(3)
    _f(s[0], s[1], s[2], p2, k, 0)
    for _ in range(n):
        for j in range(1, 7):
            _stage(s, k, st, rows[j], j, h)
            _f(st[0], st[1], st[2], p2, k, j)
        for i in range(3):
            s[i] = st[i]
            k[0, i] = k[6, i]
    return s[0]


@numba.njit(fastmath=FM)
def two(n, h, p2):
    rows = _rows()
    s, q = np.array([3.0, 3.0, 1.0]), np.array([2.0, -1.0, 1.2])
    k, g = np.zeros((7, 3)), np.zeros((7, 3))
    st, qt = np.zeros(3), np.zeros(3)
    _f(s[0], s[1], s[2], p2, k, 0)
    _f(q[0], q[1], q[2], p2, g, 0)
    for _ in range(n):
        for j in range(1, 7):
            _stage(s, k, st, rows[j], j, h)
            _stage(q, g, qt, rows[j], j, h)
            _f(st[0], st[1], st[2], p2, k, j)
            _f(qt[0], qt[1], qt[2], p2, g, j)
        for i in range(3):
            s[i], q[i] = st[i], qt[i]
            k[0, i], g[0, i] = k[6, i], g[6, i]
    return s[0] + q[0]


def main() -> None:
    n = 200_000
    one(10, 0.01, 1.5)
    two(10, 0.01, 1.5)
    t_one, t_two = [], []
    for _ in range(5):
        t0 = time.perf_counter()
        one(n, 0.01, 1.5)
        t1 = time.perf_counter()
        two(n, 0.01, 1.5)
        t_one.append(t1 - t0)
        t_two.append(time.perf_counter() - t1)
    a, b = np.median(t_one) / n * 1e9, np.median(t_two) / n / 2 * 1e9
    print(f"DOPRI5 step of (20), ns per step and member (median of 5): one member {a:.0f}, "
          f"two interleaved {b:.0f} ({a / b:.2f}x)")


if __name__ == "__main__":
    main()
