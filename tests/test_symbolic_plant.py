"""A plant given by its equations (issue 42): the text reader, the generated functions,
the observability map against hand-derived ones, the observers' kernel functions, and the
two presets against solve_ivp (two compiled runs, shared by the tests that read them)."""

from __future__ import annotations

import math

import numpy as np
import pytest
import sympy as sp
from scipy.integrate import solve_ivp

from hgo.core.errors import ConfigError
from hgo.observers.symbolic_hgo import (
    correction,
    hgo_normal_form,
    hgo_original,
    original_update,
)
from hgo.plants.observability import derive, report
from hgo.plants.symbolic import symbolic_plant

LV = {"states": ["x1", "x2"], "params": {"a": 1.0, "b": 0.5, "c": 0.5, "d": 1.0},
      "f": {"x1": "a*x1 - b*x1*x2", "x2": "c*x1*x2 - d*x2"}, "h": {"y": "x1"},
      "x0": [2.0, 1.0]}
TANK = {"states": ["h_up", "h_low"], "params": {"A": 28.0, "a": 0.071, "g": 981.0, "q": 9.99},
        "f": {"h_up": "q/A - a/A*sqrt(2*g*h_up)",
              "h_low": "a/A*sqrt(2*g*h_up) - a/A*sqrt(2*g*h_low)"},
        "h": {"y": "h_low"}, "x0": [2.0, 1.0]}
ROSSLER = {"states": ["x", "y", "z"], "params": {"a": 0.2, "b": 0.2, "c": 5.7},
           "f": {"x": "-y - z", "y": "x + a*y", "z": "b + z*(x - c)"}, "h": {"y_meas": "y"},
           "x0": [1.0, 1.0, 0.0]}


def _plant(spec: dict, **changes):
    return symbolic_plant(**{**spec, **changes})


# ---------------------------------------------------------------------- the text
def test_an_unknown_name_is_one_line_naming_the_key_and_the_token() -> None:
    f = {**LV["f"], "x2": "c*x1*x2 - dd*x2"}
    with pytest.raises(ConfigError) as err:
        _plant(LV, f=f, inputs=["u"])
    assert str(err.value) == "plant.f.x2: unknown name 'dd' (declared: a, b, c, d, x1, x2, u)"


@pytest.mark.parametrize("text, says", [
    ("x1.__class__", "unexpected '.'"), ("__import__('os')", "unknown name '__import__'"),
    ("x1[0]", "unexpected '['"), ("'a'", "unexpected"), ("x1(2)", "'x1' is not a function"),
    ("exp", "function 'exp' must be called"), ("lambda: 1", "unknown name 'lambda'"),
    ("1/0", "not a finite real expression"), ("x1 if x2 else 0", "unknown name 'if'"),
    ("x1; x2", "unexpected ';'"), ("2j*x1", "complex number"), ("", "is empty")])
def test_text_outside_the_grammar_is_refused_before_any_parse(text, says) -> None:
    with pytest.raises(ConfigError, match=r"^plant\.f\.x1: ") as err:
        _plant(LV, f={**LV["f"], "x1": text})
    assert says in str(err.value)


def test_a_python_model_gives_sympy_expressions_and_the_config_its_values() -> None:
    x1, x2, a, b, c, d = sp.symbols("x1 x2 a b c d")

    def model():
        return {"states": ["x1", "x2"], "params": {"a": 1.0, "b": 0.5, "c": 0.5, "d": 1.0},
                "f": {"x1": a * x1 - b * x1 * x2, "x2": c * x1 * x2 - d * x2},
                "h": {"y": x1}, "x0": [2.0, 1.0]}

    plant = symbolic_plant(model=model, params={"d": 2.0})
    text = _plant(LV, params={**LV["params"], "d": 2.0})
    assert plant.model == text.model and plant.p.d == 2.0
    with pytest.raises(ConfigError, match="plant.params.e: is not a parameter"):
        symbolic_plant(model=model, params={"e": 1.0})


