"""The model functions the observers of :mod:`hgo.observers.symbolic_hgo` call, generated
from a plant's equations and its observability map (:mod:`hgo.plants.observability`).

Every function reads the plant's parameters from the observer's record under the prefix
``plant_`` (``a = _p.plant_a``: an observer's own names, ``eps``, ``n``, ``K``, never clash
with a plant's), and they are written as numba source into the kernel cache like the
plant's own (:mod:`hgo.plants.symbolic_source`):

* ``model_f(t, x, u, p, dx)``: dx = f(x, u); ``model_h0(x, p)``: h_0(x);
* ``phi_map(x, p, xi)``: xi = Phi(x); ``phi_jac(x, p, J)``: J = dPhi/dx;
* ``lie_n(x, u, p)``: L_f^n h(x, u);
* with a symbolic inverse: ``phi_inverse(xi, p, x)``: x = Phi^-1(xi), and
  ``phi0_xi(xi, u, p)``: phi0(xi, u) = L_f^n h(Phi^-1(xi), u).
"""

from __future__ import annotations

import functools
from types import ModuleType

import sympy as sp

from hgo.plants import symbolic_source as source
from hgo.plants.observability import Observability

PREFIX = "plant_"


def param_binds(params: tuple[str, ...]) -> tuple[tuple[str, str], ...]:
    """``a = _p.plant_a`` for each plant parameter."""
    return tuple((name, f"_p.{PREFIX}{name}") for name in params)


@functools.cache
def observer_functions(obs: Observability, branch: tuple[sp.Expr, ...] | None) -> ModuleType:
    """The generated module of the functions of the module doc (``branch``: the inverse
    chosen, or None: no ``phi_inverse``/``phi0_xi``)."""
    model, n = obs.model, obs.n
    xs = source.array_binds("_x", model.states)
    us = source.array_binds("_u", model.inputs)
    ps = param_binds(model.params)
    xis = tuple((s.name, f"_xi[{i}]") for i, s in enumerate(obs.xi))
    F = source.Function
    functions = [
        F("model_f", ("_t", "_x", "_u", "_p", "_dx"), xs + us + ps,
          tuple(f"_dx[{i}]" for i in range(n)), model.f, "dx = f(x, u)"),
        F("model_h0", ("_x", "_p"), xs + ps, ("return",), (model.h[0],), "h_0(x)"),
        F("phi_map", ("_x", "_p", "_xi"), xs + ps, tuple(f"_xi[{i}]" for i in range(n)),
          obs.phi, "xi = Phi(x) = (h, L_f h, ..., L_f^(n-1) h)"),
        F("phi_jac", ("_x", "_p", "_J"), xs + ps,
          tuple(f"_J[{i}, {j}]" for i in range(n) for j in range(n)), tuple(obs.dphi),
          "J = dPhi/dx"),
        F("lie_n", ("_x", "_u", "_p"), xs + us + ps, ("return",), (obs.lie_n,),
          "L_f^n h(x, u)"),
    ]
    if branch is not None:
        functions += [
            F("phi_inverse", ("_xi", "_p", "_x"), xis + ps,
              tuple(f"_x[{i}]" for i in range(n)), branch, "x = Phi^-1(xi)"),
            F("phi0_xi", ("_xi", "_u", "_p"), xis + us + ps, ("return",), (obs.phi0(branch),),
              "phi0(xi, u) = L_f^n h(Phi^-1(xi), u)"),
        ]
    return source.load(functions, f"The observers' model of {model.name}")
