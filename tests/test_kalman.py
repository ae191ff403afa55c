"""The Kalman filters (hgo/observers/ekf.py, ukf.py) against references computed apart.

* Continuous EKF on a linear plant: P(t) converges to the algebraic Riccati equation's
  solution (scipy.linalg.solve_continuous_are), and the estimate to that of the
  steady-state Kalman filter (a linear observer with the constant gain P_inf C^T R^-1,
  written here) fed the same noisy measurement.
* Continuous–discrete EKF and UKF on a linear plant: the same estimates (both are the
  Kalman filter there).
* Continuous–discrete UKF on Van der Pol against filterpy's UnscentedKalmanFilter (2.0)
  fed the measurements hgo's filter took, each sigma point integrated by scipy's DOP853
  at the tolerances of hgo's run.
* Central-difference Jacobians against the analytic ones; tuning errors in one line.

One kernel for every linear check (the four observers in one run), one for Van der Pol.
"""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
import pytest
import scipy.linalg as sl
from scipy.integrate import solve_ivp

from hgo.core.components import Observer, Params, Plant
from hgo.engine.simulate import SolverSettings, simulate
from hgo.engine.system import System
from hgo.noise import noise_model
from hgo.observers.ekf import ekf, ekf_cd
from hgo.observers.plant_model import FD_STEP, jacobian_f, jacobian_h
from hgo.observers.ukf import ukf
from hgo.plants.van_der_pol import van_der_pol_plant

A = np.array([[0.0, 1.0], [-2.0, -0.5]])
C = np.array([[1.0, 0.0]])
Q_CT = np.diag([0.01, 0.1])  # spectral density (continuous EKF)
Q_CD = np.diag([1e-4, 1e-3])  # covariance per period (continuous-discrete filters)
R = np.array([[1e-3]])
TS = 0.05
NOISE = {"kind": "gaussian", "std": 0.01, "period": TS, "amplitude": 0.0, "channels": [0]}
T_END = 20.0


def linear_f(t, x, u, p, dx):
    """dx = A x."""
    for i in range(2):
        dx[i] = p.A[i, 0] * x[0] + p.A[i, 1] * x[1]


def linear_h(t, x, p, y):
    """y = C x."""
    y[0] = p.C[0, 0] * x[0] + p.C[0, 1] * x[1]


def steady_f(t, z, d, y, u, p, dz):
    """The steady-state Kalman filter: x^' = A x^ + K_inf (y - C x^)."""
    e = y[0] - (p.C[0, 0] * z[0] + p.C[0, 1] * z[1])
    for i in range(2):
        dz[i] = p.A[i, 0] * z[0] + p.A[i, 1] * z[1] + p.K[i] * e


def steady_estimate(t, z, d, p, xhat):
    xhat[0] = z[0]
    xhat[1] = z[1]


def linear_plant() -> Plant:
    return Plant(name="linear", state_names=["x1", "x2"], output_names=["y"], input_names=[],
                 x0=np.array([1.0, 0.0]), p=Params(A=A, C=C), f=linear_f, h=linear_h)


def p_inf() -> np.ndarray:
    """The ARE's solution: A P + P A^T + Q - P C^T R^-1 C P = 0."""
    return sl.solve_continuous_are(A.T, C.T, Q_CT, R)


def linear_system(sample_period: float | None = None) -> System:
    """The linear plant, its continuous EKF, the steady-state filter, CD-EKF and UKF
    (measuring every ``sample_period``; None: the noise's period TS)."""
    plant = linear_plant()
    K_inf = (p_inf() @ C.T @ np.linalg.inv(R)).ravel()
    steady = Observer(name="steady", state_names=["x1_hat", "x2_hat"], disc_names=[],
                      estimated_states=[0, 1], z0=np.array([0.5, 0.5]), d0=np.zeros(0),
                      p=Params(A=A, C=C, K=K_inf), f=steady_f, estimate=steady_estimate)
    sampled = {"Q": Q_CD, "P0": 1.0, "xhat0": [0.5, 0.5], "noise": NOISE,
               "sample_period": sample_period}
    return System(plant, [ekf("ekf", plant, Q=Q_CT, R=R, P0=1.0, xhat0=[0.5, 0.5]), steady,
                          ekf_cd("ekf_cd", plant, **sampled),
                          ukf("ukf", plant, alpha=0.5, beta=2.0, kappa=1.0, **sampled)])


