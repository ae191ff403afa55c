"""Integrators of the composed system; this file is *source text* for generated kernels.

:mod:`hgo.engine.codegen` prepends a header that defines ``jit``, ``pjit``, ``prange``,
``view``, the layout constants and the composed functions ``system_rhs``,
``system_update``, ``system_outputs`` and ``system_stiffness``, then appends the section
``common`` and the section of the one integrator the run asks for (``rk4`` or
``dopri5``): only that integrator is compiled. The result is compiled with numba (or run
as plain Python when a user component cannot be compiled). Never imported on its own.

Time handling (hybrid systems): no step straddles a noise sample instant k*noise_dt
(the held noise jumps there). Discrete logic (``system_update``: gain switches, timers,
saturations) runs after every step, so switching instants are step boundaries too.

* ``rk4``: classical RK4. The horizon is also cut at every output instant k*dt_out, and
  each segment is covered by equal substeps no longer than the step cap: ``h_max`` and
  ``stab / rho`` with ``rho`` the spectral radius the components declare *now*
  (``system_stiffness``, re-evaluated after every substep, so a switch to a stiffer gain
  shortens the very next substep).
* ``dopri5``: Dormand–Prince 5(4) with error control (rtol, atol), first-same-as-last
  (6 evaluations per step) and its 4th-order continuous extension: outputs between the
  ends of a step are interpolated, so the output grid does not cut the steps (only the
  noise instants and the horizon do). Outputs that fall on a step end are taken after the
  step's discrete update (and after the noise sample change when they coincide with one).

Status codes: 0 ok, 1 non-finite state, 2 state beyond ``bound``, 3 step-size underflow.
The record arrays (Z, D, Y, M, U, XH) are filled only when they have rows (an ensemble
passes empty ones and keeps only the metric accumulators).
"""
# ruff: noqa: F821, F811  (names come from the generated header; one `integrate` per section)
# --- section: common ---
import math

import numpy as np


@ijit
def _state_status(z, bound):
    for i in range(NZ):
        if not math.isfinite(z[i]):
            return 1
        if abs(z[i]) > bound:
            return 2
    return 0


@jit
def _n_common_work(nz):
    """Length of the work vector the integrators share: w, y, u, xh, sq, prev, win, m."""
    return NW + NY + NU + NXH + 2 * (NXH + NOBS) + 1 + NY


@ijit
def _common_views(work, o):
    """Views of the work vector shared by the integrators, from offset o:
    w, y, u, xh, sq, prev, win, m (lengths as in ``_n_common_work``)."""
    w = view(work, o, o + NW)
    y = view(work, o + NW, o + NW + NY)
    u = view(work, o + NW + NY, o + NW + NY + NU)
    xh = view(work, o + NW + NY + NU, o + NW + NY + NU + NXH)
    o += NW + NY + NU + NXH
    sq = view(work, o, o + NXH + NOBS)
    prev = view(work, o + NXH + NOBS, o + 2 * (NXH + NOBS))
    win = view(work, o + 2 * (NXH + NOBS), o + 2 * (NXH + NOBS) + 1)
    m = view(work, o + 2 * (NXH + NOBS) + 1, o + 2 * (NXH + NOBS) + 1 + NY)
    return w, y, u, xh, sq, prev, win, m


@ijit
def _start(z, d, m, P, w, y, u, xh, sq, prev, acc, win, noise, bound, t_end, dt_out, t_window,
           Z, D, Y, M, U, XH):
    """State at t = 0: first noise sample, cleared integrals, discrete update, output 0.

    Returns the state status, the number of output samples, the time tolerance of event
    comparisons and the start of the metrics window.
    """
    n_out = int(round(t_end / dt_out)) + 1
    tol = 1e-12 * max(1.0, t_end)
    t_win0 = t_end - t_window
    for i in range(NY):
        m[i] = noise[0, i]
    for j in range(acc.shape[0]):
        acc[j] = 0.0
    system_update(0.0, z, d, m, P, w)
    status = _state_status(z, bound)
    _emit(np.int64(0), 0.0, z, d, m, P, w, y, u, xh, sq, prev, acc, win, dt_out, t_win0, tol,
          Z, D, Y, M, U, XH)
    return status, n_out, tol, t_win0


