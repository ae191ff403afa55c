"""High-gain observers for any plant given by its equations (issue 42, item 3).

The plant x' = f(x, u), y = h(x) (a :class:`~hgo.plants.symbolic.SymbolicPlant`), its
observability map Phi = (h, L_f h, ..., L_f^(n-1) h) and phi0 = L_f^n h o Phi^-1 derived by
:mod:`hgo.plants.observability`; alpha from the Hurwitz ``roots`` (default all -1), E(eps) =
diag(eps^-1, ..., eps^-n). Both factories take the built plant (their parameter ``plant``)
and read its parameter values; the state they estimate is the plant's own x.

* :func:`hgo_original`, the high-gain observer in the plant's coordinates (Khalil & Praly,
  *High-gain observers in nonlinear feedback control*, Int. J. Robust Nonlinear Control
  24(6), 2014, Sec. 2):

      x^' = f(x^, u) + [dPhi/dx(x^)]^-1 E(eps) alpha (y - h(x^)).

  The correction c solves dPhi/dx(x^) c = E(eps) alpha (y - h(x^)) (Gaussian elimination
  with partial pivoting, :mod:`hgo.observers.small_lu`). **Guard** near a singular
  Jacobian (the choices made here): with ``damping`` mu > 0 (default 1e-3), c is the
  damped least-squares solution c = (J^T J + mu^2 I)^-1 J^T E alpha e, J = dPhi/dx(x^)
  (Levenberg-Marquardt:
  each singular value s of J acts as s / (s^2 + mu^2) <= 1 / (2 mu) instead of 1/s, and c
  stays continuous through the singular set, where the plain inverse flips sign; far from
  it, a change of O(mu^2 / s^2)); then a saturation, c -> c * M / max|c_i| where
  max|c_i| > M = ``max_correction``; without damping, c = 0 where dPhi/dx(x^) is exactly
  singular. The guard *acts* at a step end where the saturation caps c, the damping
  changes it by more than 1 % of max|c_i|, or J is singular. Where x^ reaches the singular
  set without damping, the sign flip of the correction there can hold x^ on it (sliding:
  the adaptive step shrinks without end; a plant measured as y = x1 + 0.2 x2 of Van der
  Pol did, at eps = 0.01). The discrete state records, at every step end: ``det_dPhi``
  (det dPhi/dx(x^)), ``min_abs_det_dPhi``
  (its running minimum of |det| since t = 0), ``guard`` (1 where the guard acts at that
  step end, else 0) and ``guard_step_ends`` (how many step ends it acted at).

* :func:`hgo_normal_form`, hgo's standard (``kind: standard``) or low-power (``kind:
  lowpower``) observer (:mod:`hgo.observers.normal_form`) on xi = Phi(x) with the derived
  phi0, started at xi^(0) = Phi(x^(0)), and the estimate x^ = Phi^-1(xi^): the symbolic
  inverse where SymPy finds one (``inverse: auto`` or ``symbolic``), else Newton iterations
  in the kernel from the last step's x^ (``inverse: newton``; at most ``newton_iters``,
  until max|Phi(x) - xi| <= ``newton_tol`` (1 + max|xi|)). ``saturation`` clips xi^ fed to
  phi0 (as for the normal-form observers). Recorded at every step end: ``x_last_<state>``
  (x^ there), ``newton_iterations``, ``inverse_residual`` (max|Phi(x^) - xi^|, for the
  symbolic inverse too), ``det_dPhi`` and ``min_abs_det_dPhi`` as above.

Both take ``model_params`` (name -> value): plant parameters whose value their model
replaces (a model error on purpose; the branch of Phi^-1 and the checks at x^(0) use the
model's values too).

The minimum of |det dPhi/dx(x^)| and the guard's step ends are metrics through the
``observability`` post-processor (:mod:`hgo.postprocess.observability`).

Example:
    ```python
    from hgo.observers.symbolic_hgo import hgo_normal_form, hgo_original
    from hgo.plants.symbolic import symbolic_plant

    lv = symbolic_plant(states=["x1", "x2"], params={"a": 1.0, "b": 0.5, "c": 0.5, "d": 1.0},
                        f={"x1": "a*x1 - b*x1*x2", "x2": "c*x1*x2 - d*x2"},
                        h={"y": "x1"}, x0=[2.0, 1.0])
    original = hgo_original("original", plant=lv, eps=0.05, xhat0=[1.0, 2.0])
    normal = hgo_normal_form("normal", plant=lv, eps=0.05, xhat0=[1.0, 2.0])
    print(original.state_names, normal.state_names)  # ['x1_hat', 'x2_hat'] ['xhat1', 'xhat2']
    ```

    In a config: ``observer=[hgo_original,hgo_normal_form]`` (``conf/observer/``).
"""

