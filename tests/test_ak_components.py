"""Ahrens & Khalil components: DC motor (38)-(39), switched-gain HGO (26)-(28) with the
scheme of Section 3.1, speed controller, and the design rules (25), (31), (37).

Closed-loop runs use the paper's Section 4 setting: H1 = (71/eps1, 70/eps1^2), eps1 = 5e-4,
H2 = (2/eps2, 1/eps2^2), eps2 = 0.01, delta = 0.05, x^(0) = (pi, 0), uniform noise in
[-0.0016, 0.0016] held for 0.0008 s on y = x1 (x3 measured exactly).
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.optimize import minimize_scalar

from hgo.controllers import open_loop
from hgo.controllers.dc_motor_speed import dc_motor_speed_controller, velocity_reference
from hgo.engine.simulate import RK4_STABILITY, Noise, SolverSettings, simulate
from hgo.engine.system import System
from hgo.observers.switched_hgo import DISC_NAMES, switched_hgo
from hgo.papers.ahrens_khalil.design import (
    eps1_from_eps2,
    fit_power_law,
    fit_ultimate_bound,
    observer_alphas,
    optimal_eps,
    ultimate_bound,
)
from hgo.plants.dc_motor import dc_motor_plant

T_END = 2.0
NOISE_DT = 0.0008
MU = 0.0016
DT_OUT = 0.004  # 5 noise periods
DELTA = 0.05
G, EPS, T_ENTER, TIMER, N_SW, T_SW = range(len(DISC_NAMES))


def _samples(t_end: float = T_END, seed: int = 0) -> np.ndarray:
    n = int(math.ceil(t_end / NOISE_DT)) + 2
    s = np.zeros((n, 2))  # channel 1 (x3) is measured noise-free
    s[:, 0] = np.random.default_rng(seed).uniform(-MU, MU, n)
    return s


def _system(T_d: float = 0.15, **obs) -> System:
    kw = dict(alpha1=(71.0, 70.0), eps1=0.0005, alpha2=(2.0, 1.0), eps2=0.01, delta=DELTA,
              T_d=T_d)
    kw.update(obs)
    return System(dc_motor_plant(), [switched_hgo("sw", **kw)], dc_motor_speed_controller())


def _h_cap(system: System) -> float:
    """The engine's RK4 cap 0.9 * 2.785 / rho."""
    return 0.9 * RK4_STABILITY / system.spectral_radius()


def _run(system: System, h: float, dt_out: float = DT_OUT, noise: Noise | None = None):
    noise = Noise(_samples(), NOISE_DT) if noise is None else noise
    tr = simulate(system, SolverSettings(t_end=T_END, dt_out=dt_out, method="rk4", h_max=h),
                  noise)
    assert tr.ok, tr.message
    return tr


# The step used by these runs: half the stability cap (see test_rk4_step_convergence).
@pytest.fixture(scope="module")
def h_used() -> float:
    return _h_cap(_system()) / 2


@pytest.fixture(scope="module")
def switched_run(h_used):
    return _run(_system(T_d=0.15), h_used)


def test_spectral_radius_is_the_fast_injection_pole() -> None:
    obs = _system().observers[0]
    # (s + 1)(s + 70) / eps1: fastest pole 70 / 5e-4 = 1.4e5 (phi0's -0.11 shifts it by ~1e-6)
    assert obs.spectral_radius == pytest.approx(70 / 0.0005, rel=1e-6)
    fixed = switched_hgo("f2", (2.0, 1.0), 0.01)
    assert fixed.spectral_radius == pytest.approx(100.0, rel=1e-2)


def test_switches_once_after_entering_zone(switched_run, h_used) -> None:
    """T_d = 0.15: one switch H1 -> H2, T_d after the error entered [-delta, delta]."""
    tr = switched_run
    d = tr.d[-1]
    assert d[N_SW] == 1
    assert d[G] == 2 and d[EPS] == 0.01
    t_enter, t_sw = d[T_ENTER], d[T_SW]
    # the switch waited the delay, and no longer than one step beyond it
    assert 0.15 <= t_sw - t_enter < 0.15 + h_used + 1e-12
    # the error stayed in the zone from entry on (no reset of the timer, Section 3.1 rule 1)
    e = tr.y[:, 0] - tr.z[:, 3]
    after = tr.t >= t_enter
    assert np.all(np.abs(e[after]) <= DELTA)
    # the logged gain index and eps(t) follow the switch
    assert np.all(tr.d[tr.t < t_sw, G] == 1) and np.all(tr.d[tr.t > t_sw, G] == 2)
    assert np.all(tr.d[tr.t < t_sw, EPS] == 0.0005)
    # closed loop tracks the reference after the transient
    rd, _ = velocity_reference(_system().controller.p, tr.t)
    assert np.max(np.abs(tr.z[tr.t > 1.5, 1] - rd[tr.t > 1.5])) < 0.05


