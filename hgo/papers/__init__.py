"""What reproducing one paper needs, one package per paper (``hgo/papers/<paper>/``).

A paper package may hold ``config.py`` (its structured-config schemas in a ``SCHEMAS``
mapping ``"<group>/<name>"`` -> dataclass), ``claims.py`` (its claims),
``figures.py`` (``PAPER_FIGURES``), its post-processors (``postprocess.py``) and its
theory / design code. Packages are discovered by :mod:`hgo.core.registry`: adding a
paper changes no file outside its own package, ``conf/`` and ``tests/``.
"""
