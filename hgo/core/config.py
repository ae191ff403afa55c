"""Structured configs: one dataclass schema per config-group option.

Each YAML option in ``conf/<group>/`` starts from a schema stored here under
``schema/<group>/<name>``, so a misspelt key, a wrong type or an unknown option fails
when Hydra composes the config, with Hydra's message naming the full key. A user's own
plant or observer needs no schema: a YAML with ``_target_`` pointing at their factory
is enough (the factory's signature then checks the keys).
"""

from __future__ import annotations

import os
import time
from dataclasses import dataclass, field
from datetime import datetime
from enum import Enum
from pathlib import Path
from typing import Any

from hydra.core.config_store import ConfigStore
from omegaconf import DictConfig, OmegaConf, open_dict

from hgo.core import hydra_guard
from hgo.core.registry import paper_modules
from hgo.core.targets import trust_config_dir


@dataclass
class SPLinearPlantConf:
    """Sanfelice & Praly (18)."""

    _target_: str = "hgo.plants.sp_linear.sp_linear_plant"
    nu1: float = 0.01
    nu2: float = 0.01
    x0: list[float] = field(default_factory=lambda: [-1.0, 0.0])


@dataclass
class TriangularHGOConf:
    """Sanfelice & Praly (5)-(7); ``law`` in {constant, sign_indefinite, dead_zone}."""

    _target_: str = "hgo.observers.triangular.triangular_hgo"
    K: list[float] = field(default_factory=lambda: [2.0, 2.0])
    xhat0: list[float] = field(default_factory=lambda: [3.0, 3.0])
    r0: float = 1.0
    law: str = "sign_indefinite"
    p1: float = 4 / 3
    p2: float = 0.008
    b: float = 0.28
    M: list[Any] | None = None  # rows of numbers (ints accepted; checked by the builder)
    c: list[float] | None = None


@dataclass
class NoiseConf:
    """Sample-and-hold measurement noise; ``kind`` in {none, uniform, gaussian}."""

    _target_: str = "hgo.noise.noise_model"
    kind: str = "none"
    amplitude: float = 0.0
    std: float = 0.0
    period: float = 0.01
    channels: list[int] = field(default_factory=lambda: [0])


@dataclass
class SolverConf:
    """Integrator settings (see :class:`hgo.engine.simulate.SolverSettings`), seconds."""

    method: str = "dopri5"
    t_end: float = 100.0
    dt_out: float = 0.01
    h_max: float = 0.01
    rtol: float = 1e-8
    atol: float = 1e-10
    state_bound: float = 1e6
    stability_safety: float = 0.9
    max_steps: int = 1_000_000_000  # a run stops (failed) after this many steps
    max_output_rows: int = 100_000_000  # larger output grids are refused before the run
    split_observers: bool = False  # each observer with its own copy of the plant


@dataclass
class MetricsConf:
    """Trailing window [t_end - window, t_end] of the mean-error estimates (11)-(12)."""

    window: float = 25.0
    # a bound above vacuous_factor x the measured value is shown as ``vacuous``, not ✓
    vacuous_factor: float = 1e6


@dataclass
class EnsembleConf:
    """``size`` members (0: a single run); ``vary``: dotted key -> [low, high] (scalar) or
    [[low, high], ...] (vector), drawn uniformly with ``seed``; ``grid``: dotted key ->
    value list (Cartesian product, ``size`` replicates per point); ``shard``: "i/N" runs
    the i-th of N blocks of the members; ``reports``: name -> ``_target_`` of
    ``f(result, out_dir)`` (see :mod:`hgo.running.ensemble_runner`)."""

    size: int = 0
    seed: int = 0
    # Optional: ``ensemble.vary=null`` clears a preset's (``={}`` merges, keeping it)
    vary: dict[str, Any] | None = field(default_factory=dict)
    grid: dict[str, Any] | None = field(default_factory=dict)
    shard: str | None = None
    reports: dict[str, Any] = field(default_factory=dict)


class RecordingMode(Enum):
    full = "full"
    decimated = "decimated"
    off = "off"


