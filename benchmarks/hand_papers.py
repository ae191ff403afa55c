"""The papers' problems written out by hand for the hand kernels (issue 24, item 5; issue 41).

Each right-hand side is written out for its one problem (constants compiled in, states as
scalars, the derivative a tuple: ``dhlm_f``, ``moreno_f``, ``apa_f``), integrated by the
unrolled DOP853 of :mod:`hand_unrolled` (the ratio line's yardsticks) and, for Moreno, by
the loop-over-arrays DOP853 of :mod:`hand_dop853` (``moreno_kernel``,
``moreno_kernel_signals``: ``hand_bench --signals``), hgo's method at the presets'
settings:

* DHLM: ``experiment=dhlm_example`` (Dimassi et al. Sec. IV): robot arm (24)-(25) under
  u = 5 (sin 2t + cos 3t), HGO (27) with the saturation S, adaptive observer (5), (7) with
  psi = [u, -sin y]; state [x1, x2, z_h1, z_h2, x^1, x^2, theta^1, theta^2, omega^] (the
  order of hgo's z; omega^ stays 0, its law off in the preset, but counts in the RMS error
  norm as in hgo's: with 8 states the hand kernel took 3890 accepted steps, hgo 3835, with 9
  it takes 3839); DOP853 rtol 1e-10, atol 1e-12, h_max 0.01, 20 s, output every 1 ms.
* Moreno: ``experiment=moreno_pe`` with ``controller=moreno_sin`` (x2 = 2 sin t, u = r' + a r),
  a = 0.5, l = (200, 120), k = N = 2, x(0) = 0, e(0) = (70, -50): plant (Section 5) and
  observer (3); state [x1, x2, x^1, x^2]; DOP853 rtol 1e-10, atol 1e-12, h_max 0.01, 40 s,
  output every 1 ms.
* APA: ``experiment=apa_fig2``, each observer's part of the split run (below).
"""

from __future__ import annotations

import math

import numba
import numpy as np
from hand_dop853 import dop853_kernel

from hgo.observers.homogeneous_dynamic import model_terms
from hgo.plants.contois import (
    clip,
    df2max,
    eta2_of_x,
    invariance_eps,
    reaction_rate,
    to_x,
    x2_high,
    x2_low,
)

# Dimassi et al. Sec. IV values (conf/plant/robot_arm.yaml, conf/observer/dhlm_cascade.yaml)
DHLM_I, DHLM_MGL = 0.5, 9.81
DHLM_EPS, DHLM_G1, DHLM_G2, DHLM_S = 0.006, 6.0, 8.0, 150.0
DHLM_L11, DHLM_L21, DHLM_L22 = 5.0, 1.0, 10.0  # L = [[5, 0], [1, 10]]
DHLM_DELTA, DHLM_SIGMA = 100.0, 0.01  # M = [0, 1]
DHLM_Z0 = np.array([1.0, 1.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0])


@numba.njit(inline="always", fastmath={"contract", "arcp"}, error_model="numpy")
def dhlm_f(t, x1, x2, zh1, zh2, xh1, xh2, th1, th2, om):
    """The DHLM right-hand side, scalars in, the derivative as a tuple out (hgo's kernel
    flags: ``hand_unrolled`` inlines it into every stage)."""
    u = 5.0 * (math.sin(2.0 * t) + math.cos(3.0 * t))
    e = x1 - zh1  # y = x1 (no noise)
    i1 = min(max(zh1, -DHLM_S), DHLM_S) - xh1  # z_h^s - x^
    i2 = min(max(zh2, -DHLM_S), DHLM_S) - xh2
    psi2 = -math.sin(x1)  # psi = [u, -sin y]
    # omega^ (its law off in the preset) stays 0 but counts in the error norm, as in hgo's
    return (x2, (u - 0.5 * DHLM_MGL * math.sin(x1)) / DHLM_I,
            zh2 + DHLM_G1 / DHLM_EPS * e, DHLM_G2 / DHLM_EPS ** 2 * e,
            xh2 + DHLM_L11 * i1, u * th1 + psi2 * th2 + DHLM_L21 * i1 + DHLM_L22 * i2,
            DHLM_DELTA * u * i2 - DHLM_SIGMA * th1, DHLM_DELTA * psi2 * i2 - DHLM_SIGMA * th2,
            0.0)


