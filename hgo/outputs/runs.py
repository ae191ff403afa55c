"""Experiment tracking: ``run.json`` in every run directory, and the index of all runs.

``run.json`` holds the provenance of a run (hgo version, git commit and dirty flag when run
from a checkout, versions of Python and the numerical libraries, host, command line, start
and end time, compile / simulate / write times, seed, status), its resolved config
flattened to dotted keys, and its metrics as ``<observer>/<quantity>`` -> empirical value.
The index reads only these files, so listing 1,000 runs takes a fraction of a second::

    import hgo.outputs.runs
    df = hgo.outputs.runs.load("outputs")   # one row per run: path, status, config.*, metric.*
    p2 = df["config.observer.sign_indefinite.p2"]
    df[p2 > 0.01]["metric.sign_indefinite/mean_sq_output_error"]

``hgo runs`` prints the same table (``--where key=value``, ``--metrics q1,q2``,
``--compare A B``); ``hgo show <run>`` one run; ``hgo export <run> --format csv``.
"""

from __future__ import annotations

import json
import math
import os
import platform
import socket
import subprocess
import sys
from datetime import datetime
from importlib.metadata import PackageNotFoundError, version
from pathlib import Path

import pandas as pd

from hgo.outputs.user_code import user_code

ROOT = Path(__file__).resolve().parents[2]
LIBRARIES = ("numpy", "numba", "rerun-sdk", "hydra-core", "scipy", "pandas")


def git_state(root: Path = ROOT) -> dict[str, object]:
    """Commit and dirty flag of the checkout hgo runs from (empty outside a checkout)."""
    try:
        sha = subprocess.run(["git", "-C", str(root), "rev-parse", "HEAD"], capture_output=True,
                             text=True, check=True, timeout=5).stdout.strip()
        dirty = subprocess.run(["git", "-C", str(root), "status", "--porcelain", "--", "hgo",
                                "conf"], capture_output=True, text=True, check=True,
                               timeout=5).stdout.strip()
    except (OSError, subprocess.SubprocessError):
        return {}
    return {"git_commit": sha, "git_dirty": bool(dirty)}


def _version(package: str) -> str:
    try:
        return version(package)
    except PackageNotFoundError:
        return "not installed"


def flatten(node: object, prefix: str = "") -> dict[str, object]:
    """Nested dicts -> dotted keys; lists stay values (as JSON text)."""
    if isinstance(node, dict):
        out = {}
        for k, v in node.items():
            out.update(flatten(v, f"{prefix}{k}."))
        return out
    return {prefix[:-1]: json.dumps(node) if isinstance(node, list) else node}


def _finite(value: float) -> float | None:
    return float(value) if isinstance(value, int | float) and math.isfinite(value) else None


def metrics_summary(table: pd.DataFrame | None) -> dict[str, float | None]:
    """``<observer>/<quantity>`` -> empirical (first of duplicates), JSON-safe."""
    if table is None:
        return {}
    out: dict[str, float | None] = {}
    for obs, q, v in zip(table["observer"], table["quantity"], table["empirical"], strict=True):
        out.setdefault(f"{obs}/{q}", _finite(v))
    return out


def write_run_json(out_dir: Path, config: dict, status: str, started: datetime,
                   timings: dict[str, float], metrics: pd.DataFrame | None) -> Path:
    """Write ``out_dir/run.json`` (see the module docstring)."""
    info = {
        "hgo": _version("hgo"), **git_state(),
        "python": platform.python_version(),
        **{lib: _version(lib) for lib in LIBRARIES},
        "host": socket.gethostname(), "command": " ".join(sys.argv),
        "cwd": os.getcwd(), "started": started.isoformat(timespec="seconds"),
        "ended": datetime.now().isoformat(timespec="seconds"),
        "seconds": {k: round(v, 4) for k, v in timings.items()},
        "run_name": config.get("run_name"), "seed": config.get("seed"), "status": status,
        "config": flatten({k: v for k, v in config.items() if k != "hydra"}),
        "metrics": metrics_summary(metrics),
        # the user's modules behind the config's _target_s (hgo.outputs.user_code)
        "user_code": user_code(config),
    }
    path = Path(out_dir) / "run.json"
    partial = path.with_name("run.json.partial")  # renamed when complete
    partial.write_text(json.dumps(info, indent=1, default=str))
    partial.replace(path)
    return path


def run_dirs(root: str | Path = "outputs") -> list[Path]:
    """Every directory under ``root`` holding a ``run.json``, newest first."""
    paths = [p.parent for p in Path(root).rglob("run.json")]

    def mtime(p: Path) -> float:
        try:
            return p.stat().st_mtime
        except OSError:  # removed meanwhile
            return 0.0
    return sorted(paths, key=mtime, reverse=True)


class BadRunRecord(ValueError):
    """A ``run.json`` that is not a run's record (damaged, truncated, another file)."""


SECTIONS = ("config", "metrics", "seconds")  # the mappings of a run.json


def read_run_json(run_dir: str | Path) -> dict:
    """``run_dir/run.json`` as a dict whose sections are mappings, else
    :class:`BadRunRecord` with one line saying why (``[]``, ``{"config": 5}``, truncated)."""
    path = Path(run_dir) / "run.json"
    try:
        info = json.loads(path.read_text())
    except OSError as err:
        raise BadRunRecord(f"{path}: cannot be read ({err.strerror or err})") from None
    except (json.JSONDecodeError, UnicodeDecodeError) as err:
        raise BadRunRecord(f"{path}: not valid JSON (truncated?): {err}") from None
    if not isinstance(info, dict):
        raise BadRunRecord(f"{path}: not a run record (a JSON {type(info).__name__}, not an "
                           "object)")
    for section in SECTIONS:
        if not isinstance(info.get(section, {}), dict):
            raise BadRunRecord(f"{path}: not a run record ('{section}' is "
                               f"{json.dumps(info[section])[:40]}, not an object)")
    return info


def load(root: str | Path = "outputs", skipped: list[str] | None = None) -> pd.DataFrame:
    """One row per run under ``root``: ``path``, provenance columns, ``config.<key>`` and
    ``metric.<observer>/<quantity>``. A damaged ``run.json`` is left out; with ``skipped``
    its one-line reason is appended there."""
    rows = []
    for d in run_dirs(root):
        try:
            info = read_run_json(d)
        except BadRunRecord as err:
            if skipped is not None:
                skipped.append(str(err))
            continue
        row = {"path": str(d), **{k: v for k, v in info.items()
                                   if k not in ("config", "metrics", "seconds", "user_code")}}
        row.update({f"seconds.{k}": v for k, v in info.get("seconds", {}).items()})
        row.update({f"config.{k}": v for k, v in info.get("config", {}).items()})
        row.update({f"metric.{k}": v for k, v in info.get("metrics", {}).items()})
        rows.append(row)
    return pd.DataFrame(rows)
