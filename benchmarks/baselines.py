"""Reference implementations the benchmark compares hgo against (not part of hgo).

* ``solve_ivp`` (scipy RK45) with a Python right-hand side, integrated segment by
  segment between noise samples (what python-control's ``input_output_response`` does
  too): the usual way these experiments are run today.
* Hand-written numba kernels for the two problems, specialised by hand (states unrolled,
  constants inlined): the reference for "close to compiled code".

  - Problem B: adaptive DOPRI5 on the 5 states hgo integrates (plant (18) and observer
    (5)-(7), not the 3-state error system (20)), Hairer's starting step, FSAL and the same
    4th-order dense output and step control as hgo, output grid, the trailing-window
    metrics as hgo computes them (Gauss-Legendre on the steps' continuous extensions); it
    records what hgo's call records (z, y, m, x^, t: ``B_REC`` columns).
  - Problem A: fixed-step RK4 on the DC motor + switched HGO, substeps aligned to the noise
    samples, as many as the stability margin of the *active* gain needs, the switching
    scheme after every substep; the trailing-window metrics as hgo's RK4 computes them
    (trapezoid on the step ends); it records what hgo's call records (z, d, y, m, u, x^, t:
    ``A_REC`` columns).

* ``reference_*``: tight-tolerance references (scipy DOP853, rtol 1e-12, segment by
  segment between noise samples) for the accuracy columns.
"""

from __future__ import annotations

import math

import numba
import numpy as np
from hand_dop853 import GAUSS_NODES, GAUSS_WEIGHTS  # hgo's window rule, as the papers' kernels
from scipy.integrate import solve_ivp

# ----------------------------------------------------------------------------------------
# Problem B: Sanfelice & Praly error system (20): e = x^ - x with x = 0 (nu2 = 0, x(0) = 0)
#   e1' = e2 + nu1 e1 - K1 r e1,  e2' = -K2 r^2 e1,
#   r'  = p1 ((e1^2 - p2) r^(1-2b) + p2 / r^(2n)),  n = 2.
# ----------------------------------------------------------------------------------------
B_NU1, B_K1, B_K2, B_P1, B_B = 3.0, 2.0, 2.0, 4.0 / 3.0, 0.28


def b_rhs_py(t, s, p2):
    e1, e2, r = s
    return [e2 + B_NU1 * e1 - B_K1 * r * e1, -B_K2 * r * r * e1,
            B_P1 * ((e1 * e1 - p2) * r ** (1.0 - 2.0 * B_B) + p2 / r ** 4)]


def b_rhs_full_py(t, s, p2):
    """Plant (18) and observer (5)-(7) as hgo integrates them: s = [x1, x2, x^1, x^2, r].

    The same 5-state ODE as hgo's (plant states included), so that solve_ivp's RMS error
    norm is the same function of the same vector as hgo's, and equal tolerances mean
    equal step control.
    """
    x1, x2, z1, z2, r = s
    e = z1 - x1
    return [x2 + B_NU1 * x1, 0.0, z2 + B_NU1 * z1 - B_K1 * r * e, -B_K2 * r * r * e,
            B_P1 * ((e * e - p2) * r ** (1.0 - 2.0 * B_B) + p2 / r ** 4)]


def b_solve_ivp(e0, p2, t_end, dt_out, rtol, atol, method="RK45", full=True):
    """solve_ivp with a Python RHS, samples of (e1, e2, r) on the output grid (dense
    output). ``full``: integrate plant + observer (5 states, what hgo integrates);
    otherwise the 3-state error system (20) (used for the tight reference: same solution,
    as x = 0)."""
    t_eval = np.arange(int(round(t_end / dt_out)) + 1) * dt_out
    t_eval[-1] = t_end
    if full:
        sol = solve_ivp(b_rhs_full_py, (0.0, t_end), [0.0, 0.0, e0[0], e0[1], 1.0],
                        method=method, rtol=rtol, atol=atol, t_eval=t_eval, args=(p2,))
        y = sol.y.T
        return t_eval, np.c_[y[:, 2] - y[:, 0], y[:, 3] - y[:, 1], y[:, 4]]
    sol = solve_ivp(b_rhs_py, (0.0, t_end), [e0[0], e0[1], 1.0], method=method, rtol=rtol,
                    atol=atol, t_eval=t_eval, args=(p2,))
    return t_eval, sol.y.T


