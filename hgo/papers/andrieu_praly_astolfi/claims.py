"""Claims of Andrieu, Praly & Astolfi (2007), Section 3 (notes ``shared/specs/apa.md`` §10).

Every claim measures real runs of the presets (``apa_fig2`` = the paper's scenario,
``apa_model``, ``apa_nominal``, ``apa_noise``; seeds 0-2 where noise is on) or, for claim 1,
the bounds on a grid; the numbers below come from those measurements. Observers: df2max
(constant gain), omega1 (Omega1), omega2 (Omega2, the paper's new observer). e = eta^2 - eta2.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from functools import cache

import numpy as np

from hgo.core.registry import PARTLY, REPRODUCED, Measured, claim
from hgo.papers.andrieu_praly_astolfi.theory import order_check, setup_constants
from hgo.running.in_memory import compose_cached, run_in_memory, run_rows

PAPER = "andrieu_praly_astolfi"
OBS = ("df2max", "omega1", "omega2")
SEEDS = (0, 1, 2)
WINDOWS = ("w1", "w2", "w3", "w4")  # [3,10), [13,20), [23,35), [38,50)
BASE = "C2 eps from hbar_o; C5 eta(0) = (0.3, 0.5), eta^(0) = (0.5, 0.3); C6 L(0) equilibrium"
R_C3 = "C3 = p0 (df2max, Omega1 observers: the Sec. 3 observer at p = 0)"
R_C8 = "C8: sigma = 0.05 held Delta = 0.01, seeds 0-2"
R_C11 = "C11: df2/dx2 along the true solution (hbar = 1), hbar_o reading also reported"


def paper(seed: int, *extra: str) -> tuple[str, ...]:
    return ("experiment=apa_fig2", f"seed={seed}", *extra)


MODEL = ("experiment=apa_model",)
NOMINAL = ("experiment=apa_nominal",)


@dataclass(frozen=True)
class Setup:
    """The constants the checks use, read from the paper run's config (apa_fig2): the
    observers' hbar_o (0.8) and the plant's hbar (1), phi2 (0.01, the least L of (8)), the
    Omega2 power p (0.9), the input's switch times (10, 20, 35), the noise period Delta
    (0.01), the late window's start (40) and the steady windows [a, b)."""

    hbar_o: float
    hbar: float
    phi2: float
    p: float
    switches: tuple[float, ...]
    noise_period: float
    late_start: float
    steady: tuple[tuple[float, float], ...]
    t_end: float


@cache
def setup() -> Setup:
    cfg = compose_cached(paper(0))
    obs, post = cfg.observer.omega2, cfg.postprocess.apa
    return Setup(float(obs.hbar), float(cfg.plant.hbar), float(obs.phi2), float(obs.p),
                 tuple(float(t) for t in cfg.controller.times), float(cfg.noise.period),
                 float(post.late[0]), tuple((float(a), float(b)) for a, b in post.steady),
                 float(cfg.solver.t_end))


def L_bound(overrides: tuple[str, ...]) -> float:
    """phi2 + (phi3/phi1) df2max (C4) of the run's Omega1 observer (its own hbar_o, M_u)."""
    o = compose_cached(overrides).observer.omega1
    return setup_constants(float(o.hbar), float(o.u_min), float(o.u_max), float(o.phi1),
                           float(o.phi2), float(o.phi3))["L_df2max"]


def noise_only(seed: int) -> tuple[str, ...]:
    return ("experiment=apa_noise", f"seed={seed}")


def _series(overrides: tuple[str, ...]) -> tuple[np.ndarray, dict]:
    run = run_in_memory(overrides)
    return run.trajectory.t, {s.entity: s.values for s in run.post.series}


def _ordered(values: list[float]) -> bool:
    """values strictly decreasing (df2max > omega1 > omega2)."""
    return all(a > b for a, b in zip(values, values[1:], strict=False))