from __future__ import annotations

import logging
import math
from collections.abc import Sequence
from dataclasses import replace

import numpy as np

from hgo.core.components import Observer, Params
from hgo.core.errors import ConfigError
from hgo.engine.jit import matrix_view, record_helper
from hgo.observers.normal_form import hurwitz_alpha, lowpower_hgo, standard_hgo
from hgo.observers.small_lu import lu_solve, max_abs
from hgo.observers.symbolic_model import PREFIX, observer_functions
from hgo.plants.observability import derive, det_at, inverse_branch, values_of
from hgo.plants.symbolic import SymbolicPlant

log = logging.getLogger(__name__)


# ---------------------------------------------------------------------- kernel functions
@record_helper
def correction(x, e, p, w):
    """c = [dPhi/dx(x)]^-1 E(eps) alpha e with the guard of the module doc, into
    w[n^2:n^2 + n] (``w``: the observer's scratch, 2 n^2 + 2 n floats); returns (det
    dPhi/dx(x), 1.0 where the guard acted, else 0.0)."""
    n = p.n
    J = matrix_view(w, 0, n, n)
    c = w[n * n:n * n + n]
    p.phi_jac(x, p, J)
    g = 1.0
    for i in range(n):
        g /= p.eps
        c[i] = p.alpha[i] * g * e
    damped = p.damping > 0.0
    if damped:  # M = J^T J + mu^2 I, b = J^T v (before J is factored)
        M = matrix_view(w, n * n + n, n, n)
        b = w[2 * n * n + n:2 * n * n + 2 * n]
        for i in range(n):
            b[i] = 0.0
            for k in range(n):
                b[i] += J[k, i] * c[k]
            for j in range(n):
                s = p.damping * p.damping if i == j else 0.0
                for k in range(n):
                    s += J[k, i] * J[k, j]
                M[i, j] = s
    det = lu_solve(J, c, n)
    acted = det == 0.0
    if damped:
        lu_solve(M, b, n)
        big, off = max_abs(c, n), 0.0
        for i in range(n):
            off = max(off, abs(b[i] - c[i]))
            c[i] = b[i]
        acted = acted or not off <= 0.01 * big
    elif acted:
        for i in range(n):
            c[i] = 0.0
    big = max_abs(c, n)
    if not big <= p.max_correction:
        scale = p.max_correction / big if math.isfinite(big) else 0.0
        for i in range(n):
            c[i] = c[i] * scale if scale > 0.0 else 0.0
        acted = True
    return det, 1.0 if acted else 0.0


def original_f(t, z, d, y, u, p, dz):
    """x^' = f(x^, u) + c, c the guarded correction."""
    n = p.n
    p.model_f(t, z, u, p, dz)
    w = p.scratch
    correction(z, y[0] - p.model_h0(z, p), p, w)
    for i in range(n):
        dz[i] += w[n * n + i]


def original_update(t, z, d, y, u, p):
    """det dPhi/dx(x^), its running minimum of |det|, the guard's flag and count."""
    det, acted = correction(z, y[0] - p.model_h0(z, p), p, p.scratch)
    d[0] = det
    d[1] = min(d[1], abs(det))
    d[2] = acted
    d[3] += acted


def original_estimate(t, z, d, p, xhat):
    """x^ = z."""
    for i in range(p.n):
        xhat[i] = z[i]


