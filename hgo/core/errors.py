"""Configuration errors and their one-line description.

Every configuration error reaches the user as one line on stderr,

    error: <full.key>: <what is wrong> (allowed: ...)

with exit code 2 (``experiments/run.py``; the full trace with ``HYDRA_FULL_ERROR=1``).
:class:`ConfigError` is what hgo's own checks raise; :func:`one_line` turns any error of
composition (Hydra, OmegaConf, YAML) or of a builder (``ValueError``/``TypeError``) into
that line, and :func:`is_config_error` tells which errors are the user's configuration.
"""

from __future__ import annotations

import errno

import yaml


class HgoError(Exception):
    """What hgo's Python API (``hgo.api``) raises: the one line ``hgo run`` prints after
    ``error:`` (the original exception is its ``__cause__``)."""


class ConfigError(HgoError, ValueError):
    """A bad configuration value: ``key`` (full dotted key), ``problem``, ``allowed``."""

    def __init__(self, key: str, problem: str, allowed: str | None = None) -> None:
        self.key, self.problem, self.allowed = key, problem, allowed
        text = f"{key}: {problem}" + (f" (allowed: {allowed})" if allowed else "")
        super().__init__(text)


class PlainError(Exception):
    """An error whose message is the whole line :func:`one_line` gives (no type name)."""


def _chain(err: BaseException) -> list[BaseException]:
    out: list[BaseException] = []
    while err is not None and err not in out:
        out.append(err)
        err = err.__cause__ or err.__context__
    return out


def _first_line(text: str) -> str:
    for line in str(text).splitlines():
        if line.strip():
            return line.strip()
    return ""


def _omegaconf_line(err) -> str | None:
    key = getattr(err, "full_key", None)
    if not key:
        return None
    msg = _first_line(getattr(err, "msg", None) or str(err))
    return f"{key}: {msg}"


def _yaml_line(err: yaml.YAMLError) -> str:
    mark = getattr(err, "problem_mark", None)
    where = f"{mark.name}:{mark.line + 1}:{mark.column + 1}" if mark else "YAML"
    problem = getattr(err, "problem", None) or _first_line(str(err))
    kind = "YAML" if isinstance(err, yaml.composer.ComposerError) else "YAML syntax error"
    return f"{where}: {kind}: {problem}"


def _missing_config_line(err) -> str:
    name = getattr(err, "missing_cfg_file", None) or ""
    options = getattr(err, "options", None)
    if "/" in name and options is not None:
        group, option = name.rsplit("/", 1)
        return (f"{group.replace('/', '.')}: unknown option '{option}' "
                f"(allowed: {', '.join(options)})")
    return _first_line(str(err))


#: Longest list shown in an error line before it is summarised, and longest line.
MAX_LIST_CHARS, MAX_LINE_CHARS = 120, 600


def _shorten_lists(line: str) -> str:
    """Each bracketed list longer than :data:`MAX_LIST_CHARS` characters as its start and
    its count (a 20,000-element ``plant.x0`` made a 100 KB "one line")."""
    out, i = [], 0
    while (start := line.find("[", i)) >= 0:
        depth, end, commas = 0, start, 0
        for end in range(start, len(line)):
            depth += {"[": 1, "]": -1}.get(line[end], 0)
            commas += line[end] == "," and depth == 1
            if depth == 0:
                break
        if depth != 0 or end - start <= MAX_LIST_CHARS:
            out.append(line[i:end + 1])
            i = end + 1
            continue
        head = line[start:start + MAX_LIST_CHARS // 2].rsplit(",", 1)[0]
        out.append(f"{line[i:start]}{head}, ... ({commas + 1:,} values)]")
        i = end + 1
    out.append(line[i:])
    text = "".join(out)
    return text if len(text) <= MAX_LINE_CHARS else text[:MAX_LINE_CHARS - 30] + \
        f"... ({len(text):,} characters)"


def one_line(err: BaseException) -> str:
    """The error as one line naming the full key where one is known, long lists
    summarised (:func:`_shorten_lists`)."""
    return _shorten_lists(_one_line(err))


def _one_line(err: BaseException) -> str:
    from hydra.errors import MissingConfigException
    from omegaconf.errors import OmegaConfBaseException

    chain = _chain(err)
    for e in chain:
        if isinstance(e, ConfigError | PlainError):
            return _first_line(str(e))
    from hydra.errors import OverrideParseException

    for e in chain:
        if isinstance(e, OverrideParseException):
            return f"{e.override}: {_first_line(e.message)} (override syntax)"
        if isinstance(e, yaml.YAMLError):
            return _yaml_line(e)
        if isinstance(e, MissingConfigException):
            return _missing_config_line(e)
    for e in chain:
        if isinstance(e, OmegaConfBaseException):
            line = _omegaconf_line(e)
            if line:
                return line
    for e in chain:
        if isinstance(e, OSError) and e.errno == errno.ENOSPC:
            where = e.filename or "device"
            return f"no space left on {where} ({e.strerror})"
    for e in chain:  # a builder's own message (Hydra wraps it in InstantiationException)
        if type(e) in (ValueError, TypeError, KeyError):
            return _first_line(str(e))
    line = _first_line(str(err)) or type(err).__name__
    return line if isinstance(err, ValueError) else f"{type(err).__name__}: {line}"


def is_config_error(err: BaseException) -> bool:
    """Whether ``err`` comes from the configuration (composition, schema, builder check)."""
    from hydra.errors import HydraException
    from omegaconf.errors import OmegaConfBaseException

    return any(isinstance(e, (ValueError, TypeError, yaml.YAMLError,
                              HydraException, OmegaConfBaseException)) for e in _chain(err))


def as_floats(key: str, value, shape: tuple[int | None, ...] | None = None):
    """``value`` as a float array (ints accepted), of ``shape`` (None: any length there),
    finite; else a :class:`ConfigError` naming ``key``."""
    import numpy as np

    try:
        arr = np.asarray(value, dtype=float)
    except (TypeError, ValueError):
        kind = "rows" if shape is not None and len(shape) == 2 else "a list"
        raise ConfigError(key, f"must be {kind} of numbers, got {value!r}") from None
    if shape is not None and (arr.ndim != len(shape) or any(
            want is not None and have != want
            for have, want in zip(arr.shape, shape, strict=True))):
        want = " x ".join("n" if s is None else str(s) for s in shape)
        raise ConfigError(key, f"must have shape {want}, got {value!r}")
    if not np.isfinite(arr).all():
        raise ConfigError(key, f"must be finite, got {value!r}")
    return arr


class UserCodeError(PlainError, ValueError):
    """A user's factory or function that fails where hgo calls or checks it, as one whole
    line naming the config key, the function and the file:line (a configuration error:
    exit 2)."""
