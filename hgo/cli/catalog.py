"""``hgo list``: the experiment presets (first line of each header) and every group's options,
hgo's and, with ``--config-dir DIR``, the user's (as ``hgo run --config-dir DIR`` sees them)."""

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


def option_files(roots: list[Path]) -> dict[str, dict[str, Path]]:
    """Group -> option -> its YAML file, over ``roots`` in search order: Hydra takes an
    option from the first folder that has it (hgo's ``conf/`` first, then the user's)."""
    found: dict[str, dict[str, Path]] = {}
    for root in roots:
        for group, options in groups(root).items():
            for option in options:
                found.setdefault(group, {}).setdefault(option, root / group / f"{option}.yaml")
    return {group: dict(sorted(options.items())) for group, options in sorted(found.items())}


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="hgo list", description=__doc__)
    parser.add_argument("--config-dir", "-cd", type=Path, default=None,
                        help="a folder of your own groups and presets (as hgo run --config-dir)")
    args = parser.parse_args(argv)
    roots = [conf_dir()]
    if args.config_dir is not None:
        if not args.config_dir.is_dir():
            parser.exit(2, f"error: --config-dir: '{args.config_dir}' is not a directory\n")
        roots.append(args.config_dir.resolve())
    catalog = option_files(roots)

    def mark(path: Path) -> str:  # the user's options are marked: "vdp (yours)"
        return " (yours)" if len(roots) > 1 and path.is_relative_to(roots[1]) else ""

    print("experiments (hgo run experiment=<name>):")
    for name, path in catalog.get("experiment", {}).items():
        print(f"  {name:16s} {preset_description(path)}{mark(path)}")
    print("\ngroups (hgo run <group>=<option>):")
    for group, options in catalog.items():
        if group != "experiment":
            print(f"  {group:12s} {', '.join(o + mark(p) for o, p in options.items())}")
    return 0