@claim(paper=PAPER, id="bound_order", where="Sec. 3, display after the observer",
       statement="df2/dx2 <= Omega2 <= Omega1 <= df2max on M_x x M_u",
       verdict=PARTLY, readings=("C2: eps from the hbar equalities", "p = 0.9",
                                 "grid 24 u x 300 x1 (log) x 60 x2",
                                 "test (the narrower statement): df2/dx2 <= Omega2 and "
                                 "Omega1 <= df2max at every grid point, hbar_o and hbar; "
                                 "partly: Omega2 <= Omega1 fails on a share of the grid for "
                                 "hbar_o (the numbers), reported, not banded"))
def bound_order() -> Measured:
    """The narrower statement that holds: df2/dx2 <= Omega2 and Omega1 <= df2max at every
    grid point, for hbar_o and hbar; Omega2 <= Omega1 is reported (share of failing points,
    largest relative excess), not required."""
    nums: dict[str, float | str] = {}
    exact = True
    su = setup()
    checks = {hbar: order_check(hbar, su.p) for hbar in (su.hbar_o, su.hbar)}  # (each once)
    for hbar, res in checks.items():
        for key, r in res.items():
            nums[f"hbar={hbar} {key}: share failing"] = r["share_fail"]
            nums[f"hbar={hbar} {key}: max rel excess"] = r["max_rel_excess"]
            if key != "Omega2<=Omega1":
                exact &= r["share_fail"] == 0.0
        r = res["Omega2<=Omega1"]
        nums[f"hbar={hbar} Omega2<=Omega1 worst at (u, x1, x2)"] = (
            f"({r['at_u']:.3g}, {r['at_x1']:.3g}, {r['at_x2']:.3g})")
    return Measured(holds=exact, numbers=nums,
                    summary="holds (narrower): df2/dx2 <= Omega2 and Omega1 <= df2max at every "
                            "grid point; Omega2 <= Omega1 fails on a share of the points for "
                            "hbar_o (see the numbers)")


TIE = 1e-9  # |Omega2 - Omega1| <= TIE Omega1: a tie (they coincide exactly on some arcs)


@claim(paper=PAPER, id="fig1_order_in_mean", where="Sec. 3.1, text on Fig. 1; (12), (13)",
       statement="the predicted order df2max >= Omega1 >= Omega2 >= df2/dx2 is observed in the "
                 "mean", verdict=REPRODUCED, runs=("experiment=apa_fig2 seed=0,1,2",),
       readings=(BASE, R_C3, R_C8, R_C11, "C12: Omega_i along its own observer",
                 "Omega2 bounds the incremental rate |f2(x2) - f2(x^2)| / |x2 - x^2| of (12): "
                 "the last inequality compares mean Omega2 with the mean of |df2/dx2| (the "
                 "signed mean is negative, -0.61, and would hold trivially)"))
def fig1_order_in_mean() -> Measured:
    nums: dict[str, float | str] = {}
    ok = True
    for s in SEEDS:
        rows = run_rows(paper(s))
        t, ser = _series(paper(s))
        means = [rows[(o, "mean_Omega")] for o in OBS]
        abs_true, abs_model = (rows[("plant", f"mean_abs_rate_{k}")] for k in ("true", "model"))
        om1 = ser["/observer/omega1/Omega"][:, 0]
        om2 = ser["/observer/omega2/Omega"][:, 0]
        tie = np.abs(om2 - om1) <= TIE * np.abs(om1)
        for o, m in zip(OBS, means, strict=True):
            nums[f"seed {s} mean {o}"] = m
        nums[f"seed {s} mean |df2/dx2| (true)"] = abs_true
        nums[f"seed {s} mean |df2/dx2| (hbar_o)"] = abs_model
        nums[f"seed {s} mean df2/dx2 (true, signed)"] = rows[("plant", "mean_rate_true")]
        nums[f"seed {s} share Omega2 < Omega1 (samples)"] = float(np.mean((om2 < om1) & ~tie))
        nums[f"seed {s} share Omega2 = Omega1 (ties, rel. {TIE:g})"] = float(np.mean(tie))
        ok &= _ordered(means) and means[-1] >= max(abs_true, abs_model)
    return Measured(holds=ok, numbers=nums,
                    summary="time means over [0, 50] (on the steps): df2max > mean Omega1 > "
                            "mean Omega2 > mean |df2/dx2| (both hbar readings) for every seed")