@record_helper
def newton_inverse(xi, guess, x, p, work):
    """x = Phi^-1(xi) by Newton's method from ``guess``; returns (iterations, max|Phi(x) -
    xi|). ``work``: n^2 + n floats."""
    n = p.n
    J = matrix_view(work, 0, n, n)
    r = work[n * n:n * n + n]
    for i in range(n):
        x[i] = guess[i]
    k = 0
    while True:
        p.phi_map(x, p, r)
        for i in range(n):
            r[i] = xi[i] - r[i]
        res = max_abs(r, n)
        if res <= p.newton_tol * (1.0 + max_abs(xi, n)) or k >= p.newton_iters:
            return k, res
        p.phi_jac(x, p, J)
        if lu_solve(J, r, n) == 0.0:
            return k, res
        for i in range(n):
            x[i] += r[i]
        k += 1


def newton_phi0(x, u, p):
    """phi0 = L_f^n h(Phi^-1(xi), u) with xi = x[:n] and Phi^-1 by Newton from the last
    step's x^ (x[n:2n]: the work area of the normal-form observer, module doc)."""
    n = p.n
    w = p.scratch
    xs = w[n * n + n:n * n + 2 * n]
    newton_inverse(x[:n], x[n:2 * n], xs, p, w)
    return p.lie_n(xs, u, p)


@record_helper
def _record_det(xs, d, p, w):
    """det dPhi/dx(x^) and its running minimum of |det| into d."""
    n = p.n
    J = matrix_view(w, 0, n, n)
    p.phi_jac(xs, p, J)
    r = w[n * n:n * n + n]
    det = lu_solve(J, r, n)
    d[2 * n + 2] = det
    d[2 * n + 3] = min(d[2 * n + 3], abs(det))


def newton_update(t, z, d, y, u, p):
    """x^ by Newton from the last x^, its iterations and residual, det dPhi/dx(x^)."""
    n = p.n
    w = p.scratch
    xs = w[n * n + n:n * n + 2 * n]
    k, res = newton_inverse(z[:n], d[n:2 * n], xs, p, w)
    for i in range(n):
        d[n + i] = xs[i]
    d[2 * n] = k
    d[2 * n + 1] = res
    _record_det(xs, d, p, w)


def newton_estimate(t, z, d, p, xhat):
    """x^ = Phi^-1(xi^) by Newton from the last step's x^."""
    n = p.n
    newton_inverse(z[:n], d[n:2 * n], xhat, p, p.scratch)


def inverse_update(t, z, d, y, u, p):
    """x^ = Phi^-1(xi^), the residual max|Phi(x^) - xi^|, det dPhi/dx(x^)."""
    n = p.n
    w = p.scratch
    xs = w[n * n + n:n * n + 2 * n]
    p.phi_inverse(z, p, xs)
    r = w[n * n:n * n + n]
    p.phi_map(xs, p, r)
    for i in range(n):
        d[n + i] = xs[i]
        r[i] -= z[i]
    d[2 * n] = 0.0
    d[2 * n + 1] = max_abs(r, n)
    _record_det(xs, d, p, w)


def inverse_estimate(t, z, d, p, xhat):
    """x^ = Phi^-1(xi^) (symbolic)."""
    p.phi_inverse(z, p, xhat)


# ---------------------------------------------------------------------- factories
def _derived(plant: object, key: str):
    """The observability of ``plant``, its singular set reported up front (logged; a
    warning where x0 is in it)."""
    if not isinstance(plant, SymbolicPlant) or plant.model is None:
        raise ConfigError(f"{key}.plant", "needs a plant given by its equations (plant="
                          "symbolic or a preset built on it)")
    obs = derive(plant.model)
    det0 = det_at(obs, values_of(plant), plant.x0)
    where = "; ".join(obs.singular) or "nowhere"
    log.log(logging.WARNING if det0 == 0 else logging.INFO,
            "%s: dPhi/dx singular where: %s; det dPhi/dx at x0 = %.6g", key, where, det0)
    return obs


