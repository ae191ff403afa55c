"""A plant given by its equations (issue 42): ``plant=symbolic``.

    x' = f(x, u),   y = h(x)   (+ noise),

written in a config as text over declared names (the states, the inputs, the parameters):

    states: [x1, x2]
    inputs: []
    params: {a: 1.0, b: 0.5, c: 0.5, d: 1.0}
    f: {x1: a*x1 - b*x1*x2, x2: c*x1*x2 - d*x2}
    h: {y: x1}
    x0: [2.0, 1.0]

or in Python (``model: {_target_: mymodule.model, _partial_: true}``, for larger models):
a function returning a mapping with the same keys, whose ``f`` and ``h`` are SymPy
expressions (or text); ``params`` and ``x0`` given in the config then replace the model's
values. The text is read without ``eval`` (:mod:`hgo.plants.symbolic_text`); the plant's
functions ``f``, ``h``, ``jac_f`` and ``jac_h`` are generated from the expressions as numba
source (:mod:`hgo.plants.symbolic_source`) reading the parameters by name (``p.a``), so
``plant.params.a=1,2`` sweeps them and the generated kernel is cached like any other.

The built plant is a :class:`SymbolicPlant`: a :class:`~hgo.core.components.Plant` that
also carries its :class:`SymbolicModel`, from which :mod:`hgo.plants.observability`
derives the observability map and the observers of :mod:`hgo.observers.symbolic_hgo`
their model. Time does not enter the equations (``t`` is reserved): inputs come from the
``controller`` group.

Example:
    ```python
    from hgo.plants.symbolic import symbolic_plant

    lv = symbolic_plant(states=["x1", "x2"], params={"a": 1.0, "b": 0.5, "c": 0.5, "d": 1.0},
                        f={"x1": "a*x1 - b*x1*x2", "x2": "c*x1*x2 - d*x2"},
                        h={"y": "x1"}, x0=[2.0, 1.0])
    print(lv.state_names, lv.output_names, lv.p.a)  # ['x1', 'x2'] ['y'] 1.0
    ```

    In a config: ``plant=symbolic`` with the same keys (``conf/plant/lotka_volterra.yaml``).
"""

from __future__ import annotations

import functools
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass

import numpy as np
import sympy as sp

from hgo.core.components import Params, Plant, user_function
from hgo.core.errors import ConfigError
from hgo.plants import symbolic_source as source
from hgo.plants.symbolic_text import check_name, checked, parse


@dataclass(frozen=True)
class SymbolicModel:
    """The equations of a plant: names and SymPy expressions (no values: one model serves
    every value of a sweep)."""

    name: str
    states: tuple[str, ...]
    inputs: tuple[str, ...]
    params: tuple[str, ...]
    outputs: tuple[str, ...]
    f: tuple[sp.Expr, ...]
    h: tuple[sp.Expr, ...]

    @property
    def symbols(self) -> dict[str, sp.Symbol]:
        """Declared name -> symbol, parameters first, then states and inputs."""
        return symbol_table(self.params, self.states, self.inputs)

    @property
    def x(self) -> list[sp.Symbol]:
        """The state symbols."""
        return [self.symbols[s] for s in self.states]

    @property
    def u(self) -> list[sp.Symbol]:
        """The input symbols."""
        return [self.symbols[s] for s in self.inputs]

    def jacobian_f(self) -> sp.Matrix:
        """df/dx (n x n)."""
        return sp.Matrix(self.f).jacobian(self.x)

    def jacobian_h(self) -> sp.Matrix:
        """dh/dx (ny x n)."""
        return sp.Matrix(self.h).jacobian(self.x)


@functools.cache
def symbol_table(params: tuple, states: tuple, inputs: tuple) -> dict[str, sp.Symbol]:
    """One real symbol per declared name (parameters, states, inputs: the order of the
    ``declared`` list of an error line)."""
    return {name: sp.Symbol(name, real=True) for name in (*params, *states, *inputs)}


@dataclass
class SymbolicPlant(Plant):
    """A plant with the equations it was generated from (``model``)."""

    model: SymbolicModel | None = None


@dataclass
class SymbolicSpec:
    """What a config or a Python model gives, before it is checked."""

    states: object
    inputs: object
    params: object
    f: object
    h: object
    x0: object


