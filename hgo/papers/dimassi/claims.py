"""Claims of Dimassi et al. (STA 2019), implementation notes ``shared/specs/dhlm.md`` §10.

Every number comes from runs of the ``dhlm_example`` preset (robot arm, T = 20 s,
W = [10, 20] s) with one change each; each check states its criterion.
"""

from __future__ import annotations

import numpy as np

from hgo.core.registry import NOT_REPRODUCED, PARTLY, REPRODUCED, Measured, claim
from hgo.running.in_memory import compose_cached, run_in_memory

PAPER = "dimassi"
NOMINAL = ("experiment=dhlm_example",)
OBS = "cascade"
K = "observer.cascade"
READINGS = ("A1: psi = [u, -sin y], theta = (1/I, m g l/(2I)) = (2, 9.81)",
            "A2: psi evaluated at y (reading a) unless stated",
            "A3: only the signal passed on is saturated, z_h^s in (5), (7)",
            "horizon T = 20 s, window W = [10, 20] s, DOP853 rtol 1e-10")
THEORY = ("A6: LMI (28) normalised P >= I, nu = 1e-3",
          "A11: beta measured = max_{t >= T(eps)} |eta|/eps, T(eps) = 25 eps",
          "A15: P, Q maximise lambda_min(Q)/lambda_max(P) subject to (8)-(9)")
EPS = (0.012, 0.006, 0.003)
DELTA = (10.0, 100.0, 1000.0)
SIGMA = (0.0, 0.01, 0.1)
IDEAL = ("plant.outputs=Hx", f"{K}.hgo=ideal")
XHAT = (f"{K}.psi_at=xhat",)
OMEGA = (f"{K}.omega_law=true",)


def saturation_level() -> float:
    """S_12 of the config (the paper's S_11 = S_12 = 150): the saturation of z_h12."""
    return float(compose_cached(NOMINAL).observer.cascade.S[1])


def window_start() -> float:
    """The start of the window W = [window_start, T] of the config (10 s)."""
    return float(compose_cached(NOMINAL).postprocess.dhlm.window_start)


def _table(extra: tuple[str, ...]):
    return run_in_memory(NOMINAL + extra).metrics.set_index(["observer", "quantity"])


def rows(*extra: str) -> dict[str, float]:
    """quantity -> empirical value of the cascade observer (nominal run + ``extra``)."""
    return _table(tuple(extra)).loc[OBS, "empirical"].to_dict()


def bound(quantity: str, *extra: str) -> float:
    """The ``bound`` column of a row of the cascade observer."""
    return float(_table(tuple(extra)).loc[(OBS, quantity), "bound"])


def _series(*extra: str) -> dict[str, np.ndarray]:
    """Post-processed series by entity, plus t, x (plant), xhat and w^ of the run."""
    run = run_in_memory(NOMINAL + tuple(extra))
    system, traj = run.experiment.system, run.trajectory
    out = {s.entity: np.asarray(s.values) for s in run.post.series}
    _, zb = system.z_slices[1]
    out.update(t=traj.t, x=traj.z[:, :system.plant.nx], xhat=traj.xh, omega_hat=traj.z[:, zb - 1])
    return out


def true_theta(*extra: str) -> np.ndarray:
    """The plant's true theta (the robot arm's (1/I, m g l/(2I)) of its configured
    parameters, or ``postprocess.dhlm.theta``), as the run's post-processor reads it."""
    mem = run_in_memory(NOMINAL + tuple(extra))
    post = next(p for p in mem.experiment.post.values() if hasattr(p, "true_theta"))
    return post.true_theta(mem.experiment.system)


def _sweep(key: str, values, quantities) -> dict[str, dict[float, float]]:
    """quantity -> {value of ``key``: measured}."""
    out: dict[str, dict[float, float]] = {q: {} for q in quantities}
    for v in values:
        r = rows(f"{K}.{key}={v}")
        for q in quantities:
            out[q][v] = r[q]
    return out


def _flat(sweep: dict[str, dict[float, float]], key: str) -> dict[str, float]:
    return {f"{q} ({key}={v:g})": x for q, d in sweep.items() for v, x in d.items()}


def _decreasing(values) -> bool:
    values = list(values)
    return all(b < a for a, b in zip(values[:-1], values[1:], strict=True))


@claim(paper=PAPER, id="hgo_estimates_z12", where="Fig. 1; Sec. IV",
       statement="the HGO (6) estimates z_12 after a short peaking, which the saturation "
                 "(S = 150) handles",
       runs=NOMINAL, readings=READINGS, verdict=REPRODUCED)
