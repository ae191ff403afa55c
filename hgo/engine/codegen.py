"""Compose a :class:`~hgo.engine.system.System` into one kernel module and compile it.

The generated module is the header written here (layout constants and the composed
``system_rhs``/``system_update``/``system_outputs``) followed by the integrators of
:mod:`hgo.engine.kernel_template`. It is written to a cache folder under a name that
hashes its text and the source of every component function it calls, so numba's
on-disk cache (``cache=True``) is reused by later processes and never goes stale.

If numba cannot compile a component (a user's plant written with Python objects, say),
the same module is loaded with ``jit`` as the identity: a pure-Python path, slower, with
one warning saying why.
"""

from __future__ import annotations

import hashlib
import importlib.util
import inspect
import os
import sys
import tempfile
from pathlib import Path
from types import ModuleType

from hgo.engine.system import System

_TEMPLATE = Path(__file__).with_name("kernel_template.py")


def cache_dir() -> Path:
    """Folder of generated kernels: ``$HGO_CACHE_DIR`` or ``~/.cache/hgo/kernels``."""
    root = os.environ.get("HGO_CACHE_DIR") or Path.home() / ".cache" / "hgo" / "kernels"
    path = Path(root)
    path.mkdir(parents=True, exist_ok=True)
    return path


def _functions(system: System) -> tuple[dict[str, object], dict]:
    """Injected name -> component function (one per distinct function), and the call names."""
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
        "ctrl": None if system.controller is None else add("c_ctrl_u", system.controller.u),
    }
    return named, calls


def _rng(a: int, b: int) -> str:
    return f"{a}:{b}"


def _header(system: System, names: dict) -> str:
    nx, ny, nu = system.plant.nx, len(system.plant.output_names), len(system.plant.input_names)
    zs, ds, ps, xs = system.z_slices, system.d_slices, system.p_slices, system.xh_slices
    ctrl_obs = system.controlled_observer()
    n_xc = 0 if ctrl_obs is None else xs[ctrl_obs][1] - xs[ctrl_obs][0]
    lines = [
        "import math",
        "import numpy as np",
        f"NX = {nx}",
        f"NY = {ny}",
        f"NU = {nu}",
        f"NXH = {system.nxh}",
        f"NOBS = {len(system.observers)}",
        f"NW = {ny + nu + n_xc}",
        f"EST_MAP = np.array({system.estimate_map().tolist()}, dtype=np.int64)",
        f"YHAT_COL = np.array({system.yhat_columns().tolist()}, dtype=np.int64)",
        "",
        "",
        "@jit",
        "def _signals(t, z, d, m, P, w):",
        '    """Measured outputs y = h(x) + m and the input u, into the work vector w."""',
        f"    y = w[0:{ny}]",
        f"    {names['plant_h']}(t, z[0:{nx}], P[{_rng(*ps[0])}], y)",
        f"    for i in range({ny}):",
        "        y[i] += m[i]",
    ]
    if ctrl_obs is not None:
        k = ctrl_obs
        lines += [
            f"    xc = w[{ny + nu}:{ny + nu + n_xc}]",
            f"    {names['obs'][k][2]}(t, z[{_rng(*zs[k + 1])}], d[{_rng(*ds[k])}], "
            f"P[{_rng(*ps[k + 1])}], xc)",
            f"    {names['ctrl']}(t, xc, y, P[{_rng(*ps[-1])}], w[{ny}:{ny + nu}])",
        ]
    lines += ["", "", "@jit", "def system_rhs(t, z, d, m, P, w, dz):", "    _signals(t, z, d, m, P, w)",
              f"    y = w[0:{ny}]", f"    u = w[{ny}:{ny + nu}]",
              f"    {names['plant_f']}(t, z[0:{nx}], u, P[{_rng(*ps[0])}], dz[0:{nx}])"]
    for k, (f, _, _) in enumerate(names["obs"]):
        zk, dk, pk = _rng(*zs[k + 1]), _rng(*ds[k]), _rng(*ps[k + 1])
        lines.append(f"    {f}(t, z[{zk}], d[{dk}], y, u, P[{pk}], dz[{zk}])")
    lines += ["", "", "@jit", "def system_update(t, z, d, m, P, w):", "    _signals(t, z, d, m, P, w)",
              f"    y = w[0:{ny}]", f"    u = w[{ny}:{ny + nu}]"]
    for k, (_, upd, _) in enumerate(names["obs"]):
        zk, dk, pk = _rng(*zs[k + 1]), _rng(*ds[k]), _rng(*ps[k + 1])
        lines.append(f"    {upd}(t, z[{zk}], d[{dk}], y, u, P[{pk}])")
    lines += ["", "", "@jit", "def system_outputs(t, z, d, m, P, w, y, u, xh):",
              "    _signals(t, z, d, m, P, w)", f"    y[:] = w[0:{ny}]", f"    u[:] = w[{ny}:{ny + nu}]"]
    for k, (_, _, est) in enumerate(names["obs"]):
        zk, dk, pk, xk = _rng(*zs[k + 1]), _rng(*ds[k]), _rng(*ps[k + 1]), _rng(*xs[k])
        lines.append(f"    {est}(t, z[{zk}], d[{dk}], P[{pk}], xh[{xk}])")
    return "\n".join(lines) + "\n\n"


def _identity(fn: object) -> str:
    """Module, name and source hash of a component function (part of the kernel's name)."""
    try:
        src = inspect.getsource(fn)
    except (OSError, TypeError):
        src = repr(fn)
    digest = hashlib.sha256(src.encode()).hexdigest()[:16]
    return f"# {getattr(fn, '__module__', '?')}.{getattr(fn, '__qualname__', '?')} {digest}"


def kernel_source(system: System) -> tuple[str, dict[str, object]]:
    """The generated module text and the functions to inject into it."""
    functions, calls = _functions(system)
    ids = "\n".join(f"{_identity(fn)} -> {name}" for name, fn in functions.items())
    text = ("# Generated by hgo.engine.codegen; do not edit.\n" + ids + "\n"
            + _header(system, calls) + _TEMPLATE.read_text())
    return text, functions


def _write_once(text: str) -> Path:
    digest = hashlib.sha256(text.encode()).hexdigest()[:20]
    path = cache_dir() / f"hgo_kernel_{digest}.py"
    if not path.exists():  # atomic: parallel sweep jobs may race here
        fd, tmp = tempfile.mkstemp(dir=path.parent, suffix=".tmp")
        with os.fdopen(fd, "w") as fh:
            fh.write(text)
        os.replace(tmp, path)
    return path


def load_kernel(system: System, compiled: bool = True) -> ModuleType:
    """Write (once) and import the kernel module of ``system``.

    ``compiled=False`` gives the pure-Python module (same code, ``jit`` = identity).
    """
    text, functions = kernel_source(system)
    path = _write_once(text)
    name = path.stem + ("" if compiled else "_py")
    if name in sys.modules:
        return sys.modules[name]
    spec = importlib.util.spec_from_file_location(name, path)
    module = importlib.util.module_from_spec(spec)
    module.__dict__.update(_decorators(compiled))
    jit = module.__dict__["jit"]
    module.__dict__.update({k: jit(fn) for k, fn in functions.items()})
    sys.modules[name] = module
    spec.loader.exec_module(module)
    return module


def _decorators(compiled: bool) -> dict[str, object]:
    if not compiled:
        return {"jit": lambda fn: fn, "pjit": lambda fn: fn, "prange": range}
    import numba

    return {
        "jit": numba.njit(cache=True),
        "pjit": numba.njit(cache=True, parallel=True),
        "prange": numba.prange,
    }