def _names(key: str, value: object, allow_empty: bool = False) -> tuple[str, ...]:
    if isinstance(value, str) or not isinstance(value, Sequence) or (
            not value and not allow_empty):
        raise ConfigError(key, f"must be a list of names, got {value!r}")
    names = tuple(check_name(f"{key}[{i}]", v) for i, v in enumerate(value))
    if len(set(names)) != len(names):
        raise ConfigError(key, f"names repeat in {list(names)}")
    return names


def _mapping(key: str, value: object) -> Mapping:
    if not isinstance(value, Mapping):
        raise ConfigError(key, f"must be a mapping name -> expression, got {value!r}")
    return value


def _param_values(params: object) -> dict[str, float]:
    params = _mapping("plant.params", params or {})
    values = {}
    for name, value in params.items():
        check_name(f"plant.params.{name}", name)
        if isinstance(value, bool) or not isinstance(value, (int, float)) or not np.isfinite(
                value):
            raise ConfigError(f"plant.params.{name}", f"must be a finite number, got {value!r}")
        values[name] = float(value)
    return values


def _expressions(key: str, given: object, wanted: Sequence[str] | None,
                 symbols: dict[str, sp.Symbol]) -> tuple[tuple[str, ...], tuple[sp.Expr, ...]]:
    """Names and expressions of ``given`` (name -> text or SymPy expression); ``wanted``:
    the names it must have, in that order (None: any names, at least one)."""
    given = _mapping(key, given)
    names = tuple(given) if wanted is None else tuple(wanted)
    if wanted is not None and set(given) != set(wanted):
        missing, extra = sorted(set(wanted) - set(given)), sorted(set(given) - set(wanted))
        raise ConfigError(key, f"needs one expression per state: missing {missing}, "
                          f"unknown {extra}", ", ".join(wanted))
    if not names:
        raise ConfigError(key, "needs at least one output (name -> expression)")
    for name in names:
        check_name(f"{key}.{name}", name)
    exprs = tuple(parse(f"{key}.{n}", given[n], symbols) if isinstance(given[n], str | int | float)
                  else checked(f"{key}.{n}", given[n], symbols) for n in names)
    return names, exprs


def model_from(spec: SymbolicSpec, name: str) -> tuple[SymbolicModel, dict[str, float],
                                                       np.ndarray]:
    """The checked model, parameter values and x0 of ``spec`` (ConfigError naming the key)."""
    states = _names("plant.states", spec.states)
    inputs = _names("plant.inputs", spec.inputs or [], allow_empty=True)
    values = _param_values(spec.params)
    clash = sorted((set(states) & set(inputs)) | (set(values) & (set(states) | set(inputs))))
    if clash:
        raise ConfigError("plant", f"'{clash[0]}' is declared twice (states, inputs and "
                          "params need distinct names)")
    for p in values:
        try:
            Params(**{p: 0.0})
        except ValueError as err:
            raise ConfigError(f"plant.params.{p}", str(err)) from None
    symbols = symbol_table(tuple(values), states, inputs)
    _, f = _expressions("plant.f", spec.f, states, symbols)
    outputs, h = _expressions("plant.h", spec.h, None, symbols)
    x0 = _initial_state(spec.x0, states)
    return SymbolicModel(name, states, inputs, tuple(values), outputs, f, h), values, x0


def _initial_state(x0: object, states: Sequence[str]) -> np.ndarray:
    if isinstance(x0, Mapping):
        if set(x0) != set(states):
            raise ConfigError("plant.x0", f"needs a value per state, got {sorted(x0)}",
                              ", ".join(states))
        x0 = [x0[s] for s in states]
    try:
        arr = np.asarray(x0, float).reshape(-1)
    except (TypeError, ValueError):
        arr = np.full(0, np.nan)
    if arr.shape != (len(states),) or not np.all(np.isfinite(arr)):
        raise ConfigError("plant.x0", f"must be {len(states)} finite numbers (one per state "
                          f"{', '.join(states)}), got {x0!r}")
    return arr


