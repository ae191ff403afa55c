"""Claims of Sanfelice & Praly (2010), Section 3, measured on runs of the presets.

Runs are the presets of the README (``experiment=sp_fig<N>``); the oscillation runs of
Figs. 3-5 are shortened to 40 s (Fig. 5: 70 s) with a 20 s trailing window, where the
oscillation has settled (its peak-to-peak amplitude agrees to 4 digits in every 20 s block
from 20 s to 120 s, ``tests/test_sp_complete.py``).
"""

from __future__ import annotations

import numpy as np

from hgo.core.registry import NOT_REPRODUCED, REPRODUCED, Measured, claim
from hgo.running.in_memory import compose_cached, run_in_memory, run_rows

PAPER = "sanfelice_praly"
FIG1 = ("experiment=sp_fig1",)
FIG2 = ("experiment=sp_fig2",)
OSC_SHORT = ("solver.t_end=40", "metrics.window=20")
FIG4 = ("experiment=sp_fig4", *OSC_SHORT)
FIG5 = ("experiment=sp_fig5", "solver.t_end=70", "metrics.window=20")
P2S = (3.0, 2.0, 1.5)
NOTCH_FACTOR = 8.0  # "significantly": read as at least 8x in peak-to-peak amplitude
AVERAGING_FACTOR = 5.0  # Fig. 5: at least 5x smaller peak-to-peak than one observer


def _fig3(p2: float) -> tuple[str, ...]:
    return ("experiment=sp_fig3", *OSC_SHORT, f"observer.sign_indefinite.p2={p2}")


def _signal(overrides: tuple[str, ...], observer: str, column: int) -> tuple[np.ndarray, ...]:
    """(t, column ``column`` of ``observer``'s state) of a run."""
    mem = run_in_memory(overrides)
    system, traj = mem.experiment.system, mem.trajectory
    k = [o.name for o in system.observers].index(observer)
    a, _ = system.z_slices[1 + k]
    return traj.t, traj.z[:, a + column]


@claim(paper=PAPER, id="fig1_law6_r_decreases", where="Section 3, Fig. 1, laws (4) and (6)",
       statement="With law (6) the gain r rises during the transient and then decreases; with "
                 "the dead-zone law (4) it stays at its largest value.",
       runs=(" ".join(FIG1),), verdict=REPRODUCED,
       readings=("x(0) = [-1, 0], law (4) for the 'constant gain' of the caption",))
def fig1_law6_r_decreases() -> Measured:
    t, r6 = _signal(FIG1, "sign_indefinite", 2)
    _, rdz = _signal(FIG1, "dead_zone", 2)
    k = int(r6.argmax())
    monotone_after_peak = float(np.diff(r6[k:]).max())
    holds = (t[k] < 5.0 and monotone_after_peak <= 1e-12 and r6[-1] < 0.7 * r6[k]
             and float(np.diff(rdz).min()) >= -1e-12)
    return Measured(holds, {"t of peak r (6) [s]": float(t[k]), "peak r (6)": float(r6[k]),
                            "r (6) at 100 s": float(r6[-1]),
                            "r (4) at 100 s": float(rdz[-1])},
                    "r of law (6) falls monotonically after its peak; r of (4) never decreases")


VISIBLE = 0.01  # a difference of r's decrease seen "comparing Figure 2 with Figure 1": >= 1 %


def worst_noise_r_end(overrides: tuple[str, ...], noise: bool) -> float:
    """r(T) of (18)-(19) (the run's parameters) integrated by solve_ivp (LSODA, rtol 1e-10),
    with no noise or with the pointwise worst noise for r's decrease, m = -M∞ sign(e1)
    (|y^ - y| = |e1| + M∞ at every instant; sign smoothed over |e1| < 1e-6)."""
    from scipy.integrate import solve_ivp

    cfg = compose_cached(overrides)
    pl, o = cfg.plant, cfg.observer.sign_indefinite
    nu1, nu2, k1, k2 = float(pl.nu1), float(pl.nu2), float(o.K[0]), float(o.K[1])
    p1, p2, b = float(o.p1), float(o.p2), float(o.b)
    M = float(cfg.noise.amplitude) if noise else 0.0

    def rhs(_, s):
        x1, x2, h1, h2, r = s
        e = h1 - x1
        v = e + M * np.tanh(e / 1e-6)  # y^ - y with y = x1 + m
        return [x2 + nu1 * x1 + nu2, 0.0, h2 + nu1 * h1 - k1 * r * v, -k2 * r * r * v,
                p1 * ((v * v - p2) * r ** (1 - 2 * b) + p2 / r ** 4)]

    s0 = [*map(float, pl.x0), *map(float, o.xhat0), float(o.r0)]
    T = float(cfg.solver.t_end)
    sol = solve_ivp(rhs, (0.0, T), s0, method="LSODA", rtol=1e-10, atol=1e-12)
    return float(sol.y[4, -1])


