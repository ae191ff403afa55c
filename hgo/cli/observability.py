"""``hgo observability <overrides>``: Phi, dPhi/dx, its singular set (and its value at x0),
L_f^n h and phi0 of the plant a config composes, e.g. ``hgo observability
plant=lotka_volterra`` or ``hgo observability experiment=lv_eps`` (the plant must be given
by its equations: ``plant=symbolic`` or a preset built on it)."""

from __future__ import annotations

import argparse
import sys
from pathlib import Path


def observability_report(overrides: list[str], config_dir: str | Path | None = None) -> str:
    """The report of :func:`hgo.plants.observability.report` for the plant of the config
    ``overrides`` compose (ConfigError, one line, if it is no plant given by equations)."""
    from hgo.core.components import Plant
    from hgo.core.config import compose
    from hgo.core.errors import ConfigError
    from hgo.plants.observability import report
    from hgo.plants.symbolic import SymbolicPlant
    from hgo.running.runner import _instantiate

    cfg = compose(list(overrides), config_dir=config_dir)
    plant = _instantiate(cfg.plant, "plant", Plant)
    if not isinstance(plant, SymbolicPlant):
        raise ConfigError("plant", f"{plant.name} is not given by its equations (plant="
                          "symbolic or a preset built on it)")
    return report(plant)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="hgo observability", description=__doc__)
    parser.add_argument("overrides", nargs="*", help="Hydra overrides, as for hgo run")
    parser.add_argument("--config-dir", "-cd", type=Path, default=None,
                        help="a folder of your own groups and presets (as hgo run --config-dir)")
    args = parser.parse_args(argv)
    from hgo.core.errors import is_config_error, one_line

    try:
        print(observability_report(args.overrides, args.config_dir))
    except Exception as err:
        if not is_config_error(err):
            raise
        print(f"error: {one_line(err)}", file=sys.stderr)
        return 2
    return 0