# ---------------------------------------------------------------------- generated code
@pytest.mark.parametrize("spec", [LV, TANK, ROSSLER], ids=["lv", "tank", "rossler"])
def test_generated_f_h_and_jacobians_equal_sympy_at_random_states(spec) -> None:
    plant = _plant(spec)
    model, rng = plant.model, np.random.default_rng(1)
    f = sp.lambdify([model.x, *[model.symbols[p] for p in model.params]], list(model.f))
    jf = sp.lambdify([model.x, *[model.symbols[p] for p in model.params]],
                     model.jacobian_f().tolist())
    values = [spec["params"][p] for p in model.params]
    n = plant.nx
    for _ in range(5):
        x = rng.uniform(0.5, 3.0, n)
        dx, J, y, C = np.zeros(n), np.zeros((n, n)), np.zeros(1), np.zeros((1, n))
        plant.f(0.0, x, np.zeros(0), plant.p, dx)
        plant.jac_f(0.0, x, np.zeros(0), plant.p, J)
        plant.h(0.0, x, plant.p, y)
        plant.jac_h(0.0, x, plant.p, C)
        np.testing.assert_allclose(dx, f(x, *values), rtol=1e-14, atol=1e-15)
        np.testing.assert_allclose(J, jf(x, *values), rtol=1e-14, atol=1e-15)
        assert y[0] == x[model.x.index(model.h[0])]
        assert C.sum() == 1.0


# ---------------------------------------------------------------------- observability
def _tank_phi0(xi1, xi2, A, a, g, q):
    """Two tanks by hand: sqrt(2 g h_up) = A xi2 / a + sqrt(2 g xi1) (xi2 = y'), and
    xi2' = (a/A) (g h_up' / sqrt(2 g h_up) - g h_low' / sqrt(2 g h_low))."""
    s_up, s_low = A * xi2 / a + math.sqrt(2 * g * xi1), math.sqrt(2 * g * xi1)
    up = q / A - a / A * s_up
    low = a / A * (s_up - s_low)
    return a / A * (g * up / s_up - g * low / s_low)


def test_phi_and_phi0_of_three_plants_equal_the_hand_derived_ones() -> None:
    # Lotka-Volterra on x1: xi2 = x1 (a - b x2), phi0 = xi2^2/xi1 - (a xi1 - xi2)(c xi1 - d)
    lv = _plant(LV)
    obs = derive(lv.model)
    s = lv.model.symbols
    x1, x2, a, b, c, d = (s[k] for k in ("x1", "x2", "a", "b", "c", "d"))
    xi1, xi2 = obs.xi[:2]
    assert sp.simplify(obs.phi[1] - x1 * (a - b * x2)) == 0
    assert len(obs.inverses) == 1
    hand = xi2 ** 2 / xi1 - (a * xi1 - xi2) * (c * xi1 - d)
    assert sp.simplify(obs.phi0(obs.inverses[0]) - hand) == 0
    # Rossler on y: Phi = (y, x + a y, a x + (a^2 - 1) y - z), x = xi2 - a xi1, z = a xi2 -
    # xi1 - xi3; phi0 = xi3' = a x' + (a^2 - 1) y' - z'
    ro = _plant(ROSSLER)
    obs = derive(ro.model)
    s = ro.model.symbols
    x, y, z, a, b, c = (s[k] for k in ("x", "y", "z", "a", "b", "c"))
    xi1, xi2, xi3 = obs.xi
    assert [sp.expand(p) for p in obs.phi] == [y, x + a * y, sp.expand(a * x + (a**2 - 1) * y - z)]
    X, Z = xi2 - a * xi1, a * xi2 - xi1 - xi3
    hand = a * (-xi1 - Z) + (a ** 2 - 1) * (X + a * xi1) - (b + Z * (X - c))
    assert sp.expand(obs.phi0(obs.inverses[0]) - hand) == 0
    # two tanks on h_low (square roots: compared in numbers, over positive levels)
    tank = _plant(TANK)
    obs = derive(tank.model)
    s = tank.model.symbols
    values = {s[k]: v for k, v in TANK["params"].items()}
    phi0 = sp.lambdify(obs.xi, obs.phi0(obs.inverses[0]).xreplace(values))
    kernel = hgo_normal_form("nf", tank, eps=1.0).p  # its generated phi0 (numba source)
    rng = np.random.default_rng(2)
    for h_up, h_low in rng.uniform(0.5, 15.0, (6, 2)):
        point = {**values, s["h_up"]: h_up, s["h_low"]: h_low}
        xi = [float(p.xreplace(point)) for p in obs.phi]
        assert xi[1] == pytest.approx(0.071 / 28 * (math.sqrt(2 * 981 * h_up)
                                                    - math.sqrt(2 * 981 * h_low)), rel=1e-13)
        assert phi0(*xi) == pytest.approx(_tank_phi0(*xi, **TANK["params"]), rel=1e-11)
        assert kernel.phi0(np.array(xi), np.zeros(0), kernel) == pytest.approx(phi0(*xi),
                                                                           rel=1e-12)


