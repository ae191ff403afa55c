"""Which callables a config may name: the ``_target_`` allowlist, checked before any call.

A config is data; the functions it names are code. A ``_target_`` (components, noise,
post-processors, figures, ensemble reports, nested nodes such as a user's ``phi0``) is
resolved here, and only when it names

* hgo's own component, post-processor, figure and report callables (:data:`HGO_MODULES`;
  not its command line, API or file helpers, nor private names);
* a module under the working directory or a ``--config-dir`` given on the command line
  (``hgo.compose(config_dir=...)`` in Python): the user's own code, never an installed
  package or the standard library, even where those lie under that folder;
* a numerical callable of numpy, scipy or math (:data:`NUMERIC_MODULES`; their file
  readers and writers excepted, :data:`FILE_NAMES`);
* a module the user allows outside the config: ``HGO_ALLOW_TARGETS=pkg,pkg2.mod`` (or
  ``hgo run --allow-targets pkg,...``, which sets it): a config cannot widen its own rights.

The rule is checked on the text first (nothing outside it is imported), then on each step
of the resolution (``hgo.running.job.shutil.rmtree`` passes through module ``shutil``: refused)
and on the module that defines the object found. ``hydra.callbacks`` take Hydra ``Callback``
classes of hgo, Hydra and installed Hydra plugins only (:data:`CALLBACK_MODULES`); the
logging factories of ``hydra.job_logging``/``hydra.hydra_logging`` (their ``()`` and
``class`` entries) classes of logging and colorlog (:data:`LOGGING_MODULES`).
"""

from __future__ import annotations

import functools
import importlib
import importlib.util
import inspect
import os
import re
import site
import sys
import sysconfig
import types
from collections.abc import Callable, Iterable, Mapping
from pathlib import Path

from hgo.core.errors import ConfigError

ENV = "HGO_ALLOW_TARGETS"
NUMERIC_MODULES = ("math", "cmath", "numpy", "numpy.linalg", "numpy.random", "numpy.fft",
                   "numpy.polynomial", "scipy.linalg", "scipy.special", "scipy.signal",
                   "scipy.integrate", "scipy.interpolate", "scipy.optimize", "scipy.stats",
                   "scipy.spatial", "scipy.fft", "scipy.sparse", "scipy.ndimage",
                   "scipy.constants")
#: Names of numpy/scipy callables that read or write files (or print, or run code): refused.
FILE_NAMES = re.compile(r"save|load|file|txt|memmap|datasource|fromregex|open|write|read|"
                        r"info|lookfor|show|exec|system|compile", re.IGNORECASE)
#: hgo's packages of callables a config names: components, post-processors, figures,
#: reports and sweep callbacks (never its command line, API or file helpers: ``hgo.cli.main``
#: with ``--allow-targets`` would widen the rule, ``hgo.cli.runs.export`` writes any path).
HGO_MODULES = ("hgo.plants", "hgo.observers", "hgo.controllers", "hgo.noise",
               "hgo.postprocess", "hgo.papers", "hgo.running.aggregate",
               # the figures and reports of the generic presets (they draw into the run's
               # own folder)
               "hgo.outputs.estimate_figures", "hgo.outputs.observer_comparison")
CALLBACK_MODULES = ("hgo", "hydra_plugins", "hydra.experimental.callbacks")
LOGGING_MODULES = ("logging", "colorlog")

_CONFIG_DIRS: list[Path] = []  # --config-dir / hgo.compose(config_dir=...) of this process


def trust_config_dir(path: str | Path) -> None:
    """Modules under ``path`` (a ``--config-dir`` the user gave) may be named."""
    resolved = Path(path).resolve()
    if resolved not in _CONFIG_DIRS:
        _CONFIG_DIRS.append(resolved)


def _under(name: str, prefixes: Iterable[str]) -> bool:
    return any(name == p or name.startswith(p + ".") for p in prefixes)


def user_prefixes() -> tuple[str, ...]:
    """The module prefixes of ``HGO_ALLOW_TARGETS``."""
    return tuple(p.strip().rstrip(".") for p in os.environ.get(ENV, "").split(",")
                 if p.strip().rstrip("."))


