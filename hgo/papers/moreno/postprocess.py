"""Weak-observer certificate of Moreno (9)-(14), Theorems 2-3, Remark 6, along a run.

For every circle-criterion observer (:mod:`hgo.observers.circle_criterion`) of the run:

1. Design data (:func:`hgo.papers.moreno.theory.certificate_design`): K1^a (SDP), K~1,
   eps = f eps_max(K~1), P = argmax lambda_min(P), c of (11) (``lambda_P``).
2. Along the recorded trajectory (output grid; the integrals are trapezoids, a grid 10x
   finer changes them by < 1 %, ``tests/test_moreno_certificate.py``):
   sigma = H x, e = x - x^ (the paper's sign), z = H_N e, phi = psi(sigma) - psi(sigma - z),
   psi^ = psi(H x^ + N (y - C x^)), theta(sigma) = K1(sigma) - K~1 (10),
   varrho = c max(0, -theta) (11), I(t) = int_0^t varrho, eta(t, 0) = eps t - I(t) (12),
   V = e^T P e / 2.
3. Rows (``observer``, quantity): the certificate (13) (eta(t_f), tail slope), (14) by
   Remark 6.3 with window Delta (alpha1 = max windowed mean of varrho over t >= t_f/2 -
   Delta, ``holds14`` = alpha1 < eps, least gamma), Remark 6.1-6.2 (I(t_f), flat over the
   last quarter, max varrho over the last quarter), and the bounds checked on the run:
   (i) pointwise V'/V + eps - varrho <= 0 (its margin, and c_need, the least c for which it
   holds), (ii) ||e(t)|| <= sqrt(lam_M/lam_m) e^{-eta/2} ||e0|| (max ratio), the bound
   V(t) <= e^{-eta} V(0) as an ``empirical``/``bound`` row, and the error norms
   ||e|| at t = 1, 5, 10, 20, 40 s, the first time ||e|| < 1e-3 after which it stays below.
4. Series under ``/observer/<name>/``: ``e`` (x - x^), ``z``, ``psi`` (psi^ and phi),
   ``certificate`` (theta, varrho, eta, V, V_bound).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from scipy.integrate import cumulative_trapezoid

from hgo.controllers.profile_input import input_period
from hgo.engine.simulate import Trajectory
from hgo.engine.system import System
from hgo.observers.circle_criterion import CircleCriterionObserver
from hgo.outputs.recording import Series
from hgo.papers.moreno.theory import CertificateDesign, ErrorSystem, certificate_design
from hgo.plants.sector import sector_lower
from hgo.postprocess import PostOutput

NORM_TIMES = (1.0, 5.0, 10.0, 20.0, 40.0)
DEFAULT_WINDOW = 5.0  # Delta of Remark 6.3 for a non-periodic input (s)
LAMBDA_P = ("half_min_eig", "min_eig", "sharp")


def first_time_below(t: np.ndarray, x: np.ndarray, level: float) -> float:
    """First t after which x stays below ``level`` (linear interpolation at the crossing);
    nan when x ends above it."""
    above = np.nonzero(x >= level)[0]
    if above.size == 0:
        return float(t[0])
    i = above[-1]
    if i == x.size - 1:
        return math.nan
    x0, x1 = x[i], x[i + 1]
    return float(t[i] + (t[i + 1] - t[i]) * (x0 - level) / (x0 - x1))


def at_time(t: np.ndarray, x: np.ndarray, when: float) -> float:
    return float(np.interp(when, t, x)) if t[0] <= when <= t[-1] + 1e-12 else math.nan


@dataclass(frozen=True)
class Certificate:
    """Moreno (12)-(14) and Remark 6 evaluated on one run (finite horizon)."""

    eta_end: float
    tail_slope: float
    alpha1: float
    holds14: bool
    gamma: float
    t_bound_1e3: float  # when the (14) bound on ||e|| reaches 1e-3 (nan if alpha1 >= eps)
    int_varrho: float
    flat_last_quarter: bool
    max_varrho_last_quarter: float
    mean_varrho: float


def windowed_alpha(t: np.ndarray, cum: np.ndarray, window: float) -> tuple[float, float]:
    """Remark 6.3 from cum = I(t) = int_0^t varrho: alpha1 = max over t >= T of
    (I(t + Delta) - I(t)) / Delta, T = t_f/2 - Delta, and gamma = max_t [J(t) - min_{s <= t}
    J(s)], J = I - alpha1 t (the least gamma with int_{t0}^{t} varrho <= alpha1 (t - t0) +
    gamma on the run)."""
    t_f = t[-1]
    if window >= t_f:
        raise ValueError(f"postprocess.moreno.window ({window}) must be < t_end ({t_f})")
    starts = t[(t >= t_f / 2 - window) & (t <= t_f - window)]
    means = (np.interp(starts + window, t, cum) - np.interp(starts, t, cum)) / window
    alpha1 = float(np.max(means))
    J = cum - alpha1 * t
    gamma = float(np.max(J - np.minimum.accumulate(J)))
    return alpha1, gamma


def certificate(t: np.ndarray, varrho: np.ndarray, eps: float, window: float,
                kappa: float, e0: float) -> tuple[Certificate, np.ndarray, np.ndarray]:
    """(Certificate, I(t) = int_0^t varrho, eta(t, 0)) for varrho sampled on t."""
    cum = cumulative_trapezoid(varrho, t, initial=0.0)
    eta = eps * t - cum
    half = np.searchsorted(t, t[-1] / 2)
    tail = (eta[-1] - eta[half]) / (t[-1] - t[half])
    alpha1, gamma = windowed_alpha(t, cum, window)
    holds14 = alpha1 < eps
    # ||e|| <= kappa e^{gamma/2} e^{-(eps - alpha1) t / 2} ||e0|| reaches 1e-3 at
    t_bound = (2 * (math.log(kappa * e0 / 1e-3) + gamma / 2) / (eps - alpha1)
               if holds14 and e0 > 0 else math.nan)
    q = np.searchsorted(t, 0.75 * t[-1])
    cert = Certificate(float(eta[-1]), float(tail), alpha1, bool(holds14), gamma,
                       max(t_bound, 0.0) if math.isfinite(t_bound) else math.nan,
                       float(cum[-1]), bool(cum[-1] - cum[q] <= 1e-9 * max(1.0, cum[-1])),
                       float(np.max(varrho[q:])), float(np.mean(varrho)))
    return cert, cum, eta


@dataclass
class MorenoCertificate:
    """Post-processor; see the module docstring. Open choices (implementation notes):
    ``lambda_P`` (A3), ``delta`` and ``regularisation`` (A5), ``eps_fraction`` and the P
    of Theorem 3 (A13), ``K1t`` (null: from ``delta``; a number imposes K~1),
    ``K1t_search`` (our extension, not the paper's: K~1 from :func:`best_K1t` on this run),
    ``window`` (Delta of Remark 6.3, s; null: the input's period for a periodic input,
    else 5 s), ``mu`` (P >= mu I in the LMIs), ``norm_floor``
    (||e|| below it is excluded from the V'/V check: V'/V is then dominated by rounding)."""

    lambda_P: str = "half_min_eig"
    delta: float = 0.1
    regularisation: str = "margin"
    eps_fraction: float = 0.99
    K1t: float | None = None
    window: float | None = None
    norm_floor: float = 1e-6
    K1t_search: bool = False
    mu: float = 1e-7

    def __post_init__(self) -> None:
        if self.lambda_P not in LAMBDA_P:
            raise ValueError(f"postprocess.moreno.lambda_P: '{self.lambda_P}' not in "
                             f"{list(LAMBDA_P)}")
        if not self.delta > 0:
            raise ValueError(f"postprocess.moreno.delta must be > 0, got {self.delta}")
        if not 0 < self.eps_fraction < 1:
            raise ValueError("postprocess.moreno.eps_fraction must be in (0, 1), got "
                             f"{self.eps_fraction}")
        if self.window is not None and not self.window > 0:
            raise ValueError(f"postprocess.moreno.window must be > 0 (s) or null, "
                             f"got {self.window}")
        if self.K1t is not None and not math.isfinite(self.K1t):
            raise ValueError(f"postprocess.moreno.K1t must be finite or null, got {self.K1t}")
        if self.K1t is not None and self.K1t_search:
            raise ValueError("postprocess.moreno: give K1t or K1t_search, not both")
        if not self.mu > 0:
            raise ValueError(f"postprocess.moreno.mu must be > 0, got {self.mu}")

    def design(self, obs: CircleCriterionObserver, K1t: float | None = None
               ) -> tuple[ErrorSystem, CertificateDesign]:
        """Error system (5) and Theorem 3 data; ``K1t`` overrides the configured K~1."""
        es = ErrorSystem(*obs.error_matrices())
        return es, certificate_design(es, obs.plant.K1, self.delta, self.eps_fraction,
                                      self.K1t if K1t is None else K1t, self.regularisation,
                                      self.mu)

    def apply(self, system: System, traj: Trajectory) -> PostOutput:
        out = PostOutput()
        window = self.window or input_period(system.controller) or DEFAULT_WINDOW
        for obs, (xa, xb) in zip(system.observers, system.xh_slices, strict=True):
            if isinstance(obs, CircleCriterionObserver):
                self._one(obs, traj, traj.xh[:, xa:xb], window, out)
        return out

    def _one(self, obs: CircleCriterionObserver, traj: Trajectory, xh: np.ndarray,
             window: float, out: PostOutput) -> None:
        pl, t = obs.plant, traj.t
        x = traj.z[:, :pl.nx]
        sigma = x @ pl.H
        es, des = self.design(obs)
        if self.K1t_search:
            K1t, _, _ = best_K1t(es, des.K1a, t, sigma, pl.psi_coeffs, window)
            es, des = self.design(obs, K1t)
        c = des.c(self.lambda_P, es)
        e = x - xh
        z = e @ es.H_N
        phi = pl.phi(z, sigma)
        psi_hat = pl.psi(xh @ pl.H + obs.N * (traj.y[:, 0] - xh @ pl.C))
        theta = sector_lower(pl.psi_coeffs, sigma) - des.K1t
        varrho = c * np.maximum(0.0, -theta)
        norm = np.linalg.norm(e, axis=1)
        cert, _, eta = certificate(t, varrho, des.eps, window, des.kappa, norm[0])
        V = 0.5 * np.einsum("ij,jk,ik->i", e, des.P, e)
        V_bound = np.exp(-eta) * V[0]
        edot = es.rhs(e.T, phi).T
        Vdot = np.einsum("ij,jk,ik->i", e, des.P, edot)
        live = norm > self.norm_floor
        rate = Vdot[live] / V[live] + des.eps  # (9)-(11): rate <= varrho
        margin_i = float(np.max(rate - varrho[live])) if live.any() else math.nan
        viol = -theta[live] > 0
        c_need = float(np.max(np.maximum(rate[viol], 0.0) / -theta[live][viol])) \
            if viol.any() else 0.0
        if np.any(rate[~viol] > 1e-9):
            c_need = math.inf  # V'/V > -eps where theta >= 0: no c can hold
        ratio_ii = float(np.max(norm / (des.kappa * np.exp(-eta / 2) * norm[0])))
        name = obs.name
        rows = {
            "K1": des.K1, "K1a_sdp": des.K1a, "K1t": des.K1t, "eps_max_K1t": des.eps_max,
            "eps": des.eps, "lambda_min_P": des.lam_m, "lambda_max_P": des.lam_M,
            "lambda_H": des.lam_H, "c": c, "strong": float(des.strong),
            "mean_varrho": cert.mean_varrho, "eta_end": cert.eta_end,
            "eta_tail_slope": cert.tail_slope, "alpha1": cert.alpha1,
            "holds14": float(cert.holds14), "gamma": cert.gamma,
            "t_bound14_1e-3": cert.t_bound_1e3, "int_varrho": cert.int_varrho,
            "int_varrho_flat_last_quarter": float(cert.flat_last_quarter),
            "max_varrho_last_quarter": cert.max_varrho_last_quarter,
            "window_14": window, "margin_i": margin_i, "c_need": c_need,
            "max_ratio_ii": ratio_ii,
            "t_norm_below_1e-3": first_time_below(t, norm, 1e-3),
        }
        for when in NORM_TIMES:
            rows[f"norm_e_t{when:g}"] = at_time(t, norm, when)
        for quantity, value in rows.items():
            out.rows.append({"observer": name, "quantity": quantity, "empirical": value})
        out.rows.append({"observer": name, "quantity": "max_V_over_bound_12",
                         "empirical": float(np.max(V / V_bound)), "bound": 1.0})
        base = f"/observer/{name}"
        out.series += [
            Series(f"{base}/e", [f"e{i + 1}" for i in range(pl.nx)], e),
            Series(f"{base}/z", ["z"], z[:, None]),
            Series(f"{base}/psi", ["psi_hat", "phi"], np.column_stack([psi_hat, phi])),
            Series(f"{base}/certificate", ["theta", "varrho", "eta", "V", "V_bound"],
                   np.column_stack([theta, varrho, eta, V, V_bound])),
        ]


def moreno_certificate(lambda_P: str = "half_min_eig", delta: float = 0.1,
                       regularisation: str = "margin", eps_fraction: float = 0.99,
                       K1t: float | None = None, window: float | None = None,
                       norm_floor: float = 1e-6, K1t_search: bool = False,
                       mu: float = 1e-7) -> MorenoCertificate:
    """Factory of the ``postprocess`` group option ``moreno_certificate``."""
    if regularisation not in ("margin", "decay"):  # (was checked only after the run)
        raise ValueError("postprocess.moreno.regularisation must be 'margin' or 'decay', "
                         f"got '{regularisation}'")
    return MorenoCertificate(lambda_P, float(delta), regularisation, float(eps_fraction),
                             None if K1t is None else float(K1t),
                             None if window is None else float(window),
                             float(norm_floor), bool(K1t_search), float(mu))


def best_K1t(es: ErrorSystem, K1a: float, t: np.ndarray, sigma: np.ndarray,
             psi: np.ndarray, window: float, span: float = 8.0, n: int = 60
             ) -> tuple[float, float, float]:
    """Our extension, not the paper's (notes 7.2 ``K1t: best``): K~1 on a grid of ``n``
    points in (K1^a, K1^a + span] maximising eps_max(K~1) - alpha1(K~1) on this run, with
    the sharp c = -2 H_N G (P-independent for r = 1) and eps_max by the exact SPR test.
    Returns (K~1, eps_max, alpha1) at the best grid point."""
    from hgo.papers.moreno.theory import eps_max_fd

    c = float(-2 * es.H_N @ es.G)
    lower = sector_lower(psi, sigma)
    best = (-math.inf, math.nan, math.nan, math.nan)
    for K1t in K1a + span * np.arange(1, n + 1) / n:
        eps = eps_max_fd(es, K1t)
        cum = cumulative_trapezoid(c * np.maximum(0.0, K1t - lower), t, initial=0.0)
        alpha1, _ = windowed_alpha(t, cum, window)
        if eps - alpha1 > best[0]:
            best = (eps - alpha1, float(K1t), eps, alpha1)
    return best[1], best[2], best[3]
