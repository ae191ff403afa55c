"""A user's component functions called once in plain Python before they are compiled.

Compiled code has no bounds checks: a plant ``f`` reading ``x[7]`` of a 2-state plant,
writing ``dx[2]``, an ``h`` that never writes a declared output or an ``f`` returning a new
array instead of filling ``dx`` ran to exit 0 with wrong metrics. :func:`check_user_code`
calls every function of each component that holds a user's code (a function, or a
function constant such as a ``phi0``, from outside hgo) once, in plain Python (a numba
dispatcher's ``py_func``), on arrays of the exact sizes the kernel gives it:

* the arguments it reads hold the initial values (``x0``, ``z0``, ``d0``, ``y = h(x0)``,
  ``u = 0``, the estimate of ``x0``), so a function that divides by a state or reads only
  some states behaves as it will in the run;
* the arrays it must fill (``dx``, ``y``, ``dz``, ``xhat``, ``u``) hold NaN sentinels;
* every argument array raises on an index out of range (:class:`Guarded`).

An index out of range, an output left unwritten or an array returned instead of written
becomes one line naming the component, the function, the index and the names there
(``plant.f reads x[7]; vdp has 2 states (x1, x2) (vdp.py:8)``). Any other exception of
the call (a function that only numba can run, a division by zero at the initial state)
is left to the run: the check reports only what it is sure of. Each distinct layout of
functions and sizes is checked once a process (an ensemble's members share theirs).
"""

from __future__ import annotations

import functools
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from hgo.core.components import Controller, Observer, Plant, no_update
from hgo.core.errors import UserCodeError
from hgo.core.targets import code_error
from hgo.engine.system import System


@dataclass(frozen=True)
class Arg:
    """An argument array of a component function: its name and what its entries are."""

    name: str
    what: str  # "vdp has 2 states (x1, x2)"


class OutOfRange(IndexError):
    """A guarded argument indexed outside its size."""

    def __init__(self, arg: Arg, key: object, verb: str) -> None:
        super().__init__(f"{verb} {arg.name}[{_index_text(key)}]; {arg.what}")


def _index_text(key: object) -> str:
    if isinstance(key, tuple):
        return ", ".join(_index_text(k) for k in key)
    if isinstance(key, slice):
        return f"{'' if key.start is None else key.start}:{'' if key.stop is None else key.stop}"
    return str(key)


class Guarded(np.ndarray):
    """An argument array that raises :class:`OutOfRange` naming itself when indexed out of
    range, and records the entries written through indexing. Views of it and results of
    arithmetic are plain arrays."""

    arg: Arg | None = None
    written: np.ndarray | None = None

    @classmethod
    def of(cls, values, arg: Arg) -> Guarded:
        out = np.array(values, dtype=float).view(cls)
        out.arg, out.written = arg, np.zeros(out.shape, bool)
        return out

    def __array_finalize__(self, obj) -> None:
        self.arg = self.written = None

    def __getitem__(self, key):
        try:
            value = super().__getitem__(key)
        except IndexError:
            if self.arg is None:
                raise
            raise OutOfRange(self.arg, key, "reads") from None
        return value.view(np.ndarray) if isinstance(value, Guarded) else value

    def __setitem__(self, key, value) -> None:
        try:
            super().__setitem__(key, value)
        except IndexError:
            if self.arg is None:
                raise
            raise OutOfRange(self.arg, key, "writes") from None
        if self.written is not None:
            self.written[key] = True


def _plural(n: int, word: str) -> str:
    return f"{n} {word}{'' if n == 1 else 's'}"


def _described(n_of: str, names: list[str], owner: str) -> str:
    listed = f" ({', '.join(names)})" if names else ""
    return f"{owner} has {_plural(len(names), n_of)}{listed}"


def _py(fn: object) -> object:
    """The plain-Python function behind a numba dispatcher (or ``fn`` itself)."""
    return getattr(fn, "py_func", fn)


def _is_user(fn: object) -> bool:
    """Whether ``fn`` is a user's (not hgo's) function (cached: checked per member)."""
    try:
        return _is_user_cached(fn)
    except TypeError:  # an unhashable callable
        return _module_is_users(fn)


def _module_is_users(fn: object) -> bool:
    module = getattr(_py(fn), "__module__", None) or ""
    return callable(fn) and not (module == "hgo" or module.startswith("hgo."))


_is_user_cached = functools.cache(_module_is_users)


def _constants(comp) -> list:
    spec = comp.params
    return [] if spec is None else [v for v in spec.constants.values() if callable(v)]


