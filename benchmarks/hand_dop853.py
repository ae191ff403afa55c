"""A hand-written numba DOP853 for the papers' hand kernels (issue 24, item 5).

``dop853_kernel(rhs, nz, errors, n_est)`` returns one compiled function

    run(z, p, noise, noise_dt, t_end, dt_out, h_max, rtol, atol, rec, window, metrics)
        -> (accepted steps, rejected steps; -1: step-size underflow)

integrating ``rhs(t, z, p, m, dz)`` (an ``inline="always"`` njit function written out by
hand for one problem, its dimension ``nz`` a compile-time constant; ``m`` the measurement
noise held on [k noise_dt, (k+1) noise_dt), ``noise[k]``; ``noise_dt = inf`` for none) from
``z`` (overwritten with the final state) and recording the state at t = k dt_out into
``rec``. The method is the one hgo's ``dop853`` takes (``hgo.engine.tableau`` /
``kernel_template``'s adaptive section), for a problem without discrete updates after
t = 0: scipy's DOP853 coefficients, Hairer's starting step, scipy's step-size control
(factor 0.9 err^(-1/8) in [0.2, 10], no growth right after a rejection), steps capped at
``h_max`` and cut at the noise instants and at ``t_end``, outputs from the 7th-order
continuous extension (3 more evaluations, only in steps that hold an output or overlap
the window). So it takes hgo's steps, up to round-off. Compiled with hgo's kernel flags
(fastmath contract, arcp; LLVM ``noalias`` on the array arguments). The ratio line's
yardsticks are ``hand_unrolled``'s (the same method written out stage by stage, ~1.4x
faster); these loop kernels serve ``hand_bench --outputs`` and ``--signals``.

The window metrics hgo's run computes, as hgo computes them (``kernel_template``'s
``_window_step``): ``errors(t, z, p, m, sq)`` writes the squared errors (x^_j - x_j)^2 of the
``n_est`` estimated states, then (y^ - y)^2; over the trailing ``window`` (the steps that
overlap [t_end - window, t_end]), ``metrics[:n_sq]`` gets their integrals by 3-point
Gauss-Legendre on each step's continuous extension, ``metrics[n_sq]`` the largest
||x^ - x|| at those nodes and at the step ends, ``metrics[n_sq + 1]`` the window's length
(``window = 0``: none).
"""

from __future__ import annotations

import math

import numba
import numpy as np
from scipy.integrate._ivp import dop853_coefficients as dop

N_STAGES = dop.N_STAGES  # 12; K[12] = f(t + h, z_new) (first same as last)
N_EXT = dop.N_STAGES_EXTENDED  # 16: 3 more stages for the continuous extension
A = np.ascontiguousarray(dop.A[:N_EXT, :N_EXT])
B = np.ascontiguousarray(dop.B)
C = np.ascontiguousarray(dop.C[:N_EXT])
D = np.ascontiguousarray(dop.D)  # (4, 16)
E3 = np.ascontiguousarray(dop.E3)
E5 = np.ascontiguousarray(dop.E5)
N_F = dop.INTERPOLATOR_POWER  # 7
ERR_EXP = -1.0 / 8.0
GAUSS_NODES = np.array([0.5 - 0.5 * math.sqrt(0.6), 0.5, 0.5 + 0.5 * math.sqrt(0.6)])
GAUSS_WEIGHTS = np.array([5.0 / 18.0, 8.0 / 18.0, 5.0 / 18.0])
FASTMATH = {"contract", "arcp"}  # hgo's kernel flags (hgo.engine.codegen.FASTMATH)


def noalias(dispatcher):
    """``dispatcher`` compiling with LLVM ``noalias`` on its array arguments, as hgo's kernels
    (``hgo.engine.codegen``: numba has the flag but no decorator option; left off if this
    numba lacks the hook). Sound here: no two arguments of a run overlap."""
    compiler = getattr(dispatcher, "_compiler", None)
    if hasattr(compiler, "_customize_flags"):
        compiler._customize_flags = _with_noalias
    return dispatcher


def _with_noalias(flags):
    flags.noalias = True
    return flags


@numba.njit(inline="always")
def _state_only(t, rec, k, p, m):
    """No signals besides the state."""
    return


