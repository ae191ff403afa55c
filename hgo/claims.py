"""Claims registry: a paper's claim as data plus the one function that measures it.

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
"""

from __future__ import annotations

import functools
import math
from collections.abc import Callable
from dataclasses import dataclass, field

REPRODUCED = "reproduced"
PARTLY = "partly"
NOT_REPRODUCED = "not reproduced"
THEORY_ONLY = "theory only"
VERDICTS = (REPRODUCED, PARTLY, NOT_REPRODUCED, THEORY_ONLY)


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


_REGISTRY: dict[str, Claim] = {}


def claim(*, paper: str, id: str, where: str, statement: str, verdict: str,
          runs: tuple[str, ...] = (), readings: tuple[str, ...] = (),
          slow: bool = False) -> Callable[[Callable[[], Measured]], Callable[[], Measured]]:
    """Register the decorated function as the check of a claim (see the module docstring)."""
    if verdict not in VERDICTS:
        raise ValueError(f"claim {paper}:{id}: verdict '{verdict}' not in {list(VERDICTS)}")

    def register(check: Callable[[], Measured]) -> Callable[[], Measured]:
        c = Claim(paper, id, where, statement, verdict, check, tuple(runs), tuple(readings),
                  slow)
        if c.key in _REGISTRY and _REGISTRY[c.key].check is not check:
            raise ValueError(f"claim {c.key} is registered twice")
        _REGISTRY[c.key] = c
        return check

    return register


def all_claims(papers: list[str] | None = None) -> list[Claim]:
    """Every registered claim of ``papers`` (default: all), importing each paper's
    ``claims`` module, in paper then definition order."""
    from hgo.papers import paper_modules

    paper_modules("claims")
    return [c for c in _REGISTRY.values() if papers is None or c.paper in papers]


@functools.lru_cache(maxsize=32)
def run_rows(overrides: tuple[str, ...]) -> dict[tuple[str, str], float]:
    """Compose ``overrides``, simulate and post-process (no files written); the metric
    rows as (observer, quantity) -> empirical. Cached: claims that need the same run
    share it. Raises if the run fails."""
    return {(r["observer"], r["quantity"]): r["empirical"]
            for r in run_in_memory(overrides).metrics.to_dict("records")}


@functools.lru_cache(maxsize=8)
def run_in_memory(overrides: tuple[str, ...]):
    """The run of ``overrides`` without files: a :class:`hgo.runner.MemoryRun`."""
    from hgo.runner import simulate_config

    return simulate_config(compose_cached(overrides))


def compose_cached(overrides: tuple[str, ...]):
    """``hgo.config.compose(overrides)``, composing each set of group choices once.

    Hydra's compose costs ~0.1 s, 10x a claim's typical run: an override that sets a
    value already in the config (``key=value``, no group, no ``+``/``~``) is applied to a
    copy of the composed base with the value as Hydra's own parser reads it; anything else
    goes through Hydra."""
    from hydra.core.override_parser.overrides_parser import OverridesParser
    from omegaconf import OmegaConf, open_dict

    from hgo.catalog import groups

    base, values = [], []
    parser = OverridesParser.create()
    group_names = set(groups())
    for text in overrides:
        (o,) = parser.parse_overrides([text])
        plain = (o.type.name == "CHANGE" and not o.is_sweep_override()
                 and o.key_or_group.split("@")[0] not in group_names
                 and "/" not in o.key_or_group)
        if plain:
            values.append(o)
        else:
            base.append(text)
    cfg = _compose_base(tuple(base)).copy()
    for o in values:
        key = o.key_or_group
        node = OmegaConf.select(cfg, key, throw_on_missing=False)
        if node is None or OmegaConf.is_config(node):  # a group or an absent key: Hydra
            return _compose_base(tuple(overrides)).copy()
        with open_dict(cfg):
            OmegaConf.update(cfg, key, o.value(), merge=False)
    return cfg


@functools.lru_cache(maxsize=64)
def _compose_base(overrides: tuple[str, ...]):
    from hgo.config import compose

    return compose(list(overrides))