# Moreno Section 5 with the `sin` profile (conf/controller/moreno_sin.yaml)
MORENO_A, MORENO_AMP = 0.5, 2.0
MORENO_L1, MORENO_L2, MORENO_N = 200.0, 120.0, 2.0
MORENO_Z0 = np.array([0.0, 0.0, -70.0, 50.0])  # x(0) = 0, x^(0) = x(0) - e(0)


@numba.njit(inline="always")
def moreno_u(t):
    """u = r' + a r with r = 2 sin t (``controller=moreno_sin``)."""
    return MORENO_AMP * math.cos(t) + MORENO_A * MORENO_AMP * math.sin(t)


@numba.njit(inline="always")
def moreno_f(t, m, x1, x2, xh1, xh2):
    """The Moreno right-hand side (plant of Section 5, observer (3)), y = x1 + m; scalars in,
    the derivative as a tuple out (``hand_unrolled`` inlines it into every stage)."""
    u = moreno_u(t)
    innov = x1 + m - xh1
    s = xh2 + MORENO_N * innov  # H x^ + N (y - C x^)
    psi = s * (s * s - 2.0)  # psi(s) = s^3 - 2 s
    return (-x1 + x2 * (x2 * x2 - 1.0), -MORENO_A * x2 + u,
            -xh1 + xh2 + MORENO_L1 * innov + psi, -MORENO_A * xh2 + MORENO_L2 * innov + u)


@numba.njit(inline="always")
def moreno_rhs(t, w, p, m, dw):
    """:func:`moreno_f` on the arrays of ``hand_dop853``."""
    dw[0], dw[1], dw[2], dw[3] = moreno_f(t, m, w[0], w[1], w[2], w[3])


@numba.njit(inline="always")
def moreno_errors(t, w, p, m, sq):
    """hgo's window errors: x^ against x, and y^ = x^1 against y = x1."""
    sq[0] = (w[2] - w[0]) ** 2
    sq[1] = (w[3] - w[1]) ** 2
    sq[2] = (w[2] - w[0]) ** 2


@numba.njit(inline="always")
def moreno_signals(t, rec, k, p, m):
    """What hgo records besides the state at output k, into ``rec[k, 4:]``: t, y = x1 + m,
    m, u = r' + a r, x^ = (x^1, x^2) (hgo's Trajectory.t, y, m, u, xh)."""
    rec[k, 4] = t
    rec[k, 5] = rec[k, 0] + m
    rec[k, 6] = m
    rec[k, 7] = moreno_u(t)
    rec[k, 8] = rec[k, 2]
    rec[k, 9] = rec[k, 3]


moreno_kernel = dop853_kernel(moreno_rhs, 4, moreno_errors, 2)
# the same run recording hgo's other signals too (rec with 10 columns: moreno_signals)
moreno_kernel_signals = dop853_kernel(moreno_rhs, 4, moreno_errors, 2, moreno_signals)


# Andrieu, Praly & Astolfi, apa_fig2 (conf/experiment/apa_fig2.yaml): the Contois plant
# (11), true hbar = 1, and each of the three observers (7)-(8) (model hbar_o = 0.8) with its
# own copy of the plant (the preset's solver.split_observers): state [eta1, eta2, x^1, x^2,
# L]; y = eta1 + noise held 0.01; u from the schedule of Section 3.1. The model's bounds
# (f2 of (12), Omega1, Omega2: an exact maximisation) are hgo.plants.contois's functions,
# the rest is written out for n = 2 with every setting a compile-time constant.
APA_OBSERVERS = {  # rate bound kind (0 df2max, 1 Omega1, 2 Omega2), p = d_inf, dynamic gain
    "df2max": (0, 0.0, False), "omega1": (1, 0.0, True), "omega2": (2, 0.9, True)}
