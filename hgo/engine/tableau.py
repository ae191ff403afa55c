"""Embedded Runge–Kutta pairs of the adaptive integrators, written out as kernel source.

The coefficients are scipy's own (``solve_ivp``'s ``RK45`` and ``DOP853``), so hgo takes
the same steps by the same formulas as ``solve_ivp`` with the same method:

* ``dopri5``: Dormand–Prince 5(4), 6 evaluations per step (first same as last), error
  weights ``E`` (order 4), 4th-order continuous extension ``P`` (Hairer, Norsett &
  Wanner, *Solving ODEs I*, II.5-II.6).
* ``dop853``: Hairer's DOP853, 8th order with the combined 5th/3rd-order error estimate,
  12 evaluations per step (first same as last) and a 7th-order continuous extension that
  costs 3 more evaluations, made only for steps that contain an output sample
  (*Solving ODEs I*, II.10). Fewer steps than ``dopri5`` at tight tolerances.

:func:`method_source` returns, for one method, the constants and the three functions the
generic loop of ``kernel_template``'s ``adaptive`` section calls:

* ``_trial(t, h, z, d, m, P, w, K, zt, rtol, atol)``: one trial step from ``(t, z)``
  with stage 0 of ``K`` holding ``f(t, z)``; the new state goes to ``zt``, ``f(t+h, zt)``
  to stage ``FSAL_STAGE``; returns the error norm (<= 1: accept).
* ``_dense_prep(t, h, z, zt, d, m, P, w, K, F, scratch)``: coefficients ``F`` of the
  continuous extension of the accepted step ``z -> zt``.
* ``_dense_eval(th, z, F, zo)``: the state at ``t + th*h`` (0 < th < 1) into ``zo``.

``K`` is one flat vector: stage ``j`` is ``K[j*NZ:(j+1)*NZ]``. Every stage is written out
with its coefficients as literals and zero coefficients left out; ``NZ`` is a constant of
the generated header, so the loops over the state are unrolled by the compiler.
"""

from __future__ import annotations

import re
from itertools import pairwise

import numpy as np

# scipy's private modules, on purpose: the tableaus solve_ivp itself uses (stable since
# scipy 1.4); tests/test_engine.py checks hgo takes solve_ivp's steps to round-off.
from scipy.integrate._ivp import dop853_coefficients as dop853
from scipy.integrate._ivp.rk import RK45

ADAPTIVE = ("dopri5", "dop853")


def _stage(j: int) -> str:
    return f"view(K, {j} * NZ, {j + 1} * NZ)"


def _combination(weights: np.ndarray) -> str:
    """``w_j * Kj[i] + ...`` over the nonzero weights ``w_j`` of stages ``j``.

    ``Kj`` is a view of stage ``j`` that :func:`_with_stage_views` defines once per
    function: numba types every operation of these long sums on its own (about 1 ms each
    when compiling), and ``Kj[i]`` needs two fewer than ``K[j * NZ + i]``."""
    terms = [f"{float(c)!r} * K{j}[i]" for j, c in enumerate(weights) if c != 0.0]
    return " + ".join(terms) if terms else "0.0"


def _with_stage_views(lines: list[str]) -> list[str]:
    """Define ``Kj = view(K, j * NZ, (j + 1) * NZ)`` in every function that uses ``Kj``,
    after its ``def`` line and one-line docstring (a function starts at its ``@`` line)."""
    starts = [k for k, line in enumerate(lines) if line.startswith("@")] + [len(lines)]
    out = lines[:starts[0]]
    for a, b in pairwise(starts):
        body = lines[a:b]
        used = sorted({int(j) for j in re.findall(r"\bK(\d+)\[", "\n".join(body))})
        at = next(k for k, line in enumerate(body) if line.startswith("def ")) + 1
        at += body[at].startswith('    """')
        out += body[:at] + [f"    K{j} = view(K, {j} * NZ, {j + 1} * NZ)" for j in used]
        out += body[at:]
    return out