@dataclass
class RecordingConf:
    """``mode`` in {full, decimated, off} (checked when Hydra composes); ``max_rows``
    (decimated): at most this many rows, the min/max envelope per bucket
    (:mod:`hgo.outputs.decimate`)."""

    mode: RecordingMode = RecordingMode.full
    max_rows: int = 16384


#: Values a YAML file may expand to through its aliases (``*name``): each alias is
#: deep-copied by OmegaConf, so nested anchors (a "billion laughs") grow exponentially.
MAX_ALIAS_VALUES = 100_000


def _expanded_size(node, memo: dict[int, int], limit: int) -> int:
    """Number of YAML nodes of ``node`` once every alias is expanded (stops above limit)."""
    import yaml

    key = id(node)
    if key not in memo:
        memo[key] = 1  # (a recursive alias counts once instead of looping)
        size = 1
        if isinstance(node, yaml.MappingNode):
            children = [n for pair in node.value for n in pair]
        elif isinstance(node, yaml.SequenceNode):
            children = node.value
        else:
            children = []
        for child in children:
            size += _expanded_size(child, memo, limit)
            if size > limit:
                break
        memo[key] = size
    return memo[key]


def bound_yaml_aliases() -> None:
    """Make OmegaConf's YAML loader (used by Hydra for every config file, a user's preset
    included) refuse a file whose aliases expand to more than :data:`MAX_ALIAS_VALUES`
    values, with its file and line (idempotent)."""
    import omegaconf._utils as utils
    import yaml

    original = utils.get_yaml_loader
    if getattr(original, "hgo_bounded", False):
        return

    def get_yaml_loader():
        base = original()

        class BoundedLoader(base):
            def compose_document(self):
                self.hgo_aliases = 0
                node = super().compose_document()
                if self.hgo_aliases and _expanded_size(node, {}, MAX_ALIAS_VALUES) \
                        > MAX_ALIAS_VALUES:
                    raise yaml.composer.ComposerError(
                        None, None, f"its aliases expand to more than {MAX_ALIAS_VALUES:,} "
                        "values (nested anchors?); refused", node.start_mark)
                return node

            def compose_node(self, parent, index):
                if self.check_event(yaml.AliasEvent):
                    self.hgo_aliases += 1
                return super().compose_node(parent, index)

        return BoundedLoader

    get_yaml_loader.hgo_bounded = True
    utils.get_yaml_loader = get_yaml_loader


_REGISTERED: list[bool] = []  # (once per process: the ConfigStore is a process singleton)
_LAST_STAMP: list[str] = []  # the last name run_stamp gave in this process


def run_stamp() -> str:
    """The name of a default run or sweep directory (``${hgo.stamp:}`` in
    ``conf/config.yaml``): local time to the millisecond and this process's id,
    ``2026-12-01_14-21-06.123_4567``. Runs started in the same second never share a
    directory, in one process or several (Hydra's ``${now:}`` to the second did); names
    sort by time. A config resolves it once (the resolver is cached per config, and Hydra
    copies that cache to a sweep's jobs); one process never gives the same name twice."""
    while True:
        now = datetime.now()
        stamp = f"{now:%Y-%m-%d_%H-%M-%S}.{now.microsecond // 1000:03d}_{os.getpid()}"
        if stamp not in _LAST_STAMP:
            _LAST_STAMP[:] = [stamp]
            return stamp
        time.sleep(0.001)


