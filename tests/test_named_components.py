"""Components with named parameters (issue 24, item 1): ``p.A[i, j]``, ``p.n``, ``p.phi``."""

from __future__ import annotations

import math
import pickle
import warnings
from fractions import Fraction

import numpy as np
import pytest
from scipy.linalg import expm

from hgo.core.components import Params, Plant
from hgo.engine.codegen import composition_source
from hgo.engine.composition import Bound
from hgo.engine.simulate import SolverSettings, no_noise, simulate, simulate_ensemble
from hgo.engine.system import System
from hgo.observers.triangular import triangular_hgo
from hgo.running.ensemble import stack_members

A_DAMPED = [[0.0, 1.0], [-2.0, -0.3]]


def linear_f(t, x, u, p, dx):
    """x' = A x + g phi(x_1): A (n x n) and g (n) run-time values, n and phi constants."""
    for i in range(p.n):
        acc = p.g[i] * p.phi(x[0])
        for j in range(p.n):
            acc += p.A[i, j] * x[j]
        dx[i] = acc


def output_h(t, x, p, y):
    y[0] = x[0]


def zero(s):
    return 0.0


def cube(s):
    return s * s * s


def linear_plant(A=A_DAMPED, g=(0.0, 0.0), phi=zero) -> Plant:
    A = np.asarray(A, float)
    n = A.shape[0]
    return Plant(name="linear", state_names=[f"x{i + 1}" for i in range(n)],
                 output_names=["y"], input_names=[], x0=np.ones(n),
                 p=Params({"n": n, "phi": phi}, A=A, g=g), f=linear_f, h=output_h)


def _observer(n: int = 2):
    return triangular_hgo("hgo", K=[2.0, 1.0][:n], xhat0=[0.0] * n, r0=2.0, law="constant")


SOLVER = SolverSettings(t_end=2.0, dt_out=0.5, rtol=1e-11, atol=1e-13)


def test_matrix_parameter_read_by_name_gives_the_exact_solution():
    """x' = A x integrated with A read as p.A[i, j] matches expm(A t) x0 to 1e-9."""
    traj = simulate(System(linear_plant(), [_observer()]), SOLVER, no_noise(1))
    assert traj.ok
    exact = np.array([expm(np.asarray(A_DAMPED) * t) @ np.ones(2) for t in traj.t])
    assert np.abs(traj.z[:, :2] - exact).max() < 1e-9


def test_kernel_text_names_parameters_and_writes_constants_as_literals():
    """Each component's function is called on the addresses of its slices (of P: the
    component's own), and its bound function's text reads each value of the record at a
    constant offset into that slice, by name, and holds the dimension as a literal and
    the function by its injected name."""
    text, functions = composition_source(System(linear_plant(phi=cube), [_observer()]))
    bound = {name: fn for name, fn in functions.items() if isinstance(fn, Bound)}
    plant_f = next(name for name, fn in bound.items() if fn.functions["function"] is linear_f)
    assert f"{plant_f}(t, at(z, 0), at(w, 1), at(P, 0), at(dz, 0))" in text
    observer_f = next(name for name, fn in bound.items()
                      if fn.functions["function"].__name__ == "f" and name != plant_f)
    assert "at(P, 6), at(dz, 2))" in text.split(observer_f + "(", 1)[1]
    assert "    P = carray(a3, 6)" in bound[plant_f].text.splitlines()

    def reads(fn: Bound, field: str) -> bool:  # one keyword argument of the record
        binding = next(line for line in fn.text.splitlines() if " = _P(" in line)
        return any(f"{before}{field}{after}" in binding for before in "(, "
                   for after in ",)")

    assert reads(bound[plant_f], "A=view2(P, 0, 2, 2)") and reads(bound[plant_f], "g=view(P, 4, 6)")
    assert reads(bound[plant_f], "n=2") and reads(bound[plant_f], "phi=c_const_phi")
    assert bound[plant_f].functions["c_const_phi"] is cube
    # the observer's values at offsets into its own slice (P[6:17] of the whole)
    assert reads(bound[observer_f], "law=0") and reads(bound[observer_f], "K=view(P, 3, 5)")