def _increment_rms(t: np.ndarray, x: np.ndarray, lag: int) -> float:
    """RMS of x(t + lag dt) - x(t), leaving out the increments across an input switch
    (Omega jumps there with u, noise or not)."""
    inc = x[lag:] - x[:-lag]
    across = np.zeros(inc.size, bool)
    for ts in setup().switches:
        across |= (t[:-lag] < ts + 1e-9) & (t[lag:] > ts - 1e-9)
    return float(np.sqrt(np.mean(inc[~across] ** 2)))


@claim(paper=PAPER, id="fig1_noise_reflected", where="Sec. 3.1, text on Fig. 1",
       statement="the noise, present in the measure, is reflected in these estimations",
       verdict=REPRODUCED, runs=("experiment=apa_fig2 seed=0,1,2", "experiment=apa_model"),
       readings=(BASE, R_C3, R_C8, "criterion: RMS of the increments of Omega over one noise "
                 "period, t >= 1, increments across the input switches left out, at least 10x "
                 "larger with noise than without"))
def fig1_noise_reflected() -> Measured:
    t_all, clean = _series(MODEL)
    keep = t_all >= 1.0
    t = t_all[keep]
    lag = int(round(setup().noise_period / (t[1] - t[0])))  # one noise period
    nums: dict[str, float | str] = {}
    ok = True
    for o in ("omega1", "omega2"):
        c = clean[f"/observer/{o}/Omega"][keep, 0]
        q = np.percentile(c, [1, 99])
        nums[f"{o} clean 1-99% range"] = f"[{q[0]:.3g}, {q[1]:.3g}]"
        nums[f"{o} clean max"] = float(c.max())
        for s in SEEDS:
            _, noisy = _series(paper(s))
            n = noisy[f"/observer/{o}/Omega"][keep, 0]
            q = np.percentile(n, [1, 99])
            ratio = _increment_rms(t, n, lag) / _increment_rms(t, c, lag)
            nums[f"{o} seed {s} noisy 1-99% range"] = f"[{q[0]:.3g}, {q[1]:.3g}]"
            nums[f"{o} seed {s} noisy max"] = float(n.max())
            nums[f"{o} seed {s} std(noisy - clean)"] = float(np.std(n - c))
            nums[f"{o} seed {s} increment RMS ratio noisy/clean"] = ratio
            ok &= ratio > 10.0
    nums["df2max: constant by construction"] = "yes"
    return Measured(holds=ok, numbers=nums,
                    summary="Omega1 and Omega2 fluctuate at the noise period with noise and "
                            "not without (df2max is a constant)")


@claim(paper=PAPER, id="fig2_bias_from_hbar", where="Sec. 3.1, text on Fig. 2",
       statement="We observe in the three cases a bias which is due to the error in hbar",
       verdict=PARTLY, runs=("experiment=apa_model", "experiment=apa_nominal",
                             "experiment=apa_fig2 seed=0,1,2", "experiment=apa_noise seed=0,1,2"),
       readings=(BASE, R_C3, R_C8, "C7: eta^ = F^{-1} of the saturated x^"))
