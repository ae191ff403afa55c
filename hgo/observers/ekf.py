"""Extended Kalman filters on any plant with named parameters: continuous (Kalman–Bucy)
and continuous–discrete.

Both use the plant's own f and h and their Jacobians A = df/dx (x^, u), C = dh/dx (x^)
(:mod:`hgo.observers.plant_model`); the observer's state is z = [x^ (n) | P's upper
triangle (n (n + 1) / 2)], so P stays symmetric by construction, and its smallest
eigenvalue is a recorded signal (discrete state ``P_min_eig``). A P that is no longer
positive definite (that eigenvalue <= 0, or not finite) makes x^ non-finite, so the run
stops there, its one-line status "non-finite state (observer <name>: the covariance P is
no longer positive definite (smallest eigenvalue ...))" (``Observer.explain``).

* :func:`ekf`, continuous time (Kalman & Bucy 1961, extended to f and h):

      x^' = f(x^, u) + K (y - h(x^)),   K = P C^T R^-1,
      P'  = A P + P A^T + Q - P C^T R^-1 C P,

  Q and R spectral densities (the default R: :mod:`hgo.observers.kalman_tuning`). The
  smallest eigenvalue of P is evaluated after every integration step. Its gain K is not
  known in advance (it follows P), so it declares no spectral radius of its own: with
  ``solver.method=rk4`` the step h_max must resolve the filter's dynamics (the adaptive
  methods control their error).

* :func:`ekf_cd`, continuous–discrete (Jazwinski 1970): between measurement instants
  t_k = k T the prediction

      x^' = f(x^, u),   P' = A P + P A^T,

  and at each instant (the engine ends a step there, ``Observer.sample_period``; the
  first at t_1 = T) the process noise of the interval and the measurement y_k:

      P- = P + Q,   S = C P- C^T + R,   K = P- C^T S^-1,
      x^+ = x^ + K (y_k - h(x^)),   P+ = P- - K S K^T,

  Q the covariance the process noise adds over one period (as in a discrete filter and
  filterpy's), R the measurement's covariance. The measurement at t_k is the engine's y
  at the end of the step that ends there: h(x(t_k)) plus the noise sample held up to
  t_k (a sample held over [t_(k-1), t_k) when T is the noise period: each instant gets
  its own sample; a first update at t = 0 would share t_1's). It is kept in the discrete
  state (``y_<output>``), with the index k of the next instant (``sample``).

Example:
    ```python
    from hgo.observers.ekf import ekf, ekf_cd
    from hgo.plants.van_der_pol import van_der_pol_plant

    vdp = van_der_pol_plant(mu=1.0)
    filt = ekf("ekf", plant=vdp, Q=0.0, R=1e-6, P0=1.0)
    print(filt.state_names[2:])  # ['P_x1_x1', 'P_x1_x2', 'P_x2_x2']
    print(ekf_cd("cd", plant=vdp, R=1e-6, sample_period=0.01).sample_period)  # 0.01
    ```

    In a config: ``observer=ekf`` or ``observer=ekf_cd`` (``conf/observer/``).
"""

from __future__ import annotations

import functools
import math
from collections.abc import Mapping, Sequence

import numpy as np

from hgo.core.components import Observer, Plant
from hgo.engine.jit import matrix_view, record_helper
from hgo.observers.kalman_linalg import (
    cholesky,
    pack_symmetric,
    smallest_eigenvalue,
    solve_rows,
    unpack_symmetric,
)
from hgo.observers.kalman_tuning import (
    covariance,
    initial_estimate,
    noise_variance,
)
from hgo.observers.kalman_tuning import sample_period as measurement_period
from hgo.observers.plant_model import jacobian_f, jacobian_h, model_params

_INSTANT_TOL = 1e-9  # of the period: a step end this close to k T is the instant k T


def _work_size(n: int, m: int) -> int:
    """Floats of scratch space of :func:`_work`."""
    return 3 * n * n + 3 * m * n + 2 * m * m + 3 * n + 3 * m


