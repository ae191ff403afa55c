"""Combine the jobs of a Hydra sweep: one CSV, a Markdown table and a comparison figure.

    python experiments/aggregate.py outputs/multirun/sp_fig3/<date_time> [--out DIR]
    python -m hgo.running.aggregate outputs/multirun/sp_fig3/<date_time>      # the same

Reads every ``job*/metrics.csv`` with the job's overrides (``job*/.hydra/overrides.yaml``)
and writes, in the sweep directory (or ``--out``):

* ``metrics_all.csv``: all rows of all jobs, with columns ``job`` and ``overrides``;
* ``metrics_all.md``: the jobs and their overrides, then one table per observer with a
  column per job (``empirical``, and ``<= bound`` with a check mark where a bound exists);
* ``compare.png``: x^1, x^2 and r of the observer ``--observer`` (default
  ``sign_indefinite``) of every job, read back from each ``recording.rrd``
  (Sanfelice & Praly Fig. 3 for the ``sp_fig3`` sweep).

A grid ensemble of the same points (``experiment=sp_fig3_grid``) writes the same files
through :func:`aggregate_ensemble` (its ``ensemble.reports``), one "job" per member.

A job without ``metrics.csv`` (it crashed before writing) is skipped and listed; a job whose
run failed (status ``failed``) keeps its rows (status column) but is left out of the figure,
and is listed too. Hydra skips ``on_multirun_end`` callbacks when a job fails, which is why
this is a separate command. When all jobs succeed, the callback
:class:`AggregateCallback` (set in ``conf/experiment/sp_fig3.yaml`` under ``hydra.callbacks``)
runs the same aggregation at the end of the multirun (``_target_:
hgo.running.aggregate.AggregateCallback``: importable from the installed package, so any launcher
can run it).

The three recordings of the sweep open together in the Rerun viewer (each job has its own
recording id, so they do not merge):

    hgo view outputs/multirun/sp_fig3/<date_time>      (--web on a headless machine)
"""

from __future__ import annotations

import argparse
import math
import sys
from collections.abc import Sequence
from pathlib import Path

import numpy as np
import pandas as pd
import yaml
from hydra.experimental.callback import Callback
from hydra.types import RunMode

from hgo.running.run_dirs import FAILED, sweep_jobs


def _job_dirs(sweep: Path) -> list[Path]:
    """The jobs of the sweep that ran last in ``sweep`` (:func:`sweep_jobs`)."""
    return sweep_jobs(sweep)


def _overrides(job: Path) -> list[str]:
    path = job / ".hydra" / "overrides.yaml"
    if not path.exists():
        return []
    return [str(o) for o in (yaml.safe_load(path.read_text()) or [])]


def _varying(all_overrides: dict[str, list[str]]) -> dict[str, str]:
    """Per job, the overrides that differ between jobs (all of them if only one job)."""
    sets = [set(v) for v in all_overrides.values()]
    common = set.intersection(*sets) if len(sets) > 1 else set()
    return {job: ", ".join(o for o in ov if o not in common) or ", ".join(ov)
            for job, ov in all_overrides.items()}


def figure_label(label: str) -> str:
    """``observer.sign_indefinite.p2=3, seed=1`` -> ``$p_{2} = 3$, seed = 1``."""
    from hgo.outputs.figures import math_label

    parts = [o.split("=", 1) for o in label.split(", ")]
    return ", ".join(math_label(*kv) if len(kv) == 2 else kv[0] for kv in parts)


def collect(sweep: Path) -> tuple[pd.DataFrame, dict[str, str], list[str], list[str]]:
    """(all rows, job -> label, skipped jobs with reasons, failed jobs)."""
    frames, overrides, skipped, failed = [], {}, [], []
    for job in _job_dirs(sweep):
        csv = job / "metrics.csv"
        if not csv.exists():
            skipped.append(f"{job.name}: no metrics.csv (the job crashed before writing it)")
            continue
        try:
            table = pd.read_csv(csv)
        except (pd.errors.EmptyDataError, pd.errors.ParserError) as err:
            skipped.append(f"{job.name}: unreadable metrics.csv ({err})")
            continue
        overrides[job.name] = _overrides(job)
        table.insert(0, "job", job.name)
        table.insert(1, "overrides", " ".join(overrides[job.name]))
        if "status" in table and (table.status != "ok").any():
            msg = table.loc[table.status != "ok", "message"].iloc[0]
            t_stop = table.loc[table.status != "ok", "t_stop"].iloc[0]
            failed.append(f"{job.name}: run failed at t = {t_stop:g} s ({msg})")
        frames.append(table)
    rows = pd.concat(frames, ignore_index=True) if frames else pd.DataFrame()
    labels = _varying(overrides) if overrides else {}
    return rows, labels, skipped, failed


