"""Building blocks of an experiment: plant, observer, controller.

Each component is a small Python object that carries its parameters (a float64
vector ``p``), its initial state and the *names* of its signals, plus plain Python
functions written in the numba-compatible subset (scalar arithmetic, loops, numpy
indexing). The engine (:mod:`hgo.engine`) composes these functions into one
compiled vector field; a component whose functions numba cannot compile still runs,
on a slower pure-Python path (the engine warns once and says why).

Parameters by name (issue 24). A component declares its parameters once, as a
:class:`Params`: run-time values (scalars and fixed-shape float arrays, e.g. ``eps``,
``A`` (n x n), ``L`` (n)) and compile-time constants (dimensions, which law, which model:
ints, floats, bools, tuples of numbers, or functions). Its functions then receive ``p`` as
a record and read ``p.eps``, ``p.A[i, j]``, ``p.n``: the generated kernel builds that
record from the flat parameter vector with constant offsets and shapes, and writes the
constants into its text as literals, so loops over ``range(p.n)`` have fixed trip counts
and a branch on ``p.law`` is decided when the kernel compiles. Values that a sweep or an
ensemble varies stay in the flat vector (``component.p``, addressed by name through
:meth:`Params.index`); a component built with a plain array ``p`` still gets the
positional view (the form of earlier versions).

Function signatures (arrays are float64, outputs are written in place):

* Plant   ``f(t, x, u, p, dx)``; ``h(t, x, p, y)`` — measured outputs before noise.
* Observer ``f(t, z, d, y, u, p, dz)`` — continuous dynamics of the observer state z;
  ``update(t, z, d, y, u, p)`` — discrete logic (gain switches, timers, saturation),
  applied between integration steps, may modify z and d;
  ``estimate(t, z, d, p, xhat)`` — the estimate of the plant states listed in
  ``estimated_states``; optional ``stiffness(t, z, d, p) -> float`` — the spectral radius
  of the active dynamics (bounds the RK4 step; default: the constant ``spectral_radius``).
* Controller ``u(t, xhat, y, p, u)`` — input computed from one observer's estimate.
* Observer: ``sample_period`` > 0 — its measurement instants k * sample_period are break
  points too (its ``update`` then runs exactly there, after the step that ends there).
* Plant and controller: optional ``breaks(p) -> sequence of float`` — the instants where
  the component's time dependence jumps (an input schedule's switches, a ramp's corners),
  from its own parameters. The engine ends a step exactly at each one, evaluates the step
  that ends there with the values just before it (left limit) and the rest after it
  (right-continuous), as at noise samples (:mod:`hgo.engine.kernel_template`).

Indices a component reads (``reads_outputs``, ``reads_inputs``, ``reads_estimate``) are
declared, and :class:`hgo.engine.system.System` checks them against the plant when it is
composed: compiled code has no bounds checks.

Why discrete updates between steps: hybrid logic (noise samples, gain switches,
timers, saturations) then never makes a step straddle a discontinuity, and the
vector fields stay smooth and compilable.
"""

from __future__ import annotations

import functools
import itertools
import math
import numbers
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field

import numpy as np

from hgo.core.errors import ConfigError
from hgo.core.records import record_class

Constant = int | float | bool | tuple | Callable
"""A compile-time constant of a component: a number, a flag, a tuple of numbers (e.g.
the output of each block), or a function the component calls (a user's phi)."""


