"""``hgo reproduce [paper ...] [--jobs N]``: every figure and claim of the papers, one report.

Each paper package declares the runs that draw its figures (``PAPER_FIGURES`` in
``hgo/papers/<paper>/figures.py``, a list of :class:`PaperFigure`) and its claims
(``hgo/papers/<paper>/claims.py``, :mod:`hgo.core.registry`). This module

1. runs every figure job (a preset, or each job of its sweep) and every paper's claims in
   parallel processes;
2. reuses a job's directory when it holds a finished run of the same composed config and the
   same code (the key hashes both), and a paper's claim results for the same code;
3. writes ``outputs/reproduce/<date_time>/report.md`` and a self-contained ``report.html``
   (figures embedded, each also as a PDF beside it): a table of contents, a summary table
   (paper x verdicts, wall time, machine, hgo version and commit), then per paper its
   figures with the paper's captions, its claims and its bounds
   (:mod:`hgo.reproduce.report`).

Job directories live under ``outputs/reproduce/runs/``, claim results under
``outputs/reproduce/claims/``.
"""

from __future__ import annotations

import argparse
import hashlib
import importlib
import json
import math
import multiprocessing
import os
import sys
import time
import traceback
from collections.abc import Iterator
from concurrent.futures import ProcessPoolExecutor, as_completed
from contextlib import contextmanager
from dataclasses import dataclass
from datetime import datetime
from pathlib import Path

from hgo.core.registry import PAPERS_PACKAGE, PaperFigure, paper_names
from hgo.outputs.integrity import Damaged, check_file, manifest

ROOT = Path(__file__).resolve().parents[2]
VECTOR = "pdf"  # every figure also as a vector file (figures.vector)


# ------------------------------------------------------------------------------ keys


# files that only render the report (always written again): not part of the results' key
REPORT_ONLY = ("hgo/reproduce/report.py", "hgo/reproduce/notation.py")


def code_fingerprint() -> str:
    """Hash of hgo's sources and configs: a change to either invalidates every result (a
    change to the report's rendering, :data:`REPORT_ONLY` and its templates, does not)."""
    from hgo.core.config import conf_dir

    h = hashlib.sha256()
    conf = conf_dir()  # the checkout's conf/ or the wheel's hgo/conf: named alike
    files = [(p.relative_to(ROOT).as_posix(), p) for p in (ROOT / "hgo").rglob("*.py")]
    files += [("conf/" + p.relative_to(conf).as_posix(), p) for p in conf.rglob("*.yaml")]
    for name, path in sorted(files):
        if name in REPORT_ONLY:
            continue
        h.update(name.encode())
        h.update(path.read_bytes())
    return h.hexdigest()[:16]


def job_key(overrides: tuple[str, ...], fingerprint: str) -> str:
    """Hash of the composed config of ``overrides`` and the code fingerprint."""
    from hgo.running.in_memory import compose_cached
    from hgo.running.runner import job_config_yaml

    text = job_config_yaml(compose_cached(tuple(overrides)))
    return hashlib.sha256((text + fingerprint).encode()).hexdigest()[:16]


# -------------------------------------------------------------------------- workers


def _silence_logs() -> None:
    import logging

    logging.getLogger("hgo").setLevel(logging.WARNING)


def run_job(overrides: tuple[str, ...], job_dir: str, key: str, cfg=None) -> dict:
    """One figure job into ``job_dir`` (Hydra's ``.hydra/`` files written too); ``cfg``:
    the composed config of ``overrides`` when the caller has it (else composed here)."""
    import yaml

    from hgo.outputs.recording import atomic_output
    from hgo.running.ensemble_runner import is_ensemble, run_ensemble
    from hgo.running.in_memory import compose_cached
    from hgo.running.runner import job_config_yaml, run

    _silence_logs()
    out = Path(job_dir)
    (out / ".hydra").mkdir(parents=True, exist_ok=True)
    t0 = time.perf_counter()
    cfg = compose_cached(tuple(overrides)) if cfg is None else cfg
    (out / ".hydra" / "config.yaml").write_text(job_config_yaml(cfg))
    (out / ".hydra" / "overrides.yaml").write_text(yaml.safe_dump(list(overrides[1:])))
    status = "ok"
    try:  # a grid preset's figures are its ensemble's reports (as under ``hgo run``)
        run_ensemble(cfg, out) if is_ensemble(cfg) else run(cfg, out)
    except Exception as err:  # the report lists it; the other jobs go on
        status = f"failed: {err}"
    info = {"key": key, "overrides": list(overrides), "status": status,
            "seconds": time.perf_counter() - t0,
            "files": {name: [size, digest] for name, (size, digest) in manifest(out).items()}}
    with atomic_output(out / "reproduce.json") as partial:
        partial.write_text(json.dumps(info, indent=1))
    return info