@record_helper
def _work(p):
    """The filter's work matrices and vectors, views of its scratch space:
    P, A, W (n x n), C (m x n), PCt, K (n x m), S, L (m x m), yh, yp, ym (m), xw, fp, fm (n)."""
    n, m = p.kf_nx, p.kf_ny
    w, o = p.scratch, p.kf_work
    P = matrix_view(w, o, n, n)
    A = matrix_view(w, o + n * n, n, n)
    W = matrix_view(w, o + 2 * n * n, n, n)
    o += 3 * n * n
    C = matrix_view(w, o, m, n)
    PCt = matrix_view(w, o + m * n, n, m)
    K = matrix_view(w, o + 2 * m * n, n, m)
    o += 3 * m * n
    S = matrix_view(w, o, m, m)
    L = matrix_view(w, o + m * m, m, m)
    o += 2 * m * m
    yh, yp, ym = w[o:o + m], w[o + m:o + 2 * m], w[o + 2 * m:o + 3 * m]
    o += 3 * m
    xw, fp, fm = w[o:o + n], w[o + n:o + 2 * n], w[o + 2 * n:o + 3 * n]
    return P, A, W, C, PCt, K, S, L, yh, yp, ym, xw, fp, fm


@record_helper
def _gain_terms(t, x, P, p, C, PCt, yh, xw, yp, ym):
    """C = dh/dx (x), y^ = h(x) into yh, and P C^T into PCt."""
    n, m = p.kf_nx, p.kf_ny
    jacobian_h(t, x, p, C, xw, yp, ym)
    p.kf_h(t, x, p, yh)
    for i in range(n):
        for k in range(m):
            v = 0.0
            for j in range(n):
                v += P[i, j] * C[k, j]
            PCt[i, k] = v


@record_helper
def _covariance_rate(t, x, u, P, p, A, W, xw, fp, fm, dP):
    """The upper triangle of A P + P A^T into dP (the Q and gain terms are the caller's);
    W: A P."""
    n = p.kf_nx
    jacobian_f(t, x, u, p, A, xw, fp, fm)
    for i in range(n):
        for j in range(n):
            v = 0.0
            for k in range(n):
                v += A[i, k] * P[k, j]
            W[i, j] = v
    k = 0
    for i in range(n):
        for j in range(i, n):
            dP[k] = W[i, j] + W[j, i]
            k += 1


@record_helper
def _check_definite(z, d, P, p, W, slot):
    """P's smallest eigenvalue into d[slot]; x^ non-finite (the run stops) if P is not
    positive definite."""
    low = smallest_eigenvalue(P, p.kf_nx, W)
    d[slot] = low
    if not low > 0.0:
        z[0] = math.nan


def ekf_f(t, z, d, y, u, p, dz):
    """x^' = f(x^, u) + K (y - h(x^)), P' = A P + P A^T + Q - K R K^T, K = P C^T R^-1."""
    n, m = p.kf_nx, p.kf_ny
    P, A, W, C, PCt, K, S, L, yh, yp, ym, xw, fp, fm = _work(p)
    x = z[:n]
    unpack_symmetric(z[n:], n, P)
    p.kf_f(t, x, u, p, dz[:n])
    _gain_terms(t, x, P, p, C, PCt, yh, xw, yp, ym)
    for i in range(n):
        for k in range(m):
            v = 0.0
            for j in range(m):
                v += PCt[i, j] * p.kf_Rinv[j, k]
            K[i, k] = v
        for k in range(m):
            dz[i] += K[i, k] * (y[k] - yh[k])
    dP = dz[n:]
    _covariance_rate(t, x, u, P, p, A, W, xw, fp, fm, dP)
    k = 0
    for i in range(n):
        for j in range(i, n):
            v = p.kf_Q[i, j]
            for c in range(m):  # P C^T R^-1 C P = K (P C^T)^T
                v -= K[i, c] * PCt[j, c]
            dP[k] += v
            k += 1


