"""Integrators of the composed system; this file is *source text* for generated kernels.

:mod:`hgo.engine.codegen` prepends a header that defines ``jit``, ``pjit``, ``prange``,
the layout constants and the composed functions ``system_rhs``, ``system_update`` and
``system_outputs``, then compiles the result with numba (or runs it as plain Python
when a user component cannot be compiled). It is never imported on its own.

Time handling (hybrid systems): the horizon is cut at every noise sample instant
k*noise_dt and every output instant k*dt_out; no step straddles one of them. Inside a
segment, ``method`` 0 is classical RK4 with equal substeps of at most ``h_max``, method 1
is Dormand–Prince 5(4) with step control (rtol, atol) and steps clipped to the segment.
Discrete logic (``system_update``: gain switches, timers, saturations) runs after every
step, so switching instants are step boundaries too.

Status codes: 0 ok, 1 non-finite state, 2 state beyond ``bound``, 3 step-size underflow.
"""
# ruff: noqa: F821  (names come from the generated header)
import math

import numpy as np

_DP_C = np.array([0.0, 1 / 5, 3 / 10, 4 / 5, 8 / 9, 1.0, 1.0])
_DP_A = np.array([
    [0.0, 0.0, 0.0, 0.0, 0.0, 0.0],
    [1 / 5, 0.0, 0.0, 0.0, 0.0, 0.0],
    [3 / 40, 9 / 40, 0.0, 0.0, 0.0, 0.0],
    [44 / 45, -56 / 15, 32 / 9, 0.0, 0.0, 0.0],
    [19372 / 6561, -25360 / 2187, 64448 / 6561, -212 / 729, 0.0, 0.0],
    [9017 / 3168, -355 / 33, 46732 / 5247, 49 / 176, -5103 / 18656, 0.0],
    [35 / 384, 0.0, 500 / 1113, 125 / 192, -2187 / 6784, 11 / 84],
])
_DP_B = np.array([35 / 384, 0.0, 500 / 1113, 125 / 192, -2187 / 6784, 11 / 84, 0.0])
_DP_E = np.array([71 / 57600, 0.0, -71 / 16695, 71 / 1920, -17253 / 339200, 22 / 525, -1 / 40])


@jit
def _state_status(z, bound):
    for i in range(z.shape[0]):
        if not math.isfinite(z[i]):
            return 1
        if abs(z[i]) > bound:
            return 2
    return 0


@jit
def _rk4_step(t, h, z, d, m, P, w, K, zt):
    n = z.shape[0]
    system_rhs(t, z, d, m, P, w, K[0])
    for i in range(n):
        zt[i] = z[i] + 0.5 * h * K[0, i]
    system_rhs(t + 0.5 * h, zt, d, m, P, w, K[1])
    for i in range(n):
        zt[i] = z[i] + 0.5 * h * K[1, i]
    system_rhs(t + 0.5 * h, zt, d, m, P, w, K[2])
    for i in range(n):
        zt[i] = z[i] + h * K[2, i]
    system_rhs(t + h, zt, d, m, P, w, K[3])
    for i in range(n):
        z[i] += h / 6.0 * (K[0, i] + 2.0 * K[1, i] + 2.0 * K[2, i] + K[3, i])


@jit
def _dopri5_error(t, h, z, d, m, P, w, K, zt, rtol, atol):
    """One Dormand–Prince trial step: the 5th-order result in zt, returns the error norm."""
    n = z.shape[0]
    system_rhs(t, z, d, m, P, w, K[0])
    for s in range(1, 7):
        for i in range(n):
            acc = 0.0
            for j in range(s):
                acc += _DP_A[s, j] * K[j, i]
            zt[i] = z[i] + h * acc
        system_rhs(t + _DP_C[s] * h, zt, d, m, P, w, K[s])
    err = 0.0
    for i in range(n):
        e = 0.0
        for s in range(7):
            e += _DP_E[s] * K[s, i]
        sc = atol + rtol * max(abs(z[i]), abs(zt[i]))
        err += (h * e / sc) ** 2
    return math.sqrt(err / n)


