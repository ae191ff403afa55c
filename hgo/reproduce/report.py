"""The report of ``hgo reproduce``: ``report.md`` and a self-contained ``report.html``.

Both are written from one structure (:class:`Section` per paper), so they say the same:
a summary (paper x verdict counts, wall time, machine, hgo version and commit), then per
paper its figures with the paper's captions, the claims ledger (statement, measured,
verdict, readings, whether the measurement agrees with the verdict) and the bound tables
(empirical, theoretical, ratio, holds / vacuous).
"""

from __future__ import annotations

import base64
import html
import json
import math
import os
import platform
import shutil
import subprocess
from dataclasses import dataclass, field
from datetime import datetime
from importlib.metadata import version
from pathlib import Path

import pandas as pd

from hgo.core.registry import NOT_REPRODUCED, VERDICTS, all_claims, paper_names, paper_title
from hgo.outputs.metrics import verdict


@dataclass
class FigureEntry:
    paper: str
    stem: str
    caption: str
    source: Path  # the PNG in its run or sweep directory
    run: str  # the command that made it


@dataclass
class Section:
    paper: str
    title: str
    figures: list[FigureEntry] = field(default_factory=list)
    claims: list[dict] = field(default_factory=list)
    bounds: pd.DataFrame | None = None


def agreement(verdict: str, holds: bool | None) -> str:
    """Whether a claim's measurement agrees with its declared verdict."""
    if holds is None:
        return "error"
    expected = verdict != NOT_REPRODUCED
    return "agrees" if holds == expected else "DISAGREES"


def _bound_rows(paper: str, plan) -> pd.DataFrame | None:
    frames = []
    for job in plan:
        path = job.dir / "metrics.csv"
        if job.paper != paper or not path.exists():
            continue
        table = pd.read_csv(path)
        table = table[pd.to_numeric(table["bound"], errors="coerce").notna()]
        if len(table):
            table = table.assign(run=" ".join(job.overrides))
            frames.append(table)
    if not frames:
        return None
    rows = pd.concat(frames, ignore_index=True)
    rows["holds"] = [verdict(float(v), float(b)) for v, b in zip(rows.empirical, rows.bound,
                                                                 strict=True)]
    return rows[["run", "observer", "quantity", "empirical", "bound", "ratio", "holds"]]


def _figures(paper: str, plan) -> list[FigureEntry]:
    entries, seen = [], set()
    for job in plan:
        fig = job.figure
        if job.paper != paper:
            continue
        where = job.dir.parent if fig.sweep else job.dir
        if (fig.preset, where) in seen:
            continue
        seen.add((fig.preset, where))
        run = f"hgo run {'-m ' if fig.sweep else ''}experiment={fig.preset}"
        for stem, caption in fig.captions.items():
            entries.append(FigureEntry(paper, stem, caption, where / f"{stem}.png", run))
    return entries


def _claims(paper: str, claim_file: Path) -> list[dict]:
    results = json.loads(claim_file.read_text()) if claim_file.exists() else {}
    rows = []
    for c in all_claims([paper]):
        r = results.get(c.id, {"holds": None, "measured": "not run"})
        rows.append({"id": c.id, "where": c.where, "statement": c.statement,
                     "measured": r["measured"], "verdict": c.verdict,
                     "readings": "; ".join(c.readings), "check": agreement(c.verdict,
                                                                          r["holds"])})
    return rows


def sections(papers: list[str], plan, claim_files: dict[str, Path]) -> list[Section]:
    return [Section(p, paper_title(p), _figures(p, plan), _claims(p, claim_files[p]),
                    _bound_rows(p, plan)) for p in papers]


def provenance(wall: float) -> dict[str, str]:
    """Machine, versions and commit of this report."""
    commit = "unknown"
    root = Path(__file__).resolve().parents[2]
    try:
        sha = subprocess.run(["git", "-C", str(root), "rev-parse", "--short", "HEAD"],
                             capture_output=True, text=True, check=True).stdout.strip()
        dirty = subprocess.run(["git", "-C", str(root), "status", "--porcelain"],
                               capture_output=True, text=True, check=True).stdout.strip()
        commit = sha + (" (with uncommitted changes)" if dirty else "")
    except (OSError, subprocess.CalledProcessError):
        pass
    return {"date": datetime.now().strftime("%Y-%m-%d %H:%M:%S"),
            "wall time": f"{wall:.1f} s",
            "machine": f"{_cpu_model()}, {os.cpu_count()} CPUs, {platform.system()}",
            "hgo": f"{version('hgo')}, commit {commit}",
            "python": platform.python_version()}


def _cpu_model() -> str:
    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("model name"):
                return line.split(":", 1)[1].strip()
    except OSError:
        pass
    return platform.processor() or platform.machine()


def summary_rows(secs: list[Section]) -> list[dict]:
    rows = []
    for s in secs:
        counts = {v: sum(c["verdict"] == v for c in s.claims) for v in VERDICTS}
        disagree = sum(c["check"] != "agrees" for c in s.claims)
        figs = sum(f.source.exists() for f in s.figures)
        rows.append({"paper": s.title, "claims": len(s.claims), **counts,
                     "measurement disagrees / errors": disagree,
                     "figures": f"{figs}/{len(s.figures)}"})
    return rows