@pytest.fixture(scope="module")
def linear_run():
    system = linear_system()
    solver = SolverSettings(t_end=T_END, dt_out=TS, method="dop853", rtol=1e-12, atol=1e-14,
                            h_max=TS)
    noise = noise_model("gaussian", std=0.01, period=TS).sample(T_END, 1, 3)
    return system, solver, noise, simulate(system, solver, noise)


def test_continuous_ekf_covariance_converges_to_the_riccati_solution(linear_run):
    """P(t_end) (the upper triangle in z) equals solve_continuous_are's P to 1e-8, and the
    recorded smallest eigenvalue is P's."""
    system, _, _, traj = linear_run
    assert traj.ok, traj.message
    a, _ = system.z_slices[1]
    P = traj.z[-1, a + 2:a + 5]
    assert np.abs(P - p_inf()[np.triu_indices(2)]).max() < 1e-8
    da, _ = system.d_slices[0]
    assert abs(traj.d[-1, da] - np.linalg.eigvalsh(p_inf())[0]) < 1e-8


def test_continuous_ekf_estimate_equals_the_steady_state_filter(linear_run):
    """After the transient (t >= 15 s of 20) the EKF's x^ equals the steady-state filter's
    to 1e-8; at t = 1 s, while K(t) still differs from K_inf, they differ by more."""
    _, _, _, traj = linear_run
    late = traj.t >= 15.0
    diff = np.abs(traj.xh[:, 0:2] - traj.xh[:, 2:4])
    assert diff[late].max() < 1e-8
    assert diff[np.searchsorted(traj.t, 1.0)].max() > 1e-4


def test_continuous_discrete_ekf_and_ukf_agree_on_a_linear_plant(linear_run):
    """CD-EKF and UKF (alpha = 0.5, beta = 2, kappa = 1) give the same estimate to 1e-9
    at every output instant, and both converge (error below 0.1 at the end)."""
    system, _, _, traj = linear_run
    assert np.abs(traj.xh[:, 4:6] - traj.xh[:, 6:8]).max() < 1e-9
    assert np.abs(traj.xh[-1, 4:6] - traj.z[-1, :2]).max() < 0.1
    # the measurement updates happened at every instant k * TS (the next k in d)
    for k in (2, 3):
        assert traj.d[-1, system.d_slices[k][0]] == round(T_END / TS) + 1


def test_measurements_are_taken_at_their_own_instants(linear_run):
    """Sample period 0.07 s against noise held 0.05 s (instants off the noise grid; the
    same kernel): each update takes y = C x(k T) + the noise sample held just before k T,
    to 1e-12, at every k (the engine ends a step at each k T: Observer.sample_period), and
    CD-EKF and UKF still agree to 1e-9."""
    _, solver, noise, _ = linear_run
    period = 0.07
    system = linear_system(sample_period=period)
    traj = simulate(system, replace(solver, t_end=285 * period, dt_out=period), noise)
    assert traj.ok, traj.message
    k = np.arange(1, len(traj.t))
    da, _ = system.d_slices[2]  # ekf_cd's: [sample, P_min_eig, y_y]
    assert np.array_equal(traj.d[1:, da], k + 1.0)
    held = noise.samples[np.ceil(k * period / TS - 1e-9).astype(int) - 1, 0]
    taken = traj.d[1:, da + 2] - traj.z[1:, 0]  # y_k - C x(t_k), C = [1, 0]
    assert np.abs(taken - held).max() < 1e-12
    assert np.abs(traj.xh[:, 4:6] - traj.xh[:, 6:8]).max() < 1e-9


def test_loss_of_positive_definiteness_stops_the_run(linear_run):
    """The continuous EKF with a negative-definite Q (written into the parameter vector,
    past the factory's check) loses P's definiteness: the run stops there, its one-line
    status saying so (``Observer.explain``)."""
    system, solver, noise, _ = linear_run
    P = system.params()
    obs = system.observers[0]
    a, _ = system.p_slices[1]
    q = obs.params.index("kf_Q")
    P[a + q.start:a + q.stop] = (-np.eye(2)).ravel()
    traj = simulate(system, solver, noise, params=P)
    assert traj.status == 1 and 0.0 < traj.t_stop < T_END
    head = ("non-finite state (observer ekf: the covariance P is no longer positive "
            "definite (smallest eigenvalue -")
    assert traj.message.startswith(head) and "\n" not in traj.message
    assert traj.d[-1, 0] > 0  # the last recorded eigenvalue, before the loss


# ------------------------------------------------------------------ Van der Pol vs filterpy
VDP_TS = 0.05
VDP_END = 5.0
RTOL, ATOL = 1e-10, 1e-12