def _hydra_config_dirs() -> list[Path]:
    """The ``--config-dir`` of the Hydra run of this process (a launcher's job process
    included), from its config sources set on the command line."""
    try:
        from hydra.core.hydra_config import HydraConfig

        if not HydraConfig.initialized():
            return []
        runtime = HydraConfig.get().runtime
    except Exception:  # noqa: BLE001 - no Hydra run: no config dir from it
        return []
    # (and the directory hgo was started in, where hydra.job.chdir=true moved away from it)
    return [Path(runtime.cwd).resolve()] + [
        Path(s.path).resolve() for s in runtime.config_sources
        if s.schema == "file" and s.provider in ("command-line",
                                                 "hydra.searchpath in command-line")]


def trusted_dirs() -> tuple[Path, ...]:
    """The working directory and the user's config dirs."""
    return (Path.cwd().resolve(), *_CONFIG_DIRS, *_hydra_config_dirs())


@functools.cache
def _install_dirs() -> tuple[Path, ...]:
    paths = sysconfig.get_paths()
    found = {paths[k] for k in ("stdlib", "platstdlib", "purelib", "platlib") if k in paths}
    found |= set(site.getsitepackages()) | {site.getusersitepackages()}
    return tuple(Path(p).resolve() for p in found if p)


def _is_user_file(path: str | None, dirs: tuple[Path, ...]) -> bool:
    """``path`` lies under a trusted folder and is no installed package's or the
    standard library's (a virtual environment inside the project folder)."""
    if not path or path in ("built-in", "frozen"):
        return False
    file = Path(path).resolve()
    parts = set(file.parts)
    if "site-packages" in parts or "dist-packages" in parts:
        return False
    if any(file.is_relative_to(d) for d in _install_dirs()):
        return False
    return any(file.is_relative_to(d) for d in dirs)


def _module_files(name: str) -> list[str | None]:
    """Where top-level module ``name`` lives, found without running it."""
    module = sys.modules.get(name)
    if module is not None:
        return [getattr(module, "__file__", None)] + list(getattr(module, "__path__", []))
    try:
        spec = importlib.util.find_spec(name)
    except (ImportError, ValueError):
        return [None]
    if spec is None:
        return [None]
    return [spec.origin] + list(spec.submodule_search_locations or [])


def _exists(name: str) -> bool:
    """Whether top-level module ``name`` can be found (without running it)."""
    try:
        return name in sys.modules or importlib.util.find_spec(name) is not None
    except (ImportError, ValueError):
        return False


def _user_module(name: str, dirs: tuple[Path, ...]) -> bool:
    if name.split(".")[0] == "hgo":  # (a checkout run from its own folder: still hgo's rule)
        return False
    files = [f for f in _module_files(name.split(".")[0]) if f is not None]
    return bool(files) and all(_is_user_file(f, dirs) for f in files)


def _numeric_module(name: str) -> bool:
    """One of :data:`NUMERIC_MODULES` itself (not numpy.testing, numpy.f2py, ...), or a
    private module under one (``scipy.linalg._matfuncs`` defines ``expm``)."""
    if name in NUMERIC_MODULES or name.startswith("numpy.polynomial."):
        return True
    return any(name.startswith(m + ".") and all(part.startswith("_") for part in
                                                name[len(m) + 1:].split("."))
               for m in NUMERIC_MODULES)


def component_module(name: str, dirs: tuple[Path, ...]) -> bool:
    """Whether module ``name`` may hold a component's ``_target_``."""
    return (_under(name, (*HGO_MODULES, *user_prefixes())) or _numeric_module(name)
            or _user_module(name, dirs))


def _callback_module(name: str, dirs: tuple[Path, ...]) -> bool:  # noqa: ARG001
    return _under(name, CALLBACK_MODULES)


def _logging_module(name: str, dirs: tuple[Path, ...]) -> bool:  # noqa: ARG001
    return _under(name, LOGGING_MODULES)


Rule = Callable[[str, tuple[Path, ...]], bool]


class Refused(ConfigError):
    """A ``_target_`` outside the allowlist."""