N_B = 5  # the states hgo integrates for B: plant x1, x2 and observer x^1, x^2, r
B_REC = N_B + 1 + 1 + 2 + 1  # a record row: z, y, m, x^, t (hgo's Trajectory; no d, no u)


@numba.njit(inline="always")
def b_f(p2, m, x1, x2, z1, z2, r):
    """Plant (18) (nu2 = 0) and observer (5)-(7) with the sign-indefinite law (6), as hgo
    integrates them: e = x^1 - y, y = x1 + m. Scalars in, the derivative as a tuple out
    (``hand_unrolled`` inlines it into every stage)."""
    e = z1 - (x1 + m)
    r2 = r * r
    # r^(1 - 2b) as exp((1 - 2b) log r) (r >= 1), r^4 by multiplication: as hgo's (the faster)
    return (x2 + B_NU1 * x1, 0.0, z2 + B_NU1 * z1 - B_K1 * r * e, -B_K2 * r2 * e,
            B_P1 * ((e * e - p2) * math.exp((1.0 - 2.0 * B_B) * math.log(r)) + p2 / (r2 * r2)))


@numba.njit(inline="always")
def _b_f(s, p2, out):
    """:func:`b_f` on arrays (no noise): s = [x1, x2, x^1, x^2, r]."""
    out[0], out[1], out[2], out[3], out[4] = b_f(p2, 0.0, s[0], s[1], s[2], s[3], s[4])


_A = (1 / 5, 3 / 40, 9 / 40, 44 / 45, -56 / 15, 32 / 9, 19372 / 6561, -25360 / 2187,
      64448 / 6561, -212 / 729, 9017 / 3168, -355 / 33, 46732 / 5247, 49 / 176,
      -5103 / 18656)
_B = (35 / 384, 500 / 1113, 125 / 192, -2187 / 6784, 11 / 84)
_E = (71 / 57600, -71 / 16695, 71 / 1920, -17253 / 339200, 22 / 525, -1 / 40)
_P = np.array([
    [1, -8048581381 / 2820520608, 8663915743 / 2820520608, -12715105075 / 11282082432],
    [0, 131558114200 / 32700410799, -68118460800 / 10900136933, 87487479700 / 32700410799],
    [0, -1754552775 / 470086768, 14199869525 / 1410260304, -10690763975 / 1880347072],
    [0, 127303824393 / 49829197408, -318862633887 / 49829197408,
     701980252875 / 199316789632],
    [0, -282668133 / 205662961, 2019193451 / 616988883, -1453857185 / 822651844],
    [0, 40617522 / 29380423, -110615467 / 29380423, 69997945 / 29380423]])


@numba.njit(inline="always")
def _b_dense(k, s, hh, th, so):
    """The 4th-order continuous extension of the step [t, t + hh] at t + th hh."""
    for i in range(N_B):
        acc_i = 0.0
        for j in range(7):
            if j == 1:
                continue
            pj = _P[0 if j == 0 else j - 1]
            acc_i += k[j, i] * th * (pj[0] + th * (pj[1] + th * (pj[2] + th * pj[3])))
        so[i] = s[i] + hh * acc_i


@numba.njit(inline="always")
def _b_point(s, acc, weight):
    """One point of the window metrics at the state s: weight * ((x^1 - x1)^2, (x^2 - x2)^2,
    (y^ - y)^2) into the integrals (y^ = x^1, y = x1), ||x^ - x|| into the running
    maximum."""
    q0 = (s[2] - s[0]) ** 2
    q1 = (s[3] - s[1]) ** 2
    acc[0] += weight * q0
    acc[1] += weight * q1
    acc[2] += weight * q0
    acc[3] = max(acc[3], math.sqrt(q0 + q1))


@numba.njit(inline="always")
def _b_emit(rec, k, t, s):
    """Output k at t: hgo's Trajectory row z, y = x1 + m, m = 0 (no noise), x^ = (x^1, x^2),
    t (``B_REC`` columns)."""
    for i in range(N_B):
        rec[k, i] = s[i]
    rec[k, N_B] = s[0]
    rec[k, N_B + 1] = 0.0
    rec[k, N_B + 2] = s[2]
    rec[k, N_B + 3] = s[3]
    rec[k, N_B + 4] = t


