"""The report of ``hgo reproduce``: ``report.md`` and a self-contained ``report.html``.

Both are rendered by Jinja2 templates (``hgo/reproduce/templates/``) from one structure
(:class:`Section` per paper), so they say the same: a table of contents, a summary (paper
x verdict counts, linked to each paper), the verdict legend and the provenance (wall time,
machine, hgo version and commit); then per paper its figures with the paper's captions,
its claims and its bounds.

A claim shows one line of its statement, the few numbers that decide it (at most
:data:`DECIDING` of its measured numbers, in the paper's notation: :mod:`notation`) and its
verdict; the whole statement, every measured number and the readings are in a collapsed
detail. The self-check (does the measurement agree with the declared verdict?) appears
only where it fails. Bounds are split into those the run tests and those it cannot: a
vacuous bound (more than ``VACUOUS_FACTOR`` times the measured value), any bound against
a measured value of exactly 0 and a measured value equal to its bound (an identity) are
listed apart and never shown as holding.
"""

from __future__ import annotations

import base64
import json
import math
import os
import platform
import re
import shutil
import subprocess
from dataclasses import dataclass, field
from datetime import datetime
from importlib.metadata import version
from pathlib import Path

import pandas as pd

from hgo.core.registry import (
    HGO_MEASUREMENT,
    LEDGER_KINDS,
    NOT_REPRODUCED,
    PARTLY,
    REPRODUCED,
    THEORY_ONLY,
    all_claims,
    paper_names,
    paper_title,
)
from hgo.outputs.metrics import VACUOUS_FACTOR
from hgo.reproduce.notation import math_names, plain

TEMPLATES = Path(__file__).with_name("templates")
DECIDING = 5  # measured numbers shown beside a claim (the rest: in its detail) ...
DECIDING_CHARS = 320  # ... as long as they fit in this many characters
ONE_LINE = 200  # characters of a statement shown in the claims table
FINDING = 150  # characters of the check's own summary shown under it
VERDICT_LEGEND = {
    REPRODUCED: "the paper's statement holds in our runs, as stated",
    PARTLY: "holds in a narrower form (a weaker bound, some of the cases, another reading "
            "of an ambiguous detail); the claim's summary says which",
    NOT_REPRODUCED: "our runs contradict the statement, or the paper's numbers cannot be "
                    "recovered; the measured numbers say by how much",
    THEORY_ONLY: "a statement about the theory (a condition, a formula) checked by "
                 "computation, with no simulation to compare",
    HGO_MEASUREMENT: "not a claim of the paper: what hgo measured on the paper's subject, "
                     "recorded with its numbers (listed apart from the claims)",
}
BOUND_LEGEND = {
    "✓": "the measured value is at or below the paper's bound",
    "✗": "the measured value exceeds the bound",
    "vacuous": f"the bound exceeds the measured value more than {VACUOUS_FACTOR:g} times: "
               "it holds but says nothing",
    "metric is 0": "the measured value is exactly 0 (no error at all): any bound holds and "
                   "the run does not test it",
    "equals the bound": "the measured value is the bound itself (an identity, e.g. a ratio "
                        "that is 1 at t = 0 by definition): listed apart, not as a test",
}


@dataclass
class FigureEntry:
    paper: str
    stem: str
    caption: str
    source: Path  # the PNG in its run or sweep directory
    run: str  # the command that made it

    @property
    def anchor(self) -> str:
        return f"{self.paper}-{self.stem}"

    @property
    def vector(self) -> Path:
        return self.source.with_suffix(".pdf")


@dataclass
class Section:
    paper: str
    title: str
    figures: list[FigureEntry] = field(default_factory=list)
    claims: list[dict] = field(default_factory=list)
    bounds: pd.DataFrame | None = None
    bounds_note: str = ""

    @property
    def tested_bounds(self) -> list[dict]:
        return _bound_group(self.bounds, tested=True)

    @property
    def untested_bounds(self) -> list[dict]:
        return _bound_group(self.bounds, tested=False)

    @property
    def paper_claims(self) -> list[dict]:
        return [c for c in self.claims if c["verdict"] != HGO_MEASUREMENT]

    @property
    def measurements(self) -> list[dict]:
        return [c for c in self.claims if c["verdict"] == HGO_MEASUREMENT]

    @property
    def failed_checks(self) -> int:
        return sum(c["self_check"] != "" for c in self.claims)


def self_check(verdict: str, holds: bool | None) -> str:
    """"" when a claim's measurement agrees with its declared verdict (a reproduced claim
    holds, a not-reproduced one does not); else what went wrong."""
    if holds is None:
        return "the check raised an error"
    expected = verdict != NOT_REPRODUCED
    return "" if holds == expected else "the measurement contradicts the declared verdict"