def _refuse(key: str, path: str, why: str, allowed: str) -> Refused:
    return Refused(key, f"{path} is not allowed ({why}); nothing was imported or called from "
                   "it", allowed)


def _numeric_name(path: str) -> bool:
    """A numpy/scipy path naming a file reader/writer (or a printer, a code runner)."""
    return _numeric_module(path.rsplit(".", 1)[0]) and bool(
        FILE_NAMES.search(path.rsplit(".", 1)[-1]))


def _check_text(path: str, key: str, rule: Rule, dirs: tuple[Path, ...], allowed: str) -> None:
    """The dotted path's module part must be allowed, read from the text alone."""
    parts = path.split(".")
    if len(parts) < 2 or not all(p.isidentifier() for p in parts):
        raise ConfigError(key, f"'{path}' is not a dotted path module.callable", allowed)
    if not any(rule(".".join(parts[:i]), dirs) for i in range(1, len(parts))):
        if not _exists(parts[0]):
            raise ConfigError(key, f"cannot import {path}: no module named '{parts[0]}' (a "
                              "module of your own: put it in the working directory or the "
                              "--config-dir)")
        raise _refuse(key, path, "not in a module the rule allows", allowed)
    if rule is component_module and _numeric_name(path):
        raise _refuse(key, path, "numpy/scipy file readers and writers are not", allowed)
    if _under(path, ("hgo",)) and any(part.startswith("_") for part in parts):
        raise _refuse(key, path, "hgo's private names are not", allowed)


def _defining_module(obj: object) -> str | None:
    """The module that defines a function, method or class (None for other objects)."""
    target = getattr(obj, "__func__", obj)
    if inspect.isroutine(target) or inspect.isclass(target):
        module = getattr(target, "__module__", None)
        return module if isinstance(module, str) else None
    return None


def _resolve(path: str, key: str, rule: Rule, dirs: tuple[Path, ...], allowed: str) -> object:
    """Import and walk ``path`` one step at a time: every module passed through and the
    module defining the object found must be allowed; between the module and the object
    only classes (``module.Class.method``)."""
    parts = path.split(".")
    obj: object = _import(parts[0], key, path)
    home = parts[0]  # the last module passed through
    for i in range(1, len(parts)):
        name = ".".join(parts[:i + 1])
        if isinstance(obj, types.ModuleType) and not hasattr(obj, parts[i]):
            if not rule(name, dirs):
                raise _refuse(key, path, f"module {name} is outside the rule", allowed)
            obj = _import(name, key, path)
        else:
            if not isinstance(obj, types.ModuleType | type):
                raise _refuse(key, path, f"{'.'.join(parts[:i])} is not a module or a class",
                              allowed)
            if not hasattr(obj, parts[i]):
                raise ConfigError(key, f"cannot find {path}: {'.'.join(parts[:i])} has no "
                                  f"'{parts[i]}'")
            obj = getattr(obj, parts[i])
        if isinstance(obj, types.ModuleType):
            # a package above an allowed module (hgo.running of hgo.running.aggregate)
            above = obj.__name__ == name and any(rule(".".join(parts[:j]), dirs)
                                                 for j in range(i + 2, len(parts)))
            if not (above or rule(obj.__name__, dirs)):
                raise _refuse(key, path, f"it passes through module {obj.__name__}", allowed)
            home = obj.__name__
    module = _defining_module(obj)
    if module is not None and not rule(module, dirs):
        raise _refuse(key, path, f"it is {module}'s", allowed)
    names = f"{parts[-1]} {getattr(obj, '__name__', '')}"
    if rule is component_module and (_numeric_module(module or "") or _numeric_module(home)) \
            and FILE_NAMES.search(names):
        raise _refuse(key, path, "numpy/scipy file readers and writers are not", allowed)
    return obj


