"""``hgo runs``, ``hgo show <run>``, ``hgo export <run or .rrd>`` (see :mod:`hgo.outputs.runs`)."""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

import pandas as pd

from hgo.outputs.runs import load

SHOWN = ["path", "run_name", "status", "started", "seconds.simulate"]


def _error(message: str) -> int:
    print(f"error: {message}", file=sys.stderr)
    return 2


def _select(df: pd.DataFrame, where: list[str]) -> pd.DataFrame:
    """Rows whose ``config.<key>`` (or provenance column) equals the value as text."""
    for cond in where:
        key, _, value = cond.partition("=")
        col = key if key in df.columns else f"config.{key}"
        if col not in df.columns:
            raise KeyError(key)
        df = df[df[col].astype(str) == value]
    return df


def _metric_columns(df: pd.DataFrame, names: list[str]) -> list[str]:
    return [c for c in df.columns if c.startswith("metric.")
            and any(c.endswith(f"/{n}") or c == f"metric.{n}" for n in names)]


def runs(argv: list[str]) -> int:
    parser = argparse.ArgumentParser(prog="hgo runs", description="Every run under a folder.")
    parser.add_argument("--root", default="outputs")
    parser.add_argument("--where", nargs="*", default=[], metavar="KEY=VALUE",
                        help="keep runs whose config key (dotted) has this value")
    parser.add_argument("--metrics", default="", help="comma-separated quantities to show")
    parser.add_argument("--compare", nargs=2, metavar=("A", "B"),
                        help="two run directories: config and metric differences")
    args = parser.parse_args(argv)
    if args.compare:
        return compare(*args.compare)
    df = load(args.root)
    if df.empty:
        print(f"no runs under {args.root}")
        return 0
    try:
        df = _select(df, args.where)
    except KeyError as err:
        return _error(f"--where: no config key {err} in the runs under {args.root}")
    metrics = _metric_columns(df, [m for m in args.metrics.split(",") if m])
    if args.metrics and not metrics:
        return _error(f"--metrics: no run has a quantity named {args.metrics}")
    table = df[[c for c in SHOWN if c in df.columns] + metrics].copy()
    table.columns = [c.removeprefix("metric.").removeprefix("seconds.") for c in table.columns]
    with pd.option_context("display.max_colwidth", 60, "display.width", 200):
        print(table.to_string(index=False))
    print(f"{len(table)} run(s)")
    return 0


def _info(run_dir: Path) -> dict:
    return json.loads((run_dir / "run.json").read_text())


def compare(a: str, b: str) -> int:
    """Config keys and metrics that differ between two runs, side by side."""
    try:
        ia, ib = _info(Path(a)), _info(Path(b))
    except OSError as err:
        return _error(f"--compare: {err.filename} has no run.json")
    for section in ("config", "metrics"):
        keys = sorted(set(ia[section]) | set(ib[section]))
        diff = [(k, ia[section].get(k), ib[section].get(k)) for k in keys
                if ia[section].get(k) != ib[section].get(k)]
        print(f"{section}: {len(diff)} difference(s)")
        for k, va, vb in diff:
            print(f"  {k:50s} {va!s:>22} {vb!s:>22}")
    return 0


def show(argv: list[str]) -> int:
    from hgo.outputs.console import compact_table

    parser = argparse.ArgumentParser(prog="hgo show", description="One run: status, config, "
                                     "metrics.")
    parser.add_argument("run", help="run directory (or outputs/latest)")
    args = parser.parse_args(argv)
    run_dir = Path(args.run).resolve()  # outputs/latest is a link
    if not (run_dir / "run.json").exists():
        return _error(f"run: {args.run} has no run.json (not a run directory)")
    info = _info(run_dir)
    print(f"{run_dir}\nstatus: {info['status']}   started {info['started']}   "
          f"seconds {info.get('seconds', {})}")
    print(f"hgo {info['hgo']} commit {info.get('git_commit', '?')}"
          f"{' (dirty)' if info.get('git_dirty') else ''}   command: {info['command']}")
    config = run_dir / ".hydra" / "config.yaml"
    if config.exists():
        print("\nconfig (.hydra/config.yaml):\n" + config.read_text())
    metrics = run_dir / "metrics.csv"
    if metrics.exists():
        print("metrics (metrics.csv):\n" + compact_table(pd.read_csv(metrics)))
    return 0


def export(argv: list[str]) -> int:
    from hgo.outputs.recording import read_recording

    parser = argparse.ArgumentParser(prog="hgo export", description="A recording's series as "
                                     "a table (index sim_time, one column per series).")
    parser.add_argument("source", help="run directory or .rrd file")
    parser.add_argument("--format", choices=("csv", "parquet"), default="csv")
    parser.add_argument("--out", help="output file (default: next to the recording)")
    args = parser.parse_args(argv)
    src = Path(args.source)
    rrd = src / "recording.rrd" if src.is_dir() else src
    if not rrd.is_file():
        return _error(f"source: {rrd} does not exist")
    out = Path(args.out) if args.out else rrd.with_suffix(f".{args.format}")
    df = read_recording(rrd)
    if args.format == "csv":
        df.to_csv(out)
    else:
        df.to_parquet(out)
    print(f"wrote {out} ({len(df)} rows x {df.shape[1]} series)")
    return 0