def register_configs() -> None:
    """Store every schema in Hydra's ConfigStore (idempotent). Stored once a process: Hydra
    hands out copies of what is stored, and storing again cost 0.044 s of a 0.19 s compose
    (an ``hgo reproduce`` composes ~50 times)."""
    bound_yaml_aliases()
    hydra_guard.install()  # callbacks, logging factories and option paths checked
    if _REGISTERED:
        return
    OmegaConf.register_new_resolver("hgo.stamp", run_stamp, use_cache=True, replace=True)
    cs = ConfigStore.instance()
    cs.store(group="schema/plant", name="sp_linear", node=SPLinearPlantConf)
    cs.store(group="schema/observer", name="triangular", node=TriangularHGOConf)
    cs.store(group="schema/noise", name="noise", node=NoiseConf)
    cs.store(group="schema/solver", name="solver", node=SolverConf)
    cs.store(group="schema", name="metrics", node=MetricsConf)
    cs.store(group="schema/ensemble", name="ensemble", node=EnsembleConf)
    cs.store(group="schema/recording", name="recording", node=RecordingConf)
    for module in paper_modules("config"):  # each paper's own schemas
        for path, node in module.SCHEMAS.items():
            group, name = path.rsplit("/", 1)
            cs.store(group=f"schema/{group}", name=name, node=node)
    _REGISTERED.append(True)


def conf_dir() -> Path:
    """hgo's configuration: ``hgo/conf`` inside an installed wheel (setup.py ships the
    repository's ``conf/`` there), else the ``conf/`` folder of the checkout hgo runs from
    (an editable install or ``PYTHONPATH``)."""
    package = Path(__file__).resolve().parents[1]  # hgo/
    shipped = package / "conf"
    return shipped if (shipped / "config.yaml").is_file() else package.parent / "conf"


def groups(root: Path | None = None) -> dict[str, list[str]]:
    """Config group -> its options (file stems), ``experiment`` included."""
    root = root or conf_dir()
    return {d.name: sorted(p.stem for p in d.glob("*.yaml"))
            for d in sorted(root.iterdir()) if d.is_dir()}


#: Longest command-line override accepted: Hydra's override parser takes seconds per
#: thousand list values (132 s for a 20,000-value plant.x0 at load ~8), a preset file
#: milliseconds.
MAX_OVERRIDE_CHARS = 20_000


def check_override_lengths(overrides: list[str]) -> None:
    """Refuse an override too long for Hydra's parser, naming its key (ConfigError)."""
    from hgo.core.errors import ConfigError

    for override in overrides:
        if len(override) > MAX_OVERRIDE_CHARS:
            key = override.partition("=")[0].lstrip("+~")
            values = override.count(",") + 1
            raise ConfigError(key, f"the override is {len(override):,} characters (~{values:,} "
                              f"values), over {MAX_OVERRIDE_CHARS:,}: Hydra's parser would take "
                              "minutes", "put long lists in a preset file (a YAML under a "
                              "folder given by hydra.searchpath)")


def search_path_override(config_dir: str | Path | None) -> list[str]:
    """The override adding a user's config folder to hgo's (as ``--config-dir`` does for
    ``hgo run``): its groups and presets join hgo's; where both hold an option of the
    same name, hgo's wins."""
    if config_dir is None:
        return []
    path = Path(config_dir).resolve()
    if not path.is_dir():
        from hgo.core.errors import ConfigError

        raise ConfigError("config_dir", f"'{path}' is not a directory")
    trust_config_dir(path)  # (its modules may be named by _target_: hgo.core.targets)
    return [f"hydra.searchpath=[file://{path}]"]


def compose(overrides: list[str], out_dir: Path | None = None,
            config_dir: str | Path | None = None) -> DictConfig:
    """Compose ``conf/config.yaml`` with ``overrides`` as ``experiments/run.py`` would
    (Hydra's node included); with ``out_dir``, Hydra's run directory is set to it; with
    ``config_dir``, a user's config folder adds its groups and presets
    (:func:`search_path_override`)."""
    from hydra import compose as hydra_compose
    from hydra import initialize_config_dir
    from hydra.core.global_hydra import GlobalHydra
    from hydra.core.hydra_config import HydraConfig

    check_override_lengths(overrides)
    register_configs()
    GlobalHydra.instance().clear()
    overrides = [*search_path_override(config_dir), *overrides]
    with initialize_config_dir(version_base="1.3", config_dir=str(conf_dir())):
        cfg = hydra_compose("config", overrides=overrides, return_hydra_config=True)
    if out_dir is not None:
        with open_dict(cfg):
            cfg.hydra.runtime.output_dir = str(out_dir)
        HydraConfig.instance().set_config(cfg)
    return cfg