@numba.njit(inline="always")
def _b_initial_step(s, p2, k, st, rtol, atol, h_max):
    """Hairer's starting step from f0 = k[0] (one evaluation into k[1]), as hgo's."""
    d0 = 0.0
    d1 = 0.0
    for i in range(N_B):
        sc = atol + rtol * abs(s[i])
        d0 += (s[i] / sc) ** 2
        d1 += (k[0, i] / sc) ** 2
    d0 = math.sqrt(d0 / N_B)
    d1 = math.sqrt(d1 / N_B)
    h0 = 1e-6 if d0 < 1e-5 or d1 < 1e-5 else 0.01 * d0 / d1
    h0 = min(h0, h_max)
    for i in range(N_B):
        st[i] = s[i] + h0 * k[0, i]
    _b_f(st, p2, k[1])
    d2 = 0.0
    for i in range(N_B):
        d2 += ((k[1, i] - k[0, i]) / (atol + rtol * abs(s[i]))) ** 2
    d2 = math.sqrt(d2 / N_B) / h0
    dm = max(d1, d2)
    h1 = max(1e-6, h0 * 1e-3) if dm <= 1e-15 else (0.01 / dm) ** 0.2
    return min(100.0 * h0, h1, h_max)


@numba.njit(cache=True, error_model="numpy")
def b_kernel(e10, e20, p2, t_end, dt_out, rtol, atol, h_max, t_window, rec, acc):
    """Hand-written DOPRI5 for problem B on hgo's 5 states (plant and observer, from x = 0,
    x^ = (e10, e20), r = 1); ``rec`` (n_out, ``B_REC``) filled with what hgo's call records
    (``_b_emit``) if it has rows.

    acc = [int (x^1 - x1)^2, int (x^2 - x2)^2, int (y^ - y)^2, max ||x^ - x||, window length]
    over the trailing window, as hgo's run computes them (``kernel_template``'s
    ``_window_step``): each step's part of the window by 3-point Gauss-Legendre on its
    continuous extension, the maximum at those nodes and at the step ends. Returns the
    number of accepted steps.
    """
    k = np.zeros((7, N_B))
    s = np.array([0.0, 0.0, e10, e20, 1.0])
    st = np.zeros(N_B)
    so = np.zeros(N_B)
    n_out = int(round(t_end / dt_out)) + 1
    t_win0 = t_end - t_window
    tol = 1e-12 * max(1.0, t_end)
    record = rec.shape[0] > 0
    for j in range(5):
        acc[j] = 0.0
    if t_win0 <= tol:
        _b_point(s, acc, 0.0)
    t = 0.0
    k_out = 0
    _b_f(s, p2, k[0])
    h = _b_initial_step(s, p2, k, st, rtol, atol, h_max)
    n_steps = 0
    while k_out < n_out:
        # outputs at or before t
        while k_out < n_out and k_out * dt_out <= t + tol:
            if record:
                _b_emit(rec, k_out, k_out * dt_out, s)
            k_out += 1
        if k_out >= n_out:
            break
        retried = False
        while True:
            hh = min(h, h_max)
            last = t + hh >= t_end - tol
            if last:
                hh = t_end - t
            for i in range(N_B):
                st[i] = s[i] + hh * _A[0] * k[0, i]
            _b_f(st, p2, k[1])
            for i in range(N_B):
                st[i] = s[i] + hh * (_A[1] * k[0, i] + _A[2] * k[1, i])
            _b_f(st, p2, k[2])
            for i in range(N_B):
                st[i] = s[i] + hh * (_A[3] * k[0, i] + _A[4] * k[1, i] + _A[5] * k[2, i])
            _b_f(st, p2, k[3])
            for i in range(N_B):
                st[i] = s[i] + hh * (_A[6] * k[0, i] + _A[7] * k[1, i] + _A[8] * k[2, i]
                                     + _A[9] * k[3, i])
            _b_f(st, p2, k[4])
            for i in range(N_B):
                st[i] = s[i] + hh * (_A[10] * k[0, i] + _A[11] * k[1, i] + _A[12] * k[2, i]
                                     + _A[13] * k[3, i] + _A[14] * k[4, i])
            _b_f(st, p2, k[5])
            for i in range(N_B):
                st[i] = s[i] + hh * (_B[0] * k[0, i] + _B[1] * k[2, i] + _B[2] * k[3, i]
                                     + _B[3] * k[4, i] + _B[4] * k[5, i])
            _b_f(st, p2, k[6])
            err = 0.0
            for i in range(N_B):
                e = hh * (_E[0] * k[0, i] + _E[1] * k[2, i] + _E[2] * k[3, i]
                          + _E[3] * k[4, i] + _E[4] * k[5, i] + _E[5] * k[6, i])
                sc = atol + rtol * max(abs(s[i]), abs(st[i]))
                err += (e / sc) ** 2
            err = math.sqrt(err / N_B)  # the RMS norm, as hgo's and solve_ivp's
            if err <= 1.0:
                break
            h = hh * max(0.2, 0.9 * err ** -0.2)
            retried = True
        t_new = t_end if last else t + hh
        if t_new > t_win0 + tol:  # the step overlaps the window
            a = max(t, t_win0)
            for q in range(3):
                _b_dense(k, s, hh, (a + (t_new - a) * GAUSS_NODES[q] - t) / hh, so)
                _b_point(so, acc, (t_new - a) * GAUSS_WEIGHTS[q])
            acc[4] += t_new - a
        while k_out < n_out and k_out * dt_out < t_new - tol:  # dense output
            if record:
                t_o = k_out * dt_out
                _b_dense(k, s, hh, (t_o - t) / hh, so)
                _b_emit(rec, k_out, t_o, so)
            k_out += 1
        for i in range(N_B):
            s[i] = st[i]
            k[0, i] = k[6, i]
        t = t_new
        if t >= t_win0 - tol:  # the step end, for the maximum
            _b_point(s, acc, 0.0)
        n_steps += 1
        fac = 10.0 if err == 0.0 else min(10.0, max(0.2, 0.9 * err ** -0.2))
        if retried:  # no growth right after a rejection (scipy, hgo)
            fac = min(1.0, fac)
        h = max(h, hh * fac) if last else hh * fac
    return n_steps