def fig2_bias_from_hbar() -> Measured:
    """Noise-free, the bias is the hbar error's (model vs nominal). With noise, the noise alone
    (apa_noise, no hbar error) also biases eta^2 through the saturations and F^{-1}: the part
    due to hbar is the paper run's bias minus the noise-only run's (same seeds)."""
    model, nominal = run_rows(MODEL), run_rows(NOMINAL)
    su = setup()
    t = run_in_memory(MODEL).trajectory.t
    eta2_late = float(run_in_memory(MODEL).trajectory.z[t >= su.late_start, 1].mean())
    analytic = (su.hbar_o - su.hbar) * eta2_late
    nums: dict[str, float | str] = {"analytic bias (hbar_o - hbar) mean eta2, late window":
                                    analytic}
    noise_free, noisy = True, True
    for o in OBS:
        bm, bn = model[(o, "bias_late")], nominal[(o, "bias_late")]
        bp = float(np.mean([run_rows(paper(s))[(o, "bias_late")] for s in SEEDS]))
        bq = float(np.mean([run_rows(noise_only(s))[(o, "bias_late")] for s in SEEDS]))
        nums[f"{o} bias [40,50] model (hbar_o = 0.8, no noise)"] = bm
        nums[f"{o} bias [40,50] nominal (no error, no noise)"] = bn
        nums[f"{o} bias [40,50] paper (hbar_o = 0.8, noise), seeds 0-2 mean"] = bp
        nums[f"{o} bias [40,50] noise only (hbar_o = 1), seeds 0-2 mean"] = bq
        nums[f"{o} paper - noise only"] = bp - bq
        for w in WINDOWS:
            nums[f"{o} bias {w} model"] = model[(o, f"bias_{w}")]
        noise_free &= bm < 0 and abs(bm) >= 0.5 * abs(analytic) and abs(bn) < 0.1 * abs(bm)
        noisy &= bp - bq < 0 and abs(bp - bq) >= 0.5 * abs(analytic)
    nums["noise-free: bias is the hbar error's, all three"] = str(noise_free)
    nums["with noise: paper - noise-only >= half the analytic bias, all three"] = str(noisy)
    return Measured(holds=noise_free, numbers=nums,
                    summary="without noise every observer has the bias (hbar_o - 1) eta2 of the "
                            "hbar error (none without it); with the paper's noise the noise alone "
                            "biases eta^2 too, and for the df2max observer the paper run's bias "
                            "is no larger than the noise-only run's (not due to hbar there)")


@claim(paper=PAPER, id="fig2_bias_increases_with_rate", where="Sec. 3.1, text on Fig. 2",
       statement="[the bias] increases with the estimates of the local incremental rate "
                 "(|bias| df2max > Omega1 > Omega2)", verdict=PARTLY,
       runs=("experiment=apa_fig2 seed=0,1,2", "experiment=apa_model",
             "experiment=apa_noise seed=0,1,2"),
       readings=(BASE, R_C3, R_C8))
def fig2_bias_increases_with_rate() -> Measured:
    nums: dict[str, float | str] = {}
    late_noisy, windows_all = True, True
    for label, ov in [("model", MODEL)] + [(f"paper seed {s}", paper(s)) for s in SEEDS]:
        rows = run_rows(ov)
        for w in ("late",) + WINDOWS:
            b = [abs(rows[(o, f"bias_{w}")]) for o in OBS]
            nums[f"{label} |bias| {w} (df2max, omega1, omega2)"] = ", ".join(
                f"{v:.4g}" for v in b)
            windows_all &= _ordered(b)
            if w == "late" and label != "model":
                late_noisy &= _ordered(b)
    nums["order holds in every window, run"] = str(windows_all)
    for s in SEEDS:  # the same order without the hbar error: it comes with the noise
        rows = run_rows(noise_only(s))
        nums[f"noise only (hbar_o = 1) seed {s} |bias| late"] = ", ".join(
            f"{abs(rows[(o, 'bias_late')]):.4g}" for o in OBS)
    return Measured(holds=late_noisy, numbers=nums,
                    summary="with noise, |bias| on [40, 50] is ordered df2max > Omega1 > "
                            "Omega2 for every seed (as in the noise-only runs: the ordered part "
                            "comes with the noise); not in every steady window, and without "
                            "noise the three biases are nearly equal")


def _pearson(a: list[float], b: list[float]) -> float:
    return float(np.corrcoef(a, b)[0, 1])


