"""Unscented Kalman filter, continuous–discrete, on any plant with named parameters:
scaled sigma points (Julier 2002; Wan & van der Merwe 2000, Algorithm 3.1) predicted
through the plant's own integrated dynamics.

The observer's state is the 2n + 1 sigma points chi_0, ..., chi_2n (n entries each, chi_0
first), each obeying the plant's chi_i' = f(chi_i, u) between measurement instants
t_k = k T: the engine integrates them with the plant, with the run's integrator and
tolerances. With lambda = alpha^2 (n + kappa) - n and gamma = sqrt(n + lambda), the
weights are

    Wm_0 = lambda / (n + lambda),   Wc_0 = Wm_0 + 1 - alpha^2 + beta,
    Wm_i = Wc_i = 1 / (2 (n + lambda)),   i = 1..2n,

and sigma points of a mean m and covariance P (L L^T = P, Cholesky):
chi_0 = m, chi_i = m + gamma L_i, chi_(n+i) = m - gamma L_i (L_i the i-th column of L).

At each instant t_k (the engine ends a step there, ``Observer.sample_period``; the first
at t_1 = T; the measurement as in :mod:`hgo.observers.ekf`):

    x- = sum Wm_i chi_i,   P- = sum Wc_i (chi_i - x-)(chi_i - x-)^T + Q,
    chi_i redrawn from (x-, P-) (so that Q enters the measurement's statistics),
    y^ = sum Wm_i h(chi_i),   S = sum Wc_i (h(chi_i) - y^)(h(chi_i) - y^)^T + R,
    P_xy = sum Wc_i (chi_i - x-)(h(chi_i) - y^)^T,   K = P_xy S^-1,
    x+ = x- + K (y_k - y^),   P+ = P- - K S K^T,

and the sigma points start afresh from (x+, P+). The estimate x^ is sum Wm_i chi_i: the
predicted mean between instants, x+ at an instant. Q is the covariance the process noise
adds over one period, as for :func:`hgo.observers.ekf.ekf_cd` and filterpy's
``UnscentedKalmanFilter`` (2.0: whose predict, sigma points redrawn from the prior
included, and update these are; tests/test_kalman.py compares the two). A P- or P+ that
is not positive definite (no Cholesky factor) makes the estimate non-finite: the run
stops there, and says why in its status line (``Observer.explain``, as
:mod:`hgo.observers.ekf`).

Example:
    ```python
    from hgo.observers.ukf import ukf
    from hgo.plants.van_der_pol import van_der_pol_plant

    filt = ukf("ukf", plant=van_der_pol_plant(mu=1.0), R=1e-6, sample_period=0.01)
    print(len(filt.state_names), filt.sample_period)  # 10 0.01
    ```

    In a config: ``observer=ukf`` (``conf/observer/ukf.yaml``).
"""

from __future__ import annotations

import functools
import math
from collections.abc import Mapping, Sequence

import numpy as np

from hgo.core.components import Observer, Plant
from hgo.engine.jit import matrix_view, record_helper
from hgo.observers.ekf import lost_definiteness, sampled_d0, sampled_names
from hgo.observers.kalman_linalg import cholesky, smallest_eigenvalue, solve_rows
from hgo.observers.kalman_tuning import covariance, initial_estimate, noise_variance
from hgo.observers.kalman_tuning import sample_period as measurement_period
from hgo.observers.plant_model import model_params

_INSTANT_TOL = 1e-9  # of the period: a step end this close to k T is the instant k T


def _work_size(n: int, m: int) -> int:
    """Floats of scratch space of :func:`_work`."""
    return (2 * n + 1) * (n + m) + 3 * n * n + 2 * n * m + 2 * m * m + n + m


@record_helper
def _work(p):
    """Views of the scratch space: X ((2n+1) x n, sigma points), Y ((2n+1) x m, their
    outputs), P, L, W (n x n), Pxy, K (n x m), S, Ls (m x m), xm (n), ym (m)."""
    n, m = p.kf_nx, p.kf_ny
    w, o = p.scratch, p.kf_work
    N = 2 * n + 1
    X = matrix_view(w, o, N, n)
    Y = matrix_view(w, o + N * n, N, m)
    o += N * (n + m)
    P = matrix_view(w, o, n, n)
    L = matrix_view(w, o + n * n, n, n)
    W = matrix_view(w, o + 2 * n * n, n, n)
    o += 3 * n * n
    Pxy = matrix_view(w, o, n, m)
    K = matrix_view(w, o + n * m, n, m)
    o += 2 * n * m
    S = matrix_view(w, o, m, m)
    Ls = matrix_view(w, o + m * m, m, m)
    o += 2 * m * m
    return X, Y, P, L, W, Pxy, K, S, Ls, w[o:o + n], w[o + n:o + n + m]