def _stages(A: np.ndarray, C: np.ndarray, first: int, stop: int, target: str) -> list[str]:
    """Stages ``first .. stop-1``: ``target = z + h*sum_j A[s,j] K_j``, then f into K_s.

    One loop over the stages whose body picks the stage's combination (written out with
    literal coefficients, zeros left out) and then evaluates the right-hand side: the
    right-hand side is inlined once instead of once per stage (DOP853 on problem B,
    fresh caches, with the stage views: median 13.5 -> 12.3 s over 4 paired runs)."""
    lines = [f"    for s in range({first}, {stop}):"]
    for s in range(first, stop):
        test = "else" if s == stop - 1 else f"{'if' if s == first else 'elif'} s == {s}"
        lines += [f"        {test}:",
                  f"            c = {float(C[s])!r}",
                  "            for i in range(NZ):",
                  f"                {target}[i] = z[i] + h * ({_combination(A[s, :s])})"]
    lines += [f"        system_rhs(t + c * h, {target}, d, m, P, w, view(K, s * NZ, (s + 1) * NZ))"]
    return lines


def _dense_rows(W: np.ndarray, first: int) -> tuple[list[str], list[str]]:
    """Module constants and function lines for ``F_(first+q) = h * sum_j W[q, j] K_j``.

    One loop over the stages with a nonzero weight, one accumulator per row, the weights
    in a constant table: a handful of operations for numba to type where the written-out
    sums are hundreds (about 2 ms of compile time each; DOP853: 376 fewer). Measured
    against the written-out sums (in-process, interleaved): same run time. A loop per row
    (each reloading every stage) was 5-10 % slower on problem B."""
    cols = np.flatnonzero(np.any(W != 0.0, axis=0))
    rows = range(W.shape[0])
    constants = [f"DENSE_W = np.array({W[:, cols].tolist()!r})",
                 f"DENSE_J = np.array({cols.tolist()!r}, dtype=np.int64)"]
    lines = ["    for i in range(NZ):",
             *[f"        a{q} = 0.0" for q in rows],
             f"        for j in range({len(cols)}):",
             "            kj = K[DENSE_J[j] * NZ + i]",
             *[f"            a{q} += DENSE_W[{q}, j] * kj" for q in rows],
             *[f"        F[{first + q} * NZ + i] = h * a{q}" for q in rows]]
    return constants, lines


def _trial(A: np.ndarray, B: np.ndarray, C: np.ndarray, n_stages: int) -> list[str]:
    return ["@jit",
            "def _trial(t, h, z, d, m, P, w, K, zt, rtol, atol):",
            '    """One trial step (see hgo.engine.tableau); returns the error norm."""',
            *_stages(A, C, 1, n_stages, "zt"),
            "    for i in range(NZ):",
            f"        zt[i] = z[i] + h * ({_combination(B)})",
            f"    system_rhs(t + h, zt, d, m, P, w, {_stage(n_stages)})",
            "    return _error_norm(h, z, zt, K, rtol, atol)"]


_SCALE = "atol + rtol * max(abs(z[i]), abs(zt[i]))"


def _dopri5() -> list[str]:
    n = RK45.n_stages
    P = RK45.P  # (n + 1, 4): zo = z + h * sum_q th^(q+1) sum_j P[j, q] K_j
    dense_constants, dense_lines = _dense_rows(P.T, 0)
    lines = ["N_K = 7", "N_F = 4", f"FSAL_STAGE = {n}", "ERR_EXP = -1.0 / 5.0", "", "",
             "@ijit",
             "def _error_norm(h, z, zt, K, rtol, atol):",
             '    """RMS of h * sum_j E_j K_j over atol + rtol * max(|z|, |zt|)."""',
             "    err = 0.0",
             "    for i in range(NZ):",
             f"        e = h * ({_combination(RK45.E)}) / ({_SCALE})",
             "        err += e * e",
             "    return math.sqrt(err / NZ)", "", "",
             *_trial(RK45.A, RK45.B, RK45.C, n), "", "",
             *dense_constants, "", "",
             "@ijit",
             "def _dense_prep(t, h, z, zt, d, m, P, w, K, F, scratch):",
             '    """F_q = h * sum_j P[j, q] K_j (no extra evaluation)."""',
             *dense_lines]
    lines += ["", "", "@ijit",
              "def _dense_eval(th, z, F, zo):",
              "    for i in range(NZ):",
              "        zo[i] = z[i] + th * (F[i] + th * (F[NZ + i] + th * (F[2 * NZ + i]"
              " + th * F[3 * NZ + i])))"]
    return lines