class Params:
    """Named parameters of a component: ``Params(constants, **values)``.

    A component's functions read ``p.eps``, ``p.A[i, j]``, ``p.n``: the kernel builds that
    record from the flat vector with constant offsets and shapes.

    Args:
        constants: name -> compile-time constant (int, float, bool, tuple of numbers, or a
            function the component calls): written into the kernel's text as literals, so
            ``range(p.n)`` has a fixed trip count and a branch on a flag is decided at
            compile time. A change compiles a new kernel.
        **values: name -> float or float array of fixed shape: run-time values, the flat
            vector :attr:`vector` (declaration order, arrays row-major) that sweeps and
            ensembles vary without compiling again.

    A name is either a value or a constant, never both, and never an attribute of numpy
    arrays (``mean``, ``T``, ``size``: the vector answers to the names too) nor private.

    Example:
        ```python
        import numpy as np
        from hgo.core.components import Params

        p = Params({"n": 2}, eps=0.01, A=np.eye(2))
        print(p.names, p.shapes, p.index("A"))  # ('eps', 'A') ((), (2, 2)) slice(1, 5, None)
        print(p.vector.eps, p.vector.n, p.vector.A[1, 1])  # 0.01 2 1.0
        ```
    """

    __slots__ = ("constants", "names", "offsets", "shapes", "vector")

    def __init__(self, constants: Mapping[str, Constant] | None = None, /,
                 **values: float | np.ndarray) -> None:
        self.constants = {k: _constant(k, v) for k, v in (constants or {}).items()}
        for name in [*self.constants, *values]:
            _check_name(name)
        both = set(self.constants) & set(values)
        if both:
            raise ValueError(f"parameters {sorted(both)} are given both as run-time values "
                             "and as compile-time constants (one name, one parameter)")
        arrays = [np.asarray(v, float) for v in values.values()]
        self.names = tuple(values)
        self.shapes = tuple(a.shape for a in arrays)
        ends = list(itertools.accumulate((a.size for a in arrays), initial=0))
        self.offsets = tuple(ends[:-1])
        flat = np.concatenate([a.ravel() for a in arrays]) if arrays else np.zeros(0)
        self.vector = flat.view(ParamVector)
        self.vector.spec = self

    def index(self, name: str) -> slice | int:
        """Where value ``name`` lies in the flat vector: an int for a scalar, else a slice."""
        k = self.names.index(name)
        if not self.shapes[k]:
            return self.offsets[k]
        return slice(self.offsets[k], self.offsets[k] + math.prod(self.shapes[k]))

    def layout(self) -> tuple:
        """What the generated kernel depends on: names, shapes and constants (hashable)."""
        return (tuple(zip(self.names, self.shapes, strict=True)),
                tuple(sorted(self.constants.items(), key=lambda kv: kv[0])))

    def get(self, vector: np.ndarray, name: str):
        """Parameter ``name`` read from ``vector``: a float, a view of the array's
        entries, or the constant."""
        if name == "scratch":  # scratch space of that many floats (the kernel's is on the stack)
            return np.empty(self.constants[name])
        if name in self.constants:
            return self.constants[name]
        k = self.names.index(name)
        o, shape = self.offsets[k], self.shapes[k]
        if not shape:
            return float(vector[o])
        return np.asarray(vector)[o:o + math.prod(shape)].reshape(shape)

    def record(self, vector: np.ndarray):
        """All parameters read from ``vector`` once, as a namedtuple (fast attribute
        access for plain-Python loops; the kernel builds the same record)."""
        names = (*self.names, *self.constants)
        return record_class(names)(*(self.get(vector, k) for k in names))

    def __repr__(self) -> str:
        shapes = ", ".join(f"{n}{list(s) if s else ''}" for n, s in
                           zip(self.names, self.shapes, strict=True))
        return f"Params({self.constants}, {shapes})"


class ParamVector(np.ndarray):
    """The flat parameter vector of a component that also answers to the names of its
    :class:`Params` (``p.eps``, ``p.A[i, j]``, ``p.n``), so a component function called
    from plain Python with ``component.p`` reads what the kernel's record gives it.
    Slices and results of arithmetic are plain arrays (no names)."""

    spec: Params | None = None

    def __array_finalize__(self, obj) -> None:
        self.spec = None  # a view or a result is not the component's vector

    def __getattr__(self, name: str):
        spec = self.__dict__.get("spec")
        if spec is None or (name not in spec.constants and name not in spec.names):
            raise AttributeError(name)
        return spec.get(self, name)

    def record(self):
        """Every named parameter read once (:meth:`Params.record`)."""
        return self.spec.record(self)

    def __reduce__(self):  # pickled (sent to a process) as a plain vector + its names
        return (_param_vector, (np.asarray(self), self.spec))