def _import(name: str, key: str, path: str) -> types.ModuleType:
    """Import module ``name``; an error in it (a SyntaxError, an exception at import) as one
    line naming the key, the target and the file:line."""
    try:
        return importlib.import_module(name)
    except ModuleNotFoundError as err:
        if err.name == name and "." in name:  # module.attribute: the attribute is missing
            parent, _, attr = name.rpartition(".")
            raise ConfigError(key, f"cannot find {path}: {parent} has no '{attr}'") from None
        if err.name and name.startswith(err.name):
            raise ConfigError(key, f"cannot import {path}: no module named '{err.name}'") \
                from None
        raise ConfigError(f"{key} {path}", code_error(err)) from None
    except Exception as err:  # noqa: BLE001 - the user's module failed while importing
        raise ConfigError(f"{key} {path}", code_error(err)) from None


def code_error(err: BaseException) -> str:
    """``Type: message (file.py:line)``: where in the user's code ``err`` was raised (a
    SyntaxError: its own file and line; else the deepest frame outside Python, its installed
    packages and hgo's own machinery)."""
    text = " ".join(str(err).split()) if not isinstance(err, SyntaxError) else err.msg
    where = None
    if isinstance(err, SyntaxError) and err.filename:
        where = f"{Path(err.filename).name}:{err.lineno}"
    else:
        frames = _frames(err.__traceback__)
        mine = [fl for fl in frames if not _machinery(fl[0])] or frames
        if mine:
            where = f"{Path(mine[-1][0]).name}:{mine[-1][1]}"
    return f"{type(err).__name__}: {text}" + (f" ({where})" if where else "")


def _frames(tb) -> list[tuple[str, int]]:
    out = []
    while tb is not None:
        out.append((tb.tb_frame.f_code.co_filename, tb.tb_lineno))
        tb = tb.tb_next
    return out


def _machinery(filename: str) -> bool:
    """A frame of Python's import system, an installed package or hgo's own runner."""
    if filename.startswith("<frozen") or filename.startswith("<"):
        return True
    file = Path(filename).resolve()
    return (any(part in ("site-packages", "dist-packages") for part in file.parts)
            or any(file.is_relative_to(d) for d in _install_dirs())
            or file.is_relative_to(_HGO / "running") or file in _HGO_CHECKS)


_HGO = Path(__file__).resolve().parents[1]
_HGO_CHECKS = (_HGO / "core" / "targets.py", _HGO / "engine" / "dry_call.py")


def _allowed_text(rule: Rule, dirs: tuple[Path, ...]) -> str:
    if rule is _callback_module:
        return "hgo's callbacks and installed Hydra plugins (hydra_plugins.*)"
    if rule is _logging_module:
        return "classes of logging and colorlog"
    extra = ", ".join(user_prefixes())
    return (f"hgo's components, post-processors, figures and reports ({', '.join(HGO_MODULES)}); "
            f"modules under {', '.join(str(d) for d in dict.fromkeys(dirs))}; "
            f"numpy, scipy, math; {ENV}" + (f" = {extra}" if extra else " (unset)"))


@functools.cache
def _locate(path: str, key: str, rule: Rule, dirs: tuple[Path, ...],
            prefixes: tuple[str, ...]) -> object:  # noqa: ARG001 - prefixes: cache key
    allowed = _allowed_text(rule, dirs)
    _check_text(path, key, rule, dirs, allowed)
    return _resolve(path, key, rule, dirs, allowed)


_FOUND: dict[tuple, object] = {}  # (path, key, context) -> what locate found


def _context() -> tuple:
    """What the rule depends on, cheaply (an ensemble locates once per member). The config
    dirs only widen it within a process: a target found stays found; one refused is looked
    at again next time."""
    return os.getcwd(), os.environ.get(ENV, "")


def locate(path: object, key: str) -> object:
    """The callable a component's ``_target_`` names (``key``: its config key), checked
    against the allowlist (module doc) before anything of it is imported or called."""
    if not isinstance(path, str):
        raise ConfigError(key, f"must be a dotted path module.callable, got {path!r}")
    found = (path, key, _context())
    if found not in _FOUND:
        _FOUND[found] = _locate(path, key, component_module, trusted_dirs(), user_prefixes())
    return _FOUND[found]