def test_the_singular_set_of_lotka_volterra_and_lorenz_is_where_the_output_vanishes() -> None:
    lv = _plant(LV)
    obs = derive(lv.model)
    s = lv.model.symbols
    assert sp.simplify(obs.det + s["b"] * s["x1"]) == 0
    assert "x1 = 0" in obs.singular
    text = report(_plant(LV, x0=[0.0, 1.0]))
    assert "at x0 (x1 = 0, x2 = 1): det dPhi/dx = 0 -- SINGULAR" in text
    lorenz = _plant({"states": ["x", "y", "z"], "params": {"s": 10.0, "r": 28.0, "beta": 2.5},
                     "f": {"x": "s*(y - x)", "y": "x*(r - z) - y", "z": "x*y - beta*z"},
                     "h": {"out": "x"}, "x0": [1.0, 1.0, 1.0]})
    obs = derive(lorenz.model)
    assert sp.simplify(obs.det + lorenz.model.symbols["s"] ** 2 * lorenz.model.symbols["x"]) == 0
    assert "x = 0" in obs.singular and "s = 0" in obs.singular
    assert derive(_plant(ROSSLER).model).singular == ()


def test_an_input_in_a_lower_lie_derivative_is_refused_naming_it() -> None:
    with pytest.raises(ConfigError, match=r"L_f\^1 h = u \+ x2 depends on input u "):
        derive(_plant({"states": ["x1", "x2"], "inputs": ["u"], "f": {"x1": "x2 + u",
                                                                        "x2": "-x1"},
                       "h": {"y": "x1"}, "x0": [1.0, 0.0]}).model)


# ---------------------------------------------------------------------- observer functions
def test_newton_finds_the_symbolic_inverse_and_phi0_from_the_last_estimate() -> None:
    lv = _plant(LV)
    newton = hgo_normal_form("nf", lv, eps=0.1, inverse="newton", xhat0=[1.0, 2.0])
    exact = hgo_normal_form("nf", lv, eps=0.1, inverse="symbolic", xhat0=[1.0, 2.0])
    np.testing.assert_allclose(newton.z0, [1.0, 1.0 * (1.0 - 0.5 * 2.0)])  # Phi(x^(0))
    xi = np.array([1.7, -0.4])
    d = newton.d0.copy()
    newton.update(0.0, xi, d, np.zeros(1), np.zeros(0), newton.p)
    x_true = np.array([1.7, (1.0 - (-0.4) / 1.7) / 0.5])
    np.testing.assert_allclose(d[2:4], x_true, rtol=1e-12)
    assert 1 <= d[4] <= 20 and d[5] <= 1e-12 * 2.7  # iterations, residual
    assert d[6] == pytest.approx(-0.5 * 1.7)  # det dPhi/dx = -b x1
    xhat = np.zeros(2)
    exact.estimate(0.0, xi, exact.d0, exact.p, xhat)
    np.testing.assert_allclose(xhat, x_true, rtol=1e-14)
    work = np.concatenate([xi, d[2:4]])  # (xi, last x^): what the kernel hands phi0
    assert newton.p.phi0(work, np.zeros(0), newton.p) == pytest.approx(
        exact.p.phi0(xi, np.zeros(0), exact.p), rel=1e-12)


