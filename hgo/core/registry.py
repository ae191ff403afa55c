"""The paper registry: paper packages found by name, their claims and their figures.

A paper package (``hgo/papers/<paper>/``) registers itself here and imports nothing above
it: its ``config.py`` holds ``SCHEMAS`` (``"<group>/<name>"`` -> dataclass, stored in
Hydra's ConfigStore by :func:`hgo.core.config.register_configs`), its ``claims.py``
registers claims with :func:`claim`, its ``figures.py`` lists ``PAPER_FIGURES``
(:class:`PaperFigure`). The packages are *discovered* (:func:`paper_names`,
:func:`paper_modules`), as plugins are: adding a paper changes no file outside its own
package, ``conf/`` and ``tests/``, and the layers that read the registry (configuration,
``hgo reproduce``, the report) never import a paper.

Claims: a paper's claim as data plus the one function that measures it.

A claim lives in ``hgo/papers/<paper>/claims.py``::

    @claim(paper="moreno", id="strong_observer_converges", where="Section 5, Fig. 1",
           statement="“the observer converges for a = 0”", runs=("experiment=moreno_fig1",),
           readings=("C3: input u = sin(t)",), verdict=REPRODUCED)
    def strong_observer_converges() -> Measured:
        rows = run_rows(("experiment=moreno_fig1",))
        e = rows[("circle", "max_abs_e1_late")]
        return Measured(holds=e < 1e-3, numbers={"max |e1| over [8, 10] s": e},
                        summary="|e1| falls below 1e-3 by t = 8 s")

``verdict`` is declared with the claim (reproduced / partly / not reproduced / theory
only) and ``holds`` is what the function measured *for the paper's statement* (for
``partly``: for the narrower statement that does hold, named in ``summary``). pytest
collects every registered claim as one test (``tests/test_claims.py``): it passes when
``holds`` is true, and a ``not reproduced`` claim is a strict xfail whose reason carries
the numbers. The report of ``hgo reproduce`` reads the same registry, so the tests and
the report cannot disagree.

An entry with ``verdict=HGO_MEASUREMENT`` is not a claim of the paper: it records what hgo
measured on the paper's subject (its ``statement`` says what is measured, ``holds`` that
the measurement's own checks passed); the report and README list it apart.
"""

from __future__ import annotations

import importlib
import itertools
import math
import pkgutil
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from types import ModuleType

PAPERS_PACKAGE = "hgo.papers"


def paper_names() -> list[str]:
    """The paper packages under ``hgo.papers``, sorted."""
    package = importlib.import_module(PAPERS_PACKAGE)
    return sorted(m.name for m in pkgutil.iter_modules(package.__path__) if m.ispkg)


def paper_modules(module: str, papers: list[str] | None = None) -> list[ModuleType]:
    """``hgo.papers.<paper>.<module>`` of every paper (of ``papers``, default all) that has
    one (imported by name)."""
    found = []
    for paper in paper_names() if papers is None else papers:
        name = f"{PAPERS_PACKAGE}.{paper}.{module}"
        try:
            found.append(importlib.import_module(name))
        except ModuleNotFoundError as err:
            if err.name != name:
                raise
    return found


def paper_title(paper: str) -> str:
    """The first line of the paper package's docstring (its citation)."""
    doc = importlib.import_module(f"{PAPERS_PACKAGE}.{paper}").__doc__ or paper
    return doc.strip().splitlines()[0]


