"""Dimassi et al. metrics: HGO peaking, state/parameter errors on a window, (8)-(10), D_R (23).

``dhlm_metrics(...)`` returns a post-processor whose ``apply`` adds, for every observer of
:mod:`hgo.observers.adaptive_cascade` (column ``observer``):

series
    ``/observer/<name>/hgo/raw`` (z_h), ``/observer/<name>/hgo/saturated`` (z_h^s, what the
    cascade uses), ``/observer/<name>/aux`` (z = H x), ``/observer/<name>/theta_error``
    (th^ - theta), ``/observer/<name>/lyapunov`` ([V, R^2] of (18), (23)).
rows (window W = [window_start, t_end], default [10, 20] s; "for good" times are the last
    exit from the band, linearly interpolated between output samples; NaN: never settles)
    HGO: ``zh<i><j>_peak`` / ``t_peak_zh<i><j>`` (raw |z_hk| peak over [0, T(eps)], from a
    noise-free re-simulation on a T(eps)/5000 grid), ``t_sat_first`` / ``t_sat_last``
    (saturation active, sampled after every integration step by the observer over the whole
    run; NaN: never),
    ``t_end_peaking`` (|z - z_h| < ``peak_band`` for good, every entry), ``max_abs_zerr<k>_W``
    (bound: the quasi-static HGO lag, eps-scaled, see :func:`quasi_static_lag`),
    ``hgo<i>_pole_slowest_re`` / ``_fastest_re`` (real parts of eig(a-bar_i)/eps),
    ``beta_measured`` = max_{t >= T(eps)} |eta|/eps of (13)-(15), ``T_eps``;
    states: ``max_abs_e<i>`` / ``t_max_abs_e<i>``, ``max_abs_e<i>_W``, ``rms_e<i>_W``,
    ``t_settle_e_<band>`` (|e| below band for good); parameters: ``theta_hat<k>_end``,
    ``mean/min/max_theta_hat<k>_W``, ``min/max_theta_hat<k>`` (whole run),
    ``rms_rel_theta_err<k>_W``, ``t_settle_theta<k>_<pct>pct``,
    ``frac_W_theta<k>_within_<pct>pct``;
    theory (``theory: true``): ``r_star`` (best lambda_min(Q)/lambda_max(P) of (8)-(9) with
    the observer's L, M; ``r_star_M_free``: M free too), ``P11``, ``margin10`` (> 0: (10)
    holds with K_psi |theta|) and ``margin10_tight`` (with the Lipschitz constant of
    x -> psi theta), ``lmi28_rho`` (L, M fixed) and ``lmi28_rho_free``, ``tau``,
    ``K0``..``K3``, ``R2`` (beta measured) and ``R2_beta_analytic``, ``beta_analytic``,
    ``psi_max`` (max |psi(x, u)| over the run), ``psi_max_bound`` = sqrt(1 + u_max^2),
    ``u_max``, ``h_max``; and the D_R row
    ``max_V_after_T_eps`` with bound R^2 (``holds``: the run stays in D_R after T(eps)).

The readings in force: ``psi_at`` of the observer (A2: K_psi = 0 under ``y``, the model's
K_psi under ``xhat``), P, Q the maximiser of (8)-(9) (A15), beta per ``beta`` (A11).
Window metrics use the output grid; ``dt_out`` = 1e-3 s is fine enough (a test divides it
by 10).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from hgo.engine.simulate import SolverSettings, Trajectory, no_noise, simulate
from hgo.engine.system import System
from hgo.observers import adaptive_cascade as ac
from hgo.outputs.recording import Series
from hgo.plants.robot_arm import dimassi_psi
from hgo.postprocess import PostOutput


def settle_time(t: np.ndarray, err: np.ndarray, band: float) -> float:
    """Time after which |err| < band for good (last exit, interpolated); NaN: never;
    0 if it starts inside and stays."""
    out = np.abs(err) >= band
    if out[-1]:
        return math.nan
    idx = np.flatnonzero(out)
    if idx.size == 0:
        return 0.0
    k = idx[-1]
    a, b = abs(err[k]), abs(err[k + 1])
    frac = (a - band) / (a - b) if a != b else 0.0
    return float(t[k] + frac * (t[k + 1] - t[k]))


def _trapz_rms(t: np.ndarray, v: np.ndarray) -> float:
    return float(math.sqrt(np.trapezoid(v * v, t) / (t[-1] - t[0])))


def psi_rows(p, xa: np.ndarray, u: np.ndarray) -> np.ndarray:
    """psi(x^a, u) of the observer with parameters ``p`` on a grid (rows of xa, u: the
    plant's inputs), shape (len, m, q) (robot_arm: [u, -sin x1], vectorised)."""
    if p.psi is dimassi_psi:
        return np.stack([u[:, 0], -np.sin(xa[:, 0])], axis=1)[:, None, :]
    out = np.empty((len(xa), p.m, p.q))
    for k in range(len(xa)):  # the user's psi, one sample at a time
        p.psi(np.ascontiguousarray(xa[k]), np.ascontiguousarray(u[k]), out[k])
    return out


def lipschitz_psi_theta(p, theta: np.ndarray) -> float:
    """Lipschitz constant of x -> psi(x, u) theta (tighter than K_psi |theta|, A7);
    robot_arm: psi theta = theta1 u - theta2 sin x1, so |theta2|; a user's psi: K_psi
    |theta|."""
    if p.psi is dimassi_psi:
        return float(abs(theta[1]))
    return float(p.K_psi * np.linalg.norm(theta))


def quasi_static_lag(gamma: np.ndarray, eps: float) -> np.ndarray:
    """|z_k - z_hk| per unit |h_i| in quasi-steady state: D (-eps a-bar^-1 b1), i.e.
    (eps^q/g_q, eps^(q-1) g_1/g_q, ...) (for q = 2: z_12 lag = eps g_1/g_2 |x2'|)."""
    a = ac.hgo_matrix(gamma)
    q = a.shape[0]
    b1 = np.zeros(q)
    b1[-1] = 1.0
    eta = -eps * np.linalg.solve(a, b1)
    return np.abs(eta * eps ** (q - 1 - np.arange(q)))


@dataclass
class DHLMMetrics:
    window_start: float = 10.0
    T_eps_factor: float = 25.0
    peak_band: float = 1.0
    state_bands: list[float] = field(default_factory=lambda: [0.2, 0.05, 0.01])
    theta_pcts: list[float] = field(default_factory=lambda: [1.0, 5.0, 10.0, 25.0])
    theta: list[float] | None = None
    theory: bool = True
    beta: str = "measured"

    def __post_init__(self) -> None:
        key = "postprocess.dhlm"
        for name in ("window_start", "T_eps_factor", "peak_band"):
            if not (math.isfinite(getattr(self, name)) and getattr(self, name) > 0):
                raise ValueError(f"{key}.{name} must be in (0, inf), got {getattr(self, name)}")
        if any(not b > 0 for b in list(self.state_bands) + list(self.theta_pcts)):
            raise ValueError(f"{key}.state_bands and theta_pcts must be > 0")
        if self.beta not in ("measured", "analytic"):
            raise ValueError(f"{key}.beta must be 'measured' or 'analytic', got '{self.beta}'")

    def check(self, system: System, solver, key: str) -> None:  # noqa: ARG002
        """``window_start`` inside the run, before it (checked only after the run before)."""
        if not self.window_start < solver.t_end:
            raise ValueError(f"{key}.window_start must be in (0, t_end={solver.t_end:g}), "
                             f"got {self.window_start}")

    def true_theta(self, system: System) -> np.ndarray:
        if self.theta is not None:
            return np.asarray(self.theta, float)
        if system.plant.name == "robot_arm":
            from hgo.plants.robot_arm import true_parameters

            return true_parameters(system.plant.p)
        raise ValueError("postprocess.dhlm.theta must be given for a plant other than "
                         f"robot_arm, got plant '{system.plant.name}'")

    def apply(self, system: System, traj: Trajectory) -> PostOutput:
        t = traj.t
        if not 0 < self.window_start < t[-1]:
            raise ValueError(f"postprocess.dhlm.window_start must be in (0, t_end={t[-1]:g}),"
                             f" got {self.window_start}")
        out = PostOutput()
        for k, obs in enumerate(system.observers):
            if obs.f is ac.f:
                self._observer(system, traj, k, out)
        return out

    def _observer(self, system: System, traj: Trajectory, k: int, out: PostOutput) -> None:
        obs = system.observers[k]
        name = obs.name
        blk = ac.unpack(obs.p)
        n, nn, nq = int(blk["n"]), int(blk["N"]), int(blk["q"])
        eps = blk["eps"]
        za, _ = system.z_slices[k + 1]
        da, _ = system.d_slices[k]
        t, plant = traj.t, system.plant
        x = traj.z[:, :plant.nx]
        zst = traj.z[:, za:]
        zh, xh, th = zst[:, :nn], zst[:, nn:nn + n], zst[:, nn + n:nn + n + nq]
        theta = self.true_theta(system)
        H = blk["H"]
        z = x @ H.T
        ideal = blk["ideal"] > 0.5
        if ideal:
            zs = traj.y[:, :nn]
        else:
            zs = np.where(blk["direct"] > 0.5, traj.y[:, blk["out"].astype(int)],
                          np.clip(zh, -blk["S"], blk["S"]))
        zn = obs.state_names[:nn]
        out.series += [
            Series(f"/observer/{name}/hgo/raw", zn, zh),
            Series(f"/observer/{name}/hgo/saturated", [f"{s}_sat" for s in zn], zs),
            Series(f"/observer/{name}/aux", [f"z{s[2:]}" for s in zn], z),
            Series(f"/observer/{name}/theta_error", [f"theta_err{i + 1}" for i in range(nq)],
                   th - theta)]
        rows: list[tuple[str, float, float | None]] = []
        W = t >= self.window_start - 1e-12
        tw = t[W]
        # --- HGO (6), (13)-(15)
        d = traj.d[-1, da:]
        zerr = z - (zs if ideal else zh)
        if not ideal:
            rows += self._peaks(system, k, zn, eps)
        rows += [("t_sat_first", math.nan if d[0] < 0 else float(d[0]), None),
                 ("t_sat_last", math.nan if d[1] < 0 else float(d[1]), None)]
        if not ideal:
            rows.append(("t_end_peaking", max(settle_time(t, zerr[:, j], self.peak_band)
                                              for j in range(nn)), None))
        h_abs = self._h_abs(system, traj, blk)
        for i, g in enumerate(self._block_gains(blk)):
            poles = np.linalg.eigvals(ac.hgo_matrix(g)) / eps
            rows += [(f"hgo{i + 1}_pole_slowest_re", float(poles.real.max()), None),
                     (f"hgo{i + 1}_pole_fastest_re", float(poles.real.min()), None)]
        T_eps = self.T_eps_factor * eps
        eta = self._eta(zerr, blk, eps)
        late = t >= T_eps
        beta_meas = float(np.max(np.linalg.norm(eta[late], axis=1)) / eps)
        rows += [("T_eps", T_eps, None), ("beta_measured", beta_meas, None)]
        lags = self._lags(obs, blk, eps, np.max(h_abs[W], axis=0))
        for j in range(nn):
            rows.append((f"max_abs_zerr{j + 1}_W", float(np.max(np.abs(zerr[W, j]))),
                         None if ideal else float(lags[j])))
        # --- states
        e = xh - x
        for i in range(n):
            a = np.abs(e[:, i])
            rows += [(f"max_abs_e{i + 1}", float(a.max()), None),
                     (f"t_max_abs_e{i + 1}", float(t[a.argmax()]), None),
                     (f"max_abs_e{i + 1}_W", float(a[W].max()), None),
                     (f"rms_e{i + 1}_W", _trapz_rms(tw, e[W, i]), None)]
        enorm = np.linalg.norm(e, axis=1)
        rows += [(f"t_settle_e_{b:g}", settle_time(t, enorm, b), None) for b in self.state_bands]
        # --- parameters
        rel = (th - theta) / np.abs(theta)
        for i in range(nq):
            s = f"theta_hat{i + 1}"
            rows += [(f"{s}_end", float(th[-1, i]), None),
                     (f"mean_{s}_W", float(np.trapezoid(th[W, i], tw) / (tw[-1] - tw[0])), None),
                     (f"min_{s}_W", float(th[W, i].min()), None),
                     (f"max_{s}_W", float(th[W, i].max()), None),
                     (f"min_{s}", float(th[:, i].min()), None),
                     (f"max_{s}", float(th[:, i].max()), None),
                     (f"rms_rel_theta_err{i + 1}_W", _trapz_rms(tw, rel[W, i]), None)]
            for pct in self.theta_pcts:
                rows += [(f"t_settle_theta{i + 1}_{pct:g}pct",
                          settle_time(t, rel[:, i], pct / 100), None)]
            for pct in (1.0, 5.0):
                inside = (np.abs(rel[W, i]) < pct / 100).astype(float)
                rows.append((f"frac_W_theta{i + 1}_within_{pct:g}pct",
                             float(np.trapezoid(inside, tw) / (tw[-1] - tw[0])), None))
        if self.theory:
            rows += self._theory(system, traj, obs, blk, theta, x, e, th, beta_meas, T_eps,
                                 out, h_abs)
        for q, v, b in rows:
            out.rows.append({"observer": name, "quantity": q, "empirical": v, "bound": b})

    def _peaks(self, system: System, k: int, zn: list[str], eps: float) -> list:
        """Raw |z_hk| peaks and their times from a noise-free re-simulation over
        [0, T(eps)] on a grid of T(eps)/5000 (DOP853 1e-10/1e-12): the peak lasts a few eps,
        far below the run's output grid."""
        T_eps = self.T_eps_factor * eps
        solver = SolverSettings(t_end=T_eps, dt_out=T_eps / 5000, method="dop853",
                                h_max=T_eps / 100, rtol=1e-10, atol=1e-12)
        fine = simulate(system, solver, no_noise(len(system.plant.output_names)))
        za, _ = system.z_slices[k + 1]
        rows = []
        for j, s in enumerate(zn):
            a = np.abs(fine.z[:, za + j])
            rows += [(f"{s}_peak", float(a.max()), None),
                     (f"t_peak_{s}", float(fine.t[a.argmax()]), None)]
        return rows

    @staticmethod
    def _eta(zerr: np.ndarray, blk: dict, eps: float) -> np.ndarray:
        """eta of (13): (z_ij - z_hij)/eps^(q_i - j) (q_i = 1 blocks: 0)."""
        nn = zerr.shape[1]
        first = blk["first"].astype(int)
        pos = np.arange(nn) - first
        qi = np.array([np.sum(first == first[j]) for j in range(nn)])
        eta = zerr / eps ** (qi - 1 - pos)
        eta[:, blk["direct"] > 0.5] = 0.0
        return eta

    @staticmethod
    def _h_abs(system: System, traj: Trajectory, blk: dict) -> np.ndarray:
        """|h_i(t)| of (12) per z entry (the block's h; the derivative of z_iqi minus
        b_i2 u), from the plant's own vector field on the output grid."""
        plant = system.plant
        x = traj.z[:, :plant.nx]
        dx = np.empty_like(x)
        for j in range(len(traj.t)):
            plant.f(traj.t[j], x[j], traj.u[j], plant.p, dx[j])
        H, Bz2 = blk["H"], blk["Bz2"]
        first = blk["first"].astype(int)
        hs = np.zeros((len(traj.t), H.shape[0]))
        for j in range(H.shape[0]):
            last = first[j] + int(np.sum(first == first[j])) - 1
            hs[:, j] = np.abs(dx @ H[last] - traj.u @ Bz2[last])
        return hs

    @staticmethod
    def _block_gains(blk: dict) -> list[np.ndarray]:
        """gamma_i of every block with q_i > 1 (undoing Gamma_ij = gamma_ij / eps^j)."""
        first = blk["first"].astype(int)
        out = []
        for f0 in np.unique(first):
            qi = int(np.sum(first == f0))
            if blk["direct"][f0] < 0.5:
                out.append(blk["Gamma"][f0:f0 + qi] * blk["eps"] ** np.arange(1, qi + 1))
        return out

    @staticmethod
    def _lags(obs, blk: dict, eps: float, h_max: np.ndarray) -> np.ndarray:
        nn = int(blk["N"])
        first = blk["first"].astype(int)
        lags = np.zeros(nn)
        j = 0
        while j < nn:
            qi = int(np.sum(first == first[j]))
            if blk["direct"][j] < 0.5:
                gains = blk["Gamma"][j:j + qi] * eps ** np.arange(1, qi + 1)
                lags[j:j + qi] = quasi_static_lag(gains, eps) * h_max[j:j + qi]
            j += qi
        return lags

    def _theory(self, system, traj, obs, blk, theta, x, e, th, beta_meas, T_eps, out, h_abs):
        from hgo.papers.dimassi import theory

        A, B, H, L, M = blk["A"], blk["B"], blk["H"], blk["L"], blk["M"]
        K_phi, K_psi = blk["K_phi"], (blk["K_psi"] if blk["psi_at"] > 0.5 else 0.0)
        chk = theory.check_conditions(A, B, H, L, M)
        rows = [("r_star", chk.r_star, None),
                ("r_star_M_free", theory.check_conditions(A, B, H, L).r_star, None),
                ("max_re_eig_A_minus_LH", float(np.max(chk.eig_closed_loop.real)), None)]
        k28 = theory.lmi28(A, B, H, L, M)
        k28f = theory.lmi28(A, B, H)
        rows += [("lmi28_rho", k28.rho, None), ("lmi28_rho_free", k28f.rho, None)]
        if chk.P is None:
            return rows + [("margin10", math.nan, None)]
        nB = float(np.linalg.norm(B, 2))
        tight = lipschitz_psi_theta(obs.p, theta) if K_psi > 0 else 0.0
        rows += [("P11", float(chk.P[0, 0]), None),
                 ("margin10", chk.margin10(nB, K_phi, K_psi * np.linalg.norm(theta)), None),
                 ("margin10_tight", chk.margin10(nB, K_phi, tight), None)]
        psi = psi_rows(obs.p, x, traj.u)
        psi_max = float(np.max(np.linalg.norm(psi.reshape(len(psi), -1), axis=1)))
        u_max = float(np.max(np.abs(traj.u)))
        rows += [("u_max", u_max, None), ("psi_max_bound", float(np.hypot(1.0, u_max)), None)]
        h_max = float(np.max(h_abs))
        beta_an = max(theory.beta_analytic(g, h_max) for g in self._block_gains(blk))
        args = (chk.P, chk.Q, L, M, B, theta, blk["delta"], blk["sigma"], blk["eps"])
        thm = theory.theorem1(*args, beta_meas, psi_max, K_phi, K_psi)
        thm_an = theory.theorem1(*args, beta_an, psi_max, K_phi, K_psi)
        rows += [("psi_max", psi_max, None), ("h_max", h_max, None),
                 ("beta_analytic", beta_an, None), ("tau", thm.tau, None), ("K0", thm.K0, None),
                 ("K1", thm.K1, None), ("K2", thm.K2, None), ("K3", thm.K3, None),
                 ("R2", thm.R2, None), ("R2_beta_analytic", thm_an.R2, None)]
        use = thm if self.beta == "measured" else thm_an
        err_th = theta - th
        V = np.einsum("ti,ij,tj->t", e, chk.P, e) + np.sum(err_th ** 2, axis=1) / blk["delta"]
        out.series.append(Series(f"/observer/{obs.name}/lyapunov", ["V", "R2"],
                                 np.column_stack([V, np.full_like(V, use.R2)])))
        late = traj.t >= T_eps
        rows.append(("max_V_after_T_eps", float(np.max(V[late])),
                     use.R2 if math.isfinite(use.R2) else None))
        return rows


def dhlm_metrics(window_start: float = 10.0, T_eps_factor: float = 25.0, peak_band: float = 1.0,
                 state_bands: list[float] | None = None, theta_pcts: list[float] | None = None,
                 theta: list[float] | None = None, theory: bool = True,
                 beta: str = "measured") -> DHLMMetrics:
    """Factory of the ``postprocess`` group
    (``_target_: hgo.papers.dimassi.postprocess.dhlm_metrics``)."""
    return DHLMMetrics(float(window_start), float(T_eps_factor), float(peak_band),
                       list(state_bands or [0.2, 0.05, 0.01]),
                       list(theta_pcts or [1.0, 5.0, 10.0, 25.0]),
                       None if theta is None else list(theta), bool(theory), beta)
