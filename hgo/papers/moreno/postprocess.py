"""Weak-observer certificate of Moreno (9)-(14), Theorems 2-3, Remark 6, along a run.

For every circle-criterion observer (:mod:`hgo.observers.circle_criterion`) of the run:

1. Design data (:func:`hgo.papers.moreno.theory.certificate_design`): K1^a (SDP), K~1,
   eps = f eps_max(K~1), P = argmax lambda_min(P), c of (11) (``lambda_P``).
2. Along the run, every row is measured on the integration's steps and their continuous
   extension (:mod:`hgo.postprocess.dense`), not the output grid: the certificate
   integrals (12)-(14) and Remark 6 from I(t) = int_0^t varrho by the steps' Gauss rule
   (:class:`dense.Cumulative`, exact to ~1e-9 t_f at any instant) and its sliding-window
   maximum (:func:`windowed_alpha`), the bound (i) (``margin_i``, ``c_need``), the
   settling time and the norms at given instants (the series stay on the grid):
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

from hgo.controllers.profile_input import input_period
from hgo.engine.simulate import Trajectory
from hgo.engine.system import System
from hgo.observers.circle_criterion import CircleCriterionObserver
from hgo.outputs.recording import Series
from hgo.papers.moreno.theory import CertificateDesign, ErrorSystem, certificate_design
from hgo.plants.sector import sector_lower
from hgo.postprocess import PostOutput, dense
from hgo.postprocess.dense import steps_of

NORM_TIMES = (1.0, 5.0, 10.0, 20.0, 40.0)
DEFAULT_WINDOW = 5.0  # Delta of Remark 6.3 for a non-periodic input (s)
LAMBDA_P = ("half_min_eig", "min_eig", "sharp")


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


def windowed_alpha(cum: dense.Cumulative, window: float) -> tuple[float, float]:
    """Remark 6.3 from cum = I(t) = int_0^t varrho on [0, t_f] (from the steps): alpha1 =
    max over s in [t_f/2 - Delta, t_f - Delta] of (I(s + Delta) - I(s)) / Delta
    (:func:`dense.window_mean_max`: I exact at any instant, every interior maximum located
    where varrho(s + Delta) = varrho(s)), and gamma = max_t [J(t) - min_{s <= t} J(s)],
    J = I - alpha1 t (the least gamma with int_{t0}^{t} varrho <= alpha1 (t - t0) + gamma
    on the run; :func:`dense.max_rise`, J's extremes where varrho crosses alpha1). Both
    are the run's values to about QTOL t_f, whatever the output grid."""
    alpha1 = _alpha1(cum, window)
    return alpha1, dense.max_rise(cum, alpha1, 0.0, cum.b)


def _alpha1(cum: dense.Cumulative, window: float) -> float:
    t_f = cum.b
    if window >= t_f:
        raise ValueError(f"postprocess.moreno.window ({window}) must be < t_end ({t_f})")
    return dense.window_mean_max(cum, window, max(t_f / 2 - window, 0.0), t_f - window)[0]


def certificate(cum: dense.Cumulative, eps: float, window: float, kappa: float, e0: float
                ) -> Certificate:
    """Moreno (12)-(14), Remark 6 from cum = I(t) = int_0^t varrho on [0, t_f], measured on
    the steps (:class:`dense.Cumulative`): eta(t) = eps t - I(t) at t_f and t_f/2, the
    windowed maxima, I(t_f) and I(3 t_f/4), the maximum of varrho over [3 t_f/4, t_f]."""
    t_f = cum.b
    I_half, I_q, I_f = cum(np.array([0.5, 0.75, 1.0]) * t_f)
    eta_end = eps * t_f - I_f
    tail = eps - (I_f - I_half) / (t_f / 2)
    alpha1, gamma = windowed_alpha(cum, window)
    holds14 = alpha1 < eps
    # ||e|| <= kappa e^{gamma/2} e^{-(eps - alpha1) t / 2} ||e0|| reaches 1e-3 at
    t_bound = (2 * (math.log(kappa * e0 / 1e-3) + gamma / 2) / (eps - alpha1)
               if holds14 and e0 > 0 else math.nan)
    max_q = dense.maximum(cum.run, cum.signal, 0.75 * t_f, t_f)[0]
    return Certificate(float(eta_end), float(tail), alpha1, bool(holds14), gamma,
                       max(t_bound, 0.0) if math.isfinite(t_bound) else math.nan,
                       float(I_f), bool(I_f - I_q <= 1e-9 * max(1.0, I_f)),
                       float(max_q), float(I_f / t_f))


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
    needs_steps = True  # bound (i), settling, norms at instants: from the steps

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
                self._one(obs, traj, (xa, xb), window, out)
        return out

    def _one(self, obs: CircleCriterionObserver, traj: Trajectory, cols: tuple[int, int],
             window: float, out: PostOutput) -> None:
        pl, t = obs.plant, traj.t
        xh = traj.xh[:, cols[0]:cols[1]]
        x = traj.z[:, :pl.nx]
        sigma = x @ pl.H
        es, des = self.design(obs)
        run, T = steps_of(traj), traj.t_stop
        if self.K1t_search:
            K1t, _, _ = best_K1t(es, des.K1a, run, lambda s: s.z[:, :pl.nx] @ pl.H,
                                 pl.psi_coeffs, window, T)
            es, des = self.design(obs, K1t)
        c = des.c(self.lambda_P, es)
        e = x - xh
        z = e @ es.H_N
        phi = pl.phi(z, sigma)
        psi_hat = pl.psi(xh @ pl.H + obs.N * (traj.y[:, 0] - xh @ pl.C))
        theta = sector_lower(pl.psi_coeffs, sigma) - des.K1t
        varrho = c * np.maximum(0.0, -theta)
        norm = np.linalg.norm(e, axis=1)
        bound_i = _BoundI(pl, es, des, c, cols, self.norm_floor)
        cum = dense.Cumulative(run, bound_i.varrho, 0.0, T)  # I(t) of (12), from the steps
        cert = certificate(cum, des.eps, window, des.kappa, norm[0])
        eta = des.eps * t - cum(t)
        V = 0.5 * np.einsum("ij,jk,ik->i", e, des.P, e)
        V_bound = np.exp(-eta) * V[0]
        margin_i = dense.maximum(run, bound_i.margin, 0.0, T)[0]
        margin_i = margin_i if math.isfinite(margin_i) else math.nan  # (never live)
        c_need = max(dense.maximum(run, bound_i.c_needed, 0.0, T)[0], 0.0)
        rate, theta_live = bound_i.rate(traj), bound_i.theta(traj)
        if np.any(rate[theta_live >= 0] > 1e-9):
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
            "t_norm_below_1e-3": dense.settles_below(run, bound_i.norm, 1e-3, 0.0, T),
        }
        norms = bound_i.norm(run.at(np.array([w for w in NORM_TIMES if w <= T])))
        for k, when in enumerate(NORM_TIMES):
            rows[f"norm_e_t{when:g}"] = float(norms[k]) if when <= T else math.nan
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