def hgo_estimates_z12() -> Measured:
    r = rows()
    lag, S = r["lag_zerr2_W"], saturation_level()
    nums = {"raw z_h12 peak": r["zh12_peak"], "t of the peak [s]": r["t_peak_zh12"],
            "S_12 (config)": S,
            "saturation active from [s]": r["t_sat_first"],
            "saturation active until [s]": r["t_sat_last"],
            "end of peaking (|z - z_h| < 1 for good) [s]": r["t_end_peaking"],
            "max |z_12 - z_h12| on W": r["max_abs_zerr2_W"],
            "quasi-static lag eps g1/g2 max|x2'| on W": lag}
    holds = (r["t_end_peaking"] < 0.1 and r["zh12_peak"] > S
             and r["max_abs_zerr2_W"] <= 1.05 * lag)
    return Measured(holds, nums, "criterion: peaking over within 0.1 s, raw peak above S_12 "
                    "(saturation active), residual on W at most 5 % above the O(eps) "
                    "quasi-static lag that predicts it (it does not vanish at fixed eps)")


@claim(paper=PAPER, id="states_converge", where="Figs. 2-3; Theorem 1",
       statement="x^ of (5), (7) tracks x1 and x2 (e converges to a compact set)",
       runs=NOMINAL, readings=READINGS, verdict=REPRODUCED)
def states_converge() -> Measured:
    r = rows()
    s = _series()
    t, x, xh = s["t"], s["x"], s["xhat"]
    W = t >= window_start()
    scale = np.max(np.abs(x[W]), axis=0)
    zerr = s[f"/observer/{OBS}/aux"][:, 1] - s[f"/observer/{OBS}/hgo/raw"][:, 1]
    e2 = xh[:, 1] - x[:, 1]
    corr = float(np.corrcoef(e2[W], zerr[W])[0, 1])
    nums = {"max |e1| on W [rad]": r["max_abs_e1_W"], "max |e2| on W [rad/s]": r["max_abs_e2_W"],
            "RMS e1 on W": r["rms_e1_W"], "RMS e2 on W": r["rms_e2_W"],
            "max |x1| on W": float(scale[0]), "max |x2| on W": float(scale[1]),
            "max |e2| over the run": r["max_abs_e2"], "at t [s]": r["t_max_abs_e2"],
            "|e| < 0.2 for good after [s]": r["t_settle_e_0.2"],
            "|e| < 0.05 for good after [s]": r["t_settle_e_0.05"],
            "corr(e2, z_12 - z_h12) on W": corr}
    holds = r["max_abs_e1_W"] < 0.05 * scale[0] and r["max_abs_e2_W"] < 0.05 * scale[1]
    return Measured(bool(holds), nums, "criterion: max |e_i| on W below 5 % of max |x_i| on W; "
                    "the residual e2 follows the HGO lag z_12 - z_h12 (correlation)")


@claim(paper=PAPER, id="parameters_converge", where="Figs. 4-5; Theorem 1",
       statement="theta^ of (7) converges to theta = (1/I, m g l/(2I)) (theta~ to a compact set)",
       runs=NOMINAL, readings=READINGS + (
           "test (the narrower statement): mean theta^i on W within 5 % of theta_i and RMS "
           "relative error on W < 10 % (theta~ in a small set); partly: theta^ does not "
           "settle at theta, see 'theta^1 within 10 % for good after' (NaN: it leaves the "
           "band inside W), reported, not required",), verdict=PARTLY)
def parameters_converge() -> Measured:
    r = rows()
    true = dict(enumerate(true_theta(), start=1))  # (1/I, m g l/(2I)) of the config
    nums = {}
    for i, theta in true.items():
        nums.update({f"mean theta^{i} on W": r[f"mean_theta_hat{i}_W"],
                     f"min theta^{i} on W": r[f"min_theta_hat{i}_W"],
                     f"max theta^{i} on W": r[f"max_theta_hat{i}_W"],
                     f"theta^{i}(20)": r[f"theta_hat{i}_end"],
                     f"RMS theta~{i}/theta{i} on W": r[f"rms_rel_theta_err{i}_W"],
                     f"transient min theta^{i}": r[f"min_theta_hat{i}"],
                     f"transient max theta^{i}": r[f"max_theta_hat{i}"]})
        for pct in (1, 5, 10, 25):
            nums[f"theta^{i} within {pct} % for good after [s]"] = \
                r[f"t_settle_theta{i}_{pct}pct"]
        for pct in (1, 5):
            nums[f"fraction of W with theta^{i} within {pct} %"] = \
                r[f"frac_W_theta{i}_within_{pct}pct"]
        nums[f"theta{i}"] = float(theta)
    mean_ok = all(abs(r[f"mean_theta_hat{i}_W"] / th - 1) < 0.05 for i, th in true.items())
    rms_ok = all(r[f"rms_rel_theta_err{i}_W"] < 0.1 for i in (1, 2))
    return Measured(bool(mean_ok and rms_ok), nums,
                    "holds (narrower): mean theta^i on W within 5 % of theta_i and RMS relative "
                    "error on W < 10 %; not pointwise: see 'theta^1 within 10 % for good "
                    "after' (NaN: theta^1 leaves the 10 % band inside W, excursions of the "
                    "HGO-lag-driven residual)")