def run_claims(paper: str, path: str) -> dict:
    """Every claim of ``paper``, measured; saved to ``path`` as JSON."""
    from hgo.core.registry import all_claims
    from hgo.running.in_memory import forget_runs

    _silence_logs()
    results = {}
    for c in all_claims([paper]):
        t0 = time.perf_counter()
        try:
            m = c.check()
            entry = {"holds": bool(m.holds), "measured": m.describe(),
                     "numbers": {k: (v if isinstance(v, str) else float(v))
                                 for k, v in m.numbers.items()}}
        except Exception as err:
            entry = {"holds": None, "measured": f"error: {err!r}",
                     "error": traceback.format_exc(limit=3)}
        entry["seconds"] = time.perf_counter() - t0
        results[c.id] = entry
    from hgo.outputs.recording import atomic_output

    with atomic_output(Path(path)) as partial:  # a killed worker leaves no truncated JSON
        partial.write_text(json.dumps(results, indent=1))
    forget_runs()  # (the runs of one paper's claims; the next task's differ)
    return results


# ----------------------------------------------------------------------------- plan


@dataclass
class Job:
    paper: str
    figure: PaperFigure
    overrides: tuple[str, ...]
    dir: Path
    key: str

    def done(self) -> bool:
        """Whether the job's directory holds its finished run: ``reproduce.json`` readable,
        of this key, and every file with the size and sha256 it recorded (an unreadable
        or truncated cache file, a damaged output: not done, run again)."""
        info = read_json(self.dir / "reproduce.json")
        if not isinstance(info, dict) or info.get("key") != self.key:
            return False
        try:
            for name, (size, digest) in dict(info["files"]).items():
                check_file(self.dir / name, int(size), str(digest))
        except Damaged as err:
            print(f"reproduce: {err}; running the job again", file=sys.stderr)
            return False
        except (KeyError, TypeError, ValueError):  # no (readable) list of files
            return False
        return True


def read_json(path: Path) -> object:
    """``path``'s JSON, or None when it is missing or unreadable (truncated, not JSON)."""
    try:
        return json.loads(path.read_text())
    except (OSError, ValueError):
        return None


def paper_figures(paper: str) -> list[PaperFigure]:
    try:
        module = importlib.import_module(f"{PAPERS_PACKAGE}.{paper}.figures")
    except ModuleNotFoundError:
        return []
    return list(getattr(module, "PAPER_FIGURES", []))


def plan_jobs(papers: list[str], runs_dir: Path, fingerprint: str) -> list[Job]:
    jobs = []
    for paper in papers:
        for fig in paper_figures(paper):
            all_overrides = [(*o, f"figures.vector={VECTOR}") for o in fig.jobs()]
            keys = [job_key(o, fingerprint) for o in all_overrides]
            if fig.sweep:  # one sweep directory per set of jobs, job<i> inside
                sweep = runs_dir / fig.preset / hashlib.sha256("".join(keys).encode()
                                                                ).hexdigest()[:16]
                dirs = [sweep / f"job{i}" for i in range(len(keys))]
            else:
                dirs = [runs_dir / fig.preset / keys[0]]
            jobs += [Job(paper, fig, o, d, k)
                     for o, d, k in zip(all_overrides, dirs, keys, strict=True)]
    return jobs


# ---------------------------------------------------------------------------- main


def _progress(k: int, n: int, text: str, t0: float) -> None:
    print(f"[{k}/{n}] {text} ({time.perf_counter() - t0:.1f} s)", flush=True)


def failures(plan: list[Job], claim_files: dict[str, Path]) -> list[str]:
    """One line per figure job that did not end ok (run now or reused) and per claim that
    raised, from the files the workers wrote: ``<what>: <status>``."""
    out = []
    for job in plan:
        try:
            status = json.loads((job.dir / "reproduce.json").read_text()).get("status")
        except (OSError, ValueError, AttributeError):
            status = "no reproduce.json (the job crashed)"
        if status != "ok":
            out.append(f"{' '.join(job.overrides)}: {' '.join(str(status).split())[:300]}")
    for paper, path in claim_files.items():
        try:
            results = json.loads(path.read_text()) if path.exists() else {}
        except (OSError, ValueError):
            results = {}
        out += [f"claim {paper}/{cid}: {entry['measured'][:300]}"
                for cid, entry in results.items()
                if isinstance(entry, dict) and "error" in entry]
    return out