def test_the_guard_caps_the_correction_near_a_singular_jacobian_and_says_so() -> None:
    lv = _plant(LV)
    obs = hgo_original("o", lv, eps=0.1, xhat0=[1.0, 2.0], max_correction=100.0, damping=0.0)
    p, w = obs.p, np.zeros(12)  # scratch: 2 n^2 + 2 n
    det, acted = correction(np.array([1.0, 2.0]), 0.01, p, w)
    assert det == pytest.approx(-0.5) and acted == 0.0  # c = J^-1 (2 e/eps, e/eps^2)
    np.testing.assert_allclose(w[4:6], np.linalg.solve([[1.0, 0.0], [0.0, -0.5]], [0.2, 1.0]))
    det, acted = correction(np.array([1e-6, 2.0]), 0.01, p, w)  # |c2| ~ 2e6 > 100
    assert acted == 1.0 and np.abs(w[4:6]).max() == pytest.approx(100.0)
    det, acted = correction(np.array([0.0, 2.0]), 0.01, p, w)  # singular: no correction
    assert det == 0.0 and acted == 1.0 and not w[4:6].any()
    d = obs.d0.copy()
    original_update(0.0, np.array([1e-6, 2.0]), d, np.array([0.01]), np.zeros(0), p)
    assert d[2] == 1.0 and d[3] == 1.0 and d[1] == pytest.approx(0.5e-6)
    original_update(0.0, np.array([1.0, 2.0]), d, np.array([1.0]), np.zeros(0), p)
    assert d[2] == 0.0 and d[3] == 1.0


def test_damping_is_the_levenberg_marquardt_correction_and_continuous_through_det_0() -> None:
    lv = _plant(LV)
    mu = 0.05
    obs = hgo_original("o", lv, eps=0.1, xhat0=[1.0, 2.0], damping=mu, max_correction=1e12)
    w = np.zeros(12)
    for x1 in (1.0, 1e-3, 0.0, -1e-3):
        det, acted = correction(np.array([x1, 2.0]), 0.01, obs.p, w)
        J = np.array([[1.0, 0.0], [1.0 - 0.5 * 2.0, -0.5 * x1]])
        v = np.array([2 * 0.01 / 0.1, 0.01 / 0.01])
        want = np.linalg.solve(J.T @ J + mu ** 2 * np.eye(2), J.T @ v)
        np.testing.assert_allclose(w[4:6], want, rtol=1e-12)
        assert acted == (1.0 if x1 != 1.0 else 0.0)  # far from x1 = 0: < 1 % change
    assert abs(w[5]) < 1.0  # bounded through x1 = 0 (the plain inverse: 1 / (0.5 x1))


def test_an_estimate_started_where_phi_is_singular_is_refused() -> None:
    with pytest.raises(ConfigError, match=r"observer.o.xhat0: dPhi/dx is singular at x\^\(0\)"):
        hgo_original("o", _plant(LV), xhat0=[0.0, 1.0])


# ---------------------------------------------------------------------- the presets, run
def _tank_rhs(t, x, A=28.0, a=0.071, g=981.0, q=9.99):
    up, low = math.sqrt(2 * g * x[0]), math.sqrt(2 * g * x[1])
    return [q / A - a / A * up, a / A * (up - low)]


def _rossler_rhs(t, x, a=0.2, b=0.2, c=5.7):
    return [-x[1] - x[2], x[0] + a * x[1], b + x[2] * (x[0] - c)]


PRESETS = {"two_tank_hgo": (_tank_rhs, 60.0), "rossler_hgo": (_rossler_rhs, 20.0)}


@pytest.fixture(scope="module", params=list(PRESETS))
def noiseless_run(request):
    """The preset without noise, DOP853 at rtol 1e-12 (one compiled kernel each)."""
    import hgo

    name = request.param
    t_end = PRESETS[name][1]
    cfg = hgo.compose([f"experiment={name}", "noise.std=0", f"solver.t_end={t_end}",
                       "solver.rtol=1e-12", "solver.atol=1e-12", "recording=off",
                       "figures.estimates=null", f"metrics.window={t_end / 4}",
                       f"postprocess.peaking.transient={t_end / 4}"])
    return name, hgo.run(cfg)


def test_the_preset_plant_equals_solve_ivp_of_the_same_equations(noiseless_run) -> None:
    name, result = noiseless_run
    rhs, t_end = PRESETS[name]
    x = result.signals.filter(like="/plant/x/").to_numpy()
    t = result.signals.index.to_numpy()
    ref = solve_ivp(rhs, (0.0, t_end), x[0], method="DOP853", rtol=1e-12, atol=1e-12,
                    t_eval=t, dense_output=False)
    assert result.ok and ref.success
    assert np.abs(x - ref.y.T).max() <= 1e-8 * max(1.0, np.abs(ref.y).max())