@ijit
def _emit(k, t, z, d, m, P, w, y, u, xh, sq, prev, acc, win, dt_out, t_win0, tol,
          Z, D, Y, M, U, XH):
    """Output sample k at time t: record it, and add it to the trailing-window integrals.

    The integrals are trapezoids of squared errors over [t_end - t_window, t_end]
    (Sanfelice & Praly (11)-(12)); ``win[0]`` tells whether a previous sample is in the
    window. ``acc[-1]`` accumulates the window length actually integrated.
    """
    system_outputs(t, z, d, m, P, w, y, u, xh)
    if Z.shape[0] > 0:
        for i in range(NZ):
            Z[k, i] = z[i]
        for i in range(d.shape[0]):
            D[k, i] = d[i]
        for i in range(NY):
            Y[k, i] = y[i]
            M[k, i] = m[i]
        for i in range(NU):
            U[k, i] = u[i]
        for i in range(NXH):
            XH[k, i] = xh[i]
    if t >= t_win0 - tol:
        for j in range(NXH):
            sq[j] = (xh[j] - z[EST_MAP[j]]) ** 2 if EST_MAP[j] >= 0 else 0.0
        for k2 in range(NOBS):
            c = YHAT_COL[k2]
            sq[NXH + k2] = (xh[c] - y[0]) ** 2 if c >= 0 else 0.0
        if win[0] > 0.0:
            for j in range(NXH + NOBS):
                acc[j] += 0.5 * dt_out * (sq[j] + prev[j])
            acc[NXH + NOBS] += dt_out
        for j in range(NXH + NOBS):
            prev[j] = sq[j]
        win[0] = 1.0


@pjit
def integrate_ensemble(Z0, D0, PP, noise, noise_dt, t_end, dt_out, h_max, rtol, atol, stab,
                       rho_const, bound, t_window, ACC, STATUS, T_STOP):
    """Integrate many runs in parallel (one per row of Z0, D0, PP, noise), metrics only."""
    n_members = Z0.shape[0]
    for i in prange(n_members):
        empty = np.zeros((0, 1))
        z = Z0[i].copy()
        d = D0[i].copy()
        st, n_rec, t_stop = integrate(z, d, PP[i], noise[i], noise_dt, t_end, dt_out, h_max,
                                      rtol, atol, stab, rho_const, bound, t_window, empty,
                                      empty, empty, empty, empty, empty, ACC[i])
        STATUS[i] = st
        T_STOP[i] = t_stop


# --- section: rk4 ---
@ijit
def _rk4_step(t, h, z, d, m, P, w, k1, k2, k3, k4, zt):
    n = NZ  # a constant of the header: loops unrolled
    system_rhs(t, z, d, m, P, w, k1)
    for i in range(n):
        zt[i] = z[i] + 0.5 * h * k1[i]
    system_rhs(t + 0.5 * h, zt, d, m, P, w, k2)
    for i in range(n):
        zt[i] = z[i] + 0.5 * h * k2[i]
    system_rhs(t + 0.5 * h, zt, d, m, P, w, k3)
    for i in range(n):
        zt[i] = z[i] + h * k3[i]
    system_rhs(t + h, zt, d, m, P, w, k4)
    h6 = h / 6.0
    for i in range(n):
        z[i] += h6 * (k1[i] + 2.0 * (k2[i] + k3[i]) + k4[i])