def registry_table() -> str:
    """Markdown: per paper, its claims by declared verdict (README's "What reproduces")."""
    rows = []
    for paper in paper_names():
        claims = all_claims([paper])
        if claims:
            rows.append({"paper": paper_title(paper), "claims": len(claims),
                         **{v: sum(c.verdict == v for c in claims) for v in VERDICTS}})
    return _md_table(rows)


# ------------------------------------------------------------------------------ writers


def _md_table(rows: list[dict]) -> str:
    if not rows:
        return "(none)\n"
    cols = list(rows[0])
    cell = lambda v: _fmt(v).replace("|", "\\|").replace("\n", " ")  # noqa: E731
    lines = ["| " + " | ".join(cols) + " |", "|" + "---|" * len(cols)]
    lines += ["| " + " | ".join(cell(r[c]) for c in cols) + " |" for r in rows]
    return "\n".join(lines) + "\n"


def _fmt(v) -> str:
    if isinstance(v, float):
        return "" if math.isnan(v) else f"{v:.4g}"
    return str(v)


def write_markdown(path: Path, secs: list[Section], prov: dict[str, str]) -> None:
    out = ["# hgo reproduce", "", _md_table([prov]), "## Summary", "",
           _md_table(summary_rows(secs))]
    for s in secs:
        out += [f"## {s.title}", "", "### Figures", ""]
        for f in s.figures:
            rel = f"figures/{f.paper}-{f.stem}.png"
            shown = f"![{f.stem}]({rel})" if f.source.exists() else "**missing**"
            out += [f"**{f.stem}** (`{f.run}`)", "", shown, "", f"> Paper's caption: {f.caption}",
                    ""]
        out += ["### Claims", "", _md_table(s.claims), "### Bounds", ""]
        out.append(_md_table(s.bounds.to_dict("records")) if s.bounds is not None
                   else "(no bound rows in this paper's runs)\n")
    path.write_text("\n".join(out))


CSS = """
body { font-family: sans-serif; max-width: 1100px; margin: 1em auto; padding: 0 1em;
       color: #222; }
.scroll { overflow-x: auto; max-width: 100%; }
table { border-collapse: collapse; font-size: 13px; margin: 0.5em 0 1.5em; }
th, td { border: 1px solid #ccc; padding: 3px 6px; vertical-align: top; text-align: left; }
td.long { max-width: 28em; overflow-wrap: anywhere; }
figure { margin: 1em 0 2em; } figure img { max-width: 100%; height: auto; }
figcaption { font-size: 13px; color: #444; }
.agrees { color: #060; } .DISAGREES, .error { color: #b00; font-weight: bold; }
"""


def _html_table(rows: list[dict], long: tuple[str, ...] = ()) -> str:
    if not rows:
        return "<p>(none)</p>"
    cols = list(rows[0])
    head = "".join(f"<th>{html.escape(c)}</th>" for c in cols)
    body = []
    for r in rows:
        cells = []
        for c in cols:
            cls = ["long"] if c in long else []
            if c == "check":
                cls.append(str(r[c]))
            attr = f' class="{" ".join(cls)}"' if cls else ""
            cells.append(f"<td{attr}>{html.escape(_fmt(r[c]))}</td>")
        body.append("<tr>" + "".join(cells) + "</tr>")
    return (f'<div class="scroll"><table><tr>{head}</tr>' + "".join(body)
            + "</table></div>")


def _img(path: Path) -> str:
    data = base64.b64encode(path.read_bytes()).decode()
    return f'<img alt="{html.escape(path.stem)}" src="data:image/png;base64,{data}">'


def write_html(path: Path, secs: list[Section], prov: dict[str, str]) -> None:
    out = ["<!DOCTYPE html><html><head><meta charset='utf-8'><title>hgo reproduce</title>",
           f"<style>{CSS}</style></head><body><h1>hgo reproduce</h1>", _html_table([prov]),
           "<h2>Summary</h2>", _html_table(summary_rows(secs))]
    for s in secs:
        out += [f"<h2>{html.escape(s.title)}</h2>", "<h3>Figures</h3>"]
        for f in s.figures:
            shown = _img(f.source) if f.source.exists() else "<p><b>missing</b></p>"
            out.append(f"<figure>{shown}<figcaption><b>{html.escape(f.stem)}</b> "
                       f"(<code>{html.escape(f.run)}</code>). Paper's caption: "
                       f"{html.escape(f.caption)}</figcaption></figure>")
        out += ["<h3>Claims</h3>",
                _html_table(s.claims, long=("statement", "measured", "readings")),
                "<h3>Bounds</h3>",
                _html_table(s.bounds.to_dict("records"), long=("run",))
                if s.bounds is not None else "<p>(no bound rows in this paper's runs)</p>"]
    out.append("</body></html>")
    path.write_text("\n".join(out))


def write_report(out: Path, papers: list[str], plan, claim_files: dict[str, Path],
                 wall: float) -> None:
    """``out/report.md`` (figures copied to ``out/figures/``) and ``out/report.html``."""
    secs = sections(papers, plan, claim_files)
    (out / "figures").mkdir(parents=True, exist_ok=True)
    for s in secs:
        for f in s.figures:
            if f.source.exists():
                shutil.copyfile(f.source, out / "figures" / f"{f.paper}-{f.stem}.png")
    prov = provenance(wall)
    write_markdown(out / "report.md", secs, prov)
    write_html(out / "report.html", secs, prov)