def check_text(path: object, key: str) -> None:
    """The rule on the text of ``path`` alone, nothing imported (a figure's module, which
    imports matplotlib, is loaded only where the figure is drawn; :func:`locate` there
    checks the rest before the call)."""
    if not isinstance(path, str):
        raise ConfigError(key, f"must be a dotted path module.callable, got {path!r}")
    dirs = trusted_dirs()
    _check_text(path, key, component_module, dirs, _allowed_text(component_module, dirs))


def locate_callback(path: object, key: str) -> type:
    """A ``hydra.callbacks`` entry's class: a Hydra ``Callback`` of hgo or a Hydra plugin."""
    from hydra.experimental.callback import Callback

    if not isinstance(path, str):
        raise ConfigError(key, f"must be a dotted path, got {path!r}")
    found = _locate(path, key, _callback_module, (), ())
    if not (isinstance(found, type) and issubclass(found, Callback)):
        raise _refuse(key, path, "not a hydra Callback class", _allowed_text(
            _callback_module, ()))
    return found


def targets(node: object, key: str = "") -> Iterable[tuple[str, object]]:
    """(config key of the ``_target_``, its value) of every node under ``node``."""
    if isinstance(node, Mapping):
        for k, v in node.items():
            sub = f"{key}.{k}" if key else str(k)
            if k == "_target_":
                yield sub, v
            elif isinstance(v, Mapping | list | tuple):
                yield from targets(v, sub)
    elif isinstance(node, list | tuple):
        for i, v in enumerate(node):
            if isinstance(v, Mapping | list | tuple):
                yield from targets(v, f"{key}[{i}]")


def check_targets(node: object, key: str = "") -> None:
    """Every ``_target_`` under ``node`` (a resolved config container) allowed by its text
    (:func:`check_text`: nothing imported; each is located in full where it is called)."""
    for sub, path in targets(node, key):
        check_text(path, sub)


def instantiate(node, key: str, **kwargs):
    """Hydra's ``instantiate`` of ``node`` (config key ``key``) once every ``_target_`` in
    it is allowed."""
    from hydra.utils import instantiate as hydra_instantiate
    from omegaconf import OmegaConf

    plain = OmegaConf.to_container(node, resolve=True) if OmegaConf.is_config(node) else node
    for sub, path in targets(plain, key):  # in full: Hydra resolves and calls each
        locate(path, sub)
    return hydra_instantiate(node, **kwargs)


def check_hydra_node(hydra: Mapping) -> None:
    """``hydra.callbacks`` from hgo and Hydra plugins only; the logging configs' factories
    from logging, Hydra, hgo or colorlog (``logging.config`` calls them); no
    ``hydra.job.env_set`` of :data:`ENV` (a config widening its own rights)."""
    if ENV in ((hydra.get("job") or {}).get("env_set") or {}):
        raise ConfigError(f"hydra.job.env_set.{ENV}", "a config cannot widen what its "
                          "_target_ may name", f"set {ENV} in the environment, or hgo run "
                          "--allow-targets")
    for name, node in (hydra.get("callbacks") or {}).items():
        if isinstance(node, Mapping) and "_target_" in node:
            locate_callback(node["_target_"], f"hydra.callbacks.{name}._target_")
    for group in ("job_logging", "hydra_logging"):
        for key, value in _factories(hydra.get(group) or {}, f"hydra.{group}"):
            if not isinstance(value, str):
                raise ConfigError(key, f"must be a dotted path, got {value!r}")
            if not isinstance(_locate(value, key, _logging_module, (), ()), type):
                raise _refuse(key, value, "not a class", _allowed_text(_logging_module, ()))


def _factories(node: object, key: str) -> Iterable[tuple[str, object]]:
    if isinstance(node, Mapping):
        for k, v in node.items():
            sub = f"{key}.{k}"
            if k in ("()", "class"):
                yield sub, v
            else:
                yield from _factories(v, sub)


def check_option_path(config_path: str) -> None:
    """An option (``experiment=../../outside``) names a file inside a config folder: a path
    with ``..`` is refused."""
    if ".." in re.split(r"[/\\]", str(config_path)):
        group, _, option = str(config_path).partition("/")
        raise ConfigError(group or str(config_path), f"option '{option or config_path}' has "
                          "'..' in it: options are files inside the config folders",
                          "an option name listed by hgo list")
