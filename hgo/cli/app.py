"""The Hydra application: ``hgo run <overrides>`` and ``python experiments/run.py <overrides>``
(``-m`` to sweep; ``ensemble.size=N`` or ``ensemble.grid`` runs the members of the config in
one compiled call).

Each job writes into its Hydra run directory (under ``outputs/``): ``recording.rrd``
(open with ``rerun <file>``), ``metrics.csv``, ``run.json`` (provenance, timings, status;
see :mod:`hgo.outputs.runs`) and the composed config in ``.hydra/``. A single run prints its
metrics (100 columns) and its directory, and ``outputs/latest`` points at it; a sweep
prints one line per job.
"""

from __future__ import annotations

import json
import logging
import sys
from pathlib import Path

import hydra
import pandas as pd
from hydra.core.hydra_config import HydraConfig
from hydra.types import RunMode
from omegaconf import DictConfig, OmegaConf

from hgo.core.config import conf_dir, register_configs
from hgo.outputs.console import job_line
from hgo.running.figure_worker import discard_prestarted
from hgo.running.job import EXIT_CONFIG, is_complete, last_error, one_line_errors, run_job
from hgo.running.run_dirs import lock_job_dirs_first, note_job

register_configs()
lock_job_dirs_first()  # (here: a joblib worker imports this module to run its jobs)
OUTPUTS = Path("outputs")


def sweep_size(argv: list[str], preset_params: dict) -> int | None:
    """Number of jobs of a multirun from its command line and the preset's sweeper params
    (best effort: None when the overrides cannot be parsed)."""
    from hydra.core.override_parser.overrides_parser import OverridesParser

    try:
        parser = OverridesParser.create()
        given = parser.parse_overrides([a for a in argv if "=" in a and not a.startswith("-")])
        params = {k: str(v) for k, v in (preset_params or {}).items()}
        params.update({o.get_key_element(): o.get_value_element_as_str() for o in given
                       if o.is_sweep_override()})
        n = 1
        for key, value in params.items():
            (o,) = parser.parse_overrides([f"{key}={value}"])
            n *= len(list(o.sweep_string_iterator())) if o.is_sweep_override() else 1
        return n
    except Exception:  # any syntax Hydra accepted but we did not foresee: no total
        return None


def _key_metric(table: pd.DataFrame | None) -> tuple[str, float] | None:
    """The first row with a bound (else the first row): what a sweep line shows."""
    if table is None or table.empty:
        return None
    with_bound = table[pd.to_numeric(table["bound"], errors="coerce").notna()]
    row = (with_bound if len(with_bound) else table).iloc[0]
    name = f"{row.observer}/{row.quantity}" if isinstance(row.observer, str) else row.quantity
    return name, float(row.empirical)


def _point_latest(out_dir: Path) -> None:
    """``outputs/latest`` -> ``out_dir`` when the run is under ``outputs/``; a link that
    cannot be made (``latest`` a directory, a read-only ``outputs/``) is a warning: the run
    itself is complete."""
    try:
        rel = out_dir.resolve().relative_to(OUTPUTS.resolve())
    except ValueError:
        return
    link = OUTPUTS / "latest"
    tmp = OUTPUTS / ".latest.tmp"
    try:
        tmp.unlink(missing_ok=True)
        tmp.symlink_to(rel, target_is_directory=True)
        tmp.replace(link)
    except OSError as err:
        tmp.unlink(missing_ok=True) if tmp.is_symlink() else None
        sys.stderr.write(f"warning: {link} not updated ({err.strerror or err}); the run is "
                         f"complete in {out_dir}\n")


def _run_status(out_dir: Path, code: int) -> tuple[str, pd.DataFrame | None]:
    """The job's status (from its ``run.json``) and metrics table, when it wrote them."""
    info, metrics = out_dir / "run.json", out_dir / "metrics.csv"
    table = pd.read_csv(metrics) if metrics.exists() else None
    if info.exists():
        return json.loads(info.read_text())["status"], table
    return ("configuration error" if code == EXIT_CONFIG else f"error (exit {code})"), table


@hydra.main(version_base="1.3", config_path=str(conf_dir()), config_name="config")
def main(cfg: DictConfig) -> None:
    hc = HydraConfig.get()
    out_dir = Path(hc.runtime.output_dir)
    multirun = hc.mode == RunMode.MULTIRUN
    if multirun:  # one line per job on the console; the table is in metrics.csv
        logging.getLogger("hgo").setLevel(logging.WARNING)
        discard_prestarted()  # (the jobs share this process and draw in it)
        note_job(Path(hc.sweep.dir), out_dir.name)  # the summary lists this sweep's jobs
    skipped = bool(cfg.get("resume", False)) and is_complete(cfg, out_dir)
    code = run_job(cfg, out_dir, figures_aside=not multirun, complete=skipped)
    if multirun and code:  # for the summary in the sweep's process (any launcher)
        from hgo.running.aggregate import record_failure

        record_failure(Path(hc.sweep.dir), out_dir.name, code, last_error())
    if not out_dir.exists():  # a configuration error: the one line is already out
        return
    _point_latest(out_dir)
    status, table = _run_status(out_dir, code)
    if skipped:
        status = "skipped (resume: the directory holds this config's complete outputs)"
    if multirun:
        params = hc.sweeper.get("params")
        n = sweep_size(sys.argv[1:], OmegaConf.to_container(params) if params else {})
        print(job_line(hc.job.num + 1, n, list(hc.overrides.task), status,
                       _key_metric(table)) + f"  ({out_dir})", flush=True)
    else:
        from hgo.outputs.console import outputs_listing

        print("\n".join(outputs_listing(out_dir)), flush=True)
        print(f"{status}: outputs in {out_dir}", flush=True)


def cli_main() -> None:
    """The application with errors as one line and the jobs' worst exit code."""
    with one_line_errors():
        main()
