"""The composition of a :class:`~hgo.engine.system.System` as module text: what is compiled per
experiment.

The module holds the composed functions the integrators call (``system_rhs``,
``system_update``, ``system_outputs``, ``system_stiffness`` and RK4's ``system_rk4``: the
components' functions on their slices of the flat vectors) and, for the compiled path,
their C entry points: ``c_system``, the first four in one function that a selector
``sel`` (:data:`SELECT`) picks from, and ``c_rk4``. They take the arrays' data pointers
(lengths are constants of the module), are compiled by :mod:`hgo.engine.codegen` as numba
``cfunc`` and handed to the integrator (:mod:`hgo.engine.kernel_template`) as function
pointers; ``system_call`` is ``c_system`` on arrays, for the pure-Python path. One entry
point instead of four: each ``cfunc`` is a numba compile and a cache entry of its own
(DHLM's three took 0.57-0.71 s to compile against 0.40-0.58 s as one, fresh processes
alternating). The integrator is compiled apart, once per method and layout.

A component with named parameters is called through a :class:`Bound` function that gets
the component's slice of the parameter vector ``P`` and builds its record there (values
at constant offsets into the slice, constants as literals). Its text depends on the
component alone, not on where the component sits in the composition, so it is compiled
once and cached with the components: the entry points only pass slices, which is what
keeps a new composition's compile short (issue 41).
"""

from __future__ import annotations

import dis
import math
import re
from dataclasses import dataclass

from hgo.core.components import no_update
from hgo.engine.system import System

ENTRY_POINTS = ("rhs", "update", "outputs", "stiffness", "rk4")
"""The composition's functions in the order of the integrator's ``S`` (``rk4``: for the RK4
integrator only). ``outputs`` also gives what the error metrics read (``with_u`` = 0: y
and x^ without the controller's input), one compile for both."""


def _components(system: System) -> list:
    """Plant, observers and controller, in the order of the parameter slices."""
    return [system.plant, *system.observers] + ([system.controller] if system.controller
                                                else [])


def _functions(system: System) -> tuple[dict[str, object], dict]:
    """Injected name -> component function (one per distinct function), and the call names.

    Functions among a component's constants (a user's phi, say) are named too (the
    kernel's key names every function it runs: :func:`hgo.engine.codegen._layout_key`);
    their bound functions get them (:class:`Bound`)."""
    named: dict[str, object] = {}

    def add(prefix: str, fn: object) -> str:
        for name, known in named.items():
            if known is fn:
                return name
        name = f"{prefix}_{len(named)}"
        named[name] = fn
        return name

    plant = system.plant
    calls = {
        "plant_f": add("c_plant_f", plant.f),
        "plant_h": add("c_plant_h", plant.h),
        "obs": [
            (add("c_obs_f", o.f), add("c_obs_update", o.update), add("c_obs_est", o.estimate))
            for o in system.observers
        ],
        "stiff": [None if getattr(o, "stiffness", None) is None
                  else add("c_obs_stiff", o.stiffness) for o in system.observers],
        "ctrl": None if system.controller is None else add("c_ctrl_u", system.controller.u),
    }
    for comp in _components(system):
        for value in (comp.params.constants.values() if comp.params is not None else ()):
            if callable(value):
                add("c_const", value)
    return named, calls


def _v(arr: str, a: int, b: int) -> str:
    """A borrowed view ``arr[a:b]`` (see :mod:`hgo.engine.jit`)."""
    return f"view({arr}, {a}, {b})"


def _literal(value: object) -> str:
    """A constant as kernel text (floats exactly, inf and nan through math)."""
    if isinstance(value, float) and not math.isfinite(value):
        return "math.nan" if math.isnan(value) else f"{'-' if value < 0 else ''}math.inf"
    if isinstance(value, tuple):
        return "(" + "".join(f"{_literal(v)}, " for v in value) + ")"
    return repr(value)


@dataclass(frozen=True, eq=False)
class Record:
    """A component's parameter record (:class:`hgo.core.components.Params`), read from the
    component's own slice ``P`` of the flat vector: its fields, each field's value as
    kernel text (at a constant offset into that slice; constants as literals, a function
    constant by its name ``c_const_<field>``) and those functions."""

    fields: tuple[str, ...]
    values: tuple[str, ...]
    constants: dict


@dataclass(frozen=True, eq=False)
class Bound:
    """A component's function called on the component's own parameter slice: the module
    text (:func:`bound_text`) whose function ``bound`` builds the record there and calls
    it, and the functions that module is given (the component's function as
    ``function``, function constants as ``c_const_<field>``). The same text for that
    function and record in every composition, so its compiled code is cached once with
    the components' (:mod:`hgo.engine.component_cache`): a new composition of known
    components only compiles its entry points, which pass slices and call these."""

    text: str
    functions: dict


