"""What Hydra itself would call or read from a config, checked before it does.

Hydra instantiates ``hydra.callbacks`` and hands ``hydra.job_logging`` to ``logging.config``
(which calls its ``()``/``class`` factories) as soon as it has composed the config, and
loads any option file a path names. :func:`install` (once a process, from
:func:`hgo.core.config.register_configs`) makes every composition (``hgo run``, each job of
a sweep, ``hgo.compose``) check those first (:func:`hgo.core.targets.check_hydra_node`)
and refuse an option whose name has ``..`` (``experiment=../../outside`` loaded a YAML from
outside every config folder).
"""

from __future__ import annotations

from typing import Any

from omegaconf import OmegaConf

from hgo.core.targets import check_hydra_node, check_option_path

_INSTALLED: list[bool] = []


def install() -> None:
    """Wrap Hydra's config loading (idempotent)."""
    if _INSTALLED:
        return
    from hydra._internal.config_loader_impl import ConfigLoaderImpl
    from hydra._internal.config_repository import ConfigRepository

    load_configuration = ConfigLoaderImpl.load_configuration
    load_config = ConfigRepository.load_config

    def checked_configuration(self, *args: Any, **kwargs: Any):
        cfg = load_configuration(self, *args, **kwargs)
        if "hydra" in cfg:  # (unresolved: its run-time values are not set yet)
            check_hydra_node(OmegaConf.to_container(cfg.hydra, resolve=False))
        return cfg

    def checked_config(self, config_path: str):
        check_option_path(config_path)
        return load_config(self, config_path)

    ConfigLoaderImpl.load_configuration = checked_configuration
    ConfigRepository.load_config = checked_config
    _INSTALLED.append(True)