def _fmt(x) -> str:
    try:
        v = float(x)
    except (TypeError, ValueError):
        return str(x)
    return "" if math.isnan(v) else f"{v:.4g}"


def _cell(row) -> str:
    text = _fmt(row.empirical)
    bound = float(row.bound) if "bound" in row and pd.notna(row.bound) else math.nan
    if math.isfinite(bound):
        mark = row.get("verdict") if isinstance(row.get("verdict"), str) else \
            {True: "✓", False: "✗"}.get(_truth(row.get("holds")), "?")
        text += f" (≤ {_fmt(bound)} {mark})"
    return text


def _truth(v):
    if isinstance(v, str):
        return {"true": True, "false": False}.get(v.lower())
    if v is None or (isinstance(v, float) and math.isnan(v)):
        return None
    return bool(v)


def markdown(rows: pd.DataFrame, labels: dict[str, str], skipped: list[str],
             failed: list[str], title: str) -> str:
    """Readable rendering: jobs, then one table per observer (quantity x job)."""
    out = [f"# {title}", ""]
    out += ["| job | overrides |", "|---|---|"]
    out += [f"| {job} | `{label}` |" for job, label in labels.items()]
    out.append("")
    if skipped or failed:
        out += ["**Skipped / failed jobs:**", ""] + [f"- {s}" for s in skipped + failed] + [""]
    if rows.empty:
        out.append("No job wrote metrics.")
        return "\n".join(out) + "\n"
    jobs = list(labels)
    rows = rows.assign(postprocess=rows["postprocess"].fillna(""))
    for observer, group in rows.groupby("observer", sort=False):
        out += [f"## observer `{observer}`", ""]
        out.append("| postprocess | quantity | " + " | ".join(jobs) + " |")
        out.append("|---|---|" + "---|" * len(jobs))
        keys = list(dict.fromkeys(zip(group.postprocess, group.quantity, strict=True)))
        for pp, quantity in keys:
            sel = group[(group.postprocess == pp) & (group.quantity == quantity)]
            cells = []
            for job in jobs:
                r = sel[sel.job == job]
                cells.append(_cell(r.iloc[0]) if len(r) else "")
            out.append(f"| {pp} | {quantity} | " + " | ".join(cells) + " |")
        out.append("")
    out.append("Cells: trailing-window value; where the paper gives a bound, "
               "(≤ bound ✓/✗) says whether it holds.")
    return "\n".join(out) + "\n"


TRANSIENT = 5.0  # s: the start of the runs on its own axis (at most a quarter of the run)
LAST = 8.0  # s: the last periods of the runs (an oscillation of ~2 s: ~4 periods)