def ekf_update(t, z, d, y, u, p):
    """P's smallest eigenvalue after every step (d[0]); the run stops if it is <= 0."""
    n = p.kf_nx
    P, A, W = _work(p)[:3]
    unpack_symmetric(z[n:], n, P)
    _check_definite(z, d, P, p, W, 0)


def ekf_cd_f(t, z, d, y, u, p, dz):
    """The prediction: x^' = f(x^, u), P' = A P + P A^T."""
    n = p.kf_nx
    P, A, W, C, PCt, K, S, L, yh, yp, ym, xw, fp, fm = _work(p)
    x = z[:n]
    unpack_symmetric(z[n:], n, P)
    p.kf_f(t, x, u, p, dz[:n])
    _covariance_rate(t, x, u, P, p, A, W, xw, fp, fm, dz[n:])


def ekf_cd_update(t, z, d, y, u, p):
    """At the instant k T (d[0] = k): P- = P + Q, then the measurement update (module doc)."""
    if not t >= d[0] * p.kf_Ts - _INSTANT_TOL * p.kf_Ts:
        return
    n, m = p.kf_nx, p.kf_ny
    P, A, W, C, PCt, K, S, L, yh, yp, ym, xw, fp, fm = _work(p)
    x = z[:n]
    unpack_symmetric(z[n:], n, P)
    for i in range(n):
        for j in range(n):
            P[i, j] += p.kf_Q[i, j]
    _check_definite(z, d, P, p, W, 1)  # P- (P+ below)
    if not d[1] > 0.0:
        return
    _gain_terms(t, x, P, p, C, PCt, yh, xw, yp, ym)
    for a in range(m):  # S = C P- C^T + R
        for b in range(m):
            v = p.kf_R[a, b]
            for j in range(n):
                v += C[a, j] * PCt[j, b]
            S[a, b] = v
    if not cholesky(S, m, L):  # (S = C P- C^T + R: only by rounding, P- and R definite)
        d[1] = math.nan
        z[0] = math.nan
        return
    for i in range(n):
        for k in range(m):
            K[i, k] = PCt[i, k]
    solve_rows(L, m, K, n)  # K = P- C^T S^-1
    for i in range(n):
        for k in range(m):
            x[i] += K[i, k] * (y[k] - yh[k])
    for i in range(n):  # P+ = P- - K S K^T = P- - K (P- C^T)^T
        for j in range(n):
            v = 0.0
            for k in range(m):
                v += K[i, k] * PCt[j, k]
            W[i, j] = P[i, j] - v
    for i in range(n):
        for j in range(i, n):
            P[i, j] = 0.5 * (W[i, j] + W[j, i])
            P[j, i] = P[i, j]
    pack_symmetric(P, n, z[n:])
    d[0] += 1.0
    for k in range(m):
        d[2 + k] = y[k]
    _check_definite(z, d, P, p, W, 1)


def ekf_estimate(t, z, d, p, xhat):
    """x^ = the first n entries of z."""
    for i in range(p.kf_nx):
        xhat[i] = z[i]


def lost_definiteness(name: str, slot: int, d: np.ndarray) -> str:
    """``Observer.explain`` of the filters: their P not positive definite at the stop
    (d[slot], P's smallest eigenvalue, <= 0 or NaN), else ""."""
    if d[slot] > 0:
        return ""
    return (f"observer {name}: the covariance P is no longer positive definite (smallest "
            f"eigenvalue {d[slot]:.3g})")


def triangle_names(names: Sequence[str]) -> list[str]:
    """Names of P's upper triangle entries, row by row: P_x1_x1, P_x1_x2, ..."""
    return [f"P_{a}_{b}" for i, a in enumerate(names) for b in names[i:]]