@claim(paper=PAPER, id="theorem1_D_R", where="Theorem 1, (8)-(10), (20)-(23)",
       statement="with (8)-(10), e and theta~ are bounded and converge to D_R = {V < R^2}",
       runs=(NOMINAL[0], NOMINAL[0] + " " + XHAT[0]), readings=READINGS + THEORY,
       verdict=PARTLY)
def theorem1_D_R() -> Measured:
    a, b = rows(), rows(*XHAT)
    R2 = bound("max_V_after_T_eps")
    cascade = compose_cached(NOMINAL).observer.cascade  # eps, delta: the config's, not typed
    eps, delta = float(cascade.eps), float(cascade.delta)
    theta = true_theta()
    nums = {"(a) margin of (10)": a["margin10"], "(a) tau": a["tau"], "(a) K0": a["K0"],
            "(a) K1": a["K1"], "(a) K2": a["K2"], "(a) K3": a["K3"],
            "(a) beta measured": a["beta_measured"], "(a) beta analytic": a["beta_analytic"],
            "(a) R^2 (beta measured)": R2, "(a) R^2 (beta analytic)": a["R2_beta_analytic"],
            "(a) max V on [T(eps), T]": a["max_V_after_T_eps"],
            "(a) sqrt(delta) R (bound on |theta~|)": float(np.sqrt(delta * R2)),
            "|theta|": float(np.linalg.norm(theta)), "eps (config)": eps,
            "delta (config)": delta,
            "(b) margin of (10) (K_psi = 1, best P)": b["margin10"], "(b) tau": b["tau"],
            "(b) R^2": b["R2"], "(b) max V on [T(eps), T]": b["max_V_after_T_eps"],
            "(b) RMS theta~1/theta1 on W": b["rms_rel_theta_err1_W"],
            "(a) RMS theta~1/theta1 on W": a["rms_rel_theta_err1_W"],
            "(b) max |e2| on W": b["max_abs_e2_W"], "(a) max |e2| on W": a["max_abs_e2_W"]}
    holds = (a["margin10"] > 0 and a["K0"] - a["K1"] * eps > 0
             and a["max_V_after_T_eps"] < R2 and b["margin10"] < 0)
    return Measured(bool(holds), nums,
                    "holds (narrower): under reading (a) (8)-(10) hold and V stays in D_R after "
                    "T(eps), but D_R is uninformative (sqrt(delta) R >> |theta|); under "
                    "reading (b) (10) fails for every P of (8)-(9) (tau < 0: Theorem 1 does "
                    "not apply), yet the run behaves as under (a)")


@claim(paper=PAPER, id="small_eps_shrinks_residual", where="text after (23)",
       statement="a smaller eps makes the radius R of D_R (and the residual) smaller",
       runs=tuple(f"{NOMINAL[0]} {K}.eps={e}" for e in EPS), readings=READINGS + THEORY,
       verdict=REPRODUCED)
def small_eps_shrinks_residual() -> Measured:
    sw = _sweep("eps", EPS, ["max_abs_e2_W", "rms_rel_theta_err1_W", "R2"])
    ok = all(_decreasing(sw[q][e] for e in EPS) for q in sw)
    ratio = sw["max_abs_e2_W"][0.012] / sw["max_abs_e2_W"][0.003]
    return Measured(ok, {**_flat(sw, "eps"), "max|e2|_W ratio eps 0.012/0.003": ratio},
                    "criterion: max |e2| on W, RMS theta~1/theta1 on W and R^2 (23) all decrease "
                    "as eps halves (the residual scales ~ eps: ratio ~ 4 for a factor 4)")