def bound_verdict(value: float, bound: float, factor: float = VACUOUS_FACTOR) -> str:
    """✓ / ✗ / ``vacuous`` (:func:`hgo.outputs.metrics.verdict`), ``metric is 0`` for a
    bound against an exact zero and ``equals the bound`` for a value that is the bound
    itself, both of which the metrics table counts as ✓."""
    if not (math.isfinite(bound)) or not math.isfinite(value) or value > bound:
        return "✗"
    if value == 0:
        return "metric is 0"
    if value == bound:
        return "equals the bound"
    return "vacuous" if factor * abs(value) < bound else "✓"


def _bound_rows(paper: str, plan) -> pd.DataFrame | None:
    frames = []
    for job in plan:
        path = job.dir / "metrics.csv"
        if job.paper != paper or not path.exists():
            continue
        table = pd.read_csv(path)
        table = table[pd.to_numeric(table["bound"], errors="coerce").notna()]
        if len(table):
            shown = [o for o in job.overrides if not o.startswith("figures.vector=")]
            table = table.assign(run=" ".join(shown))
            frames.append(table)
    if not frames:
        return None
    rows = pd.concat(frames, ignore_index=True)
    rows["holds"] = [bound_verdict(float(v), float(b))
                     for v, b in zip(rows.empirical, rows.bound, strict=True)]
    rows["quantity"] = [quantity_name(q) for q in rows.quantity]
    rows["observer"] = rows.observer.fillna("—")
    return rows[["run", "observer", "quantity", "empirical", "bound", "ratio", "holds"]]


def _bound_group(rows: pd.DataFrame | None, tested: bool) -> list[dict]:
    if rows is None:
        return []
    informative = rows.holds.isin(["✓", "✗"])
    return rows[informative if tested else ~informative].to_dict("records")


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


_ABBREVIATIONS = ("Fig", "Figs", "Eq", "Eqs", "Sec", "Secs", "Ref", "Thm", "e.g", "i.e",
                  "al", "cf", "resp", "approx", "vs")
_SENTENCE_END = re.compile(r"(?<=\.)\s+(?=[A-Z(])")


def first_sentence(text: str, limit: int = ONE_LINE) -> str:
    """The first sentence of ``text`` (not cut after "Fig." or "et al."), at most
    ``limit`` characters (cut at a word, with an ellipsis)."""
    text = " ".join(text.split())
    line = text
    for m in _SENTENCE_END.finditer(text):
        word = text[:m.start()].rstrip(".").rsplit(" ", 1)[-1]
        if word not in _ABBREVIATIONS and not re.fullmatch(r"[A-Z]", word):
            line = text[:m.start()]
            break
    if len(line) > limit:
        line = line[:limit].rsplit(" ", 1)[0] + " …"
    return line


_QUANTITIES = [  # metrics.csv quantity names in the papers' notation
    (re.compile(r"^mean_sq_error_([a-z]+)(\d+)(_f)?$"),
     lambda m: f"mean ({m[1]}{m[2]} − {m[1]}^{m[2]}{'f' if m[3] else ''})²"),
    (re.compile(r"^mean_sq_output_error(?:_copy(\d+))?$"),
     lambda m: "mean (y − y^)²" + (f", copy {m[1]}" if m[1] else "")),
    (re.compile(r"^p2_lower_bound_(\d+)$"), lambda m: f"lower bound ({m[1]}) on p2"),
    (re.compile(r"^noise_sup$"), lambda m: "sup |noise| (M_inf)"),
]


def quantity_name(name: str) -> str:
    """A metrics.csv quantity in the paper's notation (``mean_sq_error_x1`` ->
    mean (x₁ − x̂₁)²); unknown names as they are."""
    for pattern, text in _QUANTITIES:
        if m := pattern.match(name):
            return math_names(text(m))
    return name


def _number(value) -> str:
    if isinstance(value, float) and math.isfinite(value):
        return f"{value:.4g}"
    return str(value)


def deciding(numbers: list[tuple[str, str]]) -> list[tuple[str, str]]:
    """The first :data:`DECIDING` numbers (the checks list the deciding ones first), fewer
    where they would take more than :data:`DECIDING_CHARS` characters (at least one)."""
    shown, used = [], 0
    for name, value in numbers[:DECIDING]:
        used += len(name) + len(value) + 3
        if shown and used > DECIDING_CHARS:
            break
        shown.append((name, value))
    return shown