@dataclass(frozen=True)
class _BoundI:
    """The pointwise bound (i), V'/V + eps <= varrho of (9)-(11), as functions of sampled
    signals (:mod:`hgo.postprocess.dense`): maxima over the run's steps, not its grid."""

    pl: object
    es: ErrorSystem
    des: CertificateDesign
    c: float
    cols: tuple[int, int]
    norm_floor: float

    def _e(self, s: Trajectory) -> np.ndarray:  # x - x^ (the paper's sign)
        return s.z[:, :self.pl.nx] - s.xh[:, self.cols[0]:self.cols[1]]

    def norm(self, s: Trajectory) -> np.ndarray:
        return np.linalg.norm(self._e(s), axis=1)

    def theta(self, s: Trajectory) -> np.ndarray:  # (10), where ||e|| is above the floor
        live = self.norm(s) > self.norm_floor
        sigma = s.z[:, :self.pl.nx] @ self.pl.H
        return (sector_lower(self.pl.psi_coeffs, sigma) - self.des.K1t)[live]

    def _rate_theta(self, s: Trajectory) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(V'/V + eps, theta of (10), live: ||e|| above the floor) at the samples of s."""
        e = self._e(s)
        sigma = s.z[:, :self.pl.nx] @ self.pl.H
        phi = self.pl.phi(e @ self.es.H_N, sigma)
        V = 0.5 * np.einsum("ij,jk,ik->i", e, self.des.P, e)
        Vdot = np.einsum("ij,jk,ik->i", e, self.des.P, self.es.rhs(e.T, phi).T)
        live = np.linalg.norm(e, axis=1) > self.norm_floor
        theta = sector_lower(self.pl.psi_coeffs, sigma) - self.des.K1t
        with np.errstate(divide="ignore", invalid="ignore"):
            return Vdot / V + self.des.eps, theta, live

    def varrho(self, s: Trajectory) -> np.ndarray:  # (11): c max(0, -theta), every sample
        sigma = s.z[:, :self.pl.nx] @ self.pl.H
        return self.c * np.maximum(0.0, self.des.K1t - sector_lower(self.pl.psi_coeffs, sigma))

    def rate(self, s: Trajectory) -> np.ndarray:
        rate, _, live = self._rate_theta(s)
        return rate[live]

    def margin(self, s: Trajectory) -> np.ndarray:
        """V'/V + eps - varrho, varrho = c max(0, -theta) (-inf below the norm floor)."""
        rate, theta, live = self._rate_theta(s)
        return np.where(live, rate - self.c * np.maximum(0.0, -theta), -np.inf)

    def c_needed(self, s: Trajectory) -> np.ndarray:
        """max(V'/V + eps, 0) / -theta where theta < 0: the least c for (i) there."""
        rate, theta, live = self._rate_theta(s)
        ok = live & (theta < 0)
        with np.errstate(divide="ignore", invalid="ignore"):
            return np.where(ok, np.maximum(rate, 0.0) / -theta, -np.inf)


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


def best_K1t(es: ErrorSystem, K1a: float, run: dense.DenseRun | dense.GridRun,
             sigma: dense.Signal, psi: np.ndarray, window: float, t_f: float,
             span: float = 8.0, n: int = 60) -> tuple[float, float, float]:
    """Our extension, not the paper's (notes 7.2 ``K1t: best``): K~1 on a grid of ``n``
    points in (K1^a, K1^a + span] maximising eps_max(K~1) - alpha1(K~1) on this run (alpha1
    of :func:`windowed_alpha`, from the steps; ``sigma``: sigma = H x of a sampled run),
    with the sharp c = -2 H_N G (P-independent for r = 1) and eps_max by the exact SPR
    test. Returns (K~1, eps_max, alpha1) at the best grid point."""
    from hgo.papers.moreno.theory import eps_max_fd

    c = float(-2 * es.H_N @ es.G)
    # K1(sigma) at the steps' Gauss nodes and the scan: sampled and computed once for all
    # the K~1 (varrho of each K~1 is a function of it)
    k1_run = dense.Remembering(run, lambda s: sector_lower(psi, sigma(s)))
    best = (-math.inf, math.nan, math.nan, math.nan)
    for K1t in K1a + span * np.arange(1, n + 1) / n:
        eps = eps_max_fd(es, K1t)

        def varrho(k1, K1t=K1t):
            return c * np.maximum(0.0, K1t - k1)

        alpha1 = _alpha1(dense.Cumulative(k1_run, varrho, 0.0, t_f), window)
        if eps - alpha1 > best[0]:
            best = (eps - alpha1, float(K1t), eps, alpha1)
    return best[1], best[2], best[3]