def _xhat0(key: str, xhat0: Sequence[float] | None, plant: SymbolicPlant) -> np.ndarray:
    """x^(0): ``xhat0``, or the plant's x0 when not given."""
    x0 = plant.x0.copy() if xhat0 is None else np.asarray(xhat0, float).reshape(-1)
    if x0.shape != (plant.nx,) or not np.all(np.isfinite(x0)):
        raise ConfigError(f"{key}.xhat0", f"must be {plant.nx} finite numbers (one per state "
                          f"{', '.join(plant.state_names)}), got {xhat0}")
    return x0


def _model_values(plant: SymbolicPlant, key: str = "observer",
                  model_params: dict | None = None) -> dict[str, float]:
    """The observer's model values (its record's ``plant_<name>``): the plant's, except
    those ``model_params`` replaces (a model error on purpose)."""
    values = {name: float(getattr(plant.p, name)) for name in plant.model.params}
    for name, value in (model_params or {}).items():
        if name not in values:
            raise ConfigError(f"{key}.model_params.{name}", "is not a parameter of the plant",
                              ", ".join(values) or None)
        if isinstance(value, bool) or not isinstance(value, int | float) or not math.isfinite(
                value):
            raise ConfigError(f"{key}.model_params.{name}", f"must be a finite number, got "
                              f"{value!r}")
        values[name] = float(value)
    return {f"{PREFIX}{name}": v for name, v in values.items()}


def _symbols(plant: SymbolicPlant, model_values: dict[str, float]) -> dict:
    """Parameter symbol -> the observer's model value."""
    return {plant.model.symbols[k[len(PREFIX):]]: v for k, v in model_values.items()}


def _check_singular(key: str, obs, values: dict, x: np.ndarray, what: str) -> float:
    det = det_at(obs, values, x)
    if not (math.isfinite(det) and det != 0.0):
        raise ConfigError(f"{key}.xhat0", f"dPhi/dx is singular at {what} x = {x.tolist()} "
                          f"(det = {det}); singular where: {'; '.join(obs.singular)}")
    return det


def hgo_original(name: str, plant: SymbolicPlant, eps: float = 0.05,
                 roots: Sequence[float] | None = None, xhat0: Sequence[float] | None = None,
                 max_correction: float = 1e6, damping: float = 1e-3,
                 model_params: dict | None = None) -> Observer:
    """Khalil & Praly's observer in the plant's coordinates (module doc); ``model_params``
    replace plant parameter values in its model (default: the plant's own)."""
    key = f"observer.{name}"
    obs = _derived(plant, key)
    n = obs.n
    if not (isinstance(eps, int | float) and math.isfinite(eps) and eps > 0):
        raise ConfigError(f"{key}.eps", f"must be a number > 0, got {eps!r}")
    if not (isinstance(max_correction, int | float) and max_correction > 0):
        raise ConfigError(f"{key}.max_correction", f"must be > 0 (inf: no guard), got "
                          f"{max_correction!r}")
    if not (isinstance(damping, int | float) and math.isfinite(damping) and damping >= 0):
        raise ConfigError(f"{key}.damping", f"must be a number >= 0 (0: none), got {damping!r}")
    x0 = _xhat0(key, xhat0, plant)
    model_values = _model_values(plant, key, model_params)
    det0 = _check_singular(key, obs, _symbols(plant, model_values), x0, "x^(0)")
    alpha = hurwitz_alpha(n, roots)
    fns = observer_functions(obs, None)
    constants = {"n": n, "alpha": tuple(alpha.tolist()), "model_f": fns.model_f,
                 "model_h0": fns.model_h0, "phi_jac": fns.phi_jac,
                 "scratch": 2 * n * n + 2 * n}
    radius = float(np.max(np.abs(np.roots(np.concatenate([[1.0], alpha]))))) / eps
    return Observer(name=name, state_names=[f"{s}_hat" for s in plant.state_names],
                    disc_names=["det_dPhi", "min_abs_det_dPhi", "guard", "guard_step_ends"],
                    estimated_states=list(range(n)), z0=x0,
                    d0=np.array([det0, abs(det0), 0.0, 0.0]),
                    p=Params(constants, eps=float(eps), max_correction=float(max_correction),
                             damping=float(damping),
                             **model_values),
                    f=original_f, update=original_update, estimate=original_estimate,
                    spectral_radius=radius, reads_inputs=list(range(len(plant.input_names))))