@jit
def _advance(t, t_next, z, d, m, P, w, K, zt, method, h_max, rtol, atol, bound, h_state):
    """Integrate from t to t_next (no event inside). Returns (status, t)."""
    if t_next - t <= 1e-13 * max(1.0, abs(t_next)):
        return 0, t_next
    if method == 0:
        n_sub = max(1, math.ceil((t_next - t) / h_max - 1e-9))
        h = (t_next - t) / n_sub
        for s in range(n_sub):
            _rk4_step(t, h, z, d, m, P, w, K, zt)
            t = t_next if s == n_sub - 1 else t + h
            system_update(t, z, d, m, P, w)
            st = _state_status(z, bound)
            if st != 0:
                return st, t
        return 0, t
    while t < t_next:
        h = min(h_state[0], h_max, t_next - t)
        if h < 1e-14 * max(1.0, abs(t)):
            return 3, t
        err = _dopri5_error(t, h, z, d, m, P, w, K, zt, rtol, atol)
        if err <= 1.0:
            z[:] = zt
            clipped = h < h_state[0]
            t = t_next if t + h >= t_next - 1e-13 * max(1.0, abs(t_next)) else t + h
            system_update(t, z, d, m, P, w)
            st = _state_status(z, bound)
            if st != 0:
                return st, t
            fac = 5.0 if err == 0.0 else min(5.0, max(0.2, 0.9 * err ** -0.2))
            # a step clipped to the segment end must not shrink the controller's proposal
            h_state[0] = max(h_state[0], h * fac) if clipped else h * fac
        else:
            fac = 0.2 if not math.isfinite(err) else max(0.2, 0.9 * err ** -0.2)
            h_state[0] = h * fac
    return 0, t


@jit
def _accumulate(xh, z, y, sq, prev, acc, dt, first):
    """Trapezoid of squared errors over the trailing window (Sanfelice & Praly (11)-(12))."""
    for j in range(NXH):
        if EST_MAP[j] >= 0:
            sq[j] = (xh[j] - z[EST_MAP[j]]) ** 2
        else:
            sq[j] = 0.0
    for k in range(NOBS):
        c = YHAT_COL[k]
        sq[NXH + k] = (xh[c] - y[0]) ** 2 if c >= 0 else 0.0
    if not first:
        for j in range(NXH + NOBS):
            acc[j] += 0.5 * dt * (sq[j] + prev[j])
    prev[:] = sq


@jit
def integrate(z, d, P, noise, noise_dt, t_end, dt_out, method, h_max, rtol, atol, bound,
              t_window, record, Z, D, Y, M, U, XH, acc):
    """Integrate one run. Returns (status, number of recorded samples, stop time).

    ``acc`` receives the integrals of the squared errors over [t_end - t_window, t_end],
    and ``acc[-1]`` the length of the window actually integrated.
    """
    nz = z.shape[0]
    K = np.zeros((7, nz))
    zt = np.zeros(nz)
    w = np.zeros(NW)
    y = np.zeros(NY)
    u = np.zeros(NU)
    xh = np.zeros(NXH)
    sq = np.zeros(NXH + NOBS)
    prev = np.zeros(NXH + NOBS)
    h_state = np.array([h_max])
    m = noise[0].copy()
    n_out = int(round(t_end / dt_out)) + 1
    n_noise = noise.shape[0]
    t_win0 = t_end - t_window
    in_window = False
    acc[:] = 0.0
    t = 0.0
    k_noise = 0
    system_update(t, z, d, m, P, w)
    status = _state_status(z, bound)
    k_out = 0
    while True:
        system_outputs(t, z, d, m, P, w, y, u, xh)
        if record:
            Z[k_out] = z
            D[k_out] = d
            Y[k_out] = y
            M[k_out] = m
            U[k_out] = u
            XH[k_out] = xh
        if t >= t_win0 - 1e-12 * max(1.0, t_end):
            _accumulate(xh, z, y, sq, prev, acc, dt_out, not in_window)
            if in_window:
                acc[NXH + NOBS] += dt_out
            in_window = True
        k_out += 1
        if status != 0 or k_out >= n_out:
            return status, k_out, t
        t_out = k_out * dt_out
        while True:
            t_noise = (k_noise + 1) * noise_dt
            if abs(t_noise - t_out) <= 1e-12 * max(1.0, t_out):
                t_noise = t_out  # coincident events: one boundary, not a sliver of a step
            t_next = min(t_out, t_noise)
            status, t = _advance(t, t_next, z, d, m, P, w, K, zt, method, h_max, rtol, atol,
                                 bound, h_state)
            if status != 0:
                break
            if t_noise <= t_out:
                k_noise += 1
                m[:] = noise[min(k_noise, n_noise - 1)]
            if t_noise >= t_out:
                break
        if status != 0:
            return status, k_out, t
        t = t_out


@pjit
def integrate_ensemble(Z0, D0, PP, noise, noise_dt, t_end, dt_out, method, h_max, rtol, atol,
                       bound, t_window, ACC, STATUS, T_STOP):
    """Integrate many runs in parallel (one per row of Z0, D0, PP, noise), metrics only."""
    n_members = Z0.shape[0]
    empty = np.zeros((0, 1))
    for i in prange(n_members):
        z = Z0[i].copy()
        d = D0[i].copy()
        st, n_rec, t_stop = integrate(z, d, PP[i], noise[i], noise_dt, t_end, dt_out, method,
                                      h_max, rtol, atol, bound, t_window, False, empty, empty,
                                      empty, empty, empty, empty, ACC[i])
        STATUS[i] = st
        T_STOP[i] = t_stop