def test_without_noise_both_observers_converge(noiseless_run) -> None:
    name, result = noiseless_run
    s = result.signals
    span = np.ptp(s.filter(like="/plant/x/").to_numpy(), axis=0)
    for obs in ("hgo_original", "hgo_normal_form"):
        final = np.abs(s.filter(like=f"/error/{obs}/").to_numpy()[-1])
        assert np.all(final <= 1e-6 * span), (obs, final, span)
        start = np.abs(s.filter(like=f"/error/{obs}/").to_numpy()[0])
        assert start.max() > 0.5  # it started away from the state
    metrics = result.metrics.set_index(["observer", "quantity"]).empirical
    assert metrics[("hgo_original", "guard_step_ends")] == 0
    assert metrics[("hgo_original", "min_abs_det_dPhi")] > 0


def test_the_lowpower_observer_with_newton_inverse_converges_in_the_kernel() -> None:
    """kind=lowpower, inverse=newton compiled (one kernel): Newton from the last x^ every
    step, its iterations and residual recorded, the estimate converging without noise."""
    import hgo

    result = hgo.run(hgo.compose([
        "plant=lotka_volterra", "observer=hgo_normal_form", "postprocess=observability",
        "observer.hgo_normal_form.kind=lowpower", "observer.hgo_normal_form.inverse=newton",
        "observer.hgo_normal_form.eps=0.1", "observer.hgo_normal_form.xhat0=[1.0,2.0]",
        "solver=dop853", "solver.t_end=20", "metrics.window=5", "recording=off"]))
    s = result.signals
    assert result.ok
    iterations = s["/observer/hgo_normal_form/discrete/newton_iterations"]
    assert iterations.max() >= 1 and iterations.max() <= 20
    assert s["/observer/hgo_normal_form/discrete/inverse_residual"].max() <= 1e-12
    final = np.abs(s.filter(like="/error/hgo_normal_form/").to_numpy()[-1])
    assert np.all(final <= 1e-6 * np.ptp(s.filter(like="/plant/x/").to_numpy(), axis=0))
    metrics = result.metrics.set_index(["observer", "quantity"]).empirical
    assert metrics[("hgo_normal_form", "min_abs_det_dPhi")] == pytest.approx(0.5)  # at x^(0)


def test_hgo_observability_prints_the_map_and_refuses_a_plant_without_equations(
        capsys) -> None:
    from hgo.cli.observability import main

    assert main(["plant=lotka_volterra"]) == 0
    out = capsys.readouterr().out
    assert "xi2 = a*x1 - b*x1*x2" in out and "singular where: b = 0; x1 = 0" in out
    assert "phi0(xi, u) = -a*c*xi1**2 + a*d*xi1 + c*xi1*xi2 - d*xi2 + xi2**2/xi1" in out
    assert main(["plant=van_der_pol"]) == 2
    assert "error: plant: van_der_pol is not given by its equations" in capsys.readouterr().err


def test_a_generated_function_unpickles_in_another_process() -> None:
    """A figure process forked before the plant was built gets the run's system pickled:
    the generated module must import there (it failed with ModuleNotFoundError)."""
    import pickle
    import subprocess
    import sys

    blob = pickle.dumps(_plant(LV).f)
    code = ("import pickle, sys, numpy as np\n"
            "from hgo.core.components import Params\n"
            "f = pickle.loads(sys.stdin.buffer.read())\n"
            "dx = np.zeros(2)\n"
            "f(0.0, np.array([2.0, 1.0]), np.zeros(0), Params(a=1.0, b=0.5, c=0.5, d=1.0)"
            ".vector, dx)\n"
            "print(dx.tolist())\n")
    done = subprocess.run([sys.executable, "-c", code], input=blob, capture_output=True,
                          timeout=120)
    assert done.returncode == 0, done.stderr.decode()[-2000:]
    assert done.stdout.decode().strip() == "[1.0, 0.0]"