def _param_vector(values: np.ndarray, spec: Params | None) -> ParamVector:
    vec = np.asarray(values, float).view(ParamVector)
    vec.spec = spec
    return vec


def named(component, values: np.ndarray):
    """``values`` (a member's slice of the flat vector, say) answering to the names of
    ``component``'s parameters; as they are for a positional component."""
    spec = component.params
    return values if spec is None else _param_vector(values, spec)


@functools.cache
def _check_name(name: str) -> None:
    """ValueError unless ``name`` can name a parameter (cached: a component is built per
    member of an ensemble, with the same names)."""
    if hasattr(np.ndarray, name) or name.startswith("_"):
        raise ValueError(f"parameter name '{name}' is taken by numpy arrays (or private); "
                         "choose another")


def _constant(name: str, value) -> Constant:
    """A constant as the kernel text writes it: numbers, bools, tuples of numbers (from
    lists and arrays), or a callable."""
    if type(value) in (bool, int, float):  # the common case, before the abstract checks
        return value
    if isinstance(value, (bool, np.bool_)):
        return bool(value)
    if isinstance(value, numbers.Integral):
        return int(value)
    if isinstance(value, numbers.Real):
        return float(value)
    if callable(value):
        return value
    if isinstance(value, (list, tuple, np.ndarray)):
        items = np.asarray(value).ravel().tolist()
        if all(isinstance(v, (int, float, bool)) for v in items):
            return tuple(items)
    raise ValueError(f"constant {name}: {value!r} is not a number, flag, tuple of numbers "
                     "or function")


def model_values(key: str, model_params: Mapping | None, own: Mapping[str, str]) -> dict:
    """The named run-time values a user's model reads (``p.mu``), given as ``model_params``
    of the component at config key ``key``, checked against the component's own parameter
    names ``own`` (name -> what it is): the model and the component share one record ``p``,
    so a clash is refused in one line naming both keys and every reserved name (a name of
    numpy arrays' attributes, ``mean`` or ``T``, is refused the same way)."""
    given = dict(model_params or {})
    allowed = "any name but " + ", ".join(sorted(own)) + " and numpy arrays' attributes"
    for name in given:
        if name in own:
            raise ConfigError(f"{key}.model_params.{name}", f"'{name}' is the component's "
                              f"own parameter ({key} -> p.{name}: {own[name]}); rename the "
                              f"model's, e.g. {name}_m", allowed)
        if hasattr(np.ndarray, name) or name.startswith("_"):
            raise ConfigError(f"{key}.model_params.{name}", f"'{name}' is an attribute of "
                              f"numpy arrays (p.{name} would be ambiguous); rename it, e.g. "
                              f"{name}_m", allowed)
    return given


def user_function(key: str, value: object) -> Callable:
    """A user's function given for config key ``key``: a callable, or what Hydra makes
    of ``{_target_: module.function, _partial_: true}`` (a partial without arguments).
    Raises ValueError naming the key otherwise."""
    if isinstance(value, functools.partial) and not value.args and not value.keywords:
        value = value.func
    if not callable(value):
        raise ValueError(f"{key} must be a function (or {{_target_: module.function, "
                         f"_partial_: true}}), got {value!r}")
    return value


class Named:
    """Shared by the components: ``p`` given as :class:`Params` becomes its vector."""

    def __post_init__(self) -> None:
        if isinstance(self.p, Params):
            self.p = self.p.vector
        elif not isinstance(self.p, ParamVector):
            self.p = np.asarray(self.p, float)

    @property
    def params(self) -> Params | None:
        """The names behind ``p`` (None: a positional component)."""
        return getattr(self.p, "spec", None)


def no_update(t, z, d, y, u, p):  # noqa: ARG001 - fixed signature
    """Observer without discrete logic."""
    return


