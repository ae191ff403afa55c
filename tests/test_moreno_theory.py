"""Moreno's sector tools: LMI (7) against the exact SPR test, (7b), builders' errors."""

from __future__ import annotations

import numpy as np
import pytest

from hgo.controllers.profile_input import profile, profile_input
from hgo.engine.simulate import Trajectory
from hgo.observers.circle_criterion import circle_criterion_observer
from hgo.papers.moreno import theory as th
from hgo.papers.moreno.postprocess import moreno_certificate, windowed_alpha
from hgo.papers.moreno.sector_table import example_error_system
from hgo.plants.circle_form import circle_form_plant, moreno_example_plant
from hgo.postprocess import dense
from hgo.postprocess.dense import GridRun

GAINS = [(2, 200, 120, 0), (1, 50, 10, 0), (5, 1000, 500, 0), (2, 200, 120, 0.5),
         (2, 200, 20, 0.5), (2, 200, 120, 1), (2, 200, 10, 0.1)]


@pytest.mark.parametrize("g", GAINS)
def test_lmi_and_exact_spr_agree_on_k1a(g):
    """K1^a by the SDP of (7a) (1e-6), by the exact SPR bisection and the closed form (1e-9),
    for the seven gain sets of the moreno_sector preset."""
    es = example_error_system(*g)
    closed = th.k1a_closed(*g)
    assert abs(th.k1a_sdp(es) - closed) <= 1e-6
    assert abs(th.k1a_fd(es) - closed) <= 1e-9


@pytest.mark.parametrize("rho", [-0.9, 0.0, 2.0])
def test_lmi_and_exact_spr_agree_on_eps_max(rho):
    """eps_max(rho) by LMI bisection and by the shifted SPR test agree to 1e-5 (relative) for
    the Fig. 1 gains, and the LMI's P satisfies the unsubstituted (7a)."""
    es = example_error_system(2, 200, 120, 0)
    e_lmi, e_fd = th.eps_max_lmi(es, rho), th.eps_max_fd(es, rho)
    assert abs(e_lmi - e_fd) <= 1e-5 * e_fd
    res = th.lmi_7a(es, rho, 0.99 * e_lmi)
    top, eq = th.unsubstituted_7a(es, res.P, rho, 0.99 * e_lmi)
    assert res.feasible and top <= 1e-7 and eq <= 1e-7
    assert not th.lmi_7a(es, rho, 1.01 * e_fd).feasible


def test_spr_exact_known_cases():
    """1/(s+1) and (s+2)/(s^2+3s+1) are SPR; 1/(s+1)^2 (relative degree 2), 1/(s-1) and
    (s-1)/(s+1)^2 are not; (s+1)/(s^2+s+4) has Re H(j2) < 0 and is not."""
    assert th.spr_exact([1], [1, 1])
    assert th.spr_exact([1, 2], [1, 3, 1])
    assert not th.spr_exact([1], [1, 2, 1])
    assert not th.spr_exact([1], [1, -1])
    assert not th.spr_exact([1, -1], [1, 2, 1])
    assert not th.spr_exact([0.1, 1], [1, 0.1, 4])


def test_compose_is_poly1d_composition_to_the_last_bit():
    """th.compose (the poly1d arithmetic of spr_exact and shifted, without poly1d objects)
    gives np.poly1d(p)(np.poly1d(x)).coeffs bit for bit: dtype, length (leading zeros
    dropped) and values, zero and signed-zero coefficients included."""
    rng = np.random.default_rng(0)
    for _ in range(500):
        p = rng.normal(size=rng.integers(1, 6)) * 10.0 ** rng.uniform(-3, 3)
        p[rng.random(p.size) < 0.3] = 0.0
        p[rng.random(p.size) < 0.1] = -0.0
        for x in (np.array([1j, 0]), np.array([1.0, -rng.uniform(0, 5)]),
                  np.array([0.0, 2.0]), rng.normal(size=3)):
            want, got = np.poly1d(p)(np.poly1d(x)).coeffs, th.compose(p, x)
            assert got.dtype == want.dtype and got.tobytes() == want.tobytes()


