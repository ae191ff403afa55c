"""Dimassi et al. metrics: HGO peaking, state/parameter errors on a window, (8)-(10), D_R (23).

``dhlm_metrics(...)`` returns a post-processor whose ``apply`` adds, for every observer of
:mod:`hgo.observers.adaptive_cascade` (column ``observer``):

series
    ``/observer/<name>/hgo/raw`` (z_h), ``/observer/<name>/hgo/saturated`` (z_h^s, what the
    cascade uses), ``/observer/<name>/aux`` (z = H x), ``/observer/<name>/theta_error``
    (th^ - theta), ``/observer/<name>/lyapunov`` ([V, R^2] of (18), (23)).
rows (window W = [window_start, t_end], default [10, 20] s; "for good" times are the last
    exit from the band, located on the steps; NaN: never settles, i.e. outside the band
    somewhere in W)
    HGO: ``zh<i><j>_peak`` / ``t_peak_zh<i><j>`` (raw |z_hk| peak over [0, T(eps)], from a
    noise-free re-simulation on a T(eps)/5000 grid), ``t_sat_first`` / ``t_sat_last``
    (saturation active, sampled after every integration step by the observer over the whole
    run; NaN: never),
    ``t_end_peaking`` (|z - z_h| < ``peak_band`` for good, every entry), ``max_abs_zerr<k>_W``
    and ``lag_zerr<k>_W``, the quasi-static HGO lag that predicts it (eps-scaled, see
    :func:`quasi_static_lag`: an estimate of the same quantity, ratio ~1, not a bound),
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
Every row is measured from the integration's steps and their continuous extension, not
from the output grid (:mod:`hgo.postprocess.dense`: means and RMS by Gauss-Legendre on each
step, crossings by root finding, maxima refined between the steps): a test checks they do
not move with ``dt_out``. A settling time ("for good") is the last exit from the band; NaN
("never") when the signal is outside the band anywhere in the window W.
"""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass, field
from types import SimpleNamespace

import numpy as np

from hgo.engine.simulate import SolverSettings, Trajectory, no_noise, simulate
from hgo.engine.system import System
from hgo.observers import adaptive_cascade as ac
from hgo.outputs.recording import Derived, Series
from hgo.plants.robot_arm import dimassi_psi
from hgo.postprocess import PostOutput, dense
from hgo.postprocess.dense import steps_of
from hgo.postprocess.vector_field import COMPILE_ROWS, vector_field


def settle_time(run, signal, band: float, t_window: float, t_end: float) -> float:
    """The time after which |signal| < band for good (its last exit from the band, located
    on the steps); NaN ("never") if it is outside the band anywhere in the window
    [t_window, t_end] (where it should have settled); 0 if it never leaves."""
    return settling(dense.Window(run, 0.0, t_end), signal, band, t_window).value


def settling(whole: dense.Window, signal, band: float, t_window: float) -> dense.Pending:
    """:func:`settle_time` over ``whole`` (the run from 0), measured with its other metrics."""
    return whole.settles_below(lambda s: np.abs(signal(s)), band).then(
        lambda t: t if t < t_window else math.nan)


@dataclass(frozen=True)
class _Windows:
    """The windows the rows are measured on, each in one pass over its steps: the whole run
    [0, T], [T(eps), T] and W = [window_start, T]."""

    whole: dense.Window
    after_T_eps: dense.Window
    W: dense.Window
    t_window: float

    @property
    def all(self) -> tuple[dense.Window, ...]:
        return self.whole, self.after_T_eps, self.W


def _value(v):
    """A row's value: measured (:class:`dense.Pending`), computed from measured ones (a
    function of nothing) or a number."""
    if isinstance(v, dense.Pending):
        return v.value
    return v() if callable(v) else v


