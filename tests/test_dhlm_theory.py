"""Dimassi et al. theory: conditions (8)-(10), the LMI (28), Theorem 1 constants (20), (23)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from hgo.papers.dimassi import theory

A = np.array([[0.0, 1.0], [0.0, 0.0]])
B = np.array([[0.0], [1.0]])
C = np.array([[1.0, 0.0]])
H = np.eye(2)
L = np.array([[5.0, 0.0], [1.0, 10.0]])
M = np.array([[0.0, 1.0]])


def _ratio(p: float) -> float:
    """lambda_min(Q)/lambda_max(P) for P = diag(p, 1), the only P allowed by (9) with M = [0, 1]."""
    P = np.diag([p, 1.0])
    acl = A - L @ H
    Q = -0.5 * (acl.T @ P + P @ acl)
    return float(np.linalg.eigvalsh(Q)[0] / np.linalg.eigvalsh(P)[-1])


def test_check_routine_matches_the_one_parameter_search():
    """With M = [0, 1], (9) forces P = diag(p, 1); the bisection's r* equals the maximum of
    lambda_min(Q)/lambda_max(P) over a grid of p in [0.05, 20] (to 1e-5), the maximiser is
    unique (p = 1, r* = 5: the curve falls on both sides) and the SDP's P is diag(p, 1)."""
    chk = theory.check_conditions(A, B, H, L, M)
    grid = np.linspace(0.05, 20.0, 40001)
    vals = np.array([_ratio(p) for p in grid])
    k = int(np.argmax(vals))
    assert abs(chk.r_star - vals[k]) < 1e-5
    assert abs(grid[k] - 1.0) < 1e-3 and abs(vals[k] - 5.0) < 1e-6
    assert np.all(np.diff(vals[:k]) > 0) and np.all(np.diff(vals[k + 1:]) < 0)
    assert abs(chk.P[0, 1]) < 1e-6 and abs(chk.P[1, 1] - 1.0) < 1e-6
    assert np.allclose(np.sort(chk.eig_closed_loop.real), np.sort(np.linalg.eigvals(A - L).real))


def test_condition_10_holds_under_reading_a_and_fails_under_b():
    """(10): r* = 5 (M fixed; 5.022 M free) > 0 = |B| (K_phi + 0) under psi(y, u)
    (K_psi = 0); under psi(x^, u) (K_psi = 1) no P of (8)-(9) (M fixed or free) reaches
    |B| |theta| = 10.01 (margins -5.01 and -4.99)."""
    theta = np.array([2.0, 9.81])
    for chk in (theory.check_conditions(A, B, H, L, M), theory.check_conditions(A, B, H, L)):
        assert chk.margin10(1.0, 0.0, 0.0) > 4.99
        assert chk.margin10(1.0, 0.0, float(np.linalg.norm(theta))) < -4.9


def test_lmi28_needs_the_normalisation():
    """(28) is homogeneous in (P, K, M): with H = C (observer matching fails) rho* > 0.5 under
    P >= I but rho* < 1e-6 under P >= 1e-9 I; with H = I rho* < 1e-7 and the L, M it returns
    satisfy (8)-(9) (eig(A - L H) in the open left half plane, B^T P = M H)."""
    assert theory.lmi28(A, B, C).rho > 0.5
    assert theory.lmi28(A, B, C, p_min=1e-9).rho < 1e-6
    free = theory.lmi28(A, B, H)
    assert free.rho < 1e-7
    assert np.max(np.linalg.eigvals(A - free.L @ H).real) < 0
    assert np.allclose(B.T @ free.P, free.M @ H, atol=1e-5 * np.abs(free.P).max())
    assert not theory.lmi_equality(A, B, C) and theory.lmi_equality(A, B, H, L, M)


def test_theorem1_radius_limits():
    """(23) with K1 = 0 (reading a) and K0 = sigma: as eps -> 0, sqrt(delta) R -> 2 |theta|
    (implementation notes 7); tau <= 0 and K0 - K1 eps <= 0 leave R undefined."""
    P, Q = np.eye(2), np.diag([5.0, 10.0])
    theta, delta, sigma = np.array([2.0, 9.81]), 100.0, 0.01
    t1 = theory.theorem1(P, Q, L, M, B, theta, delta, sigma, 1e-12, 20.0, 9.6, 0.0, 0.0)
    assert t1.K0 == sigma and t1.K1 == 0.0
    assert math.isclose(math.sqrt(delta * t1.R2), 2 * np.linalg.norm(theta), rel_tol=1e-6)
    t2 = theory.theorem1(P, Q, L, M, B, theta, delta, sigma, 0.006, 20.0, 9.6, 0.0, 1.0)
    assert t2.tau < 0 and math.isnan(t2.R2)
    t3 = theory.theorem1(P, Q, L, M, B, theta, delta, sigma, 0.5, 20.0, 9.6, 0.0, 0.01)
    assert t3.K0 - t3.K1 * 0.5 <= 0 and math.isnan(t3.R2) and t3.status.startswith("undefined")


def test_beta_analytic_scales_with_h_max():
    """beta of (15) is linear in h_max and positive for a Hurwitz a-bar."""
    b1, b2 = theory.beta_analytic([6.0, 8.0], 1.0), theory.beta_analytic([6.0, 8.0], 3.0)
    assert b1 > 0 and math.isclose(b2, 3 * b1)


def _ratio_rotated(v: np.ndarray) -> float:
    """lambda_min(Q)/lambda_max(P) for P = R(phi) diag(1, p) R(phi)^T (every P > 0 with
    lambda_max(P) = 1 up to scale: the ratio is scale-free), v = (p, phi)."""
    p, phi = v
    c, s = math.cos(phi), math.sin(phi)
    R = np.array([[c, -s], [s, c]])
    P = R @ np.diag([1.0, p]) @ R.T
    acl = A - L @ H
    Q = -0.5 * (acl.T @ P + P @ acl)
    return float(np.linalg.eigvalsh(Q)[0] / np.linalg.eigvalsh(P)[-1])


def test_m_free_is_normalised_never_below_m_fixed_and_equals_an_independent_solve():
    """M free (H = I: (9) then holds with M = B^T P for every P) relaxes M = [0, 1], so r*
    cannot fall below the M-fixed value (before the normalisation P <= I it did: 4.99967
    against 4.999998, Clarabel stopping at P ~ 1e-8 I). The SDP's r* (measured 5.021930)
    equals an independent search without cvxpy: a grid over P = R(phi) diag(1, p) R(phi)^T,
    p in (0, 1], phi in [0, pi), refined by Nelder-Mead, to 1e-7 relative; the returned P has
    lambda_max(P) = 1 and satisfies (9) with the returned M."""
    from scipy.optimize import minimize

    fixed = theory.check_conditions(A, B, H, L, M)
    free = theory.check_conditions(A, B, H, L)
    assert free.r_star >= fixed.r_star
    grid = [(p, phi) for p in np.linspace(0.01, 1.0, 100) for phi in np.linspace(0, math.pi, 200)]
    start = max(grid, key=_ratio_rotated)
    best = minimize(lambda v: -_ratio_rotated(v), start, method="Nelder-Mead",
                    options={"xatol": 1e-12, "fatol": 1e-14, "maxiter": 5000})
    assert free.r_star == pytest.approx(-best.fun, rel=1e-7)
    assert free.r_star > fixed.r_star + 0.01  # (5.0219 against 5.0000)
    assert np.linalg.eigvalsh(free.P)[-1] == pytest.approx(1.0, abs=1e-6)
    np.testing.assert_allclose(B.T @ free.P, free.M @ H, atol=1e-8)