@dataclass
class Plant(Named):
    r"""A plant $\dot x = f(t, x, u)$, $y = h(t, x)$ (the engine adds the noise to $y$).

    The functions are compiled by numba into one kernel with the observers: they use the
    numba subset (scalar arithmetic, loops, indexing), write their outputs in place, and
    every function they call must itself compile (a helper decorated with
    ``numba.njit``). A plant whose functions do not compile still runs on a slow
    pure-Python path, with a warning naming the function and numba's first error line.

    Attributes:
        name: the plant's name (``/plant/...`` in the recording).
        state_names: names of $x$ ($n_x$); recorded as ``/plant/x/<name>``.
        output_names: names of the measured channels $y$ ($n_y$).
        input_names: names of the inputs $u$ ($n_u$, may be empty).
        x0: $x(0)$, shape $(n_x,)$.
        p: the parameters: a :class:`Params` (read by name, ``p.mu``) or a float array.
        f: ``f(t, x, u, p, dx)`` writes $\dot x$ into ``dx`` ($n_x$).
        h: ``h(t, x, p, y)`` writes the noise-free outputs into ``y`` ($n_y$).
        output_state: the state that channel 0 measures: it defines $\hat y$ of the
            output-error metric (Sanfelice & Praly (11)). Default 0.
        spectral_radius: a bound on $|\lambda(\partial f/\partial x)|$ (1/s): caps the
            fixed RK4 step. Default 0 (no cap).
        breaks: optional ``breaks(p) -> sequence of float``: instants (s) where ``f`` or
            ``h`` jump in $t$; a step ends exactly there.
        jac_f: optional ``jac_f(t, x, u, p, J)``: ``J[i, j]`` $= \partial f_i/\partial x_j$
            ($n_x \times n_x$), for observers built from the plant (Kalman filters).
        jac_h: optional ``jac_h(t, x, p, C)``: ``C[k, j]`` $= \partial h_k/\partial x_j$
            ($n_y \times n_x$).

    Example:
        ```python
        from hgo.core.components import Params, Plant

        def f(t, x, u, p, dx):  # Duffing: x1' = x2, x2' = -d x2 - a x1 - b x1^3 + u
            dx[0] = x[1]
            dx[1] = -p.d * x[1] - p.a * x[0] - p.b * x[0] ** 3 + u[0]

        def h(t, x, p, y):
            y[0] = x[0]

        plant = Plant(name="duffing", state_names=["x1", "x2"], output_names=["y"],
                      input_names=["u"], x0=[1.0, 0.0], p=Params(d=0.2, a=1.0, b=1.0),
                      f=f, h=h)
        print(plant.nx, plant.p.b, plant.params.names)  # 2 1.0 ('d', 'a', 'b')
        ```
    """

    name: str
    state_names: list[str]
    output_names: list[str]
    input_names: list[str]
    x0: np.ndarray
    p: np.ndarray
    f: object
    h: object
    output_state: int = 0
    spectral_radius: float = 0.0  # of df/dx, bounds the explicit step (RK4 stability)
    breaks: object = None  # optional ``breaks(p)``: instants where f or h jump in t
    jac_f: object = None  # optional ``jac_f(t, x, u, p, J)``: J[i, j] = df_i/dx_j (nx x nx)
    jac_h: object = None  # optional ``jac_h(t, x, p, C)``: C[k, j] = dh_k/dx_j (ny x nx)

    @property
    def nx(self) -> int:
        return len(self.state_names)