@claim(paper=PAPER, id="fig2_noise_slows_r", where="Section 3, Fig. 2",
       statement="With measurement noise (M∞ = 0.004) r decreases more slowly than without.",
       runs=(" ".join(FIG1), " ".join(FIG2)), verdict=NOT_REPRODUCED,
       readings=("noise uniform ±0.004 held 0.01 s (the paper does not give the signal)",
                 "the paper: 'comparing Figure 2 with Figure 1, the resulting gain decreases "
                 f"at a slower rate': a difference seen on the figures, read as >= "
                 f"{VISIBLE:.0%} of r's decrease over 100 s",
                 "not reproduced (was partly, on the check 'slower at all', which noise "
                 "entering (19) as (y^ - y)^2 can hardly fail): the decrease is 0.06 % "
                 "smaller with the noise; a noise |m| <= M∞ moves (y^ - y)^2 near e = 0 by at "
                 "most M∞² = 0.2 % of p2 (the bound below), and the worst pointwise noise "
                 "m = -M∞ sign(e1) (solve_ivp of (18)-(19)) leaves r(100) 0.14 % higher: "
                 "no noise within M∞ = 0.004 gives a visible difference with the "
                 "printed p2 = 0.008, a finding about the paper's parameters"))
def fig2_noise_slows_r() -> Measured:
    drops = {}
    for name, run in (("without noise", FIG1), ("with noise", FIG2)):
        _, r = _signal(run, "sign_indefinite", 2)
        drops[f"decrease of r over 100 s, {name}"] = float(r.max() - r[-1])
    a, b = drops.values()
    drops["relative slow-down of the decrease"] = (a - b) / a
    cfg = compose_cached(FIG2)
    drops["M∞² / p2 (largest change of (y^ - y)^2 - p2 near e = 0, relative)"] = (
        float(cfg.noise.amplitude) ** 2 / float(cfg.observer.sign_indefinite.p2))
    clean, worst = (worst_noise_r_end(FIG2, n) for n in (False, True))
    drops["r(100) without noise (solve_ivp)"] = clean
    drops["r(100) with the worst noise m = -M∞ sign(e1), relative rise"] = worst / clean - 1
    return Measured((a - b) / a >= VISIBLE, drops,
                    "r decreases more slowly with noise by 0.06 % of its decrease, not the "
                    "visible difference of the paper's Figs. 1-2; with M∞ = 0.004, (y^ - y)^2 "
                    "moves by at most M∞² next to p2 = 0.008")


@claim(paper=PAPER, id="fig3_amplitude_decreases_with_p2", where="Section 3, Fig. 3, (20)",
       statement="The steady oscillation of the estimates shrinks when p2 decreases "
                 "(p2 = 3, 2, 1.5).",
       runs=tuple(" ".join(_fig3(p2)) for p2 in P2S), verdict=REPRODUCED)
def fig3_amplitude_decreases_with_p2() -> Measured:
    amp = {p2: [run_rows(_fig3(p2))[("sign_indefinite", f"amplitude_xhat{k}")]
                for k in (1, 2)] for p2 in P2S}
    holds = all(amp[3.0][k] > amp[2.0][k] > amp[1.5][k] for k in range(2))
    numbers = {f"peak-to-peak x^{k + 1}, p2 = {p2:g}": amp[p2][k]
               for k in range(2) for p2 in P2S}
    return Measured(holds, numbers, "peak-to-peak amplitude over the trailing 20 s")


@claim(paper=PAPER, id="fig4_notch_reduces_oscillation", where="Section 3, Fig. 4, T(s)",
       statement="The notch filter T(s) tuned to the oscillation reduces the oscillation of "
                 "the estimates significantly.",
       runs=(" ".join(FIG4),), verdict=REPRODUCED,
       readings=(f"'significantly' read as a factor >= {NOTCH_FACTOR:g} in peak-to-peak",
                 "w0 = 2π/2.23 s, phi1 = 0, phi2 = 1"))
def fig4_notch_reduces_oscillation() -> Measured:
    rows = run_rows(FIG4)
    factors = {f"reduction of x^{k}": rows[("sign_indefinite", f"notch_reduction_xhat{k}")]
               for k in (1, 2)}
    return Measured(min(factors.values()) >= NOTCH_FACTOR, factors,
                    f"peak-to-peak before / after the notch, both >= {NOTCH_FACTOR:g}")