@jit
def integrate(z, d, P, noise, noise_dt, t_end, dt_out, h_max, rtol, atol, stab, rho_const,
              bound, t_window, Z, D, Y, M, U, XH, acc):
    """Integrate one run (RK4). Returns (status, number of output samples, stop time).

    One compiled function (no wrapper around an inner one): every extra level of numba
    functions re-optimises and re-emits the whole inlined body, which cost seconds of
    compilation.
    """
    work = np.zeros(5 * z.shape[0] + _n_common_work(z.shape[0]))
    z, d, P, noise, acc = borrow(z), borrow(d), borrow(P), borrow(noise), borrow(acc)
    Z, D, Y, M, U, XH = borrow(Z), borrow(D), borrow(Y), borrow(M), borrow(U), borrow(XH)
    nz = NZ
    k1 = view(work, 0, nz)
    k2 = view(work, nz, 2 * nz)
    k3 = view(work, 2 * nz, 3 * nz)
    k4 = view(work, 3 * nz, 4 * nz)
    zt = view(work, 4 * nz, 5 * nz)
    w, y, u, xh, sq, prev, win, m = _common_views(work, 5 * nz)
    n_noise = noise.shape[0]
    t = 0.0
    k_noise = 0
    status, n_out, tol, t_win0 = _start(z, d, m, P, w, y, u, xh, sq, prev, acc, win, noise,
                                        bound, t_end, dt_out, t_window, Z, D, Y, M, U, XH)
    if status != 0:
        return status, 1, t
    for k_out in range(1, n_out):
        t_out = t_end if k_out == n_out - 1 else k_out * dt_out
        while True:
            t_noise = (k_noise + 1) * noise_dt
            if abs(t_noise - t_out) <= tol:
                t_noise = t_out  # coincident events: one boundary, not a sliver of a step
            t_next = min(t_out, t_noise)
            n_sub = 0  # substeps left in this segment, planned with the stiffness rho_plan
            rho_plan = -1.0
            h = 0.0
            while t_next - t > tol:
                rho = max(rho_const, system_stiffness(t, z, d, P))
                if n_sub <= 0 or rho != rho_plan:  # (re)plan equal substeps to t_next
                    cap = h_max if rho <= 0.0 else min(h_max, stab / rho)
                    n_sub = max(1, math.ceil((t_next - t) / cap - 1e-9))
                    h = (t_next - t) / n_sub
                    rho_plan = rho
                _rk4_step(t, h, z, d, m, P, w, k1, k2, k3, k4, zt)
                n_sub -= 1
                t = t_next if n_sub <= 0 else t + h
                system_update(t, z, d, m, P, w)
                status = _state_status(z, bound)
                if status != 0:
                    return status, k_out, t
            t = t_next
            if t_noise <= t_out:
                k_noise += 1
                idx = min(k_noise, n_noise - 1)
                for i in range(NY):
                    m[i] = noise[idx, i]
            if t_noise >= t_out:
                break
        _emit(k_out, t, z, d, m, P, w, y, u, xh, sq, prev, acc, win, dt_out, t_win0, tol,
              Z, D, Y, M, U, XH)
    return 0, n_out, t


# --- section: dopri5 ---
# Dormand–Prince 5(4) tableau (Hairer, Norsett & Wanner), error weights E = b5 - b4 and
# the dense-output polynomial of scipy's RK45 (P: theta, theta^2, theta^3, theta^4).
A21 = 1 / 5
A31, A32 = 3 / 40, 9 / 40
A41, A42, A43 = 44 / 45, -56 / 15, 32 / 9
A51, A52, A53, A54 = 19372 / 6561, -25360 / 2187, 64448 / 6561, -212 / 729
A61, A62, A63, A64, A65 = 9017 / 3168, -355 / 33, 46732 / 5247, 49 / 176, -5103 / 18656
B1, B3, B4, B5, B6 = 35 / 384, 500 / 1113, 125 / 192, -2187 / 6784, 11 / 84
C2, C3, C4, C5 = 1 / 5, 3 / 10, 4 / 5, 8 / 9
E1, E3, E4, E5, E6, E7 = (71 / 57600, -71 / 16695, 71 / 1920, -17253 / 339200, 22 / 525,
                          -1 / 40)
P1 = (1.0, -8048581381 / 2820520608, 8663915743 / 2820520608, -12715105075 / 11282082432)
P3 = (0.0, 131558114200 / 32700410799, -68118460800 / 10900136933,
      87487479700 / 32700410799)
P4 = (0.0, -1754552775 / 470086768, 14199869525 / 1410260304, -10690763975 / 1880347072)
P5 = (0.0, 127303824393 / 49829197408, -318862633887 / 49829197408,
      701980252875 / 199316789632)
P6 = (0.0, -282668133 / 205662961, 2019193451 / 616988883, -1453857185 / 822651844)
P7 = (0.0, 40617522 / 29380423, -110615467 / 29380423, 69997945 / 29380423)


@ijit
def _poly(c, th):
    return th * (c[0] + th * (c[1] + th * (c[2] + th * c[3])))


