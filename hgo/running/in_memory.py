"""Runs of a set of overrides in memory, cached: what a claim's check measures.

``run_rows(overrides)`` composes, simulates and post-processes without writing files, and
caches the result so that claims that need the same run share it.
"""

from __future__ import annotations

import functools
from collections import OrderedDict


@functools.lru_cache(maxsize=1024)  # (small dicts: AK's trade-off sweeps ask for 80 runs twice)
def run_rows(overrides: tuple[str, ...]) -> dict[tuple[str, str], float]:
    """Compose ``overrides``, simulate and post-process (no files written); the metric
    rows as (observer, quantity) -> empirical. Cached: claims that need the same run
    share it. Raises if the run fails."""
    return {(r["observer"], r["quantity"]): r["empirical"]
            for r in run_in_memory(overrides).metrics.to_dict("records")}


RUNS_KEPT = 16  # (every run of a paper's claims: 14 at most, Moreno/APA)
_runs: OrderedDict[str, object] = OrderedDict()  # composed config -> its run, latest last


def run_in_memory(overrides: tuple[str, ...]):
    """The run of ``overrides`` without files: a :class:`hgo.running.runner.MemoryRun`.
    The last :data:`RUNS_KEPT` runs are kept by their composed config, so overrides that
    compose the same config share one run (Dimassi et al.'s claims ask for the nominal run
    in four spellings)."""
    from hgo.running.runner import simulate_config

    key, cfg = _composed(overrides)
    if key not in _runs:
        _runs[key] = simulate_config(cfg)
        if len(_runs) > RUNS_KEPT:
            _runs.popitem(last=False)
    _runs.move_to_end(key)
    return _runs[key]


@functools.lru_cache(maxsize=64)
def _composed(overrides: tuple[str, ...]):
    """(the job config's YAML, the composed config) of ``overrides``."""
    from hgo.running.runner import job_config_yaml

    cfg = compose_cached(overrides)
    return job_config_yaml(cfg), cfg


def forget_runs() -> None:
    """Drop every kept run (:func:`run_in_memory`, :func:`run_rows`): the next paper's
    claims ask for other runs."""
    _composed.cache_clear()
    run_rows.cache_clear()
    _runs.clear()


def compose_cached(overrides: tuple[str, ...]):
    """``hgo.core.config.compose(overrides)``, composing each set of group choices once.

    Hydra's compose costs ~0.1 s, 10x a claim's typical run: an override that sets a
    value or a list already in the config (``key=value``, no group, no ``+``/``~``) is
    applied to a copy of the composed base with the value as Hydra's own parser reads it
    and as Hydra applies it (``OmegaConf.update(..., merge=True)``: a list replaced);
    anything else goes through Hydra."""
    from hydra.core.override_parser.overrides_parser import OverridesParser
    from omegaconf import OmegaConf, open_dict

    from hgo.core.config import groups

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
        value = o.value()
        if not _is_value(cfg, key, value):  # a group, a dict node or an absent key: Hydra
            return _compose_base(tuple(overrides)).copy()
        with open_dict(cfg):
            OmegaConf.update(cfg, key, value, merge=True)
    return cfg


def _is_value(cfg, key: str, new) -> bool:
    """``key`` names a leaf value of ``cfg`` (a null one too: ``figures.vector: null``,
    which every ``hgo reproduce`` job sets, composed through Hydra again cost ~0.25 s a
    job) or a list that ``new`` is a list for (``plant.x0=[1.0,0.0]``: Moreno's claims
    composed 6 runs through Hydra again, ~0.25 s each; anything else there: Hydra's
    error), not a dict node or an absent key."""
    from omegaconf import OmegaConf, ValueNode

    absent = object()
    value = OmegaConf.select(cfg, key, default=absent, throw_on_missing=False)
    if value is absent or OmegaConf.is_dict(value):
        return False
    if OmegaConf.is_list(value):
        return isinstance(new, list)
    if value is not None:
        return True
    parent, _, leaf = key.rpartition(".")
    container = OmegaConf.select(cfg, parent) if parent else cfg
    return OmegaConf.is_dict(container) and isinstance(container._get_node(leaf), ValueNode)


@functools.lru_cache(maxsize=64)
def _compose_base(overrides: tuple[str, ...]):
    """The composed config without Hydra's own node (``hydra``: its run directory, job
    and help texts), which nothing run in memory reads: copying it was 40 % of the ~45 ms
    that :func:`compose_cached` spent copying the base for each claim's run."""
    from omegaconf import open_dict

    from hgo.core.config import compose

    cfg = compose(list(overrides))
    with open_dict(cfg):
        del cfg["hydra"]
    return cfg