def _dop853() -> list[str]:
    n, n_ext, n_f = dop853.N_STAGES, dop853.N_STAGES_EXTENDED, dop853.INTERPOLATOR_POWER
    A, C, D = dop853.A, dop853.C, dop853.D
    dense_constants, dense_lines = _dense_rows(D, 3)
    lines = [f"N_K = {n_ext}", f"N_F = {n_f}", f"FSAL_STAGE = {n}", "ERR_EXP = -1.0 / 8.0",
             "", "",
             "@ijit",
             "def _error_norm(h, z, zt, K, rtol, atol):",
             '    """DOP853\'s combined estimate |h| e5^2 / sqrt(N (e5^2 + 0.01 e3^2))."""',
             "    e5 = 0.0",
             "    e3 = 0.0",
             "    for i in range(NZ):",
             f"        sc = {_SCALE}",
             f"        a5 = ({_combination(dop853.E5)}) / sc",
             f"        a3 = ({_combination(dop853.E3)}) / sc",
             "        e5 += a5 * a5",
             "        e3 += a3 * a3",
             "    if e5 == 0.0 and e3 == 0.0:",
             "        return 0.0",
             "    return abs(h) * e5 / math.sqrt((e5 + 0.01 * e3) * NZ)", "", "",
             *_trial(A, dop853.B, C, n), "", "",
             *dense_constants, "", "",
             "@jit",
             "def _dense_prep(t, h, z, zt, d, m, P, w, K, F, scratch):",
             '    """Three extra stages, then F_0 = zt - z, F_1 = h K_0 - F_0,'
             ' F_2 = 2 F_0 - h (K_0 + K_12), F_3.. = h D K."""',
             *_stages(A, C, n + 1, n_ext, "scratch"),
             "    for i in range(NZ):",
             "        dz = zt[i] - z[i]",
             "        F[i] = dz",
             "        F[NZ + i] = h * K0[i] - dz",
             f"        F[2 * NZ + i] = 2.0 * dz - h * (K0[i] + K{n}[i])",
             *dense_lines]
    lines += ["", "", "@ijit",
              "def _dense_eval(th, z, F, zo):",
              "    s = 1.0 - th",
              "    for i in range(NZ):",
              f"        zo[i] = z[i] + {_dop853_horner(n_f)}"]
    return lines


def _dop853_horner(n_f: int) -> str:
    """scipy's Dop853DenseOutput in Horner form, s = 1 - x:
    y = x (F_0 + s (F_1 + x (F_2 + s (F_3 + x (F_4 + s (F_5 + x F_6))))))."""
    expr = f"F[{n_f - 1} * NZ + i]"
    for q in range(n_f - 2, -1, -1):
        expr = f"F[{q} * NZ + i] + {'s' if q % 2 == 0 else 'th'} * ({expr})"
    return f"th * ({expr})"


def method_source(method: str) -> str:
    """Constants and ``_error_norm``, ``_trial``, ``_dense_prep``, ``_dense_eval`` of
    ``method`` (one of :data:`ADAPTIVE`) as kernel source text."""
    lines = _with_stage_views({"dopri5": _dopri5, "dop853": _dop853}[method]())
    return f"# {method}: generated by hgo.engine.tableau from scipy's coefficients\n" + \
        "\n".join(lines) + "\n\n\n"