@functools.cache
def plant_functions(model: SymbolicModel):
    """The generated module of ``model``'s ``f``, ``h``, ``jac_f``, ``jac_h`` (once per
    process and model)."""
    n, ny = len(model.states), len(model.outputs)
    state_binds = source.array_binds("_x", model.states)
    input_binds = source.array_binds("_u", model.inputs)
    params = source.record_binds("_p", model.params)
    jf, jh = model.jacobian_f(), model.jacobian_h()
    functions = [
        source.Function("f", ("_t", "_x", "_u", "_p", "_dx"), state_binds + input_binds + params,
                        tuple(f"_dx[{i}]" for i in range(n)), model.f,
                        "dx/dt = f(x, u)"),
        source.Function("h", ("_t", "_x", "_p", "_y"), state_binds + params,
                        tuple(f"_y[{k}]" for k in range(ny)), model.h,
                        "y = h(x) (before noise)"),
        source.Function("jac_f", ("_t", "_x", "_u", "_p", "_J"),
                        state_binds + input_binds + params,
                        tuple(f"_J[{i}, {j}]" for i in range(n) for j in range(n)),
                        tuple(jf), "J[i, j] = df_i/dx_j"),
        source.Function("jac_h", ("_t", "_x", "_p", "_C"), state_binds + params,
                        tuple(f"_C[{k}, {j}]" for k in range(ny) for j in range(n)),
                        tuple(jh), "C[k, j] = dh_k/dx_j"),
    ]
    return source.load(functions, f"The plant {model.name}: {', '.join(model.states)}")


def output_state(model: SymbolicModel) -> int:
    """The state y[0] reads when h_0 is a state (else the first state h_0 depends on, or
    0): the output-error metric compares that state's estimate with y."""
    h0, x = model.h[0], model.x
    if h0 in x:
        return x.index(h0)
    return next((i for i, s in enumerate(x) if h0.has(s)), 0)


def symbolic_plant(states: Sequence[str] | None = None, f: Mapping | None = None,
                   h: Mapping | None = None, x0: Sequence[float] | Mapping | None = None,
                   inputs: Sequence[str] = (), params: Mapping | None = None,
                   name: str = "symbolic", model: Callable | None = None) -> SymbolicPlant:
    """The plant of the module doc, from its equations as text, or from ``model`` (a
    function returning them; ``params``/``x0`` given here replace its values)."""
    spec = SymbolicSpec(states, inputs, params, f, h, x0)
    if model is not None:
        spec = _from_python(user_function("plant.model", model), spec)
    for key in ("states", "f", "h", "x0"):
        if getattr(spec, key) in (None, "???"):  # (a config's mandatory value, unfilled)
            raise ConfigError(f"plant.{key}", "is missing (plant=symbolic needs states, f, h "
                              "and x0; inputs and params are optional)")
    sym, values, x0_arr = model_from(spec, str(name))
    fns = plant_functions(sym)
    return SymbolicPlant(name=str(name), state_names=list(sym.states),
                         output_names=list(sym.outputs), input_names=list(sym.inputs),
                         x0=x0_arr, p=Params(**values), f=fns.f, h=fns.h,
                         output_state=output_state(sym), jac_f=fns.jac_f, jac_h=fns.jac_h,
                         model=sym)


def _from_python(model: Callable, given: SymbolicSpec) -> SymbolicSpec:
    """The spec a Python model returns; ``params`` and ``x0`` of the config replace its
    values (a parameter must be one the model declares); its equations are its own."""
    out = model()
    if not isinstance(out, Mapping):
        raise ConfigError("plant.model", f"must return a mapping with states, inputs, params, "
                          f"f, h and x0, got {type(out).__name__}")
    unknown = sorted(set(out) - {"states", "inputs", "params", "f", "h", "x0"})
    if unknown:
        raise ConfigError("plant.model", f"returned unknown key '{unknown[0]}'",
                          "states, inputs, params, f, h, x0")
    for key in ("states", "inputs", "f", "h"):
        if getattr(given, key) not in (None, (), []):
            raise ConfigError(f"plant.{key}", "is given by plant.model; give either the "
                              "model or the equations")
    params = dict(out.get("params") or {})
    for key, value in dict(given.params or {}).items():
        if key not in params:
            raise ConfigError(f"plant.params.{key}", "is not a parameter of plant.model",
                              ", ".join(params) or None)
        params[key] = value
    return SymbolicSpec(out.get("states"), out.get("inputs") or [], params, out.get("f"),
                        out.get("h"), given.x0 if given.x0 is not None else out.get("x0"))