def _summary(measured: str) -> str:
    """The check's summary: its measured text without the bracketed list of numbers
    (:meth:`hgo.core.registry.Measured.describe`); "" when it is only numbers."""
    if measured.endswith("]") and " [" in measured:
        return measured[:measured.index(" [")]
    return "" if "=" in measured else measured


def _claims(paper: str, claim_file: Path) -> list[dict]:
    results = json.loads(claim_file.read_text()) if claim_file.exists() else {}
    rows = []
    for c in all_claims([paper]):
        r = results.get(c.id, {"holds": None, "measured": "not run"})
        numbers = [(math_names(k), _number(v)) for k, v in r.get("numbers", {}).items()]
        rows.append({"id": c.id, "where": c.where, "statement": math_names(plain(c.statement)),
                     "line": math_names(plain(first_sentence(c.statement))),
                     "finding": math_names(plain(first_sentence(_summary(r["measured"]),
                                                                FINDING))),
                     "deciding": deciding(numbers), "numbers": numbers,
                     "measured": math_names(r["measured"]), "verdict": c.verdict,
                     "readings": [math_names(x) for x in c.readings],
                     "self_check": self_check(c.verdict, r["holds"]),
                     "error": r.get("error", "")})
    return rows


def _bounds_note(paper: str) -> str:
    """The paper's word on its bounds (``BOUNDS_NOTE`` of its figures module), if any."""
    import importlib

    try:
        module = importlib.import_module(f"hgo.papers.{paper}.figures")
    except ModuleNotFoundError:
        return ""
    return getattr(module, "BOUNDS_NOTE", "")


def sections(papers: list[str], plan, claim_files: dict[str, Path]) -> list[Section]:
    return [Section(p, plain(paper_title(p)), _figures(p, plan), _claims(p, claim_files[p]),
                    _bound_rows(p, plan), _bounds_note(p)) for p in papers]


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
        counts = {v: sum(c["verdict"] == v for c in s.claims) for v in LEDGER_KINDS}
        figs = sum(f.source.exists() for f in s.figures)
        rows.append({"paper": s.title, "anchor": s.paper, "claims": len(s.paper_claims),
                     "counts": counts, "failed_checks": s.failed_checks,
                     "figures": f"{figs}/{len(s.figures)}"})
    return rows


def registry_table() -> str:
    """Markdown: per paper, its claims by declared verdict (README's "What reproduces"),
    and apart from them, hgo's own measurements on its subject."""
    rows = []
    for paper in paper_names():
        claims = all_claims([paper])
        if claims:
            rows.append({"paper": paper_title(paper),
                         "claims": sum(not c.is_measurement for c in claims),
                         **{v: sum(c.verdict == v for c in claims) for v in LEDGER_KINDS}})
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


def _environment():
    import jinja2

    env = jinja2.Environment(loader=jinja2.FileSystemLoader(TEMPLATES),
                             autoescape=jinja2.select_autoescape(["html.j2"]),
                             trim_blocks=True, lstrip_blocks=True,
                             undefined=jinja2.StrictUndefined)
    env.filters["num"] = _fmt
    env.filters["md"] = lambda v: _fmt(v).replace("|", "\\|").replace("\n", " ")
    env.filters["data_uri"] = _data_uri
    return env


def _data_uri(path: Path) -> str:
    return "data:image/png;base64," + base64.b64encode(path.read_bytes()).decode()


def render(template: str, secs: list[Section], prov: dict[str, str]) -> str:
    """``template`` (``report.md.j2`` or ``report.html.j2``) for these sections."""
    return _environment().get_template(template).render(
        secs=secs, prov=prov, summary=summary_rows(secs), verdicts=LEDGER_KINDS,
        verdict_legend=VERDICT_LEGEND, bound_legend=BOUND_LEGEND,
        any_failed=any(s.failed_checks for s in secs))


def write_report(out: Path, papers: list[str], plan, claim_files: dict[str, Path],
                 wall: float) -> None:
    """``out/report.md`` (figures, and their PDFs where drawn, copied to ``out/figures/``)
    and ``out/report.html`` (figures embedded, nothing fetched)."""
    secs = sections(papers, plan, claim_files)
    (out / "figures").mkdir(parents=True, exist_ok=True)
    for s in secs:
        for f in s.figures:
            for src in (f.source, f.vector):
                if src.exists():
                    shutil.copyfile(src, out / "figures" / f"{f.anchor}{src.suffix}")
    prov = provenance(wall)
    (out / "report.md").write_text(render("report.md.j2", secs, prov))
    (out / "report.html").write_text(render("report.html.j2", secs, prov))