def _record(comp) -> Record | None:
    """Component ``comp``'s record, or None (no named parameters: its functions get the
    positional slice ``P[a:b]``)."""
    spec = comp.params
    if spec is None:
        return None
    fields, values = [], []
    for name, shape, o in zip(spec.names, spec.shapes, spec.offsets, strict=True):
        fields.append(name)
        if not shape:
            values.append(f"P[{o}]")
        elif len(shape) == 1:
            values.append(_v("P", o, o + shape[0]))
        elif len(shape) == 2:
            values.append(f"view2(P, {o}, {shape[0]}, {shape[1]})")
        else:
            raise ValueError(f"{comp.name}: parameter {name} has {len(shape)} dimensions; "
                             "at most 2 are supported")
    constants = {}
    for name, value in spec.constants.items():
        fields.append(name)
        if name == "scratch":  # scratch space on the caller's stack (hgo.engine.jit)
            values.append(f"stack({value})")
        elif callable(value):
            values.append(f"c_const_{name}")
            constants[f"c_const_{name}"] = value
        else:
            values.append(_literal(value))
    return Record(tuple(fields), tuple(values), constants)


def bound_text(record: Record, n_args: int, at: int, lengths: dict[int, int]) -> str:
    """The module text of a component's function (injected as ``function``) on its own
    parameter slice: ``bound`` takes the function's ``n_args`` arguments, the arrays among
    them (``lengths``: argument -> length) as data pointers, the parameter slice ``P`` in
    place of the record (argument ``at``); it makes the arrays of those pointers, builds
    the record from ``P`` and calls the function."""
    arrays = [f"    {'P' if i == at else f'x{i}'} = carray(a{i}, {n})"
              for i, n in sorted(lengths.items())]
    call = ["p" if i == at else f"x{i}" if i in lengths else f"a{i}" for i in range(n_args)]
    binding = ", ".join(f"{name}={value}"
                        for name, value in zip(record.fields, record.values, strict=True))
    return "\n".join([
        "import math", "", "from hgo.core.records import record_class", "",
        f"_P = record_class({record.fields!r})", "", "",
        f"def bound({', '.join(f'a{i}' for i in range(n_args))}):", *arrays,
        f"    p = _P({binding})",
        f"    return function({', '.join(call)})", ""])


_VIEW = re.compile(r"view\((\w+), (\d+), (\d+)\)")


class _Calls:
    """The calls of a composition's functions: a component with a record is called
    through its :class:`Bound` function (``b<k>_<name>``) on the addresses of its slices
    (its slice of ``P`` for the record). ``called``: injected name -> what the text calls
    by that name (a component function, or a :class:`Bound` one)."""

    def __init__(self, system: System) -> None:
        self.slices = system.p_slices
        self.records = [_record(comp) for comp in _components(system)]
        self.called: dict[str, object] = {}

    def params(self, k: int) -> str:
        """What component ``k``'s functions get for their parameters (a token for a
        record, resolved by :meth:`call`)."""
        return f"p{k}" if self.records[k] is not None else _v("P", *self.slices[k])

    def call(self, name: str, fn: object, *args: str) -> str:
        """The call ``name(*args)`` of the component function ``fn`` injected as ``name``,
        through its :class:`Bound` function where an argument is a record's token."""
        tokens = [k for k, a in enumerate(args) if re.fullmatch(r"p\d+", a)]
        if not tokens:
            self.called[name] = fn
            return f"{name}({', '.join(args)})"
        at, = tokens
        k = int(args[at][1:])
        bound_name = f"b{k}_{name[2:]}"
        record = self.records[k]
        a, b = self.slices[k]
        passed, lengths = [], {at: b - a}
        for i, arg in enumerate(args):  # a view: its start's address, its length in the text
            view = _VIEW.fullmatch(arg)
            if i == at:
                passed.append(f"at(P, {a})")
            elif view is None:
                passed.append(arg)
            else:
                passed.append(f"at({view[1]}, {view[2]})")
                lengths[i] = int(view[3]) - int(view[2])
        self.called[bound_name] = Bound(bound_text(record, len(args), at, lengths),
                                        {"function": fn, **record.constants})
        return f"{bound_name}({', '.join(passed)})"


