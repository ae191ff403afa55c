"""One composition of the config for a single ``hgo run`` (Hydra 1.3 makes two).

Hydra's ``_run_hydra`` composes the config once to read ``hydra.mode``
(``Hydra.get_mode``: MULTIRUN composition rules, sweep overrides not checked) and again to
run it (``Hydra.run``: RUN rules, with the override ``hydra.mode=RUN`` added when the
config sets no mode). Each takes ~0.35 s of a warm run's ~4 s on our 2-core VM.

Inside :func:`composed_once` (a command line without ``-m``), ``get_mode`` composes by RUN
rules and keeps the config. ``run``'s composition, asked for with the same config name and the
overrides ``get_mode`` saw (plus ``hydra.mode=RUN`` when Hydra adds it), is then that config
with what composing again would change: the RUN check of sweep overrides (``a=1,2``
without ``-m`` is refused with Hydra's message), ``hydra.mode`` set to RUN with its
override recorded in ``hydra.overrides.hydra``, and the logging set-up. Everything else
takes Hydra's own path: a composition error (Hydra composes again and reports it), a
config whose ``hydra.mode`` is MULTIRUN (a sweep preset), any other composition.
``tests/test_compose_once.py`` checks the config is the one Hydra composes.
"""

from __future__ import annotations

from collections.abc import Iterator
from contextlib import contextmanager
from typing import Any

from hydra._internal.config_loader_impl import ConfigLoaderImpl
from hydra._internal.hydra import Hydra
from hydra.core.override_parser.overrides_parser import OverridesParser
from hydra.types import RunMode

RUN_OVERRIDE = "hydra.mode=RUN"  # what Hydra's _run_app adds when the config sets no mode

_HYDRA_GET_MODE = Hydra.get_mode
_HYDRA_COMPOSE = Hydra.compose_config
_kept: dict[str, Any] = {}  # "run": (config_name, overrides of the run, config, mode added)


def _get_mode(self: Hydra, config_name: str | None, overrides: list[str]) -> Any:
    """Hydra's ``get_mode``, composing by RUN rules and keeping the config for the run."""
    _kept.clear()
    try:
        cfg = _HYDRA_COMPOSE(self, config_name=config_name, overrides=overrides,
                             run_mode=RunMode.RUN, validate_sweep_overrides=False)
    except Exception:  # noqa: BLE001  (Hydra's own path: its answer, its error report)
        return _HYDRA_GET_MODE(self, config_name, overrides)
    mode = cfg.hydra.mode
    if mode is None or mode == RunMode.RUN:
        added = mode is None
        _kept["run"] = (config_name, [*overrides, *([RUN_OVERRIDE] if added else [])], cfg,
                        added)
    return mode


def _compose_config(self: Hydra, config_name: str | None, overrides: list[str],
                    run_mode: RunMode, with_log_configuration: bool = False,
                    from_shell: bool = True, validate_sweep_overrides: bool = True) -> Any:
    """Hydra's ``compose_config``; the run's config kept by :func:`_get_mode` when it is
    the one asked for."""
    kept = _kept.pop("run", None)
    if (kept is None or run_mode != RunMode.RUN or (config_name, list(overrides)) != kept[:2]
            or not (from_shell and validate_sweep_overrides)):
        return _HYDRA_COMPOSE(self, config_name, overrides, run_mode, with_log_configuration,
                              from_shell, validate_sweep_overrides)
    _, _, cfg, added = kept
    parsed = OverridesParser.create().parse_overrides(overrides=overrides)
    ConfigLoaderImpl.validate_sweep_overrides_legal(parsed, RunMode.RUN, from_shell=True)
    if added:
        cfg.hydra.mode = RunMode.RUN
        cfg.hydra.overrides.hydra.append(RUN_OVERRIDE)
    if with_log_configuration:
        from hydra._internal import hydra as hydra_module
        from hydra.core.utils import configure_log

        configure_log(cfg.hydra.hydra_logging, cfg.hydra.verbose)
        hydra_module.log = hydra_module.logging.getLogger(hydra_module.__name__)
        self._print_debug_info(config_name, overrides, run_mode)
    return cfg


@contextmanager
def composed_once() -> Iterator[None]:
    """Hydra's two compositions of a single run made as one inside this block (module
    doc); Hydra's own methods again after it."""
    Hydra.get_mode, Hydra.compose_config = _get_mode, _compose_config
    try:
        yield
    finally:
        Hydra.get_mode, Hydra.compose_config = _HYDRA_GET_MODE, _HYDRA_COMPOSE
        _kept.clear()