@pytest.fixture(scope="module")
def vdp_run():
    plant = van_der_pol_plant(mu=1.0, x0=(2.0, 0.0))
    noise_cfg = {**NOISE, "std": 0.02, "period": VDP_TS}
    obs = ukf("ukf", plant, Q=np.diag([1e-4, 1e-3]), P0=np.diag([0.5, 0.5]), alpha=0.5,
              beta=2.0, kappa=1.0, xhat0=[1.0, 0.0], noise=noise_cfg)
    system = System(plant, [obs])
    solver = SolverSettings(t_end=VDP_END, dt_out=VDP_TS, method="dop853", rtol=RTOL,
                            atol=ATOL, h_max=VDP_TS)
    noise = noise_model("gaussian", std=0.02, period=VDP_TS).sample(VDP_END, 1, 7)
    return system, simulate(system, solver, noise)


def test_ukf_agrees_with_filterpy_on_van_der_pol(vdp_run):
    """hgo's CD-UKF and filterpy's UKF fed the measurements hgo's filter took agree to 1e-6
    at every instant."""
    from filterpy.kalman import MerweScaledSigmaPoints, UnscentedKalmanFilter

    system, traj = vdp_run
    assert traj.ok, traj.message
    plant, obs = system.plant, system.observers[0]

    def fx(x, dt):
        def rhs(t, s):
            ds = np.empty(2)
            plant.f(t, s, np.zeros(0), plant.p, ds)
            return ds
        return solve_ivp(rhs, (0.0, dt), x, method="DOP853", rtol=RTOL, atol=ATOL).y[:, -1]

    points = MerweScaledSigmaPoints(2, alpha=0.5, beta=2.0, kappa=1.0)
    ref = UnscentedKalmanFilter(dim_x=2, dim_z=1, dt=VDP_TS, fx=fx, hx=lambda x: x[:1],
                                points=points)
    ref.x, ref.P = np.array([1.0, 0.0]), np.diag([0.5, 0.5])
    ref.Q, ref.R = np.diag([1e-4, 1e-3]), np.array([[0.02 ** 2]])
    y_col = obs.disc_names.index("y_y")
    worst = 0.0
    for k in range(1, len(traj.t)):
        ref.predict()  # (filterpy 2 redraws its sigma points from the prior, as hgo's)
        ref.update(traj.d[k, y_col:y_col + 1])
        worst = max(worst, float(np.abs(ref.x - traj.xh[k]).max()))
    assert worst < 1e-6
    assert traj.d[-1, 0] == len(traj.t)  # an update at every instant, none skipped


# ------------------------------------------------------------------ Jacobians and tuning
def _vdp_jacobian(x, mu):
    return np.array([[0.0, 1.0], [-2.0 * mu * x[0] * x[1] - 1.0, mu * (1.0 - x[0] ** 2)]])


def test_central_differences_match_the_analytic_jacobian():
    """On Van der Pol (mu = 1.5) at 200 points of |x| <= 3: A by central differences within
    1e-8 of the analytic one (measured 2.9e-10), C = [1, 0] to 1e-9."""
    plant = van_der_pol_plant(mu=1.5)
    obs = ekf("e", plant, R=1e-3)
    p = obs.p
    rng = np.random.default_rng(0)
    worst_a, worst_c = 0.0, 0.0
    J, Cm, w1, w2, w3 = np.empty((2, 2)), np.empty((1, 2)), *np.empty((3, 2))
    for x in rng.uniform(-3, 3, (200, 2)):
        jacobian_f(0.0, x, np.zeros(0), p, J, w1, w2, w3)
        worst_a = max(worst_a, np.abs(J - _vdp_jacobian(x, 1.5)).max())
        jacobian_h(0.0, x, p, Cm, w1, np.empty(1), np.empty(1))
        worst_c = max(worst_c, np.abs(Cm - [[1.0, 0.0]]).max())
    assert worst_a < 1e-8 and worst_c < 1e-9
    assert FD_STEP == pytest.approx(6.055e-6, rel=1e-3)


def test_plant_jacobian_is_used_when_given():
    """A plant with jac_f: the filter's A is the plant's (here deliberately 2x the true
    one, so that the difference shows), not central differences."""
    def jac_f(t, x, u, p, J):
        J[:, :] = 2.0 * _vdp_jacobian(x, p.mu)

    plant = van_der_pol_plant(mu=1.0)
    plant.jac_f = jac_f
    p = ekf("e", plant, R=1e-3).p
    J, w = np.empty((2, 2)), np.empty(2)
    x = np.array([0.7, -1.2])
    jacobian_f(0.0, x, np.zeros(0), p, J, w, w.copy(), w.copy())
    assert np.array_equal(J, 2.0 * _vdp_jacobian(x, 1.0))


