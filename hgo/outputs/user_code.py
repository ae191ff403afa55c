"""The user's own code in a run's provenance: every module a ``_target_`` of the config
loaded that is not hgo's nor an installed package's, with its path and sha256, and the git
commit and dirty flag of the repository it lives in (``run.json``'s ``user_code``).

``hgo runs --compare A B`` lists a module whose hash, commit or dirty flag differs: the
same config run twice gives other results when the code behind a ``_target_`` changed.
"""

from __future__ import annotations

import hashlib
import subprocess
import sys
import sysconfig
from pathlib import Path

HGO = Path(__file__).resolve().parents[1]  # the hgo package
INSTALLED = {Path(p).resolve() for p in {sysconfig.get_paths()["purelib"],
                                           sysconfig.get_paths()["platlib"],
                                           sysconfig.get_paths()["stdlib"]}}


def targets(node: object) -> list[str]:
    """Every ``_target_`` string of a config (nested dicts and lists), in order."""
    found: list[str] = []
    if isinstance(node, dict):
        if isinstance(node.get("_target_"), str):
            found.append(node["_target_"])
        for value in node.values():
            found += targets(value)
    elif isinstance(node, list):
        for value in node:
            found += targets(value)
    return found


def _module_of(target: str):
    """The loaded module that ``target`` (``module.function``, ``pkg.mod.Class.method``)
    names: its longest dotted prefix in ``sys.modules``."""
    parts = target.split(".")
    for k in range(len(parts) - 1, 0, -1):
        module = sys.modules.get(".".join(parts[:k]))
        if module is not None:
            return module
    return None


def is_users(path: Path) -> bool:
    """A file neither in hgo nor in the interpreter's library or site-packages."""
    return not any(path.is_relative_to(root) for root in (HGO, *INSTALLED))


def git_of(path: Path) -> dict[str, object]:
    """The commit and dirty flag of the git repository holding ``path`` (empty outside
    one)."""
    folder = str(path.parent)
    try:
        sha = subprocess.run(["git", "-C", folder, "rev-parse", "HEAD"], capture_output=True,
                             text=True, check=True, timeout=5).stdout.strip()
        dirty = subprocess.run(["git", "-C", folder, "status", "--porcelain"],
                               capture_output=True, text=True, check=True,
                               timeout=5).stdout.strip()
    except (OSError, subprocess.SubprocessError):
        return {}
    return {"git_commit": sha, "git_dirty": bool(dirty)}


def user_code(config: dict) -> dict[str, dict[str, object]]:
    """Module name -> {path, sha256, git_commit, git_dirty} for every user module a
    ``_target_`` of ``config`` (a resolved container) loaded."""
    out: dict[str, dict[str, object]] = {}
    for target in targets(config):
        module = _module_of(target)
        file = getattr(module, "__file__", None)
        if module is None or file is None or module.__name__ in out:
            continue
        path = Path(file).resolve()
        if not is_users(path) or not path.is_file():
            continue
        out[module.__name__] = {"path": str(path),
                                "sha256": hashlib.sha256(path.read_bytes()).hexdigest(),
                                **git_of(path)}
    return out


def differences(a: dict, b: dict) -> list[tuple[str, object, object]]:
    """(``module.field``, A's value, B's value) for every field of the user modules of two
    runs that differs (a module in one run only: its sha256 against None)."""
    rows = []
    for name in sorted(set(a) | set(b)):
        ma, mb = a.get(name) or {}, b.get(name) or {}
        for field in ("sha256", "path", "git_commit", "git_dirty"):
            if ma.get(field) != mb.get(field):
                rows.append((f"{name}.{field}", ma.get(field), mb.get(field)))
    return rows