# The composed functions, each written once as its body and emitted twice: on arrays
# (``system_<name>``, the pure-Python path) and as the C entry point ``c_<name>`` on the
# data pointers the integrator passes (``carray``: no copy, no reference count; lengths
# from the header). Every body is flat: the measurement written out, the components'
# functions called on slices (those with a record through their bound functions, on the
# slices' addresses); in the RK4 step, the composed right-hand side, update and stiffness
# (inlined).
ARRAYS = {"rhs": "z d m P dz", "update": "z d m P", "outputs": "z d m P y u xh",
          "stiffness": "z d P", "rk4": "z d m P k1 k2 k3 k4 zt", "system": "z d m P a b c"}
SCALARS = {"rk4": "t, h, t_lim, t_new", "outputs": "t, with_u", "system": "t, sel"}
RETURNS_FLOAT = ("stiffness", "rk4", "system")  # (the others return nothing)
SELECT = {"rhs": 0.0, "update": 1.0, "stiffness": 2.0, "outputs": 3.0}
"""``c_system``'s selector ``sel`` of each function; the outputs' is 3 + with_u. Its arrays
``a, b, c``: dz for the right-hand side, y, u, x^ for the outputs (unused ones: any
pointer, never read)."""
C_SYSTEM = ("rhs", "update", "stiffness", "outputs")  # c_system's branches, in this order
LENGTHS = {"z": "NZ", "d": "ND", "m": "NY", "P": "NP", "dz": "NZ", "y": "NY",
           "u": "NU", "xh": "NXH", "k1": "NZ", "k2": "NZ", "k3": "NZ", "k4": "NZ", "zt": "NZ"}
# called by the RK4 step (compiled into it): the others are only entry points
CALLED = ("rhs", "update", "stiffness")
# One RK4 step from (t, z), then the discrete update at t_new; the stiffness after it
RK4 = ["    system_rhs(t, z, d, m, P, k1)",
       "    for i in range(NZ):", "        zt[i] = z[i] + 0.5 * h * k1[i]",
       "    system_rhs(t + 0.5 * h, zt, d, m, P, k2)",
       "    for i in range(NZ):", "        zt[i] = z[i] + 0.5 * h * k2[i]",
       "    system_rhs(t + 0.5 * h, zt, d, m, P, k3)",
       "    for i in range(NZ):", "        zt[i] = z[i] + h * k3[i]",
       "    system_rhs(min(t + h, t_lim), zt, d, m, P, k4)",
       "    h6 = h / 6.0",
       "    for i in range(NZ):", "        z[i] += h6 * (k1[i] + 2.0 * (k2[i] + k3[i]) + k4[i])",
       "    system_update(t_new, z, d, m, P)",
       "    return system_stiffness(t_new, z, d, P)"]


# The work vector (y, u and the estimate the controller reads: a function's own scratch,
# written before it is read in every call) on the stack, zeroed: an input that ignores the
# estimate gets zeros, as from the integrator's zeroed work vector before
WORK = ["    w = stack(NW)", "    for i in range(NW):", "        w[i] = 0.0"]


def scalars_of(name: str) -> str:
    """The float arguments of entry point ``name`` before its arrays."""
    return SCALARS.get(name, "t")


def _function(name: str, body: list[str]) -> list[str]:
    """``system_<name>`` with ``body``, after the work vector ``w`` if it uses it (and RK4's
    step also as its C entry point ``c_rk4``)."""
    used = _work(body)
    arrays, scalars = ARRAYS[name].split(), scalars_of(name)
    lines = ["", "", *(["@ijit"] if name in CALLED else []),
             f"def system_{name}({scalars}, {', '.join(arrays)}):", *used, *body]
    if name != "rk4":
        return lines
    return [*lines, "", "", f"def c_rk4({scalars}, {', '.join(a + '_ptr' for a in arrays)}):",
            *[f"    {a} = carray({a}_ptr, {LENGTHS[a]})" for a in arrays], *used, *body]


def _work(body: list[str]) -> list[str]:
    return WORK if re.search(r"\bw\b", "\n".join(body)) else []


# c_system's branch of each function: its arrays from a, b, c, then its body
_ARGUMENTS = {"rhs": ["dz = carray(a_ptr, NZ)"], "update": [], "stiffness": [],
              "outputs": [f"with_u = sel - {SELECT['outputs']!r}", "y = carray(a_ptr, NY)",
                          "u = carray(b_ptr, NU)", "xh = carray(c_ptr, NXH)"]}