@contextmanager
def _ctrl_c_stops(pool: ProcessPoolExecutor) -> Iterator[None]:
    """Ctrl-C inside the block: the tasks not started are dropped and the workers ended at
    once. Without this, leaving the pool waited for every task left (measured: exit 54 s
    after a Ctrl-C 15 s into a warm reproduce), as a worker's Ctrl-C only stops the run its
    kernel is in. What a killed task was writing never looks complete (atomic writes): the
    next reproduce runs it again."""
    try:
        yield
    except KeyboardInterrupt:
        # (the executor's workers are private, and shutdown forgets them: taken first)
        workers = list((getattr(pool, "_processes", None) or {}).values())
        pool.shutdown(wait=False, cancel_futures=True)
        for worker in workers:
            worker.kill()
        raise


def reproduce(papers: list[str], jobs: int, root: Path) -> Path:
    """Run everything of ``papers`` with ``jobs`` processes; return the report directory
    (the jobs and claims that failed: :func:`failures`).

    The claims start before the figure jobs are planned (composing their configs takes
    seconds) and every task is handed out longest first by the durations of the last
    reproduce (:class:`TaskTimes`), so that no worker waits while another finishes a long
    paper; a sweep's combined figures are drawn by a worker as soon as its jobs are done."""
    from hgo.core.registry import all_claims

    t0 = time.perf_counter()
    fingerprint = code_fingerprint()
    claims_dir = root / "claims"
    claims_dir.mkdir(parents=True, exist_ok=True)
    claim_files = {p: claims_dir / f"{p}-{fingerprint}.json" for p in papers}
    todo_claims = [p for p in papers if all_claims([p])
                   and not isinstance(read_json(claim_files[p]), dict)]
    times = TaskTimes.load()
    ctx = multiprocessing.get_context("fork")
    with ProcessPoolExecutor(max_workers=max(1, jobs), mp_context=ctx) as pool, \
            _ctrl_c_stops(pool):
        futures = {pool.submit(run_claims, p, str(claim_files[p])): f"claims of {p}"
                   for p in times.longest_first(todo_claims, lambda p: [f"claims of {p}"])}
        plan = plan_jobs(papers, root / "runs", fingerprint)
        todo_jobs = [j for j in plan if not j.done()]
        reused = len(plan) - len(todo_jobs) + sum(1 for p in papers if p not in todo_claims)
        n = len(todo_jobs) + len(todo_claims)
        print(f"reproduce: {', '.join(papers)}: {len(plan)} figure jobs, claims of "
              f"{len(papers)} papers; {n} to run, {reused} reused from {root}", flush=True)
        from hgo.running.in_memory import compose_cached

        futures.update({pool.submit(run_job, j.overrides, str(j.dir), j.key,
                                    compose_cached(j.overrides)): " ".join(j.overrides)
                        for j in times.longest_first(todo_jobs, _job_costs)})
        sweeps = {j.dir.parent: [] for j in plan if j.figure.sweep}
        for j in todo_jobs:
            sweeps.get(j.dir.parent, []).append(" ".join(j.overrides))
        k = 0
        while futures:
            fut = next(as_completed(futures))
            name = futures.pop(fut)
            try:
                result = fut.result()
                status = result.get("status", "done") if isinstance(result, dict) else "done"
                times.record(name, result)
            except Exception as err:  # a crashed worker: the report says what is missing
                status = f"crashed: {err!r}"
            if name.startswith("combine "):
                continue
            k += 1
            _progress(k, n, f"{name} -> {status}", t0)
            for sweep, left in sweeps.items():  # the sweep's last job: combine it now
                if name in left:
                    left.remove(name)
                    if not left:
                        futures[pool.submit(_combine_sweep, [
                            (j.paper, _figure_index(j), str(j.dir), j.key)
                            for j in plan if j.dir.parent == sweep])] = \
                            _combine_name(sweep, plan)
    _combine(plan)  # (sweeps reused, or whose combination failed above)
    times.save()
    from hgo.reproduce.report import write_report

    out = root / datetime.now().strftime("%Y-%m-%d_%H-%M-%S")
    write_report(out, papers, plan, claim_files, time.perf_counter() - t0)
    LAST_FAILURES[:] = failures(plan, claim_files)
    return out


def _job_costs(job: Job) -> list[str]:
    """The tasks a job's cost is the sum of: itself, and its sweep's combination (handed
    out when the sweep's last job ends: a sweep timed last would leave it to the end)."""
    return [" ".join(job.overrides)] + ([f"combine {job.figure.preset}"]
                                        if job.figure.sweep else [])


def _combine_name(sweep: Path, plan: list[Job]) -> str:
    return f"combine {next(j.figure.preset for j in plan if j.dir.parent == sweep)}"


