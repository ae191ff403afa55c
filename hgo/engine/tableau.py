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

* ``_trial(S, t, h, z, d, m, P, K, zt, rtol, atol, t_lim)``: one trial step from
  ``(t, z)`` with stage 0 of ``K`` holding ``f(t, z)``; the new state goes to ``zt``,
  ``f(t+h, zt)`` to stage ``FSAL_STAGE``; returns the error norm (<= 1: accept). Every
  stage time is clamped to ``t_lim`` (just below a break point that ends the step: the
  step sees the values before the jump; ``inf`` otherwise).
* ``_dense_prep(S, t, h, z, zt, d, m, P, K, F, scratch)``: coefficients ``F`` of the
  continuous extension of the accepted step ``z -> zt``.
* ``_dense_eval(th, z, F, zo)``: the state at ``t + th*h`` (0 < th < 1) into ``zo``.

``K`` is one flat vector: stage ``j`` is ``K[j*NZ:(j+1)*NZ]``. Every weighted sum of
stages (a stage's argument, the solution, the error estimate, the dense output) is a loop
over the stages with a nonzero weight, the weights in module constants (numba freezes
global arrays); ``NZ`` and the trip counts are constants, so the compiler unrolls these
loops. Written out term by term they ran no faster (measured in-process, interleaved)
but cost numba about 2 ms of compile time per operation: hundreds for DOP853.
"""

from __future__ import annotations

import importlib.util
from pathlib import Path

import numpy as np

ADAPTIVE = ("dopri5", "dop853")


def scipy_tableau_files() -> list[Path]:
    """scipy's files holding the coefficients :func:`method_source` reads (found without
    importing scipy: a cached kernel's text is recognised without its 0.2-0.3 s import)."""
    scipy_dir = Path(importlib.util.find_spec("scipy").origin).parent
    return [scipy_dir / "integrate" / "_ivp" / name for name in ("rk.py", "dop853_coefficients.py")]


Code = tuple[list[str], list[str]]
"""Generated source: (module constants, lines of a function body)."""


def _sums(name: str, W: np.ndarray, indent: str) -> Code:
    """``a_q = sum_j W[q, j] K_j[i]`` for every row ``q`` of ``W``, inside a loop over ``i``.

    One loop over the stages with a nonzero weight in some row, each stage loaded once
    for all rows; the weights are the constant ``<name>_W``, the stages ``<name>_J``."""
    cols = np.flatnonzero(np.any(W != 0.0, axis=0))
    rows = range(W.shape[0])
    constants = [f"{name}_W = np.array({W[:, cols].tolist()!r})",
                 f"{name}_J = np.array({cols.tolist()!r}, dtype=np.int64)"]
    lines = [*[f"{indent}a{q} = 0.0" for q in rows],
             f"{indent}for j in range({len(cols)}):",
             f"{indent}    kj = K[{name}_J[j] * NZ + i]",
             *[f"{indent}    a{q} += {name}_W[{q}, j] * kj" for q in rows]]
    return constants, lines


def _stages(A: np.ndarray, C: np.ndarray, first: int, stop: int, target: str,
            time: str = "t + c * h") -> Code:
    """Stages ``first .. stop-1``: ``target = z + h*sum_j A[s,j] K_j``, then f into K_s at
    the time ``time``.

    One loop over the stages whose body picks the stage's sum and then evaluates the
    right-hand side: the right-hand side is inlined once instead of once per stage."""
    constants, lines = [], [f"    for s in range({first}, {stop}):"]
    for s in range(first, stop):
        test = "else" if s == stop - 1 else f"{'if' if s == first else 'elif'} s == {s}"
        consts, sums = _sums(f"A{s}", A[s:s + 1, :s], "                ")
        constants += consts
        lines += [f"        {test}:",
                  f"            c = {float(C[s])!r}",
                  "            for i in range(NZ):",
                  *sums,
                  f"                {target}[i] = z[i] + h * a0"]
    lines.append(f"        _rhs(S, {time}, {target}, d, m, P, "
                 "view(K, s * NZ, (s + 1) * NZ))")
    return constants, lines


def _trial(A: np.ndarray, B: np.ndarray, C: np.ndarray, n_stages: int, norm: Code) -> Code:
    """``_trial``: the stages, the solution, then ``norm`` (lines ending in ``return``
    the error norm; written into the function rather than called: one function less to
    compile). Stage times are clamped to ``t_lim``: a step that ends at a break point
    evaluates the right-hand side at most there, from the left (see kernel_template)."""
    constants, stages = _stages(A, C, 1, n_stages, "zt", "min(t + c * h, t_lim)")
    consts, sums = _sums("B", B[None, :], "        ")
    return constants + consts + norm[0], [
        "@ijit",
        "def _trial(S, t, h, z, d, m, P, K, zt, rtol, atol, t_lim):",
        '    """One trial step (see hgo.engine.tableau); returns the error norm."""',
        *stages,
        "    for i in range(NZ):",
        *sums,
        "        zt[i] = z[i] + h * a0",
        f"    _rhs(S, min(t + h, t_lim), zt, d, m, P, "
        f"view(K, {n_stages} * NZ, {n_stages + 1} * NZ))",
        *norm[1]]


def _dense_rows(W: np.ndarray, first: int) -> Code:
    """``F_(first+q) = h * sum_j W[q, j] K_j`` for the rows ``q`` of ``W``."""
    constants, sums = _sums("DENSE", W, "        ")
    return constants, ["    for i in range(NZ):", *sums,
                       *[f"        F[{first + q} * NZ + i] = h * a{q}"
                         for q in range(W.shape[0])]]


_SCALE = "atol + rtol * max(abs(z[i]), abs(zt[i]))"


def _dopri5() -> Code:
    # scipy's private modules, on purpose: the tableaus solve_ivp itself uses (stable since
    # scipy 1.4); tests/test_engine.py checks hgo takes solve_ivp's steps to round-off.
    from scipy.integrate._ivp.rk import RK45

    n = RK45.n_stages
    P = RK45.P  # (n + 1, 4): zo = z + h * sum_q th^(q+1) sum_j P[j, q] K_j
    c_err, err = _sums("E", RK45.E[None, :], "        ")
    norm = ["    # error norm: RMS of h * sum_j E_j K_j over atol + rtol * max(|z|, |zt|)",
            "    err = 0.0",
            "    for i in range(NZ):",
            *err,
            f"        e = h * a0 / ({_SCALE})",
            "        err += e * e",
            "    return math.sqrt(err / NZ)"]
    c_trial, trial = _trial(RK45.A, RK45.B, RK45.C, n, (c_err, norm))
    c_dense, dense = _dense_rows(P.T, 0)
    constants = ["N_K = 7", "N_F = 4", f"FSAL_STAGE = {n}", "ERR_EXP = -1.0 / 5.0",
                 *c_trial, *c_dense]
    return constants, [
        *trial, "", "",
        "@ijit",
        "def _dense_prep(S, t, h, z, zt, d, m, P, K, F, scratch):",
        '    """F_q = h * sum_j P[j, q] K_j (no extra evaluation)."""',
        *dense, "", "",
        "@ijit",
        "def _dense_eval(th, z, F, zo):",
        "    for i in range(NZ):",
        "        zo[i] = z[i] + th * (F[i] + th * (F[NZ + i] + th * (F[2 * NZ + i]"
        " + th * F[3 * NZ + i])))"]


def _dop853() -> Code:
    from scipy.integrate._ivp import dop853_coefficients as dop853

    n, n_ext, n_f = dop853.N_STAGES, dop853.N_STAGES_EXTENDED, dop853.INTERPOLATOR_POWER
    A, C, D = dop853.A, dop853.C, dop853.D
    c_err, err = _sums("E53", np.vstack([dop853.E5, dop853.E3]), "        ")
    norm = ["    # error norm: DOP853's combined |h| e5^2 / sqrt(N (e5^2 + 0.01 e3^2))",
            "    e5 = 0.0",
            "    e3 = 0.0",
            "    for i in range(NZ):",
            f"        sc = {_SCALE}",
            *err,
            "        a5 = a0 / sc",
            "        a3 = a1 / sc",
            "        e5 += a5 * a5",
            "        e3 += a3 * a3",
            "    if e5 == 0.0 and e3 == 0.0:",
            "        return 0.0",
            "    return abs(h) * e5 / math.sqrt((e5 + 0.01 * e3) * NZ)"]
    c_trial, trial = _trial(A, dop853.B, C, n, (c_err, norm))
    c_extra, extra = _stages(A, C, n + 1, n_ext, "scratch")
    c_dense, dense = _dense_rows(D, 3)
    constants = [f"N_K = {n_ext}", f"N_F = {n_f}", f"FSAL_STAGE = {n}",
                 "ERR_EXP = -1.0 / 8.0", *c_trial, *c_extra, *c_dense]
    return constants, [
        *trial, "", "",
        "@ijit",
        "def _dense_prep(S, t, h, z, zt, d, m, P, K, F, scratch):",
        '    """Three extra stages, then F_0 = zt - z, F_1 = h K_0 - F_0,'
        ' F_2 = 2 F_0 - h (K_0 + K_12), F_3.. = h D K."""',
        *extra,
        "    for i in range(NZ):",
        "        dz = zt[i] - z[i]",
        "        F[i] = dz",
        "        F[NZ + i] = h * K[i] - dz",
        f"        F[2 * NZ + i] = 2.0 * dz - h * (K[i] + K[{n} * NZ + i])",
        *dense, "", "",
        "@ijit",
        "def _dense_eval(th, z, F, zo):",
        "    s = 1.0 - th",
        "    for i in range(NZ):",
        f"        zo[i] = z[i] + {_dop853_horner(n_f)}"]


def _dop853_horner(n_f: int) -> str:
    """scipy's Dop853DenseOutput in Horner form, s = 1 - x:
    y = x (F_0 + s (F_1 + x (F_2 + s (F_3 + x (F_4 + s (F_5 + x F_6))))))."""
    expr = f"F[{n_f - 1} * NZ + i]"
    for q in range(n_f - 2, -1, -1):
        expr = f"F[{q} * NZ + i] + {'s' if q % 2 == 0 else 'th'} * ({expr})"
    return f"th * ({expr})"


def method_source(method: str) -> str:
    """Constants and ``_trial``, ``_dense_prep``, ``_dense_eval`` of
    ``method`` (one of :data:`ADAPTIVE`) as kernel source text."""
    constants, lines = {"dopri5": _dopri5, "dop853": _dop853}[method]()
    return (f"# {method}: generated by hgo.engine.tableau from scipy's coefficients\n"
            + "\n".join([*constants, "", "", *lines]) + "\n\n\n")
