"""Reference implementations the benchmark compares hgo against (not part of hgo).

* ``solve_ivp`` (scipy RK45) with a Python right-hand side, integrated segment by
  segment between noise samples (what python-control's ``input_output_response`` does
  too): the usual way these experiments are run today.
* Hand-written numba kernels for the two problems, specialised by hand (states unrolled,
  constants inlined): the reference for "close to compiled code".

  - Problem B: adaptive DOPRI5 on the S-P error system (20), FSAL and the same
    4th-order dense output and step control as hgo, output grid, the trailing-window
    metrics as hgo computes them (Gauss-Legendre on the steps' continuous extensions);
    its error norm is the RMS over the 5 states of plant + observer (the plant states are
    exactly 0 and contribute 0), as in hgo and in the solve_ivp baseline.
  - Problem A: fixed-step RK4 on the DC motor + switched HGO, substeps aligned to the noise
    samples, as many as the stability margin of the *active* gain needs; the
    trailing-window metrics as hgo's RK4 computes them (trapezoid on the step ends).

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


@numba.njit(inline="always")
def _b_f(s0, s1, s2, p2, out):
    out[0] = s1 + B_NU1 * s0 - B_K1 * s2 * s0
    out[1] = -B_K2 * s2 * s2 * s0
    out[2] = B_P1 * ((s0 * s0 - p2) * s2 ** (1.0 - 2.0 * B_B) + p2 / s2 ** 4)


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
    for i in range(3):
        acc_i = 0.0
        for j in range(7):
            if j == 1:
                continue
            pj = _P[0 if j == 0 else j - 1]
            acc_i += k[j, i] * th * (pj[0] + th * (pj[1] + th * (pj[2] + th * pj[3])))
        so[i] = s[i] + hh * acc_i


@numba.njit(inline="always")
def _b_point(e1, e2, acc, weight):
    """One point of the window metrics: weight * (e1^2, e2^2, (y^ - y)^2 = e1^2) into the
    integrals, ||e|| into the running maximum."""
    q0 = e1 * e1
    q1 = e2 * e2
    acc[0] += weight * q0
    acc[1] += weight * q1
    acc[2] += weight * q0
    acc[3] = max(acc[3], math.sqrt(q0 + q1))


@numba.njit(cache=True, error_model="numpy")
def b_kernel(e10, e20, p2, t_end, dt_out, rtol, atol, h0, t_window, rec, acc):
    """Hand-written DOPRI5 for problem B; ``rec`` (n_out, 3) filled if it has rows.

    acc = [int e1^2, int e2^2, int (y^ - y)^2, max ||e||, window length] over the trailing
    window, as hgo's run computes them (``kernel_template``'s ``_window_step``): each
    step's part of the window by 3-point Gauss-Legendre on its continuous extension, the
    maximum at those nodes and at the step ends. Returns the number of accepted steps.
    """
    k = np.zeros((7, 3))
    s = np.array([e10, e20, 1.0])
    st = np.zeros(3)
    so = np.zeros(3)
    n_out = int(round(t_end / dt_out)) + 1
    t_win0 = t_end - t_window
    tol = 1e-12 * max(1.0, t_end)
    record = rec.shape[0] > 0
    for j in range(5):
        acc[j] = 0.0
    if t_win0 <= tol:
        _b_point(s[0], s[1], acc, 0.0)
    t = 0.0
    h = h0
    k_out = 0
    _b_f(s[0], s[1], s[2], p2, k[0])
    n_steps = 0
    while k_out < n_out:
        # outputs at or before t
        while k_out < n_out and k_out * dt_out <= t + tol:
            if record:
                rec[k_out, 0] = s[0]
                rec[k_out, 1] = s[1]
                rec[k_out, 2] = s[2]
            k_out += 1
        if k_out >= n_out:
            break
        retried = False
        while True:
            last = t + h >= t_end - tol
            hh = t_end - t if last else h
            for i in range(3):
                st[i] = s[i] + hh * _A[0] * k[0, i]
            _b_f(st[0], st[1], st[2], p2, k[1])
            for i in range(3):
                st[i] = s[i] + hh * (_A[1] * k[0, i] + _A[2] * k[1, i])
            _b_f(st[0], st[1], st[2], p2, k[2])
            for i in range(3):
                st[i] = s[i] + hh * (_A[3] * k[0, i] + _A[4] * k[1, i] + _A[5] * k[2, i])
            _b_f(st[0], st[1], st[2], p2, k[3])
            for i in range(3):
                st[i] = s[i] + hh * (_A[6] * k[0, i] + _A[7] * k[1, i] + _A[8] * k[2, i]
                                     + _A[9] * k[3, i])
            _b_f(st[0], st[1], st[2], p2, k[4])
            for i in range(3):
                st[i] = s[i] + hh * (_A[10] * k[0, i] + _A[11] * k[1, i] + _A[12] * k[2, i]
                                     + _A[13] * k[3, i] + _A[14] * k[4, i])
            _b_f(st[0], st[1], st[2], p2, k[5])
            for i in range(3):
                st[i] = s[i] + hh * (_B[0] * k[0, i] + _B[1] * k[2, i] + _B[2] * k[3, i]
                                     + _B[3] * k[4, i] + _B[4] * k[5, i])
            _b_f(st[0], st[1], st[2], p2, k[6])
            err = 0.0
            for i in range(3):
                e = hh * (_E[0] * k[0, i] + _E[1] * k[2, i] + _E[2] * k[3, i]
                          + _E[3] * k[4, i] + _E[4] * k[5, i] + _E[5] * k[6, i])
                sc = atol + rtol * max(abs(s[i]), abs(st[i]))
                err += (e / sc) ** 2
            # RMS over the 5 states hgo integrates (plant x1, x2 and observer x^1, x^2, r):
            # x = 0 stays exactly 0 (x1' = x2 + nu1 x1), so its two error terms are 0 and
            # this is DOPRI5 on the same 5-state ODE as hgo and solve_ivp, with the same norm
            err = math.sqrt(err / 5)
            if err <= 1.0:
                break
            h = hh * max(0.2, 0.9 * err ** -0.2)
            retried = True
        t_new = t_end if last else t + hh
        if t_new > t_win0 + tol:  # the step overlaps the window
            a = max(t, t_win0)
            for q in range(3):
                _b_dense(k, s, hh, (a + (t_new - a) * GAUSS_NODES[q] - t) / hh, so)
                _b_point(so[0], so[1], acc, (t_new - a) * GAUSS_WEIGHTS[q])
            acc[4] += t_new - a
        while k_out < n_out and k_out * dt_out < t_new - tol:  # dense output
            if record:
                _b_dense(k, s, hh, (k_out * dt_out - t) / hh, so)
                rec[k_out, 0] = so[0]
                rec[k_out, 1] = so[1]
                rec[k_out, 2] = so[2]
            k_out += 1
        for i in range(3):
            s[i] = st[i]
            k[0, i] = k[6, i]
        t = t_new
        if t >= t_win0 - tol:  # the step end, for the maximum
            _b_point(s[0], s[1], acc, 0.0)
        n_steps += 1
        fac = 10.0 if err == 0.0 else min(10.0, max(0.2, 0.9 * err ** -0.2))
        if retried:  # no growth right after a rejection (scipy, hgo)
            fac = min(1.0, fac)
        h = max(h, hh * fac) if last else hh * fac
    return n_steps


@numba.njit(cache=True, parallel=True, error_model="numpy")
def b_ensemble(E0, P2, t_end, dt_out, rtol, atol, h0, t_window, ACC):
    empty = np.zeros((0, 3))
    for i in numba.prange(E0.shape[0]):
        b_kernel(E0[i, 0], E0[i, 1], P2[i], t_end, dt_out, rtol, atol, h0, t_window, empty,
                 ACC[i])


# ----------------------------------------------------------------------------------------
# Problem A: DC motor (Ahrens & Khalil (38)-(39)) with u = 1 + 0.5 sin t, HGO (26) with
# H1 = (71/eps1, 70/eps1^2), eps1 = 5e-4 for t < t_switch, then H2 = (2/eps2, 1/eps2^2),
# eps2 = 0.01; phi0 = -0.11 sat(x^2) + 0.1 x3 u; noise on x1 held every noise_dt.
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


@numba.njit(inline="always")
def _a_f(t, s, eps, a1, a2, v, out):
    u = 1.0 + 0.5 * math.sin(t)
    e = s[0] + v - s[3]
    phi0 = -0.11 * min(max(s[4], -A_SAT), A_SAT) + 0.1 * s[2] * u
    out[0] = s[1]
    out[1] = -A_A * s[1] + A_B * s[2] * u
    out[2] = -A_C * s[2] - A_D * s[1] * u + A_E
    out[3] = s[4] + a1 / eps * e
    out[4] = phi0 + a2 / (eps * eps) * e


@numba.njit(inline="always")
def _a_point(s, v, acc, prev, dt):
    """A step end of the window metrics (hgo's RK4 ``_step_end``): the squared errors
    (x^1 - x1)^2, (x^2 - x2)^2, (y^ - y)^2 with y = x1 + v, their trapezoid from the previous
    step end (``dt`` after it; none at the window's first point, dt < 0), ||x^ - x|| into the
    running maximum."""
    q0 = (s[3] - s[0]) ** 2
    q1 = (s[4] - s[1]) ** 2
    q2 = (s[3] - (s[0] + v)) ** 2
    if dt >= 0.0:
        acc[0] += 0.5 * dt * (q0 + prev[0])
        acc[1] += 0.5 * dt * (q1 + prev[1])
        acc[2] += 0.5 * dt * (q2 + prev[2])
        acc[4] += dt
    prev[0], prev[1], prev[2] = q0, q1, q2
    acc[3] = max(acc[3], math.sqrt(q0 + q1))


@numba.njit(cache=True, error_model="numpy")
def a_kernel(s0, noise, noise_dt, t_end, t_switch, stab, out_every, rec, t_window, acc):
    """Hand-written RK4 for problem A: substeps aligned to the noise samples, their number
    from the stability margin of the active gain (rho = 1.4e5 then 100). ``rec`` receives
    the state every ``out_every`` noise samples. The window metrics of hgo's run into
    ``acc`` = [int (x^1 - x1)^2, int (x^2 - x2)^2, int (y^ - y)^2, max ||x^ - x||, window
    length]: the trapezoid on the step ends in the trailing ``t_window`` (its start a noise
    instant here: a step end; 0: none). Returns the number of RK4 steps."""
    n = int(round(t_end / noise_dt))
    s = s0.copy()
    k1 = np.zeros(5)
    k2 = np.zeros(5)
    k3 = np.zeros(5)
    k4 = np.zeros(5)
    st = np.zeros(5)
    prev = np.zeros(3)
    acc[:] = 0.0
    t_win0 = t_end - t_window if t_window > 0.0 else math.inf
    tol = 1e-12 * max(1.0, t_end)
    t_last = -1.0  # the previous step end in the window (none yet)
    n_steps = 0
    rec[0] = s
    for k in range(n):
        t = k * noise_dt
        if t < t_switch - 1e-12:
            eps, a1, a2, rho = 5e-4, 71.0, 70.0, 70.0 / 5e-4
        else:
            eps, a1, a2, rho = 0.01, 2.0, 1.0, 1.0 / 0.01
        n_sub = max(1, math.ceil(noise_dt / (stab / rho) - 1e-9))
        h = noise_dt / n_sub
        v = noise[k]
        if k == 0 and t_win0 <= tol:
            _a_point(s, v, acc, prev, -1.0)
            t_last = 0.0
        for j in range(n_sub):
            tj = t + j * h
            _a_f(tj, s, eps, a1, a2, v, k1)
            for i in range(5):
                st[i] = s[i] + 0.5 * h * k1[i]
            _a_f(tj + 0.5 * h, st, eps, a1, a2, v, k2)
            for i in range(5):
                st[i] = s[i] + 0.5 * h * k2[i]
            _a_f(tj + 0.5 * h, st, eps, a1, a2, v, k3)
            for i in range(5):
                st[i] = s[i] + h * k3[i]
            _a_f(tj + h, st, eps, a1, a2, v, k4)
            for i in range(5):
                s[i] += h / 6.0 * (k1[i] + 2.0 * (k2[i] + k3[i]) + k4[i])
            t_end_j = (k + 1) * noise_dt if j == n_sub - 1 else tj + h
            if t_end_j >= t_win0 - tol:
                _a_point(s, v, acc, prev, t_end_j - t_last if t_last >= 0.0 else -1.0)
                t_last = t_end_j
        n_steps += n_sub
        if (k + 1) % out_every == 0:
            rec[(k + 1) // out_every] = s
    return n_steps
