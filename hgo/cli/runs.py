"""``hgo runs``, ``hgo show <run>``, ``hgo export <run or .rrd>`` (see :mod:`hgo.outputs.runs`)."""

from __future__ import annotations

import argparse
import math
import re
import sys
import warnings
from pathlib import Path

import pandas as pd

from hgo.core.errors import one_line
from hgo.outputs.integrity import Damaged, check_run
from hgo.outputs.runs import BadRunRecord, load, read_run_json
from hgo.outputs.user_code import differences

SHOWN = ["path", "run_name", "status", "started", "seconds.simulate"]


def _error(message: str) -> int:
    print(f"error: {message}", file=sys.stderr)
    return 2


def _damaged(err: Damaged) -> int:
    """A run's file changed since the run (:mod:`hgo.outputs.integrity`): one line, exit 1."""
    print(f"error: {err}", file=sys.stderr)
    return 1


_CONDITION = re.compile(r"^(?P<key>[^=!<>]+?)\s*(?P<op>!=|<=|>=|=|<|>)\s*(?P<value>.*)$")


class WhereError(ValueError):
    """A ``--where`` condition that cannot be applied (one line)."""


def _number(text: str) -> float | None:
    try:
        value = float(text)
    except ValueError:
        return None
    return value if math.isfinite(value) or text.strip().lower() in ("inf", "-inf") else None


def _condition(df: pd.DataFrame, cond: str) -> pd.Series:
    """The rows meeting ``key<op>value``: numbers compare as numbers (``p2=8e-3`` finds the
    stored 0.008), text as text (``true``/``false`` in any case)."""
    match = _CONDITION.match(cond)
    if not match:
        raise WhereError(f"--where: '{cond}' needs an operator and a value (allowed: "
                         "KEY=VALUE, KEY!=VALUE, KEY<VALUE, KEY>VALUE, KEY<=VALUE, KEY>=VALUE)")
    key, op, value = match["key"].strip(), match["op"], match["value"].strip()
    col = _column(df, key)
    number = _number(value)
    if number is not None:
        column = pd.to_numeric(df[col].where(df[col].map(lambda v: not isinstance(v, bool))),
                               errors="coerce")
        found = {"=": column == number, "!=": column != number, "<": column < number,
                 ">": column > number, "<=": column <= number, ">=": column >= number}[op]
        return found & column.notna() if op != "!=" else found
    if op not in ("=", "!="):
        raise WhereError(f"--where: '{cond}': {op} needs a number, got '{value}'")
    text = df[col].map(lambda v: str(v).lower() if isinstance(v, bool) else str(v))
    wanted = value.lower() if value.lower() in ("true", "false") else value
    return text == wanted if op == "=" else text != wanted


def _column(df: pd.DataFrame, key: str) -> str:
    """The column of ``key``: a provenance column, ``config.<key>``, or the one config key
    ending in ``.<key>`` (``p2`` for ``observer.sign_indefinite.p2``)."""
    for col in (key, f"config.{key}"):
        if col in df.columns:
            return col
    found = [c for c in df.columns if c.startswith("config.") and c.endswith(f".{key}")]
    if len(found) > 1:
        raise WhereError(f"--where: '{key}' matches {len(found)} config keys (allowed: one "
                         f"of {', '.join(c.removeprefix('config.') for c in found[:5])})")
    if not found:
        raise KeyError(key)
    return found[0]


def _select(df: pd.DataFrame, where: list[str]) -> pd.DataFrame:
    """Rows meeting every condition (:func:`_condition`) on a ``config.<key>`` (or a
    provenance column)."""
    for cond in where:
        df = df[_condition(df, cond)]
    return df


def _metric_columns(df: pd.DataFrame, names: list[str]) -> list[str]:
    return [c for c in df.columns if c.startswith("metric.")
            and any(c.endswith(f"/{n}") or c == f"metric.{n}" for n in names)]