def test_lmi_7b_linear_sector_toy():
    """(7b) on e' = -e + phi(z), z = e (A_L = -1, G = H_N = 1; phi = K z is stable iff K < 1,
    the circle criterion's sector [0, 1)). With the paper's corner -I (W^T W = I) the LMI
    certifies [0, K2] only for K2 <= 1/2 ((p + K)^2 <= 2p needs K <= 1/2); with the
    textbook corner -2I up to K2 < 1."""
    es = th.ErrorSystem(np.array([[-1.0]]), np.array([1.0]), np.array([1.0]))
    assert th.lmi_7b(es, 0.0, 0.45, 0.0) and not th.lmi_7b(es, 0.0, 0.55, 0.0)
    assert th.lmi_7b(es, 0.0, 0.98, 0.0, corner=2) and not th.lmi_7b(es, 0.0, 1.02, 0.0,
                                                                      corner=2)
    with pytest.raises(ValueError, match="design.corner must be 1 or 2"):
        th.lmi_7b(es, 0.0, 1.0, 0.0, corner=3)


def test_structural_lower_bound_at_a0():
    """a = 0: K1^a >= -1 for random gains (closed form), never below (notes 8.4)."""
    rng = np.random.default_rng(3)
    for k, l1, l2 in rng.uniform([0.1, 0, 0.1], [10, 1000, 1000], (50, 3)):
        assert th.k1a_closed(k, l1, l2, 0.0) >= -1


def test_remark63_alpha_and_gamma():
    """varrho = 1 on [0, 1], 0 from 1 + 1e-9 on (a broken line): over t >= t_f/2 - Delta the
    window mean is 0, so alpha1 = 0 and gamma = int varrho = 1 + 5e-10 (least constant),
    both from I(t) of the run's pieces (dense.Cumulative)."""
    t = np.array([0.0, 1.0, 1.0 + 1e-9, 20.0])
    run = GridRun(Trajectory(t, np.array([[1.0], [1.0], [0.0], [0.0]]), np.zeros((4, 0)),
                             np.zeros((4, 1)), np.zeros((4, 1)), np.zeros((4, 0)),
                             np.zeros((4, 0)), 0, 20.0, np.zeros(0)))
    alpha1, gamma = windowed_alpha(dense.Cumulative(run, lambda s: s.z[:, 0], 0.0, 20.0), 2.0)
    assert alpha1 == 0 and abs(gamma - 1) < 1e-8


def test_remark63_window_maximum_between_step_ends():
    """varrho = sin t on [0, 20] as a run of 7 pieces (straight lines between 8 samples of
    sin): the windowed mean's maximum over s in [8, 18] with Delta = 2 lies between the
    pieces' ends; window_mean_max finds it where varrho(s + Delta) = varrho(s), against a
    brute-force search on 2e5 window starts (exact integrals of the broken line)."""
    t = np.linspace(0, 20, 8)
    v = np.sin(t)
    run = GridRun(Trajectory(t, v[:, None], np.zeros((8, 0)), np.zeros((8, 1)),
                             np.zeros((8, 1)), np.zeros((8, 0)), np.zeros((8, 0)), 0, 20.0,
                             np.zeros(0)))
    cum = dense.Cumulative(run, lambda s: s.z[:, 0], 0.0, 20.0)
    alpha1, s_best = dense.window_mean_max(cum, 2.0, 8.0, 18.0)
    fine = np.linspace(0, 20, 400001)
    cum_fine = np.concatenate([[0.0], np.cumsum(np.diff(fine) * 0.5 * (np.interp(fine[1:], t, v)
                                                                 + np.interp(fine[:-1], t, v)))])
    starts = fine[(fine >= 8.0) & (fine <= 18.0)]
    brute = (np.interp(starts + 2.0, fine, cum_fine) - np.interp(starts, fine, cum_fine)) / 2.0
    assert alpha1 >= brute.max() - 1e-9 and alpha1 == pytest.approx(brute.max(), abs=1e-8)
    assert np.interp(s_best, t, v) == pytest.approx(np.interp(s_best + 2.0, t, v), abs=1e-9)
    assert not np.any(np.isclose(s_best, np.concatenate([t, t - 2.0]), atol=1e-3))


