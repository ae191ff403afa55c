"""The record classes of named parameters (:class:`hgo.core.components.Params`): one
namedtuple class per tuple of names, importable by its name (``Record_3eps_1A`` holds
``eps`` and ``A``).

Why importable: numba's on-disk cache keys a compiled component by the types of its
arguments, the record's class among them, and a later process finds the entry only if
pickle can import that class by name (:mod:`hgo.engine.component_cache`). The name spells
the fields (each prefixed by its length), so any process rebuilds the same class from it.
"""

from __future__ import annotations

import functools
import re
from collections import namedtuple

_PREFIX = "Record_"


@functools.cache
def record_class(names: tuple[str, ...]) -> type:
    """The record class with fields ``names`` (the same class for the same names)."""
    return namedtuple(_name(names), names, module=__name__)


def _name(names: tuple[str, ...]) -> str:
    return _PREFIX + "_".join(f"{len(n)}{n}" for n in names)


def _fields(name: str) -> tuple[str, ...]:
    """The field names spelled by class name ``name`` (ValueError if it spells none)."""
    rest, fields = name[len(_PREFIX):], []
    while rest:
        m = re.match(r"(\d+)", rest)
        if m is None:
            raise ValueError(name)
        start = len(m[1])
        fields.append(rest[start:start + int(m[1])])
        rest = rest[start + int(m[1]):]
        if rest and not rest.startswith("_"):
            raise ValueError(name)
        rest = rest[1:]
    if any(not f.isidentifier() for f in fields):
        raise ValueError(name)
    return tuple(fields)


def __getattr__(name: str) -> type:  # pickle imports a record class by its name
    if name.startswith(_PREFIX):
        try:
            fields = _fields(name)
        except ValueError:
            fields = None
        if fields is not None and _name(fields) == name:
            return record_class(fields)
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