@dataclass
class Observer(Named):
    r"""An observer with continuous state $z$, discrete state $d$ and parameters $p$.

    $\dot z = f(t, z, d, y, u)$ between steps; ``update`` may change $z$ and $d$ between
    steps (gain switches, timers, saturations: hybrid logic never makes a step straddle a
    jump); ``estimate`` gives $\hat x$ of the plant states ``estimated_states``. The
    functions are compiled with the plant (numba's subset; helpers they call must be
    ``numba.njit``-compiled).

    Attributes:
        name: the observer's name (``/observer/<name>/...`` in the recording).
        state_names: names of $z$ ($n_z$).
        disc_names: names of $d$, the discrete state ``update`` writes (may be empty).
        estimated_states: the plant state indices ``estimate`` writes, in order.
        z0: $z(0)$, shape $(n_z,)$.
        d0: $d(0)$, shape ``(len(disc_names),)``.
        p: the parameters (:class:`Params`, read by name, or a float array).
        f: ``f(t, z, d, y, u, p, dz)`` writes $\dot z$ into ``dz``.
        estimate: ``estimate(t, z, d, p, xhat)`` writes $\hat x$
            (``len(estimated_states)``).
        update: ``update(t, z, d, y, u, p)``, the discrete logic (default: none).
        spectral_radius: the largest $|\lambda|$ of the stiffest linear part (1/s): caps
            the fixed RK4 step (a high-gain observer's is about $1/\varepsilon$).
        stiffness: optional ``stiffness(t, z, d, p) -> float``, the spectral radius now
            (a switched gain); replaces the constant cap.
        signals: extra recorded signals, name -> state columns (``{"L": [2]}``).
        bounds: theoretical bounds of metrics, quantity -> value
            (``{"mean_sq_output_error": p2}``).
        reads_outputs: the measured channels ``f``/``update`` read (default ``[0]``).
        reads_inputs: the plant inputs they read (default none).

    The generic observers (:mod:`hgo.observers.normal_form`,
    :mod:`hgo.observers.circle_criterion`) are built by factories; see the observers'
    reference page.
    """

    name: str
    state_names: list[str]
    disc_names: list[str]
    estimated_states: list[int]  # plant state indices estimated by ``estimate``
    z0: np.ndarray
    d0: np.ndarray
    p: np.ndarray
    f: object
    estimate: object
    update: object = no_update
    spectral_radius: float = 0.0  # largest |eigenvalue| of the stiffest linear part
    # optional ``stiffness(t, z, d, p) -> float``: the spectral radius *now* (e.g. of the
    # active gain of a switched observer); when given, RK4 caps each substep with it
    # instead of the constant ``spectral_radius`` (which must then bound every mode)
    stiffness: object = None
    # extra names -> state columns, for logging (e.g. {"r": [2]})
    signals: dict[str, list[int]] = field(default_factory=dict)
    # theoretical bounds on metrics, quantity -> value (e.g. Sanfelice & Praly (11):
    # {"mean_sq_output_error": p2}); a missing quantity has no bound from the papers
    bounds: dict[str, float] = field(default_factory=dict)
    # measured channels y[i] and plant inputs u[j] that f / update read: checked against
    # the plant when the system is composed (compiled code never reads past an array)
    reads_outputs: list[int] = field(default_factory=lambda: [0])
    reads_inputs: list[int] = field(default_factory=list)
    # > 0: a sampled observer (e.g. a continuous-discrete Kalman filter): the engine ends a
    # step at every k * sample_period in (0, t_end), so ``update`` runs at each instant
    sample_period: float = 0.0
    # optional ``explain(d) -> str``: why a run stopped, read from this observer's discrete
    # state at the stop ("" if not its doing), e.g. a Kalman filter's covariance no longer
    # positive definite; appended to the run's one-line status
    explain: object = None

    @property
    def nz(self) -> int:
        return len(self.state_names)


@dataclass
class Controller(Named):
    r"""Output feedback $u = k(t, \hat x, y)$ from the estimate of observer ``observer``.

    Attributes:
        name: the controller's name.
        p: its parameters (:class:`Params` or a float array).
        u: ``u(t, xhat, y, p, u)`` writes every plant input into ``u`` ($n_u$).
        observer: the observer whose $\hat x$ it reads (``None``: open loop).
        reads_outputs: the measured channels ``u`` reads.
        reads_estimate: the entries of $\hat x$ it reads.
        breaks: optional ``breaks(p)``: instants (s) where ``u`` jumps or has a corner.
    """

    name: str
    p: np.ndarray
    u: object
    observer: str | None = None
    # measured channels y[i] and entries xhat[j] of its observer's estimate that ``u`` reads
    # (checked against the plant and the observer when the system is composed); ``u``
    # writes the plant's inputs, so the plant must have at least one
    reads_outputs: list[int] = field(default_factory=list)
    reads_estimate: list[int] = field(default_factory=list)
    # optional ``breaks(p)``: instants where ``u`` jumps in t (or its slope has a corner)
    breaks: object = None