def b_record_errors(rec: np.ndarray) -> np.ndarray:
    """(e1, e2, r) = (x^1 - x1, x^2 - x2, r) from a ``b_kernel`` record."""
    return np.c_[rec[:, 2] - rec[:, 0], rec[:, 3] - rec[:, 1], rec[:, 4]]


@numba.njit(cache=True, parallel=True, error_model="numpy")
def b_ensemble(E0, P2, t_end, dt_out, rtol, atol, h_max, t_window, ACC):
    empty = np.zeros((0, B_REC))
    for i in numba.prange(E0.shape[0]):
        b_kernel(E0[i, 0], E0[i, 1], P2[i], t_end, dt_out, rtol, atol, h_max, t_window, empty,
                 ACC[i])


# ----------------------------------------------------------------------------------------
# Problem A: DC motor (Ahrens & Khalil (38)-(39)) with u = 1 + 0.5 sin t, HGO (26) with
# H1 = (71/eps1, 70/eps1^2), eps1 = 5e-4 until T_d = 1 s in the zone |y - x^1| <= delta
# (always here), then H2 = (2/eps2, 1/eps2^2), eps2 = 0.01; phi0 = -0.11 sat(x^2) + 0.1 x3 u;
# noise on x1 held every noise_dt.
# State s = [x1, x2, x3, x^1, x^2].
# ----------------------------------------------------------------------------------------
A_A, A_B, A_C, A_D, A_E = 0.1, 0.1, 2.0, 0.2, 200.0
A_SAT = 100.0


def a_rhs_py(t, s, eps, a1, a2, v):
    x1, x2, x3, z1, z2 = s
    u = 1.0 + 0.5 * math.sin(t)
    y = x1 + v
    e = y - z1
    phi0 = -0.11 * min(max(z2, -A_SAT), A_SAT) + 0.1 * x3 * u
    return [x2, -A_A * x2 + A_B * x3 * u, -A_C * x3 - A_D * x2 * u + A_E,
            z2 + a1 / eps * e, phi0 + a2 / eps ** 2 * e]


def a_gains(t, t_switch):
    return (5e-4, 71.0, 70.0) if t < t_switch - 1e-12 else (0.01, 2.0, 1.0)


def a_solve_ivp(s0, noise, noise_dt, t_end, t_switch, rtol, atol, method="RK45",
                n_segments=None):
    """Segment by segment between noise samples; the state at every noise instant.

    ``n_segments`` stops early (to time a sample of the run and extrapolate).
    """
    n = int(round(t_end / noise_dt)) if n_segments is None else n_segments
    out = np.zeros((n + 1, 5))
    out[0] = s0
    s = np.array(s0, float)
    for k in range(n):
        t0, t1 = k * noise_dt, (k + 1) * noise_dt
        eps, a1, a2 = a_gains(t0, t_switch)
        sol = solve_ivp(a_rhs_py, (t0, t1), s, method=method, rtol=rtol, atol=atol,
                        args=(eps, a1, a2, noise[k]))
        s = sol.y[:, -1]
        out[k + 1] = s
    return out