def _tuning(key: str, plant: Plant, Q, R, P0, noise, continuous: bool) -> tuple:
    states, outputs = plant.state_names, plant.output_names
    Qm = covariance(f"{key}.Q", Q, states, definite=False)
    Rm = covariance(f"{key}.R", noise_variance(key, noise, outputs, continuous)
                    if R is None else R, outputs, definite=True)
    P0m = covariance(f"{key}.P0", P0, states, definite=True)
    return Qm, Rm, P0m


def _observer(name: str, plant: Plant, xhat0, P0: np.ndarray, **kwargs) -> Observer:
    """The EKF's Observer: z = [x^ | P's triangle], every output and input read."""
    n = plant.nx
    x0 = initial_estimate(f"observer.{name}", xhat0, plant)
    tri = np.empty(n * (n + 1) // 2)
    pack_symmetric(P0, n, tri)
    return Observer(name=name, state_names=[f"{s}_hat" for s in plant.state_names]
                    + triangle_names(plant.state_names), estimated_states=list(range(n)),
                    z0=np.concatenate([x0, tri]), signals={"P": list(range(n, n + tri.size))},
                    reads_outputs=list(range(len(plant.output_names))),
                    reads_inputs=list(range(len(plant.input_names))),
                    estimate=ekf_estimate, spectral_radius=plant.spectral_radius,
                    explain=functools.partial(lost_definiteness, name,
                                              kwargs["disc_names"].index("P_min_eig")),
                    **kwargs)


def ekf(name: str, plant: Plant, Q: object = 0.0, R: object = None, P0: object = 1.0,
        xhat0: Sequence[float] | None = None, noise: Mapping | None = None) -> Observer:
    """The continuous-time extended Kalman filter (module doc) of ``plant``.

    ``Q``, ``R`` (default from ``noise``), ``P0``: :mod:`hgo.observers.kalman_tuning`;
    ``xhat0``: x^(0), default the plant's x(0)."""
    key = f"observer.{name}"
    Qm, Rm, P0m = _tuning(key, plant, Q, R, P0, noise, continuous=True)
    n, m = plant.nx, len(plant.output_names)
    p = model_params(plant, key, _work_size(n, m), {},
                     {"kf_Q": Qm, "kf_R": Rm, "kf_Rinv": np.linalg.inv(Rm)})
    return _observer(name, plant, xhat0, P0m, disc_names=["P_min_eig"],
                     d0=np.array([float(np.linalg.eigvalsh(P0m)[0])]), p=p, f=ekf_f,
                     update=ekf_update)


def ekf_cd(name: str, plant: Plant, Q: object = 0.0, R: object = None, P0: object = 1.0,
           sample_period: float | None = None, xhat0: Sequence[float] | None = None,
           noise: Mapping | None = None) -> Observer:
    """The continuous–discrete extended Kalman filter (module doc) of ``plant``,
    measuring every ``sample_period`` seconds (default: the noise model's period)."""
    key = f"observer.{name}"
    Qm, Rm, P0m = _tuning(key, plant, Q, R, P0, noise, continuous=False)
    Ts = measurement_period(key, sample_period, noise)
    n, m = plant.nx, len(plant.output_names)
    p = model_params(plant, key, _work_size(n, m), {},
                     {"kf_Q": Qm, "kf_R": Rm, "kf_Ts": Ts})
    return _observer(name, plant, xhat0, P0m, disc_names=sampled_names(plant), p=p,
                     d0=sampled_d0(P0m, m), f=ekf_cd_f, update=ekf_cd_update,
                     sample_period=Ts)



def sampled_names(plant: Plant) -> list[str]:
    """The discrete state of a continuous–discrete filter: the next instant's index k, P's
    smallest eigenvalue after the last update, the measurement it took."""
    return ["sample", "P_min_eig", *(f"y_{o}" for o in plant.output_names)]


def sampled_d0(P0: np.ndarray, m: int) -> np.ndarray:
    """Before the first instant t_1: k = 1, P0's smallest eigenvalue, no measurement (NaN)."""
    return np.array([1.0, float(np.linalg.eigvalsh(P0)[0]), *([math.nan] * m)])