def test_remembering_a_quantity_of_the_samples_keeps_every_number():
    """best_K1t's way (K1(sigma) remembered at each array of instants, varrho of each K~1 a
    function of it): the windowed mean's maximum on Remembering(run, of) is the plain run's,
    bit for bit, and the instants asked again for the next level are not sampled again."""
    t = np.linspace(0, 20, 8)
    run = GridRun(Trajectory(t, np.sin(t)[:, None], np.zeros((8, 0)), np.zeros((8, 1)),
                             np.zeros((8, 1)), np.zeros((8, 0)), np.zeros((8, 0)), 0, 20.0,
                             np.zeros(0)))
    sampled = []

    def of(s):
        sampled.append(s.t.size)
        return s.z[:, 0] ** 2 - 0.3

    remembering = dense.Remembering(run, of)
    counts = []
    for level in (0.1, 0.5):
        plain = dense.window_mean_max(dense.Cumulative(
            run, lambda s, lv=level: np.maximum(0.0, lv - (s.z[:, 0] ** 2 - 0.3)), 0.0, 20.0),
            2.0, 8.0, 18.0)
        memo = dense.window_mean_max(dense.Cumulative(
            remembering, lambda k, lv=level: np.maximum(0.0, lv - k), 0.0, 20.0),
            2.0, 8.0, 18.0)
        assert memo == plain
        counts.append(len(sampled))
    assert counts[1] - counts[0] < counts[0]


@pytest.mark.parametrize("call, message", [
    (lambda: moreno_example_plant(a=-1), "plant.a must be a finite number >= 0, got -1"),
    (lambda: circle_form_plant([[1, 0]], [1], [1], [1], [1], [0, 1], [0]),
     "plant.A must be a finite square matrix"),
    (lambda: circle_form_plant([[1]], [1, 2], [1], [1], [1], [0, 1], [0]),
     "plant.G must have n=1 entries, got 2"),
    (lambda: circle_criterion_observer("c", moreno_example_plant(), [1, 2, 3], 2, e0=[0, 0]),
     "observer.c.L must have n=2 finite entries"),
    (lambda: circle_criterion_observer("c", moreno_example_plant(), [1, 2], 2),
     "observer.c: give exactly one of xhat0 and e0"),
    (lambda: circle_criterion_observer("c", moreno_example_plant(), [1, 2], float("nan"),
                                       e0=[0, 0]), "observer.c.N must be finite"),
    (lambda: profile_input("ramp"), "controller.kind: 'ramp' not in"),
    (lambda: profile_input("pulse", tau=0), "controller.tau must be > 0"),
    (lambda: profile_input("pulse", ramp="cubic"), "controller.ramp: 'cubic' not in"),
    (lambda: moreno_certificate(lambda_P="max"), "postprocess.moreno.lambda_P: 'max' not in"),
    (lambda: moreno_certificate(eps_fraction=1.0), "postprocess.moreno.eps_fraction must be"),
    (lambda: moreno_certificate(K1t=float("inf")), "postprocess.moreno.K1t must be finite"),
    (lambda: moreno_certificate(K1t=0.0, K1t_search=True), "give K1t or K1t_search"),
])
def test_builders_reject_bad_values(call, message):
    with pytest.raises(ValueError, match=message.replace("(", r"\(").replace("[", r"\[")):
        call()