A_DELTA = 1e12  # the switching zone's half-width (problems.a_system: never left)
A_ND = 6  # the switched HGO's discrete state: gain, eps, t_enter, timer, n_switches, t_switch
A_REC = 5 + A_ND + 2 + 2 + 1 + 2 + 1  # a record row: z, d, y (x1 + v, x3), m, u, x^, t


@numba.njit(inline="always")
def _a_f(t, x1, x2, x3, z1, z2, h1, h2, v):
    """Plant (38) and observer (26) with the injection gains h1 = a1 / eps, h2 = a2 / eps^2;
    scalars in, the derivative as a tuple out."""
    u = 1.0 + 0.5 * math.sin(t)
    e = x1 + v - z1
    phi0 = -0.11 * min(max(z2, -A_SAT), A_SAT) + 0.1 * x3 * u
    return (x2, -A_A * x2 + A_B * x3 * u, -A_C * x3 - A_D * x2 * u + A_E, z2 + h1 * e,
            phi0 + h2 * e)


@numba.njit(inline="always")
def _a_update(t, e, d, t_d):
    """The switching scheme (Ahrens & Khalil Section 3.1, hgo's ``switched_hgo.update``) on
    the output error e = y - x^1 after a step ending at t: the new d = (gain, eps, t_enter,
    timer, n_switches, t_switch)."""
    gain, _, t_enter, timer, n_sw, t_sw = d
    if abs(e) > A_DELTA:  # outside the zone: H1, timer reset
        t_enter = -1.0
        timer = 0.0
        if gain > 1.5:
            gain, n_sw, t_sw = 1.0, n_sw + 1.0, t
    else:
        if t_enter < 0.0:
            t_enter = t
        timer = t - t_enter
        if gain < 1.5 and timer >= t_d - 1e-12 * max(1.0, t):  # T_d in the zone: H2
            gain, n_sw, t_sw = 2.0, n_sw + 1.0, t
    return gain, 5e-4 if gain < 1.5 else 0.01, t_enter, timer, n_sw, t_sw


@numba.njit(inline="always")
def _a_point(x1, x2, z1, z2, v, acc, prev, dt):
    """A step end of the window metrics (hgo's RK4 ``_step_end``): the squared errors of the
    estimate x^ = (x^1, sat(x^2)), (x^1 - x1)^2, (x^2 - x2)^2, (y^ - y)^2 with y = x1 + v,
    their trapezoid from the previous step end's ``prev`` (``dt`` after it; none at the
    window's first point, dt < 0), ||x^ - x|| into the running maximum. Returns the
    squared errors (the next point's ``prev``)."""
    q0 = (z1 - x1) ** 2
    q1 = (min(max(z2, -A_SAT), A_SAT) - x2) ** 2
    q2 = (z1 - (x1 + v)) ** 2
    if dt >= 0.0:
        acc[0] += 0.5 * dt * (q0 + prev[0])
        acc[1] += 0.5 * dt * (q1 + prev[1])
        acc[2] += 0.5 * dt * (q2 + prev[2])
        acc[4] += dt
    acc[3] = max(acc[3], math.sqrt(q0 + q1))
    return q0, q1, q2


@numba.njit(inline="always")
def _a_emit(rec, j, t, x1, x2, x3, z1, z2, d, v):
    """Output j at t: hgo's Trajectory row z, d, y = (x1 + v, x3), m = (v, 0), u,
    x^ = (x^1, sat(x^2)), t (``A_REC`` columns)."""
    row = (x1, x2, x3, z1, z2, *d, x1 + v, x3, v, 0.0, 1.0 + 0.5 * math.sin(t), z1,
           min(max(z2, -A_SAT), A_SAT), t)
    for i in range(A_REC):
        rec[j, i] = row[i]