_FUNCTIONS = {Plant: ("f", "h", "jac_f", "jac_h", "breaks"),
              Observer: ("f", "update", "estimate", "stiffness"),
              Controller: ("u", "breaks")}


def _functions(comp) -> list:
    names = _FUNCTIONS.get(type(comp)) or next(
        names for kind, names in _FUNCTIONS.items() if isinstance(comp, kind))
    return [getattr(comp, n, None) for n in names]


def has_user_code(comp) -> bool:
    """Whether a component's functions or function constants include a user's."""
    return any(_is_user(fn) for fn in [*_functions(comp), *_constants(comp)]
               if fn is not None and fn is not no_update)


def _params(comp, owner: str):
    """What the component's functions get as ``p``: its record (function constants as
    plain Python), or its positional vector, guarded."""
    spec = comp.params
    if spec is None:
        return Guarded.of(comp.p, Arg("p", f"{owner} has {_plural(len(comp.p), 'parameter')}"))
    record = spec.record(comp.p)
    return record._replace(**{k: _py(v) for k, v in spec.constants.items() if callable(v)})


class _Call:
    """Calls of one component's functions, reported under ``key`` (``plant``,
    ``observer.<name>``, ``controller``)."""

    def __init__(self, key: str) -> None:
        self.key = key

    def __call__(self, name: str, fn: object, *args, outputs: tuple = ()):
        """``fn(*args)``; raises :class:`UserCodeError` for an index out of range, an
        output not written, an array returned instead; None when the call raised
        anything else (left to the run)."""
        try:
            with np.errstate(all="ignore"):
                result = _py(fn)(*args)
        except IndexError as err:
            raise UserCodeError(self._line(name, err)) from None
        except KeyboardInterrupt:  # (a function that never returns: say which)
            raise KeyboardInterrupt(f"interrupted (Ctrl-C) while {self.key}.{name} was called "
                                    "once in plain Python, before compiling") from None
        except Exception:  # noqa: BLE001 - not the check's to judge (module doc)
            return None
        for out in outputs:
            missing = [i for i in range(out.size) if not out.written[i]
                       and np.isnan(np.asarray(out)[i])]
            if not missing:
                continue
            entries = ", ".join(f"{out.arg.name}[{i}]" for i in missing)
            if result is not None:
                raise UserCodeError(f"{self.key}.{name} returns {type(result).__name__} "
                                    f"instead of writing {out.arg.name} in place ({entries} "
                                    f"never written); {out.arg.what}{_where(fn)}")
            raise UserCodeError(f"{self.key}.{name} never writes {entries}; "
                                f"{out.arg.what}{_where(fn)}")
        return result

    def _line(self, name: str, err: IndexError) -> str:
        if isinstance(err, OutOfRange):
            text = code_error(err).partition(": ")[2]  # (without the type name)
            return f"{self.key}.{name} {text}"
        return f"{self.key}.{name}: {code_error(err)}"


def _where(fn: object) -> str:
    code = getattr(_py(fn), "__code__", None)
    return f" ({Path(code.co_filename).name}:{code.co_firstlineno})" if code else ""


def _nan(n: int, arg: Arg) -> Guarded:
    return Guarded.of(np.full(n, np.nan), arg)


@dataclass
class _Signals:
    """The plant's argument arrays (described) and its measurement at x0."""

    x: Arg
    y: Arg
    u: Arg
    y0: np.ndarray


def _signals(plant: Plant) -> _Signals:
    y0 = np.zeros(len(plant.output_names))
    try:  # y = h(x0) for the observers and the controller (zeros if h cannot run here)
        with np.errstate(all="ignore"):
            _py(plant.h)(0.0, np.array(plant.x0, float), _params(plant, plant.name), y0)
    except Exception:  # noqa: BLE001 - a plain guess of y is enough for the check
        y0[:] = 0.0
    return _Signals(Arg("x", _described("state", plant.state_names, plant.name)),
                    Arg("y", _described("output", plant.output_names, plant.name)),
                    Arg("u", _described("input", plant.input_names, plant.name)),
                    np.nan_to_num(y0))