def test_a_component_at_another_offset_is_called_through_the_same_bound_function():
    """Two observers of one structure (other gains), the second at a later offset of P:
    one bound function text for both (it reads the observer's own slice, so the compiled
    function is shared), and each estimate is that observer's run alone (to 1e-8: the
    steps differ; rtol 1e-11)."""
    first = _observer()
    second = triangular_hgo("second", K=[3.0, 2.5], xhat0=[0.0, 0.0], r0=2.0,
                            law="constant")
    system = System(linear_plant(), [first, second])
    text, functions = composition_source(system)
    bound = [next(fn for name, fn in functions.items() if name.startswith(f"b{k}_obs_f"))
             for k in (1, 2)]
    assert bound[0].text == bound[1].text
    assert "at(P, 6), at(dz, 2))" in text and "at(P, 17), at(dz, 5))" in text
    both = simulate(system, SOLVER, no_noise(1))
    for k, observer in enumerate((first, second)):
        alone = simulate(System(linear_plant(), [observer]), SOLVER, no_noise(1))
        assert np.abs(both.xh[:, 2 * k:2 * k + 2] - alone.xh).max() < 1e-8
    assert np.abs(both.xh[:, :2] - both.xh[:, 2:]).max() > 1e-3  # (the gains matter)


def test_function_constant_is_called_by_the_kernel():
    """x1' = x2 - x1^3 through p.phi = cube, against the same field in plain Python."""
    plant = linear_plant(A=[[0.0, 1.0], [-1.0, 0.0]], g=(-1.0, 0.0), phi=cube)
    traj = simulate(System(plant, [_observer()]), SOLVER, no_noise(1))
    from scipy.integrate import solve_ivp

    ref = solve_ivp(lambda t, x: [x[1] - x[0] ** 3, -x[0]], (0.0, 2.0), [1.0, 1.0],
                    t_eval=traj.t, rtol=1e-12, atol=1e-14, method="DOP853")
    assert np.abs(traj.z[:, :2] - ref.y.T).max() < 1e-8


def test_ensemble_varies_a_named_value():
    """Members differing in p.A[1, 0] run in one compiled call, each as its single run."""
    systems = [System(linear_plant(A=[[0.0, 1.0], [k, -0.3]]), [_observer()])
               for k in (-1.0, -2.0, -4.0)]
    params, z0, d0 = stack_members(systems)
    out = simulate_ensemble(systems[0], SOLVER, no_noise(1), params, z0, d0, record=True)
    for system, traj in zip(systems, out["trajectories"], strict=True):
        single = simulate(system, SOLVER, no_noise(1))
        np.testing.assert_array_equal(traj.z, single.z)
    assert systems[2].plant.p.A[1, 0] == -4.0


def test_ensemble_refuses_members_with_other_constants():
    """A dimension or a function is compiled in: members must share them."""
    with pytest.raises(ValueError, match="compile-time constants"):
        stack_members([System(linear_plant(phi=zero), [_observer()]),
                       System(linear_plant(phi=cube), [_observer()])])


ONE = Fraction(1)  # a Python object numba cannot type


def uncompilable_f(t, x, u, p, dx):
    dx[0] = -float(ONE) * p.a * x[0]
    dx[1] = 0.0


def test_uncompilable_named_component_runs_in_python_with_one_warning():
    plant = Plant(name="py", state_names=["x1", "x2"], output_names=["y"], input_names=[],
                  x0=np.array([1.0, 0.0]), p=Params(a=0.5), f=uncompilable_f, h=output_h)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        traj = simulate(System(plant, [_observer()]), SOLVER, no_noise(1))
    assert len([w for w in caught if "pure-Python" in str(w.message)]) == 1
    assert abs(traj.z[-1, 0] - math.exp(-0.5 * 2.0)) < 1e-9


def test_param_vector_answers_to_names_and_survives_pickling():
    p = Params({"n": 2, "law": 1}, eps=0.5, A=[[1.0, 2.0], [3.0, 4.0]], L=[5.0, 6.0]).vector
    assert p.tolist() == [0.5, 1.0, 2.0, 3.0, 4.0, 5.0, 6.0]
    assert p.eps == 0.5 and p.A[1, 0] == 3.0 and p.L[1] == 6.0 and p.n == 2
    assert p.spec.index("A") == slice(1, 5) and p.spec.index("eps") == 0
    q = pickle.loads(pickle.dumps(p))
    assert q.A[0, 1] == 2.0 and q.law == 1
    assert not hasattr(p[1:3], "eps")  # a slice is not the component's vector


@pytest.mark.parametrize(("constants", "values", "match"), [
    ({}, {"max": 1.0}, "taken by numpy"),
    ({"n": 2}, {"n": 1.0}, "both as run-time values and as compile-time constants"),
    ({"c": "text"}, {}, "not a number"),
])
def test_params_refuses_bad_names_and_constants(constants, values, match):
    with pytest.raises(ValueError, match=match):
        Params(constants, **values)