APA_PHI, APA_ELL, APA_HBAR_O = (3.0, 0.01, 3.0), 3.0, 0.8
APA_U_RANGE, APA_ETA0, APA_ETA_HAT0 = (0.01, 0.7), (0.3, 0.5), (0.5, 0.3)


@numba.njit(inline="always")
def apa_input(t):
    """u of Section 3.1 (reading C1): 0.5, 0.02 from t = 10, 0.6 from 20, 0.1 from 35."""
    if t < 10.0:
        return 0.5
    if t < 20.0:
        return 0.02
    return 0.6 if t < 35.0 else 0.1


@numba.njit(inline="always")
def _spow(w, r):
    """Signed power sign(w) |w|^r; w itself at r = 1 (the df2max and Omega1 observers, p = 0:
    r a compile-time constant, the branch folded away)."""
    if r == 1.0:
        return w
    return math.copysign(math.pow(abs(w), r), w)


@numba.njit(inline="always")
def apa_f(t, m, eta1, eta2, x1, x2, L, kind, q, dynamic, eps1, eps2, dfmax):
    """Plant (11) (hbar = 1) and observer (7)-(8) (n = 2, b = 1/2, model hbar_o) with the rate
    bound ``kind``, p = ``q`` and a dynamic or constant gain; y = eta1 + m. Scalars in, the
    derivative as a tuple out; every argument after L a compile-time constant where the
    kernels call it."""
    u = apa_input(t)
    r = reaction_rate(eta1, eta2, 1.0)
    y = eta1 + m
    ys = clip(y, eps1, 1.0 - eps2)
    Lb = math.sqrt(L)  # L^b, b = 1/2
    s = (x1 - ys) / Lb
    k1 = s + _spow(s, 1.0 / (1.0 - q))  # k1(s) = s + s^(1/(1-q)); k2(w) = w + w^(1+q)
    k2 = APA_ELL * k1 + _spow(APA_ELL * k1, 1.0 + q)
    f2s, omega = model_terms(kind, u, ys, x2, q, APA_HBAR_O, eps2, dfmax)
    phi1, phi2, phi3 = APA_PHI
    return (r - u * eta1, -r + u * (1.0 - eta2), x2 - u * y - L * Lb * k1,
            f2s - L * L * Lb * k2, L * (phi1 * (phi2 - L) + phi3 * omega) if dynamic else 0.0)


@numba.njit(inline="always")
def apa_estimate(x1, x2, eps1, eps2):
    """eta^ = F^{-1} of the saturated x^ (bounds at the saturated x^1, reading C7)."""
    x1s = clip(x1, eps1, 1.0 - eps2)
    x2s = clip(x2, x2_low(x1s, eps2, APA_HBAR_O), x2_high(x1s, APA_HBAR_O))
    return x1s, eta2_of_x(x1s, x2s, APA_HBAR_O)


def apa_constants(name: str) -> dict:
    """The compile-time constants of the observer ``name``: kind, q, dynamic, eps1, eps2,
    dfmax (the arguments of :func:`apa_f` after L)."""
    kind, q, dynamic = APA_OBSERVERS[name]
    eps1, eps2 = invariance_eps(APA_HBAR_O, *APA_U_RANGE)
    return {"kind": kind, "q": q, "dynamic": dynamic, "eps1": eps1, "eps2": eps2,
            "dfmax": df2max(APA_HBAR_O, *APA_U_RANGE)["df2max"]}


def apa_start(name: str, m0: float) -> np.ndarray:
    """z(0) of the observer ``name``'s part, L(0) = phi2 + (phi3/phi1) Omega(0) with y(0)
    including the first noise sample ``m0`` (reading C6, hgo's update at t = 0)."""
    c = apa_constants(name)
    phi1, phi2, phi3 = APA_PHI
    x_hat = to_x(APA_ETA_HAT0, APA_HBAR_O)
    ys = clip(APA_ETA0[0] + m0, c["eps1"], 1.0 - c["eps2"])
    omega = model_terms(c["kind"], apa_input(0.0), ys, x_hat[1], c["q"], APA_HBAR_O,
                        c["eps2"], c["dfmax"])[1]
    return np.array([*APA_ETA0, *x_hat, phi2 + phi3 / phi1 * omega])