def compare_figure(runs: Sequence[tuple[str, dict[str, np.ndarray]]], path: Path,
                   observer: str = "sign_indefinite", title: str | None = None) -> None:
    """x̂1, x̂2 and the gain r of ``observer`` in several runs (label, recording as from
    ``read_arrays``): the sweep's ``compare.png`` (Sanfelice & Praly Fig. 3 for sp_fig3).
    A split time axis shows the transient and the last periods (not ~30 overlapping
    periods), one colour and line style a run."""
    from hgo.outputs.figures import (
        RUN_STYLES,
        hat,
        legend_below,
        panel_letters,
        plot_line,
        save_figure,
        split_rows,
        split_time,
    )

    fig, axes = split_rows(3)
    t_end = max(float(rec["sim_time"][-1]) for _, rec in runs)
    split = min(TRANSIENT, t_end / 4)
    late = max(split, t_end - LAST)
    for k, (label, rec) in enumerate(runs):
        t = rec["sim_time"]
        xh = rec[f"/observer/{observer}/xhat"]
        r = rec[f"/observer/{observer}/r"]
        style = RUN_STYLES[k % len(RUN_STYLES)]
        for row, y in enumerate((xh[:, 0], xh[:, 1], r[:, 0])):
            for col, window in enumerate(((0.0, split), (late, t_end))):
                plot_line(axes[row, col], t, y, window=window, lw=1.2, label=label, **style)
    for row, name in enumerate([hat("x1"), hat("x2"), "gain $r$"]):
        split_time(axes[row, 0], axes[row, 1], split, t_end, late_start=late)
        axes[row, 0].set_ylabel(f"{name} (–)")
    axes[0, 0].set_title(f"transient, $0 \\leq t \\leq {split:g}$ s")
    axes[0, 1].set_title(f"last periods, ${late:g} \\leq t \\leq {t_end:g}$ s")
    for ax in axes[-1]:
        ax.set_xlabel("$t$ (s)")
    panel_letters(axes[:, 0])
    legend_below(fig, ncol=len(runs))
    fig.suptitle(title or f"{len(runs)} runs of the sweep: observer '{observer}'")
    save_figure(fig, path)


def comparison_figure(sweep: Path, labels: dict[str, str], exclude: set[str], path: Path,
                      observer: str, title: str | None = None) -> list[str]:
    """Fig. 3-style comparison from the recordings; returns the jobs left out, with why."""
    from hgo.outputs.recording import read_arrays

    runs, left_out = [], []
    for job, label in labels.items():
        if job in exclude:
            left_out.append(f"{job}: run failed")
            continue
        rrd = sweep / job / "recording.rrd"
        if not rrd.exists():
            left_out.append(f"{job}: no recording.rrd")
            continue
        rec = read_arrays(rrd)
        if f"/observer/{observer}/xhat" not in rec:
            left_out.append(f"{job}: no observer '{observer}' in the recording")
            continue
        runs.append((figure_label(label), rec))
    if runs:
        compare_figure(runs, path, observer=observer, title=title)
    return left_out


def aggregate(sweep: str | Path, out: str | Path | None = None,
              observer: str = "sign_indefinite", figure: bool = True,
              title: str | None = None) -> dict[str, Path]:
    """Write metrics_all.csv, metrics_all.md and compare.png; returns their paths."""
    sweep = Path(sweep)
    if not sweep.is_dir():
        raise SystemExit(f"aggregate: {sweep} is not a directory")
    out = Path(out) if out else sweep
    out.mkdir(parents=True, exist_ok=True)
    rows, labels, skipped, failed = collect(sweep)
    paths = {"csv": out / "metrics_all.csv", "md": out / "metrics_all.md"}
    rows.to_csv(paths["csv"], index=False)
    if figure and labels:
        failed_jobs = {f.split(":")[0] for f in failed}
        left = comparison_figure(sweep, labels, failed_jobs, out / "compare.png", observer,
                                 title)
        if (out / "compare.png").exists():
            paths["png"] = out / "compare.png"
        skipped = skipped + [f"{s} (not in compare.png)" for s in left
                             if not any(s.split(":")[0] == f.split(":")[0] for f in failed)]
    paths["md"].write_text(markdown(rows, labels, skipped, failed, f"Sweep {sweep}"))
    for line in skipped + failed:
        print(f"aggregate: {line}", file=sys.stderr)
    print(f"aggregate: {len(labels)} job(s) -> " + ", ".join(str(p) for p in paths.values()))
    if any(sweep.glob("*/recording.rrd")):
        print(f"open together in the Rerun viewer:  hgo view {sweep}")
    return paths