@record_helper
def _moments(X, p, xm, P):
    """Weighted mean xm and covariance P (without Q) of the sigma points X."""
    n = p.kf_nx
    for j in range(n):
        v = 0.0
        for i in range(2 * n + 1):
            v += p.kf_Wm[i] * X[i, j]
        xm[j] = v
    for a in range(n):
        for b in range(a, n):
            v = 0.0
            for i in range(2 * n + 1):
                v += p.kf_Wc[i] * (X[i, a] - xm[a]) * (X[i, b] - xm[b])
            P[a, b] = v
            P[b, a] = v


@record_helper
def _sigma_points(xm, L, p, X):
    """chi_0 = m, chi_(1+j) = m + gamma L[:, j], chi_(1+n+j) = m - gamma L[:, j]."""
    n = p.kf_nx
    for a in range(n):
        X[0, a] = xm[a]
        for j in range(n):
            X[1 + j, a] = xm[a] + p.kf_gamma * L[a, j]
            X[1 + n + j, a] = xm[a] - p.kf_gamma * L[a, j]


def ukf_f(t, z, d, y, u, p, dz):
    """chi_i' = f(chi_i, u): every sigma point through the plant's dynamics."""
    n = p.kf_nx
    for i in range(2 * n + 1):
        p.kf_f(t, z[i * n:(i + 1) * n], u, p, dz[i * n:(i + 1) * n])


def ukf_update(t, z, d, y, u, p):
    """At the instant k T (d[0] = k): the prediction's moments, then the measurement
    update (module doc); the sigma points of (x+, P+) into z."""
    if not t >= d[0] * p.kf_Ts - _INSTANT_TOL * p.kf_Ts:
        return
    n, m = p.kf_nx, p.kf_ny
    N = 2 * n + 1
    X, Y, P, L, W, Pxy, K, S, Ls, xm, ym = _work(p)
    for i in range(N):
        for a in range(n):
            X[i, a] = z[i * n + a]
    _moments(X, p, xm, P)
    for a in range(n):
        for b in range(n):
            P[a, b] += p.kf_Q[a, b]
    if not cholesky(P, n, L):
        d[1] = smallest_eigenvalue(P, n, W)
        z[0] = math.nan
        return
    _sigma_points(xm, L, p, X)
    for i in range(N):
        p.kf_h(t, X[i], p, Y[i])
    for k in range(m):
        v = 0.0
        for i in range(N):
            v += p.kf_Wm[i] * Y[i, k]
        ym[k] = v
    for a in range(m):
        for b in range(m):
            v = p.kf_R[a, b]
            for i in range(N):
                v += p.kf_Wc[i] * (Y[i, a] - ym[a]) * (Y[i, b] - ym[b])
            S[a, b] = v
        for j in range(n):
            v = 0.0
            for i in range(N):
                v += p.kf_Wc[i] * (X[i, j] - xm[j]) * (Y[i, a] - ym[a])
            Pxy[j, a] = v
            K[j, a] = v
    if not cholesky(S, m, Ls):  # (S = P_yy + R: only by rounding, P- and R definite)
        d[1] = math.nan
        z[0] = math.nan
        return
    solve_rows(Ls, m, K, n)  # K = P_xy S^-1
    for j in range(n):
        for k in range(m):
            xm[j] += K[j, k] * (y[k] - ym[k])
    for a in range(n):  # P+ = P- - K S K^T = P- - K P_xy^T
        for b in range(a, n):
            v = 0.0
            for k in range(m):
                v += 0.5 * (K[a, k] * Pxy[b, k] + K[b, k] * Pxy[a, k])
            P[a, b] -= v
            P[b, a] = P[a, b]
    d[0] += 1.0
    for k in range(m):
        d[2 + k] = y[k]
    d[1] = smallest_eigenvalue(P, n, W)
    if not cholesky(P, n, L):
        d[1] = min(d[1], 0.0)  # (no factor: not definite, whatever the rounding says)
        z[0] = math.nan
        return
    _sigma_points(xm, L, p, X)
    for i in range(N):
        for a in range(n):
            z[i * n + a] = X[i, a]