def _c_system(bodies: dict[str, list[str]], called: set[str]) -> list[str]:
    """``c_system`` (the ``called`` functions, each body written in its branch: one numba
    function, not one more per function) and ``system_call``, the same on arrays."""
    names = [n for n in C_SYSTEM if n in called]
    tests = [f"{'if' if k == 0 else 'elif'} sel == {SELECT[name]!r}:"
             for k, name in enumerate(names[:-1])] + ["else:"]
    arrays = ARRAYS["system"].split()
    lines = ["", "", f"def c_system({scalars_of('system')}, "
                     f"{', '.join(a + '_ptr' for a in arrays)}):",
             *[f"    {a} = carray({a}_ptr, {LENGTHS[a]})" for a in arrays[:4]]]
    python = ["", "", f"def system_call({scalars_of('system')}, {', '.join(arrays)}):",
              "    \"\"\"c_system on arrays (the pure-Python path).\"\"\""]
    calls = {"rhs": "system_rhs(t, z, d, m, P, a)", "update": "system_update(t, z, d, m, P)",
             "stiffness": "return system_stiffness(t, z, d, P)",
             "outputs": f"system_outputs(t, sel - {SELECT['outputs']!r}, z, d, m, P, a, b, c)"}
    for test, name in zip(tests, names, strict=True):
        lines += [f"    {test}  # {name}", *[f"        {a}" for a in _ARGUMENTS[name]],
                  *["    " + line for line in [*_work(bodies[name]), *bodies[name]]]]
        python += [f"    {test}", f"        {calls[name]}"]
    return [*lines, "    return 0.0", *python, "    return 0.0"]


def composition_text(system: System, functions: dict[str, object], names: dict,
                     noisy: bool) -> tuple[str, dict[str, object]]:
    """The composition's module text (module doc): sizes, the entry points; and what it
    calls by injected name, component functions and :class:`Bound` ones (``functions``:
    injected name -> component function, ``names``: the call names, :func:`_functions`)."""
    nx, ny, nu = system.plant.nx, len(system.plant.output_names), len(system.plant.input_names)
    zs, ds, xs = system.z_slices, system.d_slices, system.xh_slices
    ctrl_obs = system.controlled_observer()
    y, u = _v("w", 0, ny), _v("w", ny, ny + nu)
    calls = _Calls(system)

    def call(name: str, *args: str) -> str:
        return calls.call(name, functions[name], *args)

    def obs_args(k: int) -> tuple[str, str, str]:
        return _v("z", *zs[k + 1]), _v("d", *ds[k]), calls.params(k + 1)

    def measure(with_u: bool) -> list[str]:
        """y = h(x) + m into w (a run without noise: y is h(x) itself, so the compiler can
        share what the plant and an observer compute of it, e.g. sin x1 and sin y); with
        the controller's input u when ``with_u``."""
        lines = ["    " + call(names["plant_h"], "t", _v("z", 0, nx), calls.params(0), y),
                 *([f"    for i in range({ny}):", "        w[i] += m[i]"] if noisy else
                   ["    # noiseless: y = h(x)"])]
        return lines + (control() if with_u else [])

    def control() -> list[str]:
        """The controller's input u into w, from y and its observer's estimate."""
        if ctrl_obs is None:
            return []
        zk, dk, pk = obs_args(ctrl_obs)
        xc = _v("w", ny + nu, work_length(system))
        lines = []
        if reads_estimate(system):  # (an open-loop input ignores the estimate)
            lines.append("    " + call(names["obs"][ctrl_obs][2], "t", zk, dk, pk, xc))
        ctrl = call(names["ctrl"], "t", xc, y, calls.params(len(calls.records) - 1), u)
        return [*lines, "    " + ctrl]

    updates = [o.update for o in system.observers]
    # the update needs u only if some update reads it (u may cost a controller evaluation)
    update_u = ctrl_obs is not None and any(_reads(fn, 4) for fn in updates
                                            if fn is not no_update)
    rhs = [*measure(True),
           "    " + call(names["plant_f"], "t", _v("z", 0, nx), u, calls.params(0),
                         _v("dz", 0, nx))]
    for k, (f, _, _) in enumerate(names["obs"]):
        zk, dk, pk = obs_args(k)
        rhs.append("    " + call(f, "t", zk, dk, y, u, pk, _v("dz", *zs[k + 1])))
    update = ["    return"]  # no discrete logic: nothing to evaluate between steps
    if has_discrete_update(system):
        update = measure(update_u)
        for k, (_, upd, _) in enumerate(names["obs"]):
            if updates[k] is not no_update:
                zk, dk, pk = obs_args(k)
                update.append("    " + call(upd, "t", zk, dk, y, u, pk))
    estimates = ["    " + call(est, "t", *obs_args(k), _v("xh", *xs[k]))
                 for k, (_, _, est) in enumerate(names["obs"])]
    # with_u = 0: what the error metrics read, y and x^ only (their points cost no
    # controller evaluation; u is not written)
    outputs = [*measure(False), f"    for i in range({ny}):", "        y[i] = w[i]",
               "    if with_u != 0.0:",
               *["    " + line for line in control()],
               f"        for i in range({nu}):", f"            u[i] = w[{ny} + i]", *estimates]
    stiffness = ["    rho = 0.0"]  # the largest spectral radius declared *now* by hooks
    for k, fn in enumerate(names["stiff"]):
        if fn is not None:
            stiffness.append(f"    rho = max(rho, {call(fn, 't', *obs_args(k))})")
    stiffness.append("    return rho")
    lines = ["import math", "", "import numpy as np", "",
             "# the lengths of the arrays the entry points get as pointers",
             f"NZ = {system.nz}", f"ND = {system.nd}", f"NY = {ny}", f"NU = {nu}",
             f"NP = {system.p_slices[-1][1]}", f"NXH = {system.nxh}",
             f"NW = {work_length(system)}", "",
             "# which entry points the integrator calls (the others: address 0)",
             f"HAS_UPDATE = {has_discrete_update(system)}",
             f"HAS_STIFFNESS = {has_stiffness(system)}"]
    bodies = dict(zip(ENTRY_POINTS, (rhs, update, outputs, stiffness, RK4), strict=True))
    for name, body in bodies.items():
        lines += _function(name, body)
    called = {"rhs", "outputs"} | ({"update"} if has_discrete_update(system) else set()) \
        | ({"stiffness"} if has_stiffness(system) else set())
    lines += _c_system(bodies, called)
    return "\n".join(lines) + "\n", calls.called