@claim(paper=PAPER, id="fig2_std_correlates_with_rate", where="Sec. 3.1, text on Fig. 2",
       statement="strong correlation between the std of eta^2 - eta2 and the magnitude of "
                 "df2max, Omega1, Omega2", verdict=REPRODUCED,
       runs=("experiment=apa_fig2 seed=0,1,2",),
       readings=(BASE, R_C3, R_C8, "criterion: same order of std[40,50] and mean Omega "
                 "across observers, and in each steady window Pearson r(log std, log mean "
                 "Omega) > 0.7 over 3 observers x 3 seeds (pooled r reported)"))
def fig2_std_correlates_with_rate() -> Measured:
    nums: dict[str, float | str] = {}
    su = setup()
    spans = {f"w{k}": ab for k, ab in enumerate(su.steady, start=1)}
    std_late = {o: [] for o in OBS}
    log_std, log_om = [], []
    for s in SEEDS:
        rows = run_rows(paper(s))
        t, ser = _series(paper(s))
        for o in OBS:
            std_late[o].append(rows[(o, "std_late")])
            om = ser[f"/observer/{o}/Omega"][:, 0]
            for w, (a, b) in spans.items():
                mask = (t >= a) & (t < b) if b < su.t_end else (t >= a)
                log_std.append(math.log(rows[(o, f"std_{w}")]))
                log_om.append(math.log(float(om[mask].mean())))
    mean_std = [float(np.mean(std_late[o])) for o in OBS]
    mean_om = [float(np.mean([run_rows(paper(s))[(o, "mean_Omega")] for s in SEEDS]))
               for o in OBS]
    r = _pearson(log_std, log_om)
    for o, sd, om in zip(OBS, mean_std, mean_om, strict=True):
        nums[f"{o} std[40,50] (3-seed mean)"] = sd
        nums[f"{o} mean Omega (3-seed mean)"] = om
    n_w = len(spans)
    for k, w in enumerate(spans):  # per-window correlation across observers and seeds
        idx = [i for i in range(len(log_std)) if i % n_w == k]
        nums[f"r(log std, log Omega) window {w}"] = _pearson([log_std[i] for i in idx],
                                                             [log_om[i] for i in idx])
    nums["pooled r(log std, log Omega), 4 windows x 3 observers x 3 seeds"] = r
    per_window = [v for k, v in nums.items() if k.startswith("r(log std, log Omega) window")]
    same_order = _ordered(mean_std) and _ordered(mean_om)
    return Measured(holds=same_order and min(per_window) > 0.7, numbers=nums,
                    summary="std[40,50] and mean Omega have the same order across observers; "
                            "within each steady window log std and log mean Omega correlate "
                            "(r > 0.7); pooled over windows the correlation is weaker (the "
                            "eta2 level, hence the gain of F^{-1}, differs between windows)")


def _order_table(extra: tuple[str, ...], seeds: tuple[int, ...],
                 nums: dict[str, float | str], tag: str) -> tuple[bool, bool]:
    """RMS[10,50] order and per-window std order for the runs paper(seed, *extra)."""
    rms_ok, win_ok = True, True
    for s in seeds:
        rows = run_rows(paper(s, *extra))
        rms = [rows[(o, "rms_post")] for o in OBS]
        nums[f"{tag} seed {s} RMS[10,50] (df2max, omega1, omega2)"] = ", ".join(
            f"{v:.4g}" for v in rms)
        rms_ok &= _ordered(rms)
        for w in WINDOWS:
            sd = [rows[(o, f"std_{w}")] for o in OBS]
            nums[f"{tag} seed {s} std {w}"] = ", ".join(f"{v:.4g}" for v in sd)
            win_ok &= _ordered(sd)
    return rms_ok, win_ok


PAPER_SET_UP = "C3=p0 Delta=0.01"  # the readings in force (the paper's noise period)