def test_no_delay_repeated_switching(h_used) -> None:
    """T_d = 0: Ahrens & Khalil Section 4 report repeated switching between eps1 and eps2."""
    tr = _run(_system(T_d=0.0), h_used)
    n_sw = int(tr.d[-1, N_SW])
    assert n_sw > 1, f"T_d = 0 switched {n_sw} times"
    assert n_sw % 2 == 1 and tr.d[-1, G] == 2  # ends on H2


def test_fixed_gain_never_switches(h_used) -> None:
    tr = _run(_system(alpha2=None, eps2=None), h_used)
    assert tr.d[-1, N_SW] == 0 and np.all(tr.d[:, G] == 1)
    assert tr.d[-1, T_ENTER] >= 0  # the zone timer still runs (error settled)


def _rms_velocity_errors(tr) -> np.ndarray:
    rd, _ = velocity_reference(_system().controller.p, tr.t)
    est = np.sqrt(np.mean((tr.xh[:, 1] - tr.z[:, 1]) ** 2))  # saturated x^2 - x2
    trk = np.sqrt(np.mean((tr.z[:, 1] - rd) ** 2))  # x2 - r'
    return np.array([est, trk])


def test_rk4_step_convergence(switched_run, h_used) -> None:
    """h and h/2 give RMS velocity errors within 1 % of the h/4 reference, over [0, T].

    Measured: at h = cap/2 the relative changes are ~5e-3 (estimation) and ~1.5e-3
    (tracking); at the bare stability cap (2h) they are ~7 % and ~2 %, because RK4 at
    |h lambda| = 2.5 misrepresents the fast mode during the initial peaking, and the zone
    entry and the switch are snapped to step boundaries (O(h)).
    """
    runs = [switched_run, _run(_system(), h_used / 2), _run(_system(), h_used / 4)]
    rms = np.array([_rms_velocity_errors(tr) for tr in runs])
    ref = rms[2]
    assert np.all(rms > 0)
    for k in (0, 1):
        np.testing.assert_array_less(np.abs(rms[k] - ref) / ref, 0.01)


def test_noise_samples_are_step_boundaries(switched_run, h_used) -> None:
    """No step straddles a noise sample.

    Runs whose segments are cut differently (output grid = noise period, output grid =
    5 noise periods, the same noise given on a grid 90 times finer) agree to round-off,
    while the same noise delayed by one substep (what a straddling step amounts to)
    moves x^2 by orders of magnitude more.
    """
    system = _system()
    n_sub = math.ceil(NOISE_DT / h_used - 1e-9)
    h_sub = NOISE_DT / n_sub
    base = switched_run  # dt_out = 5 noise periods
    at_noise = _run(system, h_used, dt_out=NOISE_DT)
    fine = np.repeat(_samples(), n_sub, axis=0)
    refined = _run(system, h_used, noise=Noise(fine, h_sub))
    delayed = _run(system, h_used, noise=Noise(np.vstack([fine[:1], fine[:-1]]), h_sub))
    scale = np.max(np.abs(base.z), axis=0)
    same = max(np.max(np.abs(at_noise.z[::5] - base.z) / scale),
               np.max(np.abs(refined.z - base.z) / scale))
    shifted = np.max(np.abs(delayed.z - base.z) / scale)
    assert same < 1e-10
    assert shifted > 1e4 * same
    # switching instants (zone entry, gain switch) are step boundaries by construction
    for t_event in (base.d[-1, T_ENTER], base.d[-1, T_SW]):
        k = t_event / h_sub
        assert abs(k - round(k)) < 1e-6, t_event


def test_open_loop_input() -> None:
    ctrl = open_loop.open_loop_controller()
    out = np.zeros(1)
    for t in (0.0, 0.7, 3.0):
        ctrl.u(t, np.zeros(2), np.zeros(2), ctrl.p, out)
        assert out[0] == pytest.approx(1 + 0.5 * math.sin(t))


def test_plant_starts_at_rest_equilibrium() -> None:
    plant = dc_motor_plant()
    dx = np.zeros(3)
    plant.f(0.0, plant.x0, np.array([0.0]), plant.p, dx)
    np.testing.assert_allclose(dx, 0.0, atol=1e-12)
    plant.f(0.0, plant.x0, np.array([1.3]), plant.p, dx)  # x3 = 100 at rest for any u
    assert dx[2] == 0.0 and dx[1] == pytest.approx(0.1 * 100 * 1.3)