class TaskTimes:
    """Seconds each task (a paper's claims, a figure job by its overrides) took the last
    time it ran, kept in the kernel cache (``reproduce_seconds.json``): only the order in
    which tasks are handed out depends on them, never a result."""

    FILE = "reproduce_seconds.json"

    def __init__(self, seconds: dict[str, float], path: Path | None) -> None:
        self.seconds, self.path = seconds, path

    @classmethod
    def load(cls) -> TaskTimes:
        try:
            from hgo.engine.codegen import cache_dir

            path = cache_dir() / cls.FILE
            seconds = json.loads(path.read_text()) if path.exists() else {}
            return cls(seconds if isinstance(seconds, dict) else {}, path)
        except (OSError, ValueError):
            return cls({}, None)

    def longest_first(self, tasks: list, names) -> list:
        """``tasks`` by their last seconds (the sum over ``names(task)``), longest first;
        those never timed first of all, in their given order."""
        return sorted(tasks, key=lambda t: -sum(self.seconds.get(n, math.inf if k == 0
                                                                   else 0.0)
                                                for k, n in enumerate(names(t))))

    def record(self, name: str, result) -> None:
        if name.startswith("claims of ") and isinstance(result, dict):
            self.seconds[name] = sum(e.get("seconds", 0.0) for e in result.values()
                                     if isinstance(e, dict))
        elif isinstance(result, dict) and "seconds" in result:
            self.seconds[name] = float(result["seconds"])

    def save(self) -> None:
        if self.path is None:
            return
        try:
            tmp = self.path.with_suffix(f".{os.getpid()}.tmp")
            tmp.write_text(json.dumps(self.seconds, indent=1, sort_keys=True))
            tmp.replace(self.path)
        except OSError:
            pass


LAST_FAILURES: list[str] = []  # of the last reproduce() of this process


def _figure_index(job: Job) -> int:
    return next(i for i, f in enumerate(paper_figures(job.paper)) if f is job.figure)


def _combine_sweep(jobs: list[tuple[str, int, str, str]]) -> dict:
    """:func:`_combine` of one sweep in a worker, its jobs as (paper, index of the figure in
    its PAPER_FIGURES, directory, key): a figure's combiner need not pickle."""
    t0 = time.perf_counter()
    _combine([Job(paper, paper_figures(paper)[index], (), Path(d), key)
              for paper, index, d, key in jobs])
    return {"seconds": time.perf_counter() - t0}


def _combine(plan: list[Job]) -> None:
    """Run the combiner of every sweep whose combined figures are missing or stale."""
    seen = set()
    for job in plan:
        fig = job.figure
        sweep = job.dir.parent
        if not fig.sweep or fig.combine is None or sweep in seen:
            continue
        seen.add(sweep)
        stamp = sweep / "combined.json"
        keys = sorted(j.key for j in plan if j.dir.parent == sweep)
        if read_json(stamp) == keys:
            continue
        try:
            from hgo.outputs.figures import also_saved_as

            with also_saved_as(VECTOR):
                fig.combine(sweep)
            stamp.write_text(json.dumps(keys))
        except Exception as err:
            print(f"reproduce: combining {sweep} failed: {err!r}", file=sys.stderr)


def main(argv: list[str] | None = None) -> int:
    known = paper_names()
    parser = argparse.ArgumentParser(prog="hgo reproduce", description=__doc__.split("\n")[0])
    parser.add_argument("papers", nargs="*", metavar="paper",
                        help=f"papers to reproduce (default: all): {', '.join(known)}")
    parser.add_argument("--jobs", type=int, default=os.cpu_count() or 1,
                        help="parallel processes (default: the number of CPUs)")
    parser.add_argument("--out", default="outputs/reproduce",
                        help="root of runs, claim results and reports (default: %(default)s)")
    parser.add_argument("--table", action="store_true",
                        help="print README's 'What reproduces' table (from the claims "
                             "registry, no runs) and exit")
    args = parser.parse_args(argv)
    if args.table:
        from hgo.reproduce.report import registry_table

        print(registry_table(), end="")
        return 0
    unknown = [p for p in args.papers if p not in known]
    if unknown:
        print(f"error: paper: {', '.join(unknown)} unknown (allowed: {', '.join(known)})",
              file=sys.stderr)
        return 2
    if args.jobs < 1:
        print(f"error: --jobs: must be >= 1, got {args.jobs}", file=sys.stderr)
        return 2
    papers = args.papers or known
    out = reproduce(papers, args.jobs, Path(args.out))
    print(f"reproduce: wrote {out / 'report.md'} and {out / 'report.html'}")
    failed = list(LAST_FAILURES)
    for line in failed:
        print(f"error: {line}", file=sys.stderr)
    if failed:
        print(f"reproduce: {len(failed)} job(s) or claim(s) failed (listed above; the "
              "report has the details)", file=sys.stderr)
    return 1 if failed else 0