INVERSES = ("auto", "symbolic", "newton")
KINDS = {"standard": standard_hgo, "lowpower": lowpower_hgo}


def hgo_normal_form(name: str, plant: SymbolicPlant, eps: float | None = None,
                    ell: float | None = None, kind: str = "standard",
                    roots: Sequence[float] | None = None,
                    K: Sequence[Sequence[float]] | None = None,
                    saturation: float | Sequence[float] | None = None,
                    xhat0: Sequence[float] | None = None, inverse: str = "auto",
                    newton_iters: int = 20, newton_tol: float = 1e-12,
                    model_params: dict | None = None) -> Observer:
    """hgo's standard or low-power observer on xi = Phi(x) (module doc); ``model_params``
    replace plant parameter values in its model (default: the plant's own)."""
    key = f"observer.{name}"
    obs = _derived(plant, key)
    n = obs.n
    if kind not in KINDS:
        raise ConfigError(f"{key}.kind", f"unknown kind '{kind}'", ", ".join(KINDS))
    if inverse not in INVERSES:
        raise ConfigError(f"{key}.inverse", f"unknown inverse '{inverse}'", ", ".join(INVERSES))
    if not (isinstance(newton_iters, int) and newton_iters >= 1 and newton_tol > 0):
        raise ConfigError(f"{key}.newton_iters", f"newton_iters must be an integer >= 1 and "
                          f"newton_tol > 0, got {newton_iters!r}, {newton_tol!r}")
    model_values = _model_values(plant, key, model_params)
    values = _symbols(plant, model_values)
    x0 = _xhat0(key, xhat0, plant)
    det0 = _check_singular(key, obs, values, x0, "x^(0)")
    branch = None if inverse == "newton" else inverse_branch(obs, values, plant.x0)
    if branch is None and inverse == "symbolic":
        raise ConfigError(f"{key}.inverse", "SymPy found no inverse of Phi that maps Phi(x0) "
                          "back to x0", "auto, newton")
    fns = observer_functions(obs, branch)
    xi0 = np.zeros(n)
    fns.phi_map(x0, _record(model_values), xi0)
    if (roots is not None and kind != "standard") or (K is not None and kind != "lowpower"):
        raise ConfigError(f"{key}.{'roots' if roots is not None else 'K'}", "applies to "
                          f"kind {'standard' if roots is not None else 'lowpower'} only, this "
                          f"observer is kind {kind}")
    common = {"eps": eps, "ell": ell, "phi0": fns.phi0_xi if branch else newton_phi0,
              "saturation": np.full(n, np.inf) if saturation is None else saturation,
              "xhat0": xi0}
    base = (standard_hgo(name, n, roots=roots, **common) if kind == "standard"
            else lowpower_hgo(name, n, K=K, **common))
    spec = base.params
    constants = {**spec.constants, "phi_map": fns.phi_map, "phi_jac": fns.phi_jac,
                 "lie_n": fns.lie_n, "newton_iters": newton_iters, "scratch": n * n + 2 * n}
    if branch is not None:
        constants["phi_inverse"] = fns.phi_inverse
    run_values = {k: spec.get(base.p, k) for k in spec.names}
    states = plant.state_names
    d0 = np.concatenate([base.d0, x0, [0.0, 0.0, det0, abs(det0)]])
    return replace(
        base, p=Params(constants, **run_values, newton_tol=float(newton_tol), **model_values),
        disc_names=[*base.disc_names, *(f"x_last_{s}" for s in states), "newton_iterations",
                    "inverse_residual", "det_dPhi", "min_abs_det_dPhi"],
        d0=d0, update=inverse_update if branch else newton_update,
        estimate=inverse_estimate if branch else newton_estimate,
        signals={**base.signals, "xi_hat": list(range(n))},
        reads_inputs=list(range(len(plant.input_names))))


def _record(values: dict[str, float]):
    """The plant's values under the observer's names, as the generated functions read them
    from plain Python (x^(0) -> xi^(0))."""
    return Params(**values).vector