def test_factory_errors_name_the_key() -> None:
    with pytest.raises(ValueError, match=r"eps1 must be in \(0, inf\)"):
        switched_hgo("o", (2, 1), 0.0)
    with pytest.raises(ValueError, match=r"eps2 must be in \[eps1"):
        switched_hgo("o", (2, 1), 0.01, eps2=0.001)
    with pytest.raises(ValueError, match=r"alpha1: the roots"):
        switched_hgo("o", (-2, 1), 0.01)
    with pytest.raises(ValueError, match=r"delta must be in \(0, inf\)"):
        switched_hgo("o", (2, 1), 0.01, delta=0)
    with pytest.raises(ValueError, match=r"T_d must be in \[0, inf\)"):
        switched_hgo("o", (2, 1), 0.01, T_d=-1)
    with pytest.raises(ValueError, match=r"xhat0 must have r=2"):
        switched_hgo("o", (2, 1), 0.01, xhat0=(0, 0, 0))
    with pytest.raises(ValueError, match="alpha2 given without eps2"):
        switched_hgo("o", (2, 1), 0.01, alpha2=(2, 1))
    with pytest.raises(ValueError, match=r"k must be in \(0, inf\)"):
        dc_motor_speed_controller(k=0)
    with pytest.raises(ValueError, match="plant.x0 must have 3"):
        dc_motor_plant(x0=(0, 0))


# --- design helpers, Ahrens & Khalil Section 3 --------------------------------------------


def test_observer_polynomial_31() -> None:
    # (40): H1 from (s + 1)(s + 70), H2 from (s + 1)^2
    np.testing.assert_allclose(observer_alphas([1.0], 70.0), [71.0, 70.0])
    np.testing.assert_allclose(observer_alphas([1.0], 1.0), [2.0, 1.0])
    # r = 3: (s^2 + 3 s + 2)(s + 10) = s^3 + 13 s^2 + 32 s + 20
    np.testing.assert_allclose(observer_alphas([3.0, 2.0], 10.0), [13.0, 32.0, 20.0])
    with pytest.raises(ValueError, match="kappa"):
        observer_alphas([1.0], -1.0)


def test_eps_ratio_37() -> None:
    assert eps1_from_eps2(0.01, 5.0, 2) == pytest.approx(0.0005)  # Section 4 values
    assert eps1_from_eps2(0.01, 1.0, 3) == pytest.approx(0.01 ** 1.5)


@pytest.mark.parametrize("r", [2, 3])
def test_fit_recovers_c1_c2(r: int) -> None:
    c1, c2 = 1.7, 0.35
    eps, mu = np.meshgrid(np.geomspace(1e-3, 5e-2, 9), np.geomspace(1e-5, 1e-3, 4))
    bound = ultimate_bound(eps, mu, c1, c2, r)
    fit = fit_ultimate_bound(eps, mu, bound, r)
    assert fit.c1 == pytest.approx(c1, rel=1e-9) and fit.c2 == pytest.approx(c2, rel=1e-9)
    noisy = bound * (1 + 0.01 * np.random.default_rng(3).standard_normal(bound.shape))
    fit = fit_ultimate_bound(eps, mu, noisy, r)
    assert fit.c1 == pytest.approx(c1, rel=0.05) and fit.c2 == pytest.approx(c2, rel=0.05)


@pytest.mark.parametrize("r", [2, 3, 4])
def test_eps_star_exponent_is_one_over_r(r: int) -> None:
    c1, c2 = 2.0, 0.5
    mu = np.geomspace(1e-6, 1e-2, 9)
    # minimise the exact F_r numerically (independent of the closed form)
    numeric = np.array([minimize_scalar(lambda e, m=m: ultimate_bound(e, m, c1, c2, r),
                                        bounds=(1e-6, 10.0), method="bounded",
                                        options={"xatol": 1e-12}).x for m in mu])
    np.testing.assert_allclose(optimal_eps(mu, c1, c2, r), numeric, rtol=1e-5)
    fit = fit_power_law(mu, numeric)
    assert fit.exponent == pytest.approx(1 / r, abs=1e-5)
    assert fit.stderr < 1e-5
    exact = fit_power_law(mu, optimal_eps(mu, c1, c2, r))
    assert exact.exponent == pytest.approx(1 / r, rel=1e-12)
    assert exact.prefactor == pytest.approx(((r - 1) * c2 / c1) ** (1 / r), rel=1e-10)
