"""Notch filter of the estimates, Sanfelice & Praly Section 3 (Fig. 4):

    T(s) = (s^2 + 2 phi1 w0 s + w0^2) / (s^2 + 2 phi2 w0 s + w0^2),

defaults w0 = 2 pi / 2.23 rad/s, phi1 = 0 (an exact zero at w0), phi2 = 1, applied to every
estimate of every observer (for a collection: to its average <x^>).

Discretisation (exact for the output grid)
------------------------------------------
The filter is applied after the simulation to the recorded estimates, sampled every
dt = solver.dt_out. The estimates are smooth, so between two samples they are taken to be
*linear in time* (first-order hold): T(s) in state space is discretised with
``scipy.signal.cont2discrete(..., dt, method="foh")``, which is the exact solution of the
continuous filter driven by the piecewise-linear interpolation of the samples, at the
sampling instants (computed here with one matrix exponential, in the filter's own state
coordinates). The only error is the interpolation of x^ between samples, O(dt^2 x^''/8),
~1e-4 at w0 with dt = 0.01 s; a notch for the wrong sample rate would put its zero
elsewhere (see tests: sin(w0 t) is removed to ~1e-3 peak-to-peak). ``method="zoh"``
(input held constant between samples) is available for comparison.

Initial filter state (``init``): "steady" (default) starts the filter at the equilibrium of
a constant input x^(0) (T(0) = 1, so x^_f(0) = x^(0) and no start-up transient); "zero"
starts it at rest, as an analogue filter switched on at t = 0 would be.

Outputs: the series ``/observer/<name>/xhat_f`` (columns ``<x>_hat_f``) and, per observer
and state, rows over the trailing window:

* ``mean_sq_error_<x>_f``: (1/T) int |x^_f - x|^2 (trapezoid, like the runner's rows);
* ``amplitude_xhat<k>`` and ``amplitude_xhat<k>_f``: peak-to-peak before / after;
* ``notch_reduction_xhat<k>``: their ratio (before / after).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from hgo.engine.simulate import Trajectory
from hgo.engine.system import System
from hgo.outputs.recording import Series
from hgo.postprocess import PostOutput
from hgo.postprocess.oscillation import peak_to_peak, window_slice


@dataclass(frozen=True)
class DiscreteFilter:
    """x_{k+1} = Phi x_k + G1 u_k + G2 (u_{k+1} - u_k),  y_k = C x_k + D u_k.

    The state x is the continuous filter's state at the sampling instants (so "zero" and
    "steady" initial states mean what they say); G2 = 0 for the zero-order hold.
    """

    Phi: np.ndarray
    G1: np.ndarray
    G2: np.ndarray
    A: np.ndarray
    B: np.ndarray
    C: np.ndarray
    D: float


def discrete_notch(w0: float, phi1: float, phi2: float, dt: float,
                   method: str = "foh") -> DiscreteFilter:
    """T(s) discretised exactly for sample time dt under the chosen input hold.

    With M = [[A, B, 0], [0, 0, 1], [0, 0, 0]], expm(M dt) = [[Phi, G1, G2'], ...] where
    G1 = int_0^dt e^(A s) ds B and G2' = int_0^dt e^(A s) (dt - s) ds B; an input linear
    on [t_k, t_k+1] gives x_{k+1} = Phi x_k + G1 u_k + (G2'/dt)(u_{k+1} - u_k) exactly
    (the same map as ``scipy.signal.cont2discrete(..., method="foh")``, in the original
    state coordinates).
    """
    from scipy.linalg import expm

    A, B, C, D = notch_state_space(w0, phi1, phi2)
    n = A.shape[0]
    M = np.zeros((n + 2, n + 2))
    M[:n, :n] = A
    M[:n, n] = B
    M[n, n + 1] = 1.0
    E = expm(M * dt)
    Phi, G1, G2 = E[:n, :n], E[:n, n], E[:n, n + 1] / dt
    if method == "zoh":
        G2 = np.zeros(n)
    return DiscreteFilter(Phi, G1, G2, A, B, C, D)


def notch_state_space(w0: float, phi1: float, phi2: float
                      ) -> tuple[np.ndarray, np.ndarray, np.ndarray, float]:
    """T(s) in controller canonical form, x' = A x + B u, y = C x + D u: what
    ``scipy.signal.tf2ss`` returns for it (the same operations, so the same bits; the test
    compares them), without importing ``scipy.signal`` (1.2-1.7 s of a run on a 2-core VM,
    for a 2 x 2 matrix)."""
    a1, a2 = 2 * phi2 * w0, w0**2  # s^2 + a1 s + a2: monic, so tf2ss divides by 1.0
    b1, b2 = 2 * phi1 * w0, w0**2
    A = np.array([[-a1, -a2], [1.0, 0.0]])
    B = np.array([1.0, 0.0])
    C = np.array([b1 - a1, b2 - a2])  # numerator minus D times the denominator, D = 1
    return A, B, C, 1.0


def filter_signal(v: np.ndarray, filt: DiscreteFilter, init: str = "steady") -> np.ndarray:
    """Filter each column of v (N, S); ``init`` 'steady' (equilibrium for v[0]) or 'zero'."""
    v = np.asarray(v, float)
    N, S = v.shape
    n = filt.Phi.shape[0]
    if init == "steady":  # A x + B u0 = 0
        x = -np.linalg.solve(filt.A, filt.B)[:, None] * v[0][None, :]
    else:
        x = np.zeros((n, S))
    out = np.empty_like(v)
    Phi, G1, G2, C = filt.Phi, filt.G1[:, None], filt.G2[:, None], filt.C
    for k in range(N):
        out[k] = C @ x + filt.D * v[k]
        if k + 1 < N:
            x = Phi @ x + G1 * v[k] + G2 * (v[k + 1] - v[k])
    return out


def window_mean_sq(t: np.ndarray, e: np.ndarray) -> float:
    """(1/T) int e^2 dt by the trapezoid rule over the samples given."""
    T = t[-1] - t[0]
    return float(np.trapezoid(e**2, t) / T) if T > 0 else math.nan


@dataclass
class Notch:
    """Post-processor: the notch filter T(s) on every observer's estimates."""

    w0: float
    phi1: float = 0.0
    phi2: float = 1.0
    method: str = "foh"
    init: str = "steady"

    def apply(self, system: System, traj: Trajectory) -> PostOutput:
        dt = float(traj.t[1] - traj.t[0])
        filt = discrete_notch(self.w0, self.phi1, self.phi2, dt, self.method)
        sl = window_slice(traj)
        x = traj.z[:, : system.plant.nx]
        out = PostOutput()
        for obs, (xa, xb) in zip(system.observers, system.xh_slices, strict=True):
            xh = traj.xh[:, xa:xb]
            xf = filter_signal(xh, filt, self.init)
            names = [system.plant.state_names[i] for i in obs.estimated_states]
            out.series.append(Series(f"/observer/{obs.name}/xhat_f",
                                     [f"{n}_hat_f" for n in names], xf))
            for j, (i, name) in enumerate(zip(obs.estimated_states, names, strict=True)):
                before, after = peak_to_peak(xh[sl, j]), peak_to_peak(xf[sl, j])
                out.rows += [
                    {"observer": obs.name, "quantity": f"mean_sq_error_{name}_f",
                     "empirical": window_mean_sq(traj.t[sl], xf[sl, j] - x[sl, i])},
                    {"observer": obs.name, "quantity": f"amplitude_xhat{i + 1}",
                     "empirical": before},
                    {"observer": obs.name, "quantity": f"amplitude_xhat{i + 1}_f",
                     "empirical": after},
                    {"observer": obs.name, "quantity": f"notch_reduction_xhat{i + 1}",
                     "empirical": before / after if after > 0 else math.inf},
                ]
        return out


def notch(w0: float | None = None, period: float = 2.23, phi1: float = 0.0, phi2: float = 1.0,
          method: str = "foh", init: str = "steady") -> Notch:
    """Factory: centre w0 (rad/s), or 2 pi / period when w0 is None (paper: 2.23 s)."""
    if w0 is None:
        if not period > 0:
            raise ValueError(f"postprocess.notch.period must be > 0, got {period}")
        w0 = 2 * math.pi / period
    if not w0 > 0:
        raise ValueError(f"postprocess.notch.w0 must be > 0, got {w0}")
    if phi1 < 0 or not phi2 > 0:
        raise ValueError(f"postprocess.notch: need phi1 >= 0 and phi2 > 0, got {phi1}, {phi2}")
    if method not in ("foh", "zoh"):
        raise ValueError(f"postprocess.notch.method: '{method}' not in ['foh', 'zoh']")
    if init not in ("steady", "zero"):
        raise ValueError(f"postprocess.notch.init: '{init}' not in ['steady', 'zero']")
    return Notch(float(w0), float(phi1), float(phi2), method, init)