def ukf_estimate(t, z, d, p, xhat):
    """x^ = sum Wm_i chi_i."""
    n = p.kf_nx
    for a in range(n):
        v = 0.0
        for i in range(2 * n + 1):
            v += p.kf_Wm[i] * z[i * n + a]
        xhat[a] = v


def weights(n: int, alpha: float, beta: float, kappa: float) -> tuple:
    """Wm, Wc (2n + 1 each) and gamma = sqrt(n + lambda) of the scaled sigma points."""
    lam = alpha * alpha * (n + kappa) - n
    Wm = np.full(2 * n + 1, 0.5 / (n + lam))
    Wc = Wm.copy()
    Wm[0] = lam / (n + lam)
    Wc[0] = Wm[0] + 1.0 - alpha * alpha + beta
    return Wm, Wc, math.sqrt(n + lam)


def sigma_points(x: np.ndarray, P: np.ndarray, gamma: float) -> np.ndarray:
    """The 2n + 1 sigma points of (x, P) as rows (module doc)."""
    L = np.linalg.cholesky(P)
    return np.vstack([x, x + gamma * L.T, x - gamma * L.T])


def ukf(name: str, plant: Plant, Q: object = 0.0, R: object = None, P0: object = 1.0,
        alpha: float = 1e-3, beta: float = 2.0, kappa: float = 0.0,
        sample_period: float | None = None, xhat0: Sequence[float] | None = None,
        noise: Mapping | None = None) -> Observer:
    """The continuous–discrete unscented Kalman filter (module doc) of ``plant``, measuring
    every ``sample_period`` seconds (default: the noise model's period). ``alpha``,
    ``beta``, ``kappa``: the scaled sigma points (defaults Wan & van der Merwe's
    alpha = 1e-3, beta = 2 (Gaussian), kappa = 0); ``Q``, ``R``, ``P0``:
    :mod:`hgo.observers.kalman_tuning`."""
    key = f"observer.{name}"
    states, outputs = plant.state_names, plant.output_names
    n, m = plant.nx, len(outputs)
    for k, v in (("alpha", alpha), ("beta", beta), ("kappa", kappa)):
        if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v):
            raise ValueError(f"{key}.{k} must be a finite number, got {v!r}")
    if not (alpha > 0 and n + kappa > 0):
        raise ValueError(f"{key}: need alpha > 0 and n + kappa > 0 (n = {n}), got "
                         f"alpha = {alpha}, kappa = {kappa}")
    Qm = covariance(f"{key}.Q", Q, states, definite=False)
    Rm = covariance(f"{key}.R", noise_variance(key, noise, outputs, False) if R is None
                    else R, outputs, definite=True)
    P0m = covariance(f"{key}.P0", P0, states, definite=True)
    Ts = measurement_period(key, sample_period, noise)
    x0 = initial_estimate(key, xhat0, plant)
    Wm, Wc, gamma = weights(n, float(alpha), float(beta), float(kappa))
    p = model_params(plant, key, _work_size(n, m), {},
                     {"kf_Q": Qm, "kf_R": Rm, "kf_Ts": Ts, "kf_Wm": Wm, "kf_Wc": Wc,
                      "kf_gamma": gamma})
    names = [f"chi{i}_{s}" for i in range(2 * n + 1) for s in states]
    return Observer(name=name, state_names=names, disc_names=sampled_names(plant),
                    estimated_states=list(range(n)),
                    z0=sigma_points(x0, P0m, gamma).ravel(), d0=sampled_d0(P0m, m), p=p,
                    f=ukf_f, estimate=ukf_estimate, update=ukf_update,
                    spectral_radius=plant.spectral_radius,
                    reads_outputs=list(range(m)),
                    reads_inputs=list(range(len(plant.input_names))), sample_period=Ts,
                    explain=functools.partial(lost_definiteness, name, 1))
