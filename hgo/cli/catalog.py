"""``hgo list``: the experiment presets (first line of each header) and every group's options."""

from __future__ import annotations

import argparse
from pathlib import Path

from hgo.core.config import conf_dir, groups


def preset_description(path: Path) -> str:
    """The first comment line of a preset after ``# @package``, without the ``#``."""
    for line in path.read_text().splitlines():
        text = line.lstrip("#").strip()
        if line.startswith("#") and text and not text.startswith("@package"):
            return text
        if line and not line.startswith("#"):
            break
    return ""


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="hgo list", description=__doc__)
    parser.parse_args(argv)
    root = conf_dir()
    print("experiments (hgo run experiment=<name>):")
    for name in groups(root)["experiment"]:
        print(f"  {name:16s} {preset_description(root / 'experiment' / f'{name}.yaml')}")
    print("\ngroups (hgo run <group>=<option>):")
    for group, options in groups(root).items():
        if group != "experiment":
            print(f"  {group:12s} {', '.join(options)}")
    return 0
