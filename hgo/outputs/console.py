"""What a run prints: a metrics table that fits 100 columns, one line per sweep job.

The full table stays in ``metrics.csv``; the console shows observer, quantity, value,
bound, ratio and whether the bound holds (✓ / ✗ / vacuous / empty when there is no bound);
for an ensemble, the members' mean, std, min, max and the counts of members ok / failed.
"""

from __future__ import annotations

import math
import textwrap
from pathlib import Path

import pandas as pd

from hgo.outputs.metrics import verdict

WIDTH = 100


def _num(v: float) -> str:
    if not isinstance(v, int | float) or math.isnan(v):
        return ""
    if float(v).is_integer() and abs(v) < 1e9:
        return str(int(v))
    return f"{v:.4g}"


def _clip(text: str, n: int) -> str:
    return text if len(text) <= n else text[: n - 1] + "…"


def _verdict(row, bound: float) -> str:
    """The row's own verdict (its run's vacuous factor), else computed with the default."""
    given = getattr(row, "verdict", None)
    return given if isinstance(given, str) else verdict(float(row.empirical), bound)


def _name_widths(rows: pd.DataFrame, width: int, rest: int) -> tuple[int, int]:
    """Widths of the observer and quantity columns when the others take ``rest``."""
    obs_w = min(16, max(8, *(len(str(o)) for o in rows.observer)))
    return obs_w, width - obs_w - rest - 2


def _notes(rows: pd.DataFrame) -> list[str]:
    """Each row's note (``""`` without one), from a ``note`` column when there is one."""
    if "note" not in rows.columns:
        return [""] * len(rows)
    return ["" if pd.isna(n) else str(n).strip() for n in rows["note"]]


def compact_table(table: pd.DataFrame, width: int = WIDTH) -> str:
    """The metrics of a run in at most ``width`` columns, duplicates dropped; a row with a
    note (the ``note`` column some post-processors fill) is marked ``[k]`` and its note
    is printed whole below the table (wrapped to ``width``)."""
    rows = table.drop_duplicates(subset=["observer", "quantity"])
    notes = _notes(rows)
    distinct = list(dict.fromkeys(n for n in notes if n))
    obs_w, q_w = _name_widths(rows, width, 3 * 11 + 9)
    head = f"{'observer':{obs_w}} {'quantity':{q_w}} {'value':>10} {'bound':>10} " \
           f"{'ratio':>10} {'holds':>8}"
    lines = [head, "-" * len(head)]
    for r, note in zip(rows.itertuples(), notes, strict=True):
        bound = float(r.bound) if pd.notna(r.bound) else math.nan
        mark = f" [{distinct.index(note) + 1}]" if note else ""
        quantity = _clip(str(r.quantity), q_w - len(mark)) + mark
        lines.append(f"{_clip(str(r.observer), obs_w):{obs_w}} {quantity:{q_w}}"
                     f" {_num(r.empirical):>10} {_num(bound):>10} {_num(r.ratio):>10}"
                     f" {_verdict(r, bound):>8}")
    if distinct:
        lines.append("notes:")
        lines += [textwrap.fill(note, width, initial_indent=f"  [{k}] ",
                                subsequent_indent=" " * (len(str(k)) + 5))
                  for k, note in enumerate(distinct, 1)]
    return "\n".join(lines)


def _size(path: Path) -> str:
    n = float(path.stat().st_size)
    for unit in ("B", "KB", "MB", "GB"):
        if n < 1024 or unit == "GB":
            return f"{n:.0f} {unit}" if unit == "B" else f"{n:.1f} {unit}"
        n /= 1024
    return ""


FIGURE_SUFFIXES = (".png", ".pdf", ".svg")


def outputs_listing(out_dir: Path) -> list[str]:
    """What a run wrote, by kind (figures, recording, metrics, provenance), and the commands
    to look at it: the lines printed before ``ok: outputs in <dir>``."""
    out_dir = Path(out_dir)
    files = sorted(p for p in out_dir.iterdir() if p.is_file()) if out_dir.is_dir() else []
    figures = [p for p in files if p.suffix in FIGURE_SUFFIXES]
    lines = ["wrote:"]
    if figures:
        lines.append("  figures    " + ", ".join(p.name for p in figures))
    for name, kind in (("recording.rrd", "recording"), ("metrics.csv", "metrics"),
                       ("run.json", "provenance")):
        if (out_dir / name).is_file():
            lines.append(f"  {kind:10s} {name} ({_size(out_dir / name)})")
    if (out_dir / "recording.rrd").is_file():
        lines.append(f"view:  hgo view {out_dir}   (no display: --web)")
    if not figures and (out_dir / "recording.rrd").is_file():
        lines.append(f"plot:  hgo plot {out_dir}   (states, estimates and errors)")
    return lines


def ensemble_table(aggregate: pd.DataFrame, width: int = WIDTH) -> str:
    """An ensemble's aggregate rows (member ``all``) in at most ``width`` columns: mean
    (``empirical``), std, min, max over the members, and the members ok / failed."""
    rows = aggregate.drop_duplicates(subset=["observer", "quantity"])
    obs_w, q_w = _name_widths(rows, width, 4 * 11 + 2 * 7)
    head = (f"{'observer':{obs_w}} {'quantity':{q_w}} {'mean':>10} {'std':>10} {'min':>10} "
            f"{'max':>10} {'ok':>6} {'failed':>6}")
    lines = [head, "-" * len(head)]
    for r in rows.itertuples():
        observer = "" if pd.isna(r.observer) else str(r.observer)
        lines.append(f"{_clip(observer, obs_w):{obs_w}} {_clip(str(r.quantity), q_w):{q_w}}"
                     f" {_num(r.empirical):>10} {_num(r.std):>10} {_num(r.min):>10}"
                     f" {_num(r.max):>10} {_num(r.n_ok):>6} {_num(r.n_failed):>6}")
    return "\n".join(lines)


def job_line(k: int, n: int | None, overrides: list[str], status: str,
             key_metric: tuple[str, float] | None) -> str:
    """``[k/N] overrides -> status, metric = value`` (``[k]`` when N is unknown)."""
    head = f"[{k}/{n}]" if n else f"[{k}]"
    tail = f", {key_metric[0]} = {_num(key_metric[1])}" if key_metric else ""
    return f"{head} {' '.join(overrides) or '(no overrides)'} → {status}{tail}"