def dop853_kernel(rhs, nz: int, errors, n_est: int, signals=_state_only):
    """The compiled DOP853 run of ``rhs`` with the window metrics of ``errors`` (see the
    module docstring); ``signals(t, rec, k, p, m)``: what else is recorded at output k
    (columns ``nz:`` of ``rec``, from the state in its first ``nz``)."""

    @numba.njit(inline="always")
    def emit(rec, k, t, z, p, m):
        """Output k at t: the state z, then the other signals."""
        for i in range(nz):
            rec[k, i] = z[i]
        signals(t, rec, k, p, m)

    @numba.njit(inline="always")
    def stage(s, t, h, z, p, m, K, zt):
        """K[s] = rhs(t + C[s] h, z + h sum_{j<s} A[s, j] K[j])."""
        for i in range(nz):
            acc = 0.0
            for j in range(s):
                acc += A[s, j] * K[j, i]
            zt[i] = z[i] + h * acc
        rhs(t + C[s] * h, zt, p, m, K[s])

    @numba.njit(inline="always")
    def trial(t, h, z, p, m, K, zt, rtol, atol):
        """One step: stages 1-11, the new state into zt, f(t + h, zt) into K[12]; the error
        norm (DOP853's combined estimate, scipy's formula)."""
        for s in range(1, N_STAGES):
            stage(s, t, h, z, p, m, K, zt)
        for i in range(nz):
            acc = 0.0
            for j in range(N_STAGES):
                acc += B[j] * K[j, i]
            zt[i] = z[i] + h * acc
        rhs(t + h, zt, p, m, K[N_STAGES])
        e5 = 0.0
        e3 = 0.0
        for i in range(nz):
            sc = atol + rtol * max(abs(z[i]), abs(zt[i]))
            a5 = 0.0
            a3 = 0.0
            for j in range(N_STAGES + 1):
                a5 += E5[j] * K[j, i]
                a3 += E3[j] * K[j, i]
            e5 += (a5 / sc) ** 2
            e3 += (a3 / sc) ** 2
        if e5 == 0.0 and e3 == 0.0:
            return 0.0
        return abs(h) * e5 / math.sqrt((e5 + 0.01 * e3) * nz)

    @numba.njit(inline="always")
    def dense(t, h, z, zn, p, m, K, F, scratch):
        """Coefficients F of the continuous extension of the accepted step z -> zn."""
        for s in range(N_STAGES + 1, N_EXT):
            stage(s, t, h, z, p, m, K, scratch)
        for i in range(nz):
            dz = zn[i] - z[i]
            F[0, i] = dz
            F[1, i] = h * K[0, i] - dz
            F[2, i] = 2.0 * dz - h * (K[0, i] + K[N_STAGES, i])
            for q in range(4):
                acc = 0.0
                for j in range(N_EXT):
                    acc += D[q, j] * K[j, i]
                F[3 + q, i] = h * acc

    @numba.njit(inline="always")
    def initial_step(t, z, p, m, K, zt, rtol, atol, h_max):
        """Hairer's starting step from f0 = K[0] (one evaluation), as hgo's."""
        d0 = 0.0
        d1 = 0.0
        for i in range(nz):
            sc = atol + rtol * abs(z[i])
            d0 += (z[i] / sc) ** 2
            d1 += (K[0, i] / sc) ** 2
        d0 = math.sqrt(d0 / nz)
        d1 = math.sqrt(d1 / nz)
        h0 = 1e-6 if d0 < 1e-5 or d1 < 1e-5 else 0.01 * d0 / d1
        h0 = min(h0, h_max)
        for i in range(nz):
            zt[i] = z[i] + h0 * K[0, i]
        rhs(t + h0, zt, p, m, K[1])
        d2 = 0.0
        for i in range(nz):
            d2 += ((K[1, i] - K[0, i]) / (atol + rtol * abs(z[i]))) ** 2
        d2 = math.sqrt(d2 / nz) / h0
        dm = max(d1, d2)
        h1 = max(1e-6, h0 * 1e-3) if dm <= 1e-15 else (0.01 / dm) ** -ERR_EXP
        return min(100.0 * h0, h1, h_max)

    @numba.njit(inline="always")
    def extension(x, z, F, i):
        """State i at the fraction x of the step: scipy's Dop853DenseOutput, Horner form."""
        s = 1.0 - x
        v = F[N_F - 1, i]
        for c in range(N_F - 2, -1, -1):
            v = F[c, i] + (s if c % 2 == 0 else x) * v
        return z[i] + x * v

    @numba.njit(inline="always")
    def largest_norm(sq, metrics, n_sq):
        """metrics[n_sq] = max(metrics[n_sq], ||x^ - x||) from the squared errors sq[:n_est]."""
        norm2 = 0.0
        for j in range(n_est):
            norm2 += sq[j]
        metrics[n_sq] = max(metrics[n_sq], math.sqrt(norm2))

    @numba.njit(inline="always")
    def window_step(t, h, a, b, z, p, m, F, zo, sq, metrics):
        """The part [a, b] of the step [t, t + h]: 3-point Gauss-Legendre on its continuous
        extension."""
        n_sq = sq.shape[0]
        for q in range(3):
            tq = a + (b - a) * GAUSS_NODES[q]
            for i in range(nz):
                zo[i] = extension((tq - t) / h, z, F, i)
            errors(tq, zo, p, m, sq)
            largest_norm(sq, metrics, n_sq)
            for j in range(n_sq):
                metrics[j] += (b - a) * GAUSS_WEIGHTS[q] * sq[j]
        metrics[n_sq + 1] += b - a

    @noalias
    @numba.njit(error_model="numpy", fastmath=FASTMATH)
    def run(z, p, noise, noise_dt, t_end, dt_out, h_max, rtol, atol, rec, window, metrics):
        K = np.zeros((N_EXT, nz))
        F = np.zeros((N_F, nz))
        zt = np.zeros(nz)
        scratch = np.zeros(nz)
        n_sq = metrics.shape[0] - 2
        sq = np.zeros(n_sq)
        n_out = int(round(t_end / dt_out)) + 1
        tol = 1e-12 * max(1.0, t_end)
        t_win0 = t_end - window
        metrics[:] = 0.0
        t = 0.0
        k_noise = 0
        m = noise[0]
        emit(rec, 0, t, z, p, m)
        k_out = 1
        rhs(t, z, p, m, K[0])
        h = initial_step(t, z, p, m, K, zt, rtol, atol, h_max)
        fsal = True  # K[0] holds f(t, z) under the current noise sample
        retried = False
        accepted = 0
        rejected = 0
        while True:  # segments between noise instants
            t_seg = (k_noise + 1) * noise_dt
            if t_seg >= t_end - tol:
                t_seg = t_end
            while True:  # steps inside [t, t_seg]
                if not fsal:
                    rhs(t, z, p, m, K[0])
                    fsal = True
                hh = min(h, h_max)
                last = t + hh >= t_seg - min(tol, 0.01 * hh)
                if last:
                    hh = t_seg - t
                if not hh >= 1e-14 * max(1.0, abs(t)):
                    return accepted, -1  # step-size underflow
                err = trial(t, hh, z, p, m, K, zt, rtol, atol)
                if not err <= 1.0:
                    h = hh * (0.2 if not math.isfinite(err) else max(0.2, 0.9 * err ** ERR_EXP))
                    retried = True
                    rejected += 1
                    continue
                accepted += 1
                t_new = t_seg if last else t + hh
                prepared = False
                if t_new > t_win0 + tol:  # the step overlaps the metrics window
                    dense(t, hh, z, zt, p, m, K, F, scratch)
                    prepared = True
                    window_step(t, hh, max(t, t_win0), t_new, z, p, m, F, scratch, sq,
                                metrics)
                while k_out < n_out and k_out * dt_out < t_new - tol:  # outputs in the step
                    if not prepared:
                        dense(t, hh, z, zt, p, m, K, F, scratch)
                        prepared = True
                    for i in range(nz):
                        rec[k_out, i] = extension((k_out * dt_out - t) / hh, z, F, i)
                    signals(k_out * dt_out, rec, k_out, p, m)
                    k_out += 1
                for i in range(nz):
                    z[i] = zt[i]
                    K[0, i] = K[N_STAGES, i]
                t = t_new
                if t >= t_win0 - tol:  # the step end, for the largest norm
                    errors(t, z, p, m, sq)
                    largest_norm(sq, metrics, n_sq)
                fac = 10.0 if err == 0.0 else min(10.0, max(0.2, 0.9 * err ** ERR_EXP))
                if retried:
                    fac = min(1.0, fac)
                    retried = False
                h = max(h, hh * fac) if last else hh * fac
                if last:
                    break
                while k_out < n_out and k_out * dt_out <= t + tol:  # output on the step end
                    emit(rec, k_out, k_out * dt_out, z, p, m)
                    k_out += 1
            if t_seg < t_end:  # the next noise sample holds from here on
                k_noise += 1
                m = noise[min(k_noise, noise.shape[0] - 1)]
                fsal = False
            while k_out < n_out and k_out * dt_out <= t + tol:
                emit(rec, k_out, k_out * dt_out, z, p, m)
                k_out += 1
            if k_out >= n_out:
                return accepted, rejected

    return run