@dataclass(frozen=True)
class _Signals:
    """The signals of one adaptive-cascade observer as functions of sampled signals
    (:mod:`hgo.postprocess.dense`): plant x, e = x^ - x, z = H x, z_h, its saturation,
    theta^."""

    nx: int
    za: int
    blk: dict

    @property
    def sizes(self) -> tuple[int, int, int]:
        return int(self.blk["n"]), int(self.blk["N"]), int(self.blk["q"])

    def x(self, s: Trajectory) -> np.ndarray:
        return s.z[:, :self.nx]

    def zh(self, s: Trajectory) -> np.ndarray:
        return s.z[:, self.za:self.za + self.sizes[1]]

    def xh(self, s: Trajectory) -> np.ndarray:
        n, nn, _ = self.sizes
        return s.z[:, self.za + nn:self.za + nn + n]

    def th(self, s: Trajectory) -> np.ndarray:
        n, nn, nq = self.sizes
        return s.z[:, self.za + nn + n:self.za + nn + n + nq]

    def e(self, s: Trajectory) -> np.ndarray:
        return self.xh(s) - self.x(s)

    def zs(self, s: Trajectory) -> np.ndarray:
        """What the cascade uses: y (ideal), or the direct outputs and the saturated z_h."""
        blk = self.blk
        if blk["ideal"] > 0.5:
            return s.y[:, :self.sizes[1]]
        return np.where(blk["direct"] > 0.5, s.y[:, blk["out"].astype(int)],
                        np.clip(self.zh(s), -blk["S"], blk["S"]))

    def zerr(self, s: Trajectory) -> np.ndarray:
        """z - z_h (z - z^s for the ideal observer)."""
        z = self.x(s) @ self.blk["H"].T
        return z - (self.zs(s) if self.blk["ideal"] > 0.5 else self.zh(s))

    def V(self, s: Trajectory, P: np.ndarray, theta: np.ndarray) -> np.ndarray:
        """V of (18): e' P e + |theta - theta^|^2 / delta."""
        e, err_th = self.e(s), theta - self.th(s)
        return (np.einsum("ti,ij,tj->t", e, P, e)
                + np.sum(err_th ** 2, axis=1) / self.blk["delta"])