def runs(argv: list[str]) -> int:
    parser = argparse.ArgumentParser(prog="hgo runs", description="Every run under a folder.")
    parser.add_argument("--root", default="outputs")
    parser.add_argument("--where", nargs="*", default=[], metavar="KEY=VALUE",
                        help="keep runs whose config key (dotted) meets this: KEY=VALUE, "
                             "!=, <, >, <=, >= (numbers compare as numbers)")
    parser.add_argument("--metrics", default="", help="comma-separated quantities to show")
    parser.add_argument("--compare", nargs=2, metavar=("A", "B"),
                        help="two run directories: config and metric differences")
    args = parser.parse_args(argv)
    if args.compare:
        return compare(*args.compare)
    skipped: list[str] = []
    df = load(args.root, skipped)
    for line in skipped:  # one line each; the other runs are listed
        print(f"skipped: {line}", file=sys.stderr)
    if df.empty:
        print(f"no runs under {args.root}")
        return 0
    try:
        df = _select(df, args.where)
    except KeyError as err:
        return _error(f"--where: no config key {err} in the runs under {args.root}")
    except WhereError as err:
        return _error(str(err))
    metrics = _metric_columns(df, [m for m in args.metrics.split(",") if m])
    if args.metrics and not metrics:
        return _error(f"--metrics: no run has a quantity named {args.metrics}")
    table = df[[c for c in SHOWN if c in df.columns] + metrics].copy()
    table.columns = [c.removeprefix("metric.").removeprefix("seconds.") for c in table.columns]
    with pd.option_context("display.max_colwidth", 60, "display.width", 200):
        print(table.to_string(index=False))
    print(f"{len(table)} run(s)")
    return 0


def compare(a: str, b: str) -> int:
    """Config keys and metrics that differ between two runs, side by side."""
    try:
        for run in (a, b):
            check_run(Path(run), only={"run.json"})
        ia, ib = read_run_json(Path(a)), read_run_json(Path(b))
    except BadRunRecord as err:
        return _error(f"--compare: {err}")
    except Damaged as err:
        return _damaged(err)
    for section in ("config", "metrics"):
        sa, sb = ia.get(section, {}), ib.get(section, {})
        keys = sorted(set(sa) | set(sb))
        diff = [(k, sa.get(k), sb.get(k)) for k in keys if sa.get(k) != sb.get(k)]
        print(f"{section}: {len(diff)} difference(s)")
        for k, va, vb in diff:
            print(f"  {k:50s} {va!s:>22} {vb!s:>22}")
    code = differences(ia.get("user_code") or {}, ib.get("user_code") or {})
    print(f"user code: {len(code)} difference(s)")
    for k, va, vb in code:
        print(f"  {k}\n    A: {va}\n    B: {vb}")
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
    try:  # sizes of all its files, hashes of those shown
        check_run(run_dir, hashed={"run.json", "metrics.csv"})
        info = read_run_json(run_dir)
    except BadRunRecord as err:
        return _error(f"run: {err}")
    except Damaged as err:
        return _damaged(err)
    print(f"{run_dir}\nstatus: {info.get('status', '?')}   started "
          f"{info.get('started', '?')}   seconds {info.get('seconds', {})}")
    print(f"hgo {info.get('hgo', '?')} commit {info.get('git_commit', '?')}"
          f"{' (dirty)' if info.get('git_dirty') else ''}   command: "
          f"{info.get('command', '?')}")
    config = run_dir / ".hydra" / "config.yaml"
    if config.exists():
        print("\nconfig (.hydra/config.yaml):\n" + config.read_text(errors="replace"))
    metrics = run_dir / "metrics.csv"
    if metrics.exists():
        try:
            print("metrics (metrics.csv):\n" + compact_table(pd.read_csv(metrics)))
        except Exception as err:  # noqa: BLE001 - pandas' errors for a damaged file vary
            print(f"warning: {metrics} unreadable ({one_line(err)})", file=sys.stderr)
    return 0


def export(argv: list[str]) -> int:
    from hgo.outputs.recording import atomic_output, read_recording

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
    if not out.parent.is_dir():
        return _error(f"--out: folder {out.parent} does not exist")
    try:
        check_run(rrd.parent, only={rrd.name})
    except Damaged as err:
        return _damaged(err)
    try:
        with warnings.catch_warnings():  # (Rerun's warning about a footer; the line says it)
            warnings.simplefilter("ignore")
            df = read_recording(rrd)
    except ValueError as err:  # not a recording, truncated (RecordingIncomplete)
        return _error(f"source: {one_line(err)}")
    try:  # under <out>.partial until complete: never a truncated file under its name
        with atomic_output(out) as partial:
            if args.format == "csv":
                df.to_csv(partial)
            else:
                df.to_parquet(partial)
    except OSError as err:
        return _error(f"--out: {one_line(err)}")
    print(f"wrote {out} ({len(df)} rows x {df.shape[1]} series)")
    return 0
