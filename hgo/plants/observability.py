"""Observability of a plant given by its equations, computed (issue 42, item 2).

For x' = f(x, u), y = h(x) (channel 0) of order n, the observability map is

    Phi(x) = (h, L_f h, ..., L_f^(n-1) h),   L_f^(k+1) h = d(L_f^k h)/dx f,

(Khalil & Praly, *High-gain observers in nonlinear feedback control*, Int. J. Robust
Nonlinear Control 24(6), 2014, Sec. 2): in xi = Phi(x) the plant is in observability
normal form, xi_i' = xi_(i+1), xi_n' = phi0(xi, u) = L_f^n h(Phi^-1(xi), u), y = xi_1. The
observers need Phi free of u: an input in L_f^k h with k <= n - 1 is refused in one line
naming that Lie derivative. Where dPhi/dx is singular, Phi is no local change of
coordinates: :func:`derive` factors det dPhi/dx and solves each factor for a state (the
singular set), and :func:`report` prints it with the value at x0.

Phi^-1 is asked of SymPy (``solve``, within ``INVERSE_SECONDS`` where a timer can stop it;
real, not too long: ``MAX_INVERSE_OPS``); of several solutions the one that maps Phi(x0)
back to x0 is taken (:func:`inverse_branch`).
Without one, phi0 stays a function of x and the observer inverts Phi numerically (Newton,
:mod:`hgo.observers.symbolic_hgo`).
"""

from __future__ import annotations

import functools
import signal
import threading
from collections.abc import Mapping
from contextlib import contextmanager
from dataclasses import dataclass

import numpy as np
import sympy as sp

from hgo.core.errors import ConfigError
from hgo.plants.symbolic import SymbolicModel, SymbolicPlant

INVERSE_SECONDS = 10
"""How long SymPy may look for Phi^-1 (where a timer can stop it: the main thread)."""
MAX_INVERSE_OPS = 400
"""A solution with more operations than this, or with complex intermediates (Cardano's
formula: ``I`` in a real root), is left to Newton's method: it would cost more than the
iterations and could not be compiled as real arithmetic."""


@dataclass(frozen=True)
class Observability:
    """What :func:`derive` finds for a model (values aside: they are the plant's)."""

    model: SymbolicModel
    phi: tuple[sp.Expr, ...]  # Phi(x) = (h, L_f h, ..., L_f^(n-1) h)
    dphi: sp.ImmutableMatrix  # dPhi/dx
    det: sp.Expr  # det dPhi/dx, factored
    lie_n: sp.Expr  # L_f^n h (x, u)
    xi: tuple[sp.Symbol, ...]  # the normal-form coordinates
    inverses: tuple[tuple[sp.Expr, ...], ...]  # the solutions x = Phi^-1(xi) SymPy found
    singular: tuple[str, ...]  # conditions (one per factor of det) where dPhi/dx is singular

    @property
    def n(self) -> int:
        return len(self.phi)

    def phi0(self, inverse: tuple[sp.Expr, ...]) -> sp.Expr:
        """phi0(xi, u) = L_f^n h(Phi^-1(xi), u) for the branch ``inverse``."""
        return self.lie_n.xreplace(dict(zip(self.model.x, inverse, strict=True)))


def lie_derivative(expr: sp.Expr, f: tuple[sp.Expr, ...], x: list[sp.Symbol]) -> sp.Expr:
    """L_f expr = sum_j d expr/dx_j f_j."""
    return sp.expand(sum(sp.diff(expr, xj) * fj for xj, fj in zip(x, f, strict=True)))


@functools.cache
def derive(model: SymbolicModel) -> Observability:
    """Phi, dPhi/dx, its determinant and singular set, L_f^n h and Phi^-1 (if SymPy finds
    it) of ``model`` for its output 0; ConfigError if the observers cannot use it."""
    x, u, n = model.x, set(model.u), len(model.states)
    if n < 2:
        raise ConfigError("plant.states", "the high-gain observers need n >= 2 states")
    phi = [model.h[0]]
    for k in range(1, n + 1):
        nxt = lie_derivative(phi[-1], model.f, x)
        if k < n and nxt.free_symbols & u:
            names = sorted(s.name for s in nxt.free_symbols & u)
            raise ConfigError("plant", f"L_f^{k} h = {nxt} depends on input {names[0]} "
                              f"(k = {k} < n = {n}): the plant is not uniformly observable in "
                              "the sense these observers need (u may enter L_f^n h only)")
        phi.append(nxt)
    lie_n = phi.pop()
    dphi = sp.ImmutableMatrix(sp.Matrix(phi).jacobian(x))
    det = sp.factor(dphi.det(method="berkowitz"))
    xi = tuple(sp.Symbol(f"_xi{i + 1}", real=True) for i in range(n))
    return Observability(model, tuple(phi), dphi, det, lie_n, xi,
                         _inverses(tuple(phi), tuple(x), xi), _singular(det, x))


def _singular(det: sp.Expr, x: list[sp.Symbol]) -> tuple[str, ...]:
    """One condition per factor of det's numerator that can vanish ('x1 = 0', 'b = 0', or
    'factor = 0' where no state can be solved for) and per factor of its denominator
    (det unbounded there); ('everywhere',) if det = 0."""
    if det == 0:
        return ("everywhere",)
    num, den = sp.fraction(sp.together(det))
    out = []
    for part, label in ((num, ""), (den, " (det unbounded)")):
        for factor in sp.Mul.make_args(sp.factor(part)):
            base = factor.as_base_exp()[0] if factor.is_Pow else factor
            if not base.free_symbols:
                continue
            states = [s for s in x if base.has(s)] or sorted(base.free_symbols, key=str)
            condition = _condition(base, states[0])
            if not any(c.startswith(condition) for c in out):
                out.append(condition + label)
    return tuple(out)