@jit
def _dopri5_trial(t, h, z, d, m, P, w, k1, k2, k3, k4, k5, k6, k7, zt, rtol, atol):
    """One trial step from (t, z) with k1 = f(t, z): 5th-order result in zt, k7 = f(zt).

    Returns the RMS error norm (<= 1: accept).
    """
    n = NZ  # a constant of the header: loops unrolled
    for i in range(n):
        zt[i] = z[i] + h * A21 * k1[i]
    system_rhs(t + C2 * h, zt, d, m, P, w, k2)
    for i in range(n):
        zt[i] = z[i] + h * (A31 * k1[i] + A32 * k2[i])
    system_rhs(t + C3 * h, zt, d, m, P, w, k3)
    for i in range(n):
        zt[i] = z[i] + h * (A41 * k1[i] + A42 * k2[i] + A43 * k3[i])
    system_rhs(t + C4 * h, zt, d, m, P, w, k4)
    for i in range(n):
        zt[i] = z[i] + h * (A51 * k1[i] + A52 * k2[i] + A53 * k3[i] + A54 * k4[i])
    system_rhs(t + C5 * h, zt, d, m, P, w, k5)
    for i in range(n):
        zt[i] = z[i] + h * (A61 * k1[i] + A62 * k2[i] + A63 * k3[i] + A64 * k4[i]
                            + A65 * k5[i])
    system_rhs(t + h, zt, d, m, P, w, k6)
    for i in range(n):
        zt[i] = z[i] + h * (B1 * k1[i] + B3 * k3[i] + B4 * k4[i] + B5 * k5[i] + B6 * k6[i])
    system_rhs(t + h, zt, d, m, P, w, k7)
    err = 0.0
    for i in range(n):
        e = h * (E1 * k1[i] + E3 * k3[i] + E4 * k4[i] + E5 * k5[i] + E6 * k6[i] + E7 * k7[i])
        sc = atol + rtol * max(abs(z[i]), abs(zt[i]))
        err += (e / sc) ** 2
    return math.sqrt(err / n)


@ijit
def _dense(th, h, z, k1, k3, k4, k5, k6, k7, zo):
    """The continuous extension at t + th*h (0 < th < 1) into zo."""
    b1 = _poly(P1, th)
    b3 = _poly(P3, th)
    b4 = _poly(P4, th)
    b5 = _poly(P5, th)
    b6 = _poly(P6, th)
    b7 = _poly(P7, th)
    for i in range(NZ):
        zo[i] = z[i] + h * (b1 * k1[i] + b3 * k3[i] + b4 * k4[i] + b5 * k5[i] + b6 * k6[i]
                            + b7 * k7[i])


@jit
def _rms(a, z, rtol, atol):
    s = 0.0
    for i in range(a.shape[0]):
        s += (a[i] / (atol + rtol * abs(z[i]))) ** 2
    return math.sqrt(s / a.shape[0])


@jit
def _initial_step(t, z, d, m, P, w, k1, k2, zt, rtol, atol, h_max):
    """Hairer's starting step (Solving ODEs I, II.4) from f0 = k1; uses 1 evaluation."""
    d0 = _rms(z, z, rtol, atol)
    d1 = _rms(k1, z, rtol, atol)
    h0 = 1e-6 if d0 < 1e-5 or d1 < 1e-5 else 0.01 * d0 / d1
    h0 = min(h0, h_max)
    for i in range(z.shape[0]):
        zt[i] = z[i] + h0 * k1[i]
    system_rhs(t + h0, zt, d, m, P, w, k2)
    for i in range(z.shape[0]):
        zt[i] = k2[i] - k1[i]
    d2 = _rms(zt, z, rtol, atol) / h0
    dm = max(d1, d2)
    h1 = max(1e-6, h0 * 1e-3) if dm <= 1e-15 else (0.01 / dm) ** 0.2
    return min(100.0 * h0, h1, h_max)