def aggregate_ensemble(result, out_dir: str | Path, observer: str = "sign_indefinite",
                       title: str | None = None) -> dict[str, Path]:
    """:func:`aggregate` of a grid ensemble (``ensemble.reports`` of e.g. ``sp_fig3_grid``):
    the same metrics_all.csv/.md with one "job" per member (``member<i>``, its overrides
    the member's varied values) and compare.png from the members' trajectories (kept when
    the config post-processes)."""
    from hgo.running.runner import signals

    out = Path(out_dir)
    members = result.metrics[result.metrics.member != "all"].dropna(axis=1, how="all")
    jobs = [f"member{i}" for i in result.index]
    overrides = {job: " ".join(f"{k}={v[i].tolist()}" for k, v in result.draws.items())
                 for i, job in enumerate(jobs)}
    frames = []
    for i, job in enumerate(jobs):
        rows = members[members.member == str(result.index[i])].drop(columns="member")
        rows = rows.drop(columns=[c for c in result.draws if c in rows])
        rows.insert(0, "job", job)
        rows.insert(1, "overrides", overrides[job])
        frames.append(rows)
    rows = pd.concat(frames, ignore_index=True)
    failed = [f"{job}: run failed at t = {result.t_stop[i]:g} s"
              for i, job in enumerate(jobs) if result.status[i] != 0]
    paths = {"csv": out / "metrics_all.csv", "md": out / "metrics_all.md"}
    rows.to_csv(paths["csv"], index=False)
    paths["md"].write_text(markdown(rows, overrides, [], failed, f"Grid ensemble {out}"))
    if result.trajectories is not None:
        runs = []
        for i, job in enumerate(jobs):
            tr = result.trajectories[i]
            rec = {s.entity: s.values for s in signals(result.systems[i], tr)}
            if result.status[i] == 0 and f"/observer/{observer}/xhat" in rec:
                runs.append((overrides[job], {"sim_time": tr.t, **rec}))
        if runs:
            compare_figure(runs, out / "compare.png", observer=observer, title=title)
            paths["png"] = out / "compare.png"
    print(f"aggregate: {len(jobs)} member(s) -> " + ", ".join(str(p) for p in paths.values()))
    return paths


class AggregateCallback(Callback):
    """Hydra callback: aggregate the sweep directory at ``on_multirun_end``.

    Hydra does not call it when a job fails: run ``experiments/aggregate.py <sweep>`` then.
    """

    def __init__(self, observer: str = "sign_indefinite", title: str | None = None) -> None:
        self.observer = observer
        self.title = title

    def on_multirun_end(self, config, **kwargs) -> None:
        try:
            aggregate(config.hydra.sweep.dir, observer=self.observer, title=self.title)
        except Exception as err:  # never turn a finished sweep into a failure
            print(f"aggregate: failed ({err}); run experiments/aggregate.py "
                  f"{config.hydra.sweep.dir}", file=sys.stderr)


class SweepSummary(Callback):
    """Hydra callback (every multirun, ``conf/config.yaml``): at the end, one table of the
    jobs with their varying overrides, status and key metric, from their ``run.json``.
    At the start, the sweep's own process is set to exit quickly (a joblib sweep runs no
    job in it; :func:`hgo.core.memory.skip_exit_collection`)."""

    def on_multirun_start(self, config, **kwargs) -> None:
        from hgo.core.memory import skip_exit_collection

        skip_exit_collection()

    def on_job_end(self, config, job_return, **kwargs) -> None:
        """Drop the job's configs from its ``JobReturn``: Hydra's launchers keep every
        job's until the sweep ends (~130 KB a job with hgo's config: a no-op 100-job sweep
        grew by 12 MB, and stays flat without them; ``benchmarks/sweeps_bench.py``,
        memory row). The sweepers read only its return value, and this callback is the
        last to see the job (Hydra calls ``on_job_end`` in reverse order of the list)."""
        if config.hydra.mode == RunMode.MULTIRUN:
            job_return.cfg = None
            job_return.hydra_cfg = None

    def on_multirun_end(self, config, **kwargs) -> None:
        """Print the table; the sweep's process exits with the worst code of its jobs (1
        for a job that did not finish): jobs run by submitit, joblib or ray report their
        exit code in other processes, and a sweep of failed jobs exited 0."""
        from hgo.running.job import exit_with

        sweep = Path(config.hydra.sweep.dir)
        print(sweep_summary(sweep), flush=True)
        code = sweep_exit_code(sweep)
        if code:
            exit_with(code)




def record_failure(sweep: Path, job: str, code: int, line: str) -> None:
    """Note that ``job`` of ``sweep`` failed (its directory may be gone: a configuration
    error leaves none), for :func:`sweep_summary` in the sweep's own process."""
    folder = Path(sweep) / FAILED
    folder.mkdir(parents=True, exist_ok=True)
    (folder / job).write_text(f"{code}\n{line}\n")