def _fig5_numbers() -> dict[str, float]:
    rows = run_rows(FIG5)
    return {"single x^2": rows[("sign_indefinite", "amplitude_xhat2")],
            "average <x^2>": rows[("collection", "amplitude_xhat2")],
            "notch x^2f": rows[("sign_indefinite", "amplitude_xhat2_f")]}


@claim(paper=PAPER, id="fig5_averaging_reduces_oscillation", where="Section 3, Fig. 5, (21)",
       statement="Averaging a collection of N = 3 observers reduces the oscillation of x^2.",
       runs=(" ".join(FIG5),), verdict=REPRODUCED,
       readings=("injection k̄_k(r) = 0.1 r^k (not given in the paper)",
                 f"'reduces' read as >= {AVERAGING_FACTOR:g}x smaller peak-to-peak"))
def fig5_averaging_reduces_oscillation() -> Measured:
    v = _fig5_numbers()
    return Measured(v["average <x^2>"] < v["single x^2"] / AVERAGING_FACTOR, v,
                    "peak-to-peak over the trailing 20 s")


@claim(paper=PAPER, id="fig5_averaging_better_than_notch", where="Section 3, Fig. 5",
       statement="Compared to filtering, the improvement obtained with the averaging method "
                 "is substantial (on x^2).",
       runs=(" ".join(FIG5),), verdict=NOT_REPRODUCED,
       readings=("injection k̄_k(r) = 0.1 r^k (not given in the paper)",
                 "'substantial' read as <x^2> at least 2x below the notch output"))
def fig5_averaging_better_than_notch() -> Measured:
    v = _fig5_numbers()
    return Measured(v["average <x^2>"] < v["notch x^2f"] / 2, v,
                    "with N = 3 the average keeps the 3rd harmonic of the half-wave symmetric "
                    "oscillation; the notch is slightly better")


ALL_RUNS = (FIG1, FIG2, FIG4, FIG5, *(_fig3(p2) for p2 in P2S))


@claim(paper=PAPER, id="theorem22_output_error_below_p2", where="Theorem 2.2, (11)",
       statement="With law (6), limsup of the mean of (y^ - y)^2 is at most p2.",
       runs=tuple(" ".join(r) for r in ALL_RUNS), verdict=REPRODUCED,
       readings=("limsup estimated by the trailing-window mean (metrics.window)",))
def theorem22_output_error_below_p2() -> Measured:
    ratios = []
    for run in ALL_RUNS:
        table = run_in_memory(run).metrics
        rows = table[(table.quantity == "mean_sq_output_error") & (table.observer != "dead_zone")
                     & (table.observer != "collection")
                     | table.quantity.str.startswith("mean_sq_output_error_copy")]
        ratios += list(rows.empirical / rows.bound)
    return Measured(len(ratios) == 10 and max(ratios) <= 1.0,
                    {"observers checked": float(len(ratios)), "largest mean / p2": max(ratios)},
                    "every law-(6) observer of Figs. 1-5 (each copy of the collection)")


@claim(paper=PAPER, id="fig2_parameters_satisfy_13", where="Section 3, (13)",
       statement="The parameters of Fig. 2 satisfy (13).", runs=(" ".join(FIG2),),
       verdict=REPRODUCED, readings=("P, d0 = 0.95, d1 = 3 of the paper's example",))
def fig2_parameters_satisfy_13() -> Measured:
    table = run_in_memory(FIG2).metrics
    row = table[table.quantity == "p2_lower_bound_13"].iloc[0]
    return Measured(bool(row.holds), {"right-hand side of (13)": float(row.empirical),
                                      "p2": float(row.bound)})


PAPER_S_STAR, PAPER_BOUND = 1.375, 4.5e5


@claim(paper=PAPER, id="example_bound_14", where="Section 3, (14)",
       statement="For the example, the minimiser of (14) is s* = 1.375 and B_{1,o} ≈ 4.5·10⁵.",
       runs=(" ".join(FIG2),), verdict=NOT_REPRODUCED,
       readings=("(14) is OCR-damaged: the literal reading (the minimum over s > "
                 "max{√(c0 L̂/d0), 1})",))
def example_bound_14() -> Measured:
    rows = run_rows(FIG2)
    s_star = rows[("sign_indefinite", "s_star_x1")]
    table = run_in_memory(FIG2).metrics
    bound = float(table[(table.quantity == "mean_sq_error_x1")
                        & (table.observer == "sign_indefinite")].bound.iloc[0])
    holds = abs(s_star / PAPER_S_STAR - 1) < 0.02 and abs(bound / PAPER_BOUND - 1) < 0.1
    return Measured(holds, {"s*": s_star, "B_1,o": bound, "paper s*": PAPER_S_STAR,
                            "paper B_1,o": PAPER_BOUND},
                    "no reading of the damaged formula tried reproduces both numbers")