@jit
def integrate(z, d, P, noise, noise_dt, t_end, dt_out, h_max, rtol, atol, stab, rho_const,
              bound, t_window, Z, D, Y, M, U, XH, acc):
    """Integrate one run (DOPRI5). Returns (status, number of output samples, stop time).

    One compiled function, as for RK4 (``stab`` and ``rho_const`` are unused here).
    """
    work = np.zeros(9 * z.shape[0] + d.shape[0] + _n_common_work(z.shape[0]))
    z, d, P, noise, acc = borrow(z), borrow(d), borrow(P), borrow(noise), borrow(acc)
    Z, D, Y, M, U, XH = borrow(Z), borrow(D), borrow(Y), borrow(M), borrow(U), borrow(XH)
    nz = NZ
    nd = d.shape[0]
    k1 = view(work, 0, nz)
    k2 = view(work, nz, 2 * nz)
    k3 = view(work, 2 * nz, 3 * nz)
    k4 = view(work, 3 * nz, 4 * nz)
    k5 = view(work, 4 * nz, 5 * nz)
    k6 = view(work, 5 * nz, 6 * nz)
    k7 = view(work, 6 * nz, 7 * nz)
    zt = view(work, 7 * nz, 8 * nz)
    zo = view(work, 8 * nz, 9 * nz)
    dsave = view(work, 9 * nz, 9 * nz + nd)
    w, y, u, xh, sq, prev, win, m = _common_views(work, 9 * nz + nd)
    n_noise = noise.shape[0]
    t = 0.0
    k_noise = 0
    status, n_out, tol, t_win0 = _start(z, d, m, P, w, y, u, xh, sq, prev, acc, win, noise,
                                        bound, t_end, dt_out, t_window, Z, D, Y, M, U, XH)
    if status != 0:
        return status, 1, t
    k_out = np.int64(1)
    system_rhs(t, z, d, m, P, w, k1)
    h = _initial_step(t, z, d, m, P, w, k1, k2, zt, rtol, atol, h_max)
    fsal = True  # k1 holds f(t, z) for the current noise sample and discrete state
    while k_out < n_out:
        t_seg = (k_noise + 1) * noise_dt
        if t_seg >= t_end - tol:
            t_seg = t_end
        while True:  # steps inside [t, t_seg]
            if not fsal:
                system_rhs(t, z, d, m, P, w, k1)
                fsal = True
            hh = min(h, h_max)
            last = t + hh >= t_seg - tol
            if last:
                hh = t_seg - t
            if hh < 1e-14 * max(1.0, abs(t)):
                return 3, k_out, t
            err = _dopri5_trial(t, hh, z, d, m, P, w, k1, k2, k3, k4, k5, k6, k7, zt,
                                rtol, atol)
            if not err <= 1.0:  # rejected (or non-finite)
                h = hh * (0.2 if not math.isfinite(err) else max(0.2, 0.9 * err ** -0.2))
                continue
            t_new = t_seg if last else t + hh
            while k_out < n_out and k_out * dt_out < t_new - tol:  # outputs inside the step
                t_o = k_out * dt_out
                _dense((t_o - t) / hh, hh, z, k1, k3, k4, k5, k6, k7, zo)
                _emit(k_out, t_o, zo, d, m, P, w, y, u, xh, sq, prev, acc, win, dt_out,
                      t_win0, tol, Z, D, Y, M, U, XH)
                k_out += 1
            for i in range(nz):
                z[i] = zt[i]
                k1[i] = k7[i]
            t = t_new
            if HAS_UPDATE:  # (a constant of the generated header: no discrete logic, no code)
                for i in range(nd):
                    dsave[i] = d[i]
                system_update(t, z, d, m, P, w)
                for i in range(nz):  # the discrete update changed z or d: k7 is stale
                    if z[i] != zt[i]:
                        fsal = False
                for i in range(nd):
                    if d[i] != dsave[i]:
                        fsal = False
            status = _state_status(z, bound)
            if status != 0:
                return status, k_out, t
            fac = 10.0 if err == 0.0 else min(10.0, max(0.2, 0.9 * err ** -0.2))
            # a step shortened to reach the segment end must not shrink the next proposal
            h = max(h, hh * fac) if last else hh * fac
            if last:
                break
            while k_out < n_out and k_out * dt_out <= t + tol:  # an output on the step end
                _emit(k_out, t, z, d, m, P, w, y, u, xh, sq, prev, acc, win, dt_out, t_win0,
                      tol, Z, D, Y, M, U, XH)
                k_out += 1
        if t_seg < t_end:  # the next noise sample holds from here on
            k_noise += 1
            idx = min(k_noise, n_noise - 1)
            for i in range(NY):
                m[i] = noise[idx, i]
            fsal = False
        while k_out < n_out and k_out * dt_out <= t + tol:
            _emit(k_out, t, z, d, m, P, w, y, u, xh, sq, prev, acc, win, dt_out, t_win0,
                  tol, Z, D, Y, M, U, XH)
            k_out += 1
    return 0, n_out, t