@claim(paper=PAPER, id="large_delta_shrinks_D_R", where="text after (23)",
       statement="with eps and sigma fixed, a larger delta diminishes D_R",
       runs=tuple(f"{NOMINAL[0]} {K}.delta={d}" for d in DELTA), readings=READINGS + THEORY,
       verdict=NOT_REPRODUCED)
def large_delta_shrinks_D_R() -> Measured:
    sw = _sweep("delta", DELTA, ["R2", "rms_rel_theta_err1_W", "rms_rel_theta_err2_W",
                                 "max_abs_e1_W", "max_abs_e2_W"])
    formula = _decreasing(sw["R2"][d] for d in DELTA)
    sim = all(_decreasing(sw[q][d] for d in DELTA) for q in sw if q != "R2")
    return Measured(formula and sim, _flat(sw, "delta"),
                    "criterion: R^2 (23) and the simulated residuals on W decrease with delta. "
                    "R^2 grows with delta (K2 holds sqrt(delta) beta Psi_max, which dominates "
                    "K3 = 2 sigma |theta|/sqrt(delta)); the simulated residuals are not monotone")


@claim(paper=PAPER, id="T_eps_to_zero", where="(15)",
       statement="T(eps) -> 0 as eps -> 0+ (OCR: '+inf', A8)",
       runs=tuple(f"{NOMINAL[0]} {K}.eps={e}" for e in EPS), readings=READINGS,
       verdict=REPRODUCED)
def T_eps_to_zero() -> Measured:
    sw = _sweep("eps", EPS, ["t_end_peaking", "zh12_peak"])
    nums = _flat(sw, "eps")
    for e in EPS:
        nums[f"end of peaking / eps (eps={e:g})"] = sw["t_end_peaking"][e] / e
        nums[f"raw peak * eps (eps={e:g})"] = sw["zh12_peak"][e] * e
    ok = (_decreasing(sw["t_end_peaking"][e] for e in EPS)
          and _decreasing(sw["zh12_peak"][e] for e in reversed(EPS)))
    return Measured(ok, nums, "criterion: the end of peaking (|z - z_h| < 1 for good) "
                    "decreases with eps and the raw z_h12 peak grows as eps decreases (~1/eps)")


@claim(paper=PAPER, id="sigma_modification_residual", where="text after (23)",
       statement="with the sigma-modification there is no exact convergence but a residual "
                 "set, and no persistency of excitation is needed",
       runs=tuple(f"{NOMINAL[0]} {K}.sigma={s}" for s in SIGMA)
       + (" ".join(NOMINAL + IDEAL + (f"{K}.sigma=0", "solver.t_end=40")),),
       readings=READINGS + ("ideal z_h = Hx run: no HGO, no saturation (diagnostic)",),
       verdict=PARTLY)
def sigma_modification_residual() -> Measured:
    sw = _sweep("sigma", SIGMA, ["mean_theta_hat1_W", "mean_theta_hat2_W",
                                 "rms_rel_theta_err1_W", "rms_rel_theta_err2_W"])
    ideal = _series(*IDEAL, f"{K}.sigma=0", "solver.t_end=40")
    t, V = ideal["t"], ideal[f"/observer/{OBS}/lyapunov"][:, 0]
    theta2 = float(true_theta()[1])  # m g l/(2I) of the config (sigma changes the observer)
    bias = {s: abs(sw["mean_theta_hat2_W"][s] - theta2) for s in SIGMA}
    nums = {**_flat(sw, "sigma"), **{f"|mean theta^2 - theta2| on W (sigma={s:g})": b
                                     for s, b in bias.items()},
            "ideal z_h, sigma = 0: V(0)": float(V[0]),
            "ideal z_h, sigma = 0: V(10 s)": float(V[np.searchsorted(t, 10.0)]),
            "ideal z_h, sigma = 0: V(40 s)": float(V[-1])}
    pe = V[-1] < 1e-12 * V[0]
    holds = bias[0.1] > bias[0.01] > bias[0.0] and pe
    return Measured(bool(holds), nums,
                    "holds (narrower): sigma > 0 leaves a sigma-dependent bias of theta^2 "
                    "(|mean - theta2| on W grows with sigma; theta^1's mean is not monotone in "
                    "sigma); the 'no PE needed' part is not "
                    "tested by this example: with ideal z_h and sigma = 0, V -> 0 exponentially, "
                    "so u = 5(sin 2t + cos 3t) is persistently exciting")


@claim(paper=PAPER, id="matching_fails_for_C", where="Sec. IV; (9), (28)",
       statement="observer matching fails for C (rank CB != rank B) and holds for H = [C; CA]",
       readings=THEORY[:1], verdict=REPRODUCED)