@pytest.mark.parametrize("ramp", ["smooth", "linear"])
def test_profile_input_drives_x2_along_the_profile(ramp):
    """u = r' + a r makes x2 = r (a = 0.5, pulse then return): x2' = -a x2 + u integrated
    by the trapezoid rule on a 1e-4 grid stays within 1e-6 of r (smooth ramp) or within
    5e-4 > h * jump of u (linear ramp, whose u jumps by level / tau = 4 at the corners,
    while the smooth ramp's u is continuous there: jump < 1e-9)."""
    c = profile_input("pulse_return", a=0.5, ramp=ramp)
    t = np.linspace(0, 12, 120_001)
    r, dr = np.array([profile(s, c.p) for s in t]).T
    u = dr + 0.5 * r
    x2 = np.zeros_like(t)
    h = t[1] - t[0]
    for i in range(t.size - 1):  # trapezoid rule for x2' = -a x2 + u, exact for linear u
        x2[i + 1] = ((1 - 0.25 * h) * x2[i] + 0.5 * h * (u[i] + u[i + 1])) / (1 + 0.25 * h)
    assert np.max(np.abs(x2 - r)) <= (1e-6 if ramp == "smooth" else 5e-4)
    jump = max(abs(profile(5.0 + 1e-12, c.p)[1] - profile(5.0 - 1e-12, c.p)[1]),
               abs(profile(5.5 + 1e-12, c.p)[1] - profile(5.5 - 1e-12, c.p)[1]))
    assert jump < 1e-9 if ramp == "smooth" else abs(jump - 4.0) < 1e-9


def test_eps_max_fd_is_remembered_for_an_equal_error_system():
    """A second error system with the same gains is answered from memory (the K~1 search
    asks for the same values on every run), with the value computed afresh."""
    th._eps_max_fd.cache_clear()
    first = th.eps_max_fd(example_error_system(2, 200, 120, 0), 0.5)
    computed = th._eps_max_fd.cache_info().misses
    again = th.eps_max_fd(example_error_system(2, 200, 120, 0), 0.5)
    assert again == first and th._eps_max_fd.cache_info().misses == computed == 1
    assert th._eps_max_fd.cache_info().hits == 1
    th._eps_max_fd.cache_clear()
    assert th.eps_max_fd(example_error_system(2, 200, 120, 0), 0.5) == first


def test_certificate_design_does_not_depend_on_earlier_solves():
    """The design's P (an SDP on a shared, parametrized LMI) is the same fresh and after
    other solves of that LMI at other parameters, to the last bit (computed both times: the
    design without its disk cache)."""
    es = example_error_system(2, 200, 120, 0)
    design = th.certificate_design.__wrapped__
    th._lmi.cache_clear()
    fresh = design(es, -2.0)
    th._lmi(es.key(), 1e-7, True).solve(fresh.K1t + 0.3, 0.5 * fresh.eps)
    th._lmi(es.key(), 1e-7, False).solve(-1.3, 0.7)
    after = design(es, -2.0)
    assert after.K1t == fresh.K1t and after.lam_m == fresh.lam_m
    assert np.array_equal(after.P, fresh.P)


@pytest.mark.parametrize("gains", [(2, 200, 120, 0), (2, 200, 120, 0.5), (1, 30, 5, -1.0)])
def test_transfer_is_scipys_ss2tf_bit_for_bit(gains):
    """The error system's G(s) (hgo's SISO ss2tf, no scipy.signal import) equals
    ``scipy.signal.ss2tf`` exactly, for the Section 5 gains and two other (k, l1, l2, a)."""
    from scipy import signal

    es = example_error_system(*gains)
    num, den = signal.ss2tf(es.A_L, -es.G.reshape(-1, 1), es.H_N.reshape(1, -1),
                            np.zeros((1, 1)))
    mine_num, mine_den = th.ss2tf_siso(es.A_L, -es.G, es.H_N)
    assert np.array_equal(mine_num, num[0]) and np.array_equal(mine_den, den)