def _condition(factor: sp.Expr, symbol: sp.Symbol) -> str:
    try:
        with _time_limit(INVERSE_SECONDS):
            roots = sp.solve(factor, symbol)
    except (NotImplementedError, TimeoutError, ValueError):
        roots = None
    if roots:
        return " or ".join(f"{symbol} = {r}" for r in roots)
    if roots == []:  # no real root for the symbol: the factor is never 0 there
        return f"never: {factor} = 0 has no solution"
    return f"{factor} = 0"


def _inverses(phi: tuple, x: tuple, xi: tuple) -> tuple[tuple[sp.Expr, ...], ...]:
    """Every x = Phi^-1(xi) SymPy finds in time (maybe none)."""
    try:
        with _time_limit(INVERSE_SECONDS):
            found = sp.solve([p - s for p, s in zip(phi, xi, strict=True)], list(x), dict=True)
    except (NotImplementedError, TimeoutError, ValueError, TypeError):
        return ()
    return tuple(tuple(sol[s] for s in x) for sol in found if all(s in sol for s in x)
                 and not any(v.free_symbols & set(x) or v.has(sp.I)
                             or sp.count_ops(v) > MAX_INVERSE_OPS for v in sol.values()))


@contextmanager
def _time_limit(seconds: int):
    """TimeoutError after ``seconds`` (SIGALRM; no limit outside the main thread)."""
    if threading.current_thread() is not threading.main_thread() or not hasattr(
            signal, "SIGALRM"):
        yield
        return

    def stop(signum, frame):
        raise TimeoutError

    old = signal.signal(signal.SIGALRM, stop)
    signal.alarm(seconds)
    try:
        yield
    finally:
        signal.alarm(0)
        signal.signal(signal.SIGALRM, old)


def values_of(plant: SymbolicPlant) -> dict[sp.Symbol, float]:
    """Parameter symbol -> the plant's value."""
    model = plant.model
    return {model.symbols[name]: float(getattr(plant.p, name)) for name in model.params}


def inverse_branch(obs: Observability, values: Mapping, x0: np.ndarray,
                   tol: float = 1e-9) -> tuple[sp.Expr, ...] | None:
    """The branch of Phi^-1 that maps Phi(x0) back to x0 at the parameter ``values``
    (None: SymPy found none that does)."""
    point = {**values, **dict(zip(obs.model.x, (float(v) for v in x0), strict=True))}
    try:
        xi0 = [complex(sp.N(p.xreplace(point))) for p in obs.phi]
    except (TypeError, ValueError):
        return None
    at = {**values, **dict(zip(obs.xi, xi0, strict=True))}
    for branch in obs.inverses:
        try:
            back = np.array([complex(sp.N(v.xreplace(at))) for v in branch])
        except (TypeError, ValueError, ZeroDivisionError):
            continue
        if np.all(np.isfinite(back)) and np.allclose(back, x0, rtol=tol, atol=tol) and \
                np.all(np.abs(back.imag) <= tol):
            return branch
    return None


def det_at(obs: Observability, values: Mapping, x: np.ndarray) -> float:
    """det dPhi/dx at the state ``x``."""
    point = {**values, **dict(zip(obs.model.x, (float(v) for v in x), strict=True))}
    return float(obs.det.xreplace(point))


def report(plant: SymbolicPlant) -> str:
    """Phi, dPhi/dx, its determinant and singular set (with the value at x0), L_f^n h and
    phi0 of ``plant``, as text (``hgo observability``)."""
    obs = derive(plant.model)
    model, values = plant.model, values_of(plant)
    branch = inverse_branch(obs, values, plant.x0)
    det0 = det_at(obs, values, plant.x0)
    xi_names = {s: sp.Symbol(s.name[1:]) for s in obs.xi}
    x0 = ", ".join(f"{s} = {v:g}" for s, v in zip(model.states, plant.x0, strict=True))
    lines = [f"plant {model.name}: n = {obs.n}, measured {model.outputs[0]} = {model.h[0]}",
             "Phi(x) = (h, L_f h, ..., L_f^(n-1) h):"]
    lines += [f"  xi{i + 1} = {p}" for i, p in enumerate(obs.phi)]
    lines += [f"dPhi/dx = {obs.dphi.tolist()}", f"det dPhi/dx = {obs.det}",
              "singular where: " + ("; ".join(obs.singular) if obs.singular else "nowhere "
                                    "(det dPhi/dx never vanishes)"),
              f"at x0 ({x0}): det dPhi/dx = {det0:.6g}"
              + (" -- SINGULAR: Phi is no change of coordinates there" if det0 == 0 else ""),
              f"L_f^{obs.n} h = {obs.lie_n}"]
    if branch is None:
        found = (f"{len(obs.inverses)} candidate(s) found, none maps Phi(x0) back to x0"
                 if obs.inverses else "none found symbolically")
        lines.append(f"Phi^-1: {found} (the observers invert Phi by Newton iterations); "
                     "phi0 = L_f^n h evaluated at x = Phi^-1(xi)")
    else:
        lines += ["Phi^-1(xi):"] + [f"  {s} = {_readable(v).xreplace(xi_names)}"
                                    for s, v in zip(model.states, branch, strict=True)]
        lines.append(f"phi0(xi, u) = {_readable(obs.phi0(branch)).xreplace(xi_names)}")
    return "\n".join(lines)


def _readable(expr: sp.Expr) -> sp.Expr:
    """``expr`` simplified when it is small enough to simplify quickly."""
    return sp.simplify(expr) if sp.count_ops(expr) < 150 else expr