@dataclass(frozen=True)
class _Series:
    """A series of one observer from rows of the run's z and y, computed when they are read
    (:class:`hgo.outputs.recording.Derived`): ``saturated`` (z_h^s), ``aux`` (z = H x),
    ``theta_error`` (th^ - theta), ``lyapunov`` ([V, R^2])."""

    sig: _Signals
    what: str
    theta: np.ndarray
    P: np.ndarray | None = None
    R2: float = math.nan

    def __call__(self, z: np.ndarray, y: np.ndarray) -> np.ndarray:
        s, sig = SimpleNamespace(z=z, y=y), self.sig
        if self.what == "saturated":
            return sig.zs(s)
        if self.what == "aux":
            return sig.x(s) @ sig.blk["H"].T
        if self.what == "theta_error":
            return sig.th(s) - self.theta
        V = sig.V(s, self.P, self.theta)
        return np.column_stack([V, np.full_like(V, self.R2)])

    def of(self, traj: Trajectory, columns: int) -> Derived:
        return Derived(self, (traj.z, traj.y), columns)


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
    needs_steps = True  # metrics from the integration's steps (hgo.postprocess.dense)

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
        sig = _Signals(system.plant.nx, system.z_slices[k + 1][0], blk)
        n, nn, nq = sig.sizes
        theta = self.true_theta(system)
        zn = obs.state_names[:nn]
        out.series += [  # (computed when read: none of the run's length held here)
            Series(f"/observer/{name}/hgo/raw", zn, sig.zh(traj)),
            Series(f"/observer/{name}/hgo/saturated", [f"{s}_sat" for s in zn],
                   _Series(sig, "saturated", theta).of(traj, nn)),
            Series(f"/observer/{name}/aux", [f"z{s[2:]}" for s in zn],
                   _Series(sig, "aux", theta).of(traj, nn)),
            Series(f"/observer/{name}/theta_error", [f"theta_err{i + 1}" for i in range(nq)],
                   _Series(sig, "theta_error", theta).of(traj, nq))]
        run, T = steps_of(traj), traj.t_stop
        win = _Windows(dense.Window(run, 0.0, T), dense.Window(run, self.T_eps_factor
                                                               * blk["eps"], T),
                       dense.Window(run, self.window_start, T), self.window_start)
        # every row asked for first (measured values pending), then each window measured in
        # one pass over its steps
        rows = self._hgo_rows(system, traj, k, zn, blk["ideal"] > 0.5, blk, blk["eps"], win)
        rows += self._state_rows(sig, win, n)
        rows += self._theta_rows(sig, traj, theta, nq, win)
        if self.theory:
            beta_meas = next(v for q, v, _ in rows if q == "beta_measured")
            rows += self._theory(system, traj, obs, sig, theta, beta_meas, out, win)
        for q, v, b in rows:
            out.rows.append({"observer": name, "quantity": q, "empirical": _value(v),
                             "bound": _value(b)})
        for w in win.all:  # done with them
            dense.release(run, w.a, w.b)

    def _hgo_rows(self, system, traj, k, zn, ideal, blk, eps, win: _Windows) -> list:
        """Peaks, saturation times, end of peaking, eta of (13), lags of the HGO (6)."""
        sig = _Signals(system.plant.nx, system.z_slices[k + 1][0], blk)
        da, _ = system.d_slices[k]
        d = traj.d[-1, da:]
        nn = sig.sizes[1]
        rows = [] if ideal else self._peaks(system, k, zn, eps)
        rows += [("t_sat_first", math.nan if d[0] < 0 else float(d[0]), None),
                 ("t_sat_last", math.nan if d[1] < 0 else float(d[1]), None)]
        if not ideal:
            ends = [settling(win.whole, lambda s, j=j: sig.zerr(s)[:, j], self.peak_band,
                             win.t_window) for j in range(nn)]
            rows.append(("t_end_peaking", lambda: max(e.value for e in ends), None))
        for i, g in enumerate(self._block_gains(blk)):
            poles = np.linalg.eigvals(ac.hgo_matrix(g)) / eps
            rows += [(f"hgo{i + 1}_pole_slowest_re", float(poles.real.max()), None),
                     (f"hgo{i + 1}_pole_fastest_re", float(poles.real.min()), None)]
        beta_meas = win.after_T_eps.maximum(lambda s: np.linalg.norm(
            self._eta(sig.zerr(s), blk, eps), axis=1)).then(lambda m: float(m[0] / eps))
        rows += [("T_eps", self.T_eps_factor * eps, None), ("beta_measured", beta_meas, None)]
        h_max = self._h_max(system, blk, win.W, nn)
        lags = functools.cache(lambda: self._lags(None, blk, eps, np.array(
            [h.value for h in h_max])))
        for j in range(nn):
            peak = win.W.maximum(lambda s, j=j: np.abs(sig.zerr(s)[:, j]))
            rows.append((f"max_abs_zerr{j + 1}_W", peak.then(lambda m: float(m[0])), None))
            if not ideal:
                rows.append((f"lag_zerr{j + 1}_W", lambda j=j: float(lags()[j]), None))
        return rows

    def _h_max(self, system: System, blk: dict, window: dense.Window, nn: int
               ) -> list[dense.Pending]:
        """max |h_i| of (12) over ``window``, per z entry (|h| computed once per chunk for
        every entry; compiled when the window has many scan points)."""
        many = window.size() >= COMPILE_ROWS
        h_abs = dense.LastValue(lambda s: self._h_abs(system, s, blk, compiled=many))
        return [window.maximum(lambda s, j=j: h_abs(s)[:, j]).then(lambda m: m[0])
                for j in range(nn)]

    def _state_rows(self, sig: _Signals, win: _Windows, n: int) -> list:
        """max |e_i| (and when), on W too, RMS e_i on W, settling of ||e||."""
        rows = []
        for i in range(n):
            abs_e = lambda s, i=i: np.abs(sig.e(s)[:, i])  # noqa: E731
            peak = win.whole.maximum(abs_e)
            rows += [(f"max_abs_e{i + 1}", peak.then(lambda m: m[0]), None),
                     (f"t_max_abs_e{i + 1}", peak.then(lambda m: m[1]), None),
                     (f"max_abs_e{i + 1}_W", win.W.maximum(abs_e).then(lambda m: m[0]), None),
                     (f"rms_e{i + 1}_W", win.W.rms(lambda s, i=i: sig.e(s)[:, i]), None)]
        enorm = lambda s: np.linalg.norm(sig.e(s), axis=1)  # noqa: E731
        return rows + [(f"t_settle_e_{b:g}", settling(win.whole, enorm, b, win.t_window), None)
                       for b in self.state_bands]

    def _theta_rows(self, sig: _Signals, traj: Trajectory, theta: np.ndarray, nq: int,
                    win: _Windows) -> list:
        """theta^ at the end, its mean / min / max on W and over the run, the RMS relative
        error on W, settling within pct % and the share of W within 1 and 5 %."""
        run, T = steps_of(traj), traj.t_stop
        end = sig.th(run.at(np.array([T])))[0]
        rows = []
        for i in range(nq):
            s_ = f"theta_hat{i + 1}"
            th = lambda s, i=i: sig.th(s)[:, i]  # noqa: E731
            rel = lambda s, i=i: (sig.th(s)[:, i] - theta[i]) / abs(theta[i])  # noqa: E731
            rows += [(f"{s_}_end", float(end[i]), None),
                     (f"mean_{s_}_W", win.W.mean(th), None),
                     (f"min_{s_}_W", win.W.minimum(th).then(lambda m: m[0]), None),
                     (f"max_{s_}_W", win.W.maximum(th).then(lambda m: m[0]), None),
                     (f"min_{s_}", win.whole.minimum(th).then(lambda m: m[0]), None),
                     (f"max_{s_}", win.whole.maximum(th).then(lambda m: m[0]), None),
                     (f"rms_rel_theta_err{i + 1}_W", win.W.rms(rel), None)]
            rows += [(f"t_settle_theta{i + 1}_{pct:g}pct",
                      settling(win.whole, rel, pct / 100, win.t_window), None)
                     for pct in self.theta_pcts]
            rows += [(f"frac_W_theta{i + 1}_within_{pct:g}pct", win.W.fraction_above(
                lambda s, rel=rel, pct=pct: pct / 100 - np.abs(rel(s)), 0.0), None)
                for pct in (1.0, 5.0)]
        return rows

    def _peaks(self, system: System, k: int, zn: list[str], eps: float) -> list:
        """Raw |z_hk| peaks and their times from a noise-free re-simulation over
        [0, T(eps)] (DOP853 1e-10/1e-12, h_max T(eps)/100): the peak lasts a few eps, far
        below the run's output grid; located on that run's steps."""
        T_eps = self.T_eps_factor * eps
        solver = SolverSettings(t_end=T_eps, dt_out=T_eps / 100, method="dop853",
                                h_max=T_eps / 100, rtol=1e-10, atol=1e-12, dense_steps=True)
        fine = simulate(system, solver, no_noise(len(system.plant.output_names)))
        za, _ = system.z_slices[k + 1]
        rows = []
        for j, s in enumerate(zn):
            peak, t_peak = dense.maximum(fine.dense, lambda r, j=j: np.abs(r.z[:, za + j]),
                                         0.0, fine.t_stop)
            rows += [(f"{s}_peak", peak, None), (f"t_peak_{s}", t_peak, None)]
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
    def _h_abs(system: System, traj: Trajectory, blk: dict, compiled: bool | None = None
               ) -> np.ndarray:
        """|h_i(t)| of (12) per z entry (the block's h; the derivative of z_iqi minus
        b_i2 u), from the plant's own vector field at the samples (``compiled``: of
        :func:`vector_field`)."""
        dx = vector_field(system.plant, traj.t, traj.z[:, :system.plant.nx], traj.u, compiled)
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

    def _theory(self, system, traj, obs, sig: _Signals, theta, beta_meas: dense.Pending,
                out: PostOutput, win: _Windows) -> list:
        from hgo.papers.dimassi import theory

        blk = sig.blk
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
        psi_max = win.whole.maximum(lambda s: np.linalg.norm(
            psi_rows(obs.p, sig.x(s), s.u).reshape(len(s.t), -1), axis=1)).then(
            lambda m: m[0])
        u_max = win.whole.maximum(lambda s: np.max(np.abs(s.u), axis=1)).then(lambda m: m[0])
        h_each = self._h_max(system, blk, win.whole, int(blk["N"]))

        max_V = win.after_T_eps.maximum(lambda s: sig.V(s, chk.P, theta)).then(lambda m: m[0])

        @functools.cache
        def bounds() -> tuple:
            """h_max, beta_analytic, Theorem 1 with beta measured and analytic, the one in
            force (from the measured maxima)."""
            h_max = max(h.value for h in h_each)
            beta_an = max(theory.beta_analytic(g, h_max) for g in self._block_gains(blk))
            args = (chk.P, chk.Q, L, M, B, theta, blk["delta"], blk["sigma"], blk["eps"])
            thm = theory.theorem1(*args, beta_meas.value, psi_max.value, K_phi, K_psi)
            thm_an = theory.theorem1(*args, beta_an, psi_max.value, K_phi, K_psi)
            return h_max, beta_an, thm, thm_an, thm if self.beta == "measured" else thm_an

        rows += [("u_max", u_max, None),
                 ("psi_max_bound", lambda: float(np.hypot(1.0, u_max.value)), None),
                 ("psi_max", psi_max, None), ("h_max", lambda: bounds()[0], None),
                 ("beta_analytic", lambda: bounds()[1], None)]
        rows += [(q, lambda q=q: getattr(bounds()[2], q), None)
                 for q in ("tau", "K0", "K1", "K2", "K3", "R2")]
        rows += [("R2_beta_analytic", lambda: bounds()[3].R2, None),
                 ("max_V_after_T_eps", max_V,
                  lambda: bounds()[4].R2 if math.isfinite(bounds()[4].R2) else None)]
        out.series.append(Series(f"/observer/{obs.name}/lyapunov", ["V", "R2"], _Series(
            sig, "lyapunov", theta, chk.P, bounds()[4].R2).of(traj, 2)))
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