@numba.njit(cache=True, error_model="numpy")
def a_kernel(s0, noise, noise_dt, t_end, t_d, stab, out_every, rec, t_window, acc):
    """Hand-written RK4 for problem A (the state and stages as scalar locals): substeps
    aligned to the noise samples, their number from the stability margin of the active gain
    (rho = 1.4e5 then 100), the switching scheme after every substep (``_a_update``, delay
    timer ``t_d``). ``rec`` receives what hgo's call records (``_a_emit``: z, d, y, m, u, x^,
    t) every ``out_every`` noise samples. The window metrics of hgo's run into ``acc`` =
    [int (x^1 - x1)^2, int (x^2 - x2)^2, int (y^ - y)^2, max ||x^ - x||, window length]: the
    trapezoid on the step ends in the trailing ``t_window`` (its start a noise instant here:
    a step end; 0: none). Returns the number of RK4 steps. A segment's substeps are planned
    with the gain at its start (hgo re-plans after a switch inside a segment: here the switch
    falls on a segment's end, t = T_d = 1 s, a noise instant)."""
    n = int(round(t_end / noise_dt))
    dt_out = out_every * noise_dt
    x1, x2, x3, z1, z2 = s0[0], s0[1], s0[2], s0[3], s0[4]
    prev = (0.0, 0.0, 0.0)
    acc[:] = 0.0
    t_win0 = t_end - t_window if t_window > 0.0 else math.inf
    tol = 1e-12 * max(1.0, t_end)
    t_last = -1.0  # the previous step end in the window (none yet)
    n_steps = 0
    d = _a_update(0.0, x1 + noise[0] - z1, (1.0, 5e-4, -1.0, 0.0, 0.0, -1.0), t_d)
    _a_emit(rec, 0, 0.0, x1, x2, x3, z1, z2, d, noise[0])
    for k in range(n):
        t = k * noise_dt
        if d[0] < 1.5:
            h1, h2, rho = 71.0 / 5e-4, 70.0 / (5e-4 * 5e-4), 70.0 / 5e-4
        else:
            h1, h2, rho = 2.0 / 0.01, 1.0 / (0.01 * 0.01), 1.0 / 0.01
        n_sub = max(1, math.ceil(noise_dt / (stab / rho) - 1e-9))
        h = noise_dt / n_sub
        v = noise[k]
        if k == 0 and t_win0 <= tol:
            prev = _a_point(x1, x2, z1, z2, v, acc, prev, -1.0)
            t_last = 0.0
        for j in range(n_sub):
            tj = t + j * h
            a1, a2, a3, a4, a5 = _a_f(tj, x1, x2, x3, z1, z2, h1, h2, v)
            b1, b2, b3, b4, b5 = _a_f(tj + 0.5 * h, x1 + 0.5 * h * a1, x2 + 0.5 * h * a2,
                                      x3 + 0.5 * h * a3, z1 + 0.5 * h * a4, z2 + 0.5 * h * a5,
                                      h1, h2, v)
            c1, c2, c3, c4, c5 = _a_f(tj + 0.5 * h, x1 + 0.5 * h * b1, x2 + 0.5 * h * b2,
                                      x3 + 0.5 * h * b3, z1 + 0.5 * h * b4, z2 + 0.5 * h * b5,
                                      h1, h2, v)
            e1, e2, e3, e4, e5 = _a_f(tj + h, x1 + h * c1, x2 + h * c2, x3 + h * c3,
                                      z1 + h * c4, z2 + h * c5, h1, h2, v)
            h6 = h / 6.0
            x1 += h6 * (a1 + 2.0 * (b1 + c1) + e1)
            x2 += h6 * (a2 + 2.0 * (b2 + c2) + e2)
            x3 += h6 * (a3 + 2.0 * (b3 + c3) + e3)
            z1 += h6 * (a4 + 2.0 * (b4 + c4) + e4)
            z2 += h6 * (a5 + 2.0 * (b5 + c5) + e5)
            t_end_j = (k + 1) * noise_dt if j == n_sub - 1 else tj + h
            d = _a_update(t_end_j, x1 + v - z1, d, t_d)
            if t_end_j >= t_win0 - tol:
                prev = _a_point(x1, x2, z1, z2, v, acc, prev,
                                t_end_j - t_last if t_last >= 0.0 else -1.0)
                t_last = t_end_j
        n_steps += n_sub
        if (k + 1) % out_every == 0:
            j_out = (k + 1) // out_every
            _a_emit(rec, j_out, j_out * dt_out, x1, x2, x3, z1, z2, d,
                    noise[min(k + 1, noise.shape[0] - 1)])
    return n_steps