@claim(paper=PAPER, id="fig2_best_is_omega2", where="Sec. 3.1 end of the text on Fig. 2; Sec. 3",
       statement="As predicted the best result is given by the new observer based on Omega2 "
                 "(updated gain better than constant, the new one even better, in particular "
                 "with noise)", verdict=REPRODUCED,
       runs=("experiment=apa_fig2 seed=0,1,2", "readings.c3=linear seed=0,1,2",
             "noise.period=0.1 seed=0,1,2"),
       readings=(BASE, R_C3 + "; also C3 = unit", R_C8 + "; also Delta = 0.1",
                 "test, at the readings in force (C3 = p0, Delta = 0.01, seeds 0-2): RMS of e "
                 "on [10, 50] and the std of e in every steady window ordered df2max > Omega1 > "
                 "Omega2; Omega2 has the smallest RMS in all 9 runs",
                 "reproduced (was partly): the two variants are sensitivities, not the paper's "
                 "set-up (spec §10.7): Delta = 0.1 holds the noise 10x longer than the paper's "
                 "and reverses df2max / Omega1 (RMS 0.17 vs 0.21-0.23), C3 = unit keeps the "
                 "RMS order but not every window's std; Omega2 stays best in both"))
def fig2_best_is_omega2() -> Measured:
    nums: dict[str, float | str] = {}
    best = []
    flags = {}
    for tag, extra in ((PAPER_SET_UP, ()), ("C3=unit Delta=0.01", ("readings.c3=linear",)),
                       ("C3=p0 Delta=0.1", ("noise.period=0.1",))):
        flags[tag] = _order_table(extra, SEEDS, nums, tag)
        best += [min(OBS, key=lambda o, s=s: run_rows(paper(s, *extra))[(o, "rms_post")])
                 for s in SEEDS]
    for tag, (rms_ok, win_ok) in flags.items():
        nums[f"{tag}: full RMS order / every-window std order"] = f"{rms_ok} / {win_ok}"
    nums["observer with the smallest RMS[10,50], 9 runs"] = ", ".join(best)
    return Measured(holds=all(flags[PAPER_SET_UP]) and all(b == "omega2" for b in best),
                    numbers=nums,
                    summary="at the readings in force the order df2max > Omega1 > Omega2 holds "
                            "for the RMS on [10, 50] and every steady-window std, every seed; "
                            "Omega2 has the smallest RMS in all 9 runs (variants: the flags)")


@claim(paper=PAPER, id="theorem1_L_bounded", where="Sec. 2.2, Theorem 1 (10)",
       statement="the updated gain L remains bounded for any bounded system solution even "
                 "with modelling errors and measurement noise", verdict=REPRODUCED,
       runs=("experiment=apa_nominal", "experiment=apa_model", "experiment=apa_noise seed=0,1,2",
             "experiment=apa_fig2 seed=0,1,2"),
       readings=(BASE, R_C3, R_C8, "over the horizon [0, 50]; bound: phi2 + (phi3/phi1) df2max"
                 " (Omega <= df2max; for Omega2 measured, not derived)"))
def theorem1_L_bounded() -> Measured:
    nums: dict[str, float | str] = {}
    ok = True
    runs = [("nominal", NOMINAL), ("model", MODEL)]
    runs += [(f"noise seed {s}", noise_only(s)) for s in SEEDS]
    runs += [(f"paper seed {s}", paper(s)) for s in SEEDS]
    for label, ov in runs:
        rows = run_rows(ov)
        for o in ("omega1", "omega2"):
            lo, hi = rows[(o, "min_L")], rows[(o, "max_L")]
            nums[f"{label} {o} L in"] = f"[{lo:.4g}, {hi:.4g}]"
            ok &= math.isfinite(hi) and lo >= setup().phi2 and hi <= L_bound(ov)
    nums["phi2 + (phi3/phi1) df2max, paper run (hbar_o)"] = L_bound(paper(0))
    nums["phi2 + (phi3/phi1) df2max, nominal run (hbar_o = hbar)"] = L_bound(NOMINAL)
    return Measured(holds=ok, numbers=nums,
                    summary="L of both adaptive observers stays in [phi2, phi2 + (phi3/phi1) "
                            "df2max] in all four scenarios and seeds")