def _check_plant(plant: Plant, s: _Signals) -> None:
    call, nx, ny = _Call("plant"), plant.nx, len(plant.output_names)
    p = _params(plant, plant.name)
    x = Guarded.of(plant.x0, s.x)
    u = Guarded.of(np.zeros(len(plant.input_names)), s.u)
    y = _nan(ny, s.y)
    call("h", plant.h, 0.0, x, p, y, outputs=(y,))
    dx = _nan(nx, Arg("dx", s.x.what))
    call("f", plant.f, 0.0, x, u, p, dx, outputs=(dx,))
    if plant.jac_f is not None:
        call("jac_f", plant.jac_f, 0.0, x, u, p,
             Guarded.of(np.zeros((nx, nx)), Arg("J", f"J is {nx} x {nx}; {s.x.what}")))
    if plant.jac_h is not None:
        call("jac_h", plant.jac_h, 0.0, x, p,
             Guarded.of(np.zeros((ny, nx)), Arg("C", f"C is {ny} x {nx}; {s.y.what}")))
    if plant.breaks is not None:
        call("breaks", plant.breaks, p)


def _estimate_arg(obs: Observer, plant: Plant) -> Arg:
    names = [plant.state_names[i] for i in obs.estimated_states]
    return Arg("xhat", f"observer {obs.name} estimates {_plural(len(names), 'state')} "
                       f"({', '.join(names)})")


def _check_observer(obs: Observer, plant: Plant, s: _Signals) -> None:
    call, owner = _Call(f"observer.{obs.name}"), f"observer {obs.name}"
    p = _params(obs, owner)
    z_arg = Arg("z", _described("state", obs.state_names, owner))
    d_arg = Arg("d", _described("discrete state", obs.disc_names, owner))
    y = Guarded.of(s.y0, s.y)
    u = Guarded.of(np.zeros(len(plant.input_names)), s.u)
    dz = _nan(obs.nz, Arg("dz", z_arg.what))
    call("f", obs.f, 0.0, Guarded.of(obs.z0, z_arg), Guarded.of(obs.d0, d_arg), y, u, p, dz,
         outputs=(dz,))
    if obs.update is not no_update:  # (on copies: it may change z and d)
        call("update", obs.update, 0.0, Guarded.of(obs.z0, z_arg), Guarded.of(obs.d0, d_arg),
             y, u, p)
    xhat = _nan(len(obs.estimated_states), _estimate_arg(obs, plant))
    call("estimate", obs.estimate, 0.0, Guarded.of(obs.z0, z_arg),
         Guarded.of(obs.d0, d_arg), p, xhat, outputs=(xhat,))
    if obs.stiffness is not None:
        call("stiffness", obs.stiffness, 0.0, Guarded.of(obs.z0, z_arg),
             Guarded.of(obs.d0, d_arg), p)


def _check_controller(system: System, s: _Signals) -> None:
    ctrl, plant = system.controller, system.plant
    obs = system.observers[system.controlled_observer()]
    call = _Call("controller")
    xhat = Guarded.of(np.asarray(plant.x0, float)[list(obs.estimated_states)],
                      _estimate_arg(obs, plant))
    u = _nan(len(plant.input_names), s.u)
    p = _params(ctrl, f"controller {ctrl.name}")
    call("u", ctrl.u, 0.0, xhat, Guarded.of(s.y0, s.y), p, u, outputs=(u,))
    if ctrl.breaks is not None:
        call("breaks", ctrl.breaks, p)


def _layout(comp) -> tuple:
    """What the check of a component depends on: its functions and sizes."""
    spec = comp.params
    sizes = tuple(-1 if getattr(comp, n, None) is None else len(getattr(comp, n))
                  for n in ("x0", "z0", "d0", "state_names", "output_names", "input_names",
                            "disc_names", "estimated_states"))
    return (type(comp), *_functions(comp), *_constants(comp), sizes,
            len(comp.p) if spec is None else spec.layout())


_CHECKED: set[tuple] = set()  # layouts already checked in this process


def check_user_code(system: System) -> None:
    """Call the functions of every component holding a user's code once (module doc);
    raises :class:`UserCodeError` (one line) for what compiled code would do silently."""
    comps = [system.plant, *system.observers, *([system.controller] if system.controller
                                                 else [])]
    if not any(has_user_code(c) for c in comps):
        return
    key = tuple(_layout(c) for c in comps)
    try:
        if key in _CHECKED:
            return
    except TypeError:  # an unhashable function constant: checked every time
        key = None
    s = _signals(system.plant)
    if has_user_code(system.plant):
        _check_plant(system.plant, s)
    for obs in system.observers:
        if has_user_code(obs):
            _check_observer(obs, system.plant, s)
    if system.controller is not None and has_user_code(system.controller):
        _check_controller(system, s)
    if key is not None:
        _CHECKED.add(key)