def selector_constants() -> str:
    """``c_system``'s selectors as the integrator's constants ``SEL_RHS`` .. (:data:`SELECT`)."""
    return "".join(f"SEL_{name.upper()} = {value!r}\n" for name, value in SELECT.items()) + "\n"


def has_discrete_update(system: System) -> bool:
    """Whether some observer has discrete logic (an ``update``)."""
    return any(o.update is not no_update for o in system.observers)


def has_stiffness(system: System) -> bool:
    """Whether some observer declares its stiffness (a hook bounding RK4's step)."""
    return any(getattr(o, "stiffness", None) is not None for o in system.observers)


def work_length(system: System) -> int:
    """Length of the work vector ``w``, each entry point's own scratch (``WORK``): y, u
    and the estimate the controller reads."""
    plant, ctrl_obs = system.plant, system.controlled_observer()
    n_xc = 0 if ctrl_obs is None else len(system.observers[ctrl_obs].estimated_states)
    return len(plant.output_names) + len(plant.input_names) + n_xc


def integrator_constants(system: System) -> str:
    """What an integrator is specialised on (its header, :mod:`hgo.engine.kernel_template`):
    the sizes of the state, outputs and estimates, the maps of the error metrics, whether
    there is discrete logic and whether a component declares its stiffness (RK4's step
    cap): as constants, the code a composition never needs is not compiled. Not the
    number of inputs nor the composition's work vector (sizes only: read at run time)."""
    plant = system.plant
    return "\n".join([
        f"HAS_UPDATE = {has_discrete_update(system)}",
        f"HAS_STIFFNESS = {has_stiffness(system)}",
        f"NZ = {system.nz}",
        f"NY = {len(plant.output_names)}",
        f"NXH = {system.nxh}",
        f"NOBS = {len(system.observers)}",
        f"EST_MAP = np.array({system.estimate_map().tolist()}, dtype=np.int64)",
        f"YHAT_COL = np.array({system.yhat_columns().tolist()}, dtype=np.int64)",
        f"OBS_OF = np.array({system.xh_observer().tolist()}, dtype=np.int64)",
    ]) + "\n\n"



def reads_estimate(system: System) -> bool:
    """Whether the controller's input may depend on its observer's estimate (the
    argument ``xhat`` of ``u``): False for no controller or an open-loop input."""
    return system.controller is not None and _reads(system.controller.u, 1)


def _reads(fn: object, index: int) -> bool:
    """Whether Python function ``fn`` may read its positional argument ``index``.

    Conservative: True unless the bytecode provably never touches that argument (used to
    skip computing signals, e.g. a controller's input, that a component ignores).
    """
    code = getattr(fn, "__code__", None)
    if code is None or index >= code.co_argcount:
        return True
    name = code.co_varnames[index]
    if name in code.co_cellvars:  # captured by an inner function
        return True
    for ins in dis.get_instructions(code):
        val = ins.argval
        if val == name or (isinstance(val, tuple) and name in val):
            return True
    return False