def matching_fails_for_C() -> Measured:
    from hgo.papers.dimassi import theory

    A = np.array([[0.0, 1.0], [0.0, 0.0]])
    B = np.array([[0.0], [1.0]])
    C = np.array([[1.0, 0.0]])
    H = np.eye(2)
    rk = np.linalg.matrix_rank
    nums = {"rank CB": float(rk(C @ B)), "rank HB": float(rk(H @ B)), "rank B": float(rk(B)),
            "rho* (28), H = C, P >= I": theory.lmi28(A, B, C).rho,
            "rho* (28), H = C, P >= 1e-9 I": theory.lmi28(A, B, C, p_min=1e-9).rho,
            "rho* (28), H = I, P >= I": theory.lmi28(A, B, H).rho,
            "equality mode (9), H = C: feasible": str(theory.lmi_equality(A, B, C)),
            "equality mode (9), H = I: feasible": str(theory.lmi_equality(A, B, H))}
    holds = (nums["rank CB"] != nums["rank B"] and nums["rank HB"] == nums["rank B"]
             and nums["rho* (28), H = C, P >= I"] > 1e-3 and nums["rho* (28), H = I, P >= I"] < 1e-7
             and not theory.lmi_equality(A, B, C) and theory.lmi_equality(A, B, H))
    return Measured(bool(holds), nums, "criterion: ranks as stated; (28) with P >= I has "
                    "rho* > 0 for H = C and rho* = 0 for H = I (equality mode agrees). Without "
                    "the normalisation rho* -> 0 for H = C too (the literal (28) is degenerate)")


def _converged(r: dict[str, float], run: dict[str, np.ndarray]) -> bool:
    """The criteria of states_converge and parameters_converge on one run: max |e_i| on W
    below 5 % of max |x_i| on W, RMS theta~_i / theta_i on W below 10 %."""
    W = run["t"] >= window_start()
    scale = np.max(np.abs(run["x"][W]), axis=0)
    return bool(r["max_abs_e1_W"] < 0.05 * scale[0] and r["max_abs_e2_W"] < 0.05 * scale[1]
                and r["rms_rel_theta_err1_W"] < 0.1 and r["rms_rel_theta_err2_W"] < 0.1)


@claim(paper=PAPER, id="omega_law_relaxes_10", where="Remark 1, (11) (reconstructed, A10)",
       statement="the additional adaptation law (11) relaxes condition (10)",
       runs=tuple(" ".join(NOMINAL + o) for o in ((), OMEGA, XHAT, XHAT + OMEGA)),
       readings=READINGS + ("A10: (11) injected as w^ B M (z_h^s - H x^), sigma2 = 0.01, "
                            "reconstructed",
                            "the paper states (11) in a remark citing [9], keeps it out of "
                            "Theorem 1 and runs no simulation with it; the test: under reading "
                            "(b), where (10) fails, the observer with (11) converges (the "
                            "criteria of states_converge and parameters_converge)",
                            "partly, not reproduced: what the example cannot show is that (11) "
                            "is what relaxes (10): the run without (11) converges under (b) "
                            "too (the deciding numbers: (b) margin of (10) < 0, (b) converges "
                            "without (11) = True)"), verdict=PARTLY)
def omega_law_relaxes_10() -> Measured:
    nums: dict[str, float | str] = {}
    for tag, base in (("(a)", ()), ("(b)", XHAT)):
        r0, r1 = rows(*base), rows(*base, *OMEGA)
        for q in ("max_V_after_T_eps", "rms_rel_theta_err1_W", "rms_rel_theta_err2_W",
                  "max_abs_e2_W"):
            nums[f"{tag} {q} without (11)"] = r0[q]
            nums[f"{tag} {q} with (11)"] = r1[q]
    margin = rows(*XHAT)["margin10"]
    with11 = _converged(rows(*XHAT, *OMEGA), _series(*XHAT, *OMEGA))
    without11 = _converged(rows(*XHAT), _series(*XHAT))
    nums["(b) margin of (10)"] = margin
    nums["(b) converges with (11)"] = str(with11)
    nums["(b) converges without (11)"] = str(without11)
    nums["(a) w^(20) with (11)"] = float(_series(*OMEGA)["omega_hat"][-1])
    return Measured(bool(margin < 0 and with11), nums,
                    "holds (narrower): where (10) fails (reading (b)) the observer with (11) "
                    "converges; the run without (11) converges as well, so the example "
                    "cannot show (11) relaxing (10)")
