"""What reproducing one paper needs, one package per paper (``hgo/papers/<paper>/``).

A paper package may hold ``config.py`` (its structured-config schemas in a ``SCHEMAS``
mapping ``"<group>/<name>"`` -> dataclass, stored by :func:`hgo.config.register_configs`),
``claims.py`` (its claims, see :mod:`hgo.claims`), ``figures.py`` and its theory / design
code. Packages are discovered: adding a paper
changes no file outside its own package, ``conf/`` and ``tests/``.
"""

from __future__ import annotations

import importlib
import pkgutil
from types import ModuleType


def paper_names() -> list[str]:
    """The paper packages under ``hgo.papers``, sorted."""
    return sorted(m.name for m in pkgutil.iter_modules(__path__) if m.ispkg)


def paper_modules(module: str) -> list[ModuleType]:
    """``hgo.papers.<paper>.<module>`` of every paper that has one."""
    found = []
    for paper in paper_names():
        name = f"{__name__}.{paper}.{module}"
        try:
            found.append(importlib.import_module(name))
        except ModuleNotFoundError as err:
            if err.name != name:
                raise
    return found