def _failures(sweep: Path) -> dict[str, tuple[int, str]]:
    out = {}
    folder = Path(sweep) / FAILED
    for note in sorted(folder.iterdir()) if folder.is_dir() else []:
        code, _, line = note.read_text().partition("\n")
        out[note.name] = (int(code) if code.strip().lstrip("-").isdigit() else 1,
                          line.strip())
    return out


def _job_status(job: Path) -> tuple[str, dict]:
    import json

    try:
        data = json.loads((job / "run.json").read_text())
        return str(data.get("status", "no status in run.json")), data
    except (OSError, ValueError, AttributeError):
        return "no run.json (the job did not finish)", {}


def _is_ok(status: str) -> bool:
    return status == "ok" or status.startswith("ok (")


def sweep_exit_code(sweep: Path) -> int:
    """The worst exit code of the sweep's jobs: a recorded failure's, 1 for a job without a
    successful run.json, 0 when every job is ok."""
    failures = _failures(sweep)
    codes = [code for code, _ in failures.values()]
    codes += [1 for job in _job_dirs(sweep)
              if job.name not in failures and not _is_ok(_job_status(job)[0])]
    return max(codes, default=0)


def swept_values(all_overrides: dict[str, list[str]]) -> tuple[list[str], dict[str, dict]]:
    """The keys whose overrides differ between jobs (in order of appearance), and per job
    key -> value (all of a single job's overrides)."""
    parsed = {job: dict(o.split("=", 1) if "=" in o else (o, "") for o in ov)
              for job, ov in all_overrides.items()}
    keys: list[str] = []
    for values in parsed.values():
        keys += [k for k in values if k not in keys]
    if len(parsed) > 1:
        keys = [k for k in keys if len({v.get(k) for v in parsed.values()}) > 1]
    return keys, {job: {k: v.get(k, "") for k in keys} for job, v in parsed.items()}


def _table(header: list[str], rows: list[list[str]]) -> list[str]:
    """Left-aligned columns as wide as their widest cell (nothing cut)."""
    widths = [max(len(r[i]) for r in [header, *rows]) for i in range(len(header))]
    return ["  " + "  ".join(c.ljust(w) for c, w in zip(r, widths, strict=True)).rstrip()
            for r in [header, *rows]]


def sweep_summary(sweep: Path) -> str:
    """``<n> jobs in <sweep>: <k> ok, <f> failed`` then a table: a row per job, one column
    per swept key (its value, never cut), the status and the first metric; and each failed
    job's one-line error."""
    failures = _failures(sweep)
    jobs = _job_dirs(sweep)
    keys, values = swept_values({j.name: _overrides(j) for j in jobs}) if jobs else ([], {})
    rows, n_ok, metric_name = [], 0, ""
    for job in jobs:
        status, data = _job_status(job)
        n_ok += _is_ok(status)
        metric = next(iter((data.get("metrics") or {}).items()), None)
        shown = f"{metric[1]:.4g}" if metric and isinstance(metric[1], int | float) else ""
        metric_name = metric_name or (metric[0] if shown else "")
        rows.append([job.name, *(values.get(job.name, {}).get(k, "") for k in keys), status,
                     shown])
    names = {j.name for j in jobs} | set(failures)
    n_failed = len(names) - n_ok
    errors = [f"  {name}: error: {line}" for name, (_, line) in failures.items()]
    head = f"sweep: {len(names)} jobs in {sweep}: {n_ok} ok" + (
        f", {n_failed} failed" if n_failed else "")
    table = _table(["job", *keys, "status", metric_name], rows) if rows else []
    return "\n".join([head, *table, *errors])


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("sweep", help="sweep directory (outputs/multirun/<run_name>/<date_time>)")
    parser.add_argument("--out", help="output directory (default: the sweep directory)")
    parser.add_argument("--observer", default="sign_indefinite",
                        help="observer drawn in compare.png")
    parser.add_argument("--no-figure", action="store_true", help="skip compare.png")
    args = parser.parse_args(argv)
    aggregate(args.sweep, args.out, args.observer, figure=not args.no_figure)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