@dataclass(frozen=True)
class PaperFigure:
    """A preset whose run (or sweep) draws figures of a paper.

    ``captions`` maps a figure file stem (``fig2`` for ``fig2.png``) to the paper's caption.
    With ``sweep`` (key -> values) the preset runs once per combination, and ``combine``
    (a function of the sweep directory) draws the figures of ``captions`` from the jobs;
    without it the single run draws them.
    """

    preset: str
    captions: dict[str, str]
    overrides: tuple[str, ...] = ()
    sweep: dict[str, tuple] = field(default_factory=dict)
    combine: Callable[[Path], object] | None = None

    def jobs(self) -> list[tuple[str, ...]]:
        """The overrides of every job."""
        base = (f"experiment={self.preset}", *self.overrides)
        if not self.sweep:
            return [base]
        keys = list(self.sweep)
        return [base + tuple(f"{k}={v}" for k, v in zip(keys, combo, strict=True))
                for combo in itertools.product(*(self.sweep[k] for k in keys))]


REPRODUCED = "reproduced"
PARTLY = "partly"
NOT_REPRODUCED = "not reproduced"
THEORY_ONLY = "theory only"
VERDICTS = (REPRODUCED, PARTLY, NOT_REPRODUCED, THEORY_ONLY)
#: not a verdict: an entry that records what hgo measured on a paper's subject, which the
#: paper does not claim (shown apart from the paper's claims in the report and README)
HGO_MEASUREMENT = "hgo's measurement"
LEDGER_KINDS = (*VERDICTS, HGO_MEASUREMENT)


@dataclass(frozen=True)
class Measured:
    """What a claim's function measured: does the statement hold, and the numbers."""

    holds: bool
    numbers: dict[str, float | str] = field(default_factory=dict)
    summary: str = ""

    def describe(self) -> str:
        """One line: the summary, then every number (4 significant digits)."""
        nums = "; ".join(f"{k} = {_fmt(v)}" for k, v in self.numbers.items())
        return f"{self.summary} [{nums}]" if self.summary else nums


def _fmt(value: float | str) -> str:
    if isinstance(value, float) and math.isfinite(value):
        return f"{value:.4g}"
    return str(value)


@dataclass(frozen=True)
class Claim:
    """One statement of a paper, where it is, what it needs, and how it is checked."""

    paper: str
    id: str
    where: str
    statement: str
    verdict: str
    check: Callable[[], Measured]
    runs: tuple[str, ...] = ()
    readings: tuple[str, ...] = ()
    slow: bool = False  # minutes rather than seconds; pytest marks it ``slow``

    @property
    def key(self) -> str:
        return f"{self.paper}:{self.id}"

    @property
    def is_measurement(self) -> bool:
        """hgo's own measurement, not a claim of the paper."""
        return self.verdict == HGO_MEASUREMENT


_REGISTRY: dict[str, Claim] = {}


def claim(*, paper: str, id: str, where: str, statement: str, verdict: str,
          runs: tuple[str, ...] = (), readings: tuple[str, ...] = (),
          slow: bool = False) -> Callable[[Callable[[], Measured]], Callable[[], Measured]]:
    """Register the decorated function as the check of a claim (see the module docstring)."""
    if verdict not in LEDGER_KINDS:
        raise ValueError(f"claim {paper}:{id}: verdict '{verdict}' not in "
                         f"{list(LEDGER_KINDS)}")

    def register(check: Callable[[], Measured]) -> Callable[[], Measured]:
        c = Claim(paper, id, where, statement, verdict, check, tuple(runs), tuple(readings),
                  slow)
        if c.key in _REGISTRY and _REGISTRY[c.key].check is not check:
            raise ValueError(f"claim {c.key} is registered twice")
        _REGISTRY[c.key] = c
        return check

    return register


def all_claims(papers: list[str] | None = None) -> list[Claim]:
    """Every registered claim of ``papers`` (default: all), importing those papers'
    ``claims`` modules only (Moreno's imports cvxpy: ~1.5 s in each worker of ``hgo
    reproduce`` that measures another paper's claims), in paper then definition order."""
    paper_modules("claims", papers)
    order = {paper: k for k, paper in enumerate(paper_names())}  # (modules import on demand)
    chosen = [c for c in _REGISTRY.values() if papers is None or c.paper in papers]
    return sorted(chosen, key=lambda c: order.get(c.paper, len(order)))  # stable: definitions