def test_symbolic_plant_jacobians_reach_the_filter():
    """A plant given by its equations (plant=symbolic, Rossler) has generated jac_f and
    jac_h; the filter's A and C are theirs: the analytic Jacobian to rounding."""
    from hgo.plants.symbolic import symbolic_plant

    plant = symbolic_plant(name="rossler", states=["x", "y", "z"],
                           params={"a": 0.2, "b": 0.2, "c": 5.7},
                           f={"x": "-y - z", "y": "x + a*y", "z": "b + z*(x - c)"},
                           h={"y_meas": "y"}, x0=[1.0, 1.0, 0.0])
    p = ekf("e", plant, R=1e-3).p
    assert p.kf_has_jac_f and p.kf_has_jac_h
    x = np.array([0.3, -1.2, 2.0])
    J, Cm, w = np.empty((3, 3)), np.empty((1, 3)), np.empty(3)
    jacobian_f(0.0, x, np.zeros(0), p, J, w, w.copy(), w.copy())
    jacobian_h(0.0, x, p, Cm, w, np.empty(1), np.empty(1))
    expected = [[0.0, -1.0, -1.0], [1.0, 0.2, 0.0], [x[2], 0.0, x[0] - 5.7]]
    assert np.abs(J - expected).max() < 1e-15
    assert np.array_equal(Cm, [[0.0, 1.0, 0.0]])


@pytest.mark.parametrize(("kwargs", "message"), [
    ({"Q": [1.0, 2.0, 3.0]}, "observer.f.Q must be a scalar, 2 numbers (the diagonal) or a "
                             "2x2 matrix for (x1, x2), got shape (3,)"),
    ({"P0": [[1.0, 0.5], [0.4, 1.0]]}, "observer.f.P0 must be finite and symmetric"),
    ({"P0": 0.0}, "observer.f.P0 must be positive definite; its smallest eigenvalue is 0"),
    ({"Q": -1.0}, "observer.f.Q must be positive semidefinite"),
    ({"R": None, "noise": {"kind": "none"}},
     "observer.f.R: noise.kind=none gives no measurement variance; give R"),
    ({"R": None}, "observer.f.R: give it (no noise model"),
])
def test_tuning_errors_are_one_line(kwargs, message):
    plant = van_der_pol_plant()
    with pytest.raises(ValueError) as err:
        ekf("f", plant, **{"R": 1e-3, **kwargs})
    assert str(err.value).startswith(message)
    assert "\n" not in str(err.value)


def test_default_r_is_the_noise_variance():
    """R from the noise model: std^2 for the sampled filters, std^2 * period (the held
    noise's spectral density) for the continuous one; uniform: amplitude^2 / 3."""
    plant = van_der_pol_plant()
    gauss = {"kind": "gaussian", "std": 0.1, "period": 0.01, "channels": [0]}
    assert ekf_cd("a", plant, noise=gauss).p.kf_R[0, 0] == pytest.approx(0.01)
    assert ekf_cd("a", plant, noise=gauss).sample_period == 0.01
    assert ekf("a", plant, noise=gauss).p.kf_R[0, 0] == pytest.approx(1e-4)
    uniform = {"kind": "uniform", "amplitude": 0.3, "period": 0.02, "channels": [0]}
    assert ukf("a", plant, noise=uniform).p.kf_R[0, 0] == pytest.approx(0.03)
    assert not math.isnan(ukf("a", plant, noise=uniform).p.kf_gamma)


def test_ensemble_members_take_r_from_their_own_noise():
    """experiment=vdp_kalman_noise (a grid over noise.std): each member's EKF and UKF get
    R from that member's noise (std^2 * 1 ms and std^2), built without integrating."""
    import hgo
    from hgo.running.ensemble import build_members, member_nodes, plan_members

    cfg = hgo.compose(["experiment=vdp_kalman_noise"])
    plan = plan_members(cfg)
    for std, system in zip(plan.values["noise.std"], build_members(member_nodes(
            cfg, plan.values)), strict=True):
        R = {o.name: o.p.kf_R[0, 0] for o in system.observers if o.name in ("ekf", "ukf")}
        assert R["ekf"] == pytest.approx(std ** 2 * 1e-3, rel=1e-12)
        assert R["ukf"] == pytest.approx(std ** 2, rel=1e-12)
