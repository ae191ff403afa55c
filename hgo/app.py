"""The Hydra application: ``hgo run <overrides>`` and ``python experiments/run.py <overrides>``
(``-m`` to sweep; ``ensemble.size=N`` runs N members of the config in one compiled call).

Each job writes into its Hydra run directory (under ``outputs/``): ``recording.rrd``
(open with ``rerun <file>``), ``metrics.csv``, ``run.json`` (provenance, timings, status;
see :mod:`hgo.runs`) and the composed config in ``.hydra/``. A single run prints its
metrics (100 columns) and its directory, and ``outputs/latest`` points at it; a sweep
prints one line per job.
"""

from __future__ import annotations

import logging
import math
import sys
from datetime import datetime
from pathlib import Path

import hydra
import pandas as pd
from hydra.core.hydra_config import HydraConfig
from hydra.types import RunMode
from omegaconf import DictConfig, OmegaConf

from hgo.config import conf_dir, register_configs
from hgo.console import job_line
from hgo.runs import write_run_json

register_configs()
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
    """``outputs/latest`` -> ``out_dir`` when the run is under ``outputs/``."""
    try:
        rel = out_dir.resolve().relative_to(OUTPUTS.resolve())
    except ValueError:
        return
    link = OUTPUTS / "latest"
    tmp = OUTPUTS / ".latest.tmp"
    tmp.unlink(missing_ok=True)
    tmp.symlink_to(rel, target_is_directory=True)
    tmp.replace(link)


def _status(table: pd.DataFrame | None, error: BaseException | None) -> str:
    if error is not None and (table is None or (table.status == "ok").all()):
        return f"error: {error}"
    if table is not None and (table.status != "ok").any():
        return f"failed: {table.message.iloc[0]}"
    return "ok"


@hydra.main(version_base="1.3", config_path=str(conf_dir()), config_name="config")
def main(cfg: DictConfig) -> None:
    from hgo.runner import run

    hc = HydraConfig.get()
    out_dir = Path(hc.runtime.output_dir)
    multirun = hc.mode == RunMode.MULTIRUN
    if multirun:  # one line per job on the console; the table is in metrics.csv
        logging.getLogger("hgo").setLevel(logging.WARNING)
    started, result, error = datetime.now(), None, None
    try:
        if cfg.ensemble.size > 0:
            from hgo.ensemble_runner import run_ensemble

            result = run_ensemble(cfg, out_dir)
        else:
            result = run(cfg, out_dir)
    except Exception as err:
        error = err
        raise
    finally:
        metrics = out_dir / "metrics.csv"
        table = pd.read_csv(metrics) if metrics.exists() else None
        status = _status(table, error)
        timings = getattr(result, "timings", {})
        write_run_json(out_dir, OmegaConf.to_container(cfg, resolve=True), status, started,
                       timings, table)
        _point_latest(out_dir)
        if multirun:
            n = sweep_size(sys.argv[1:], OmegaConf.to_container(hc.sweeper.params or {}))
            print(job_line(hc.job.num + 1, n, list(hc.overrides.task), status,
                           _key_metric(table)) + f"  ({out_dir})", flush=True)
        else:
            print(f"{status}: outputs in {out_dir}" + (
                f" (simulated in {timings['simulate']:.3g} s)" if timings and
                math.isfinite(timings.get("simulate", math.nan)) else ""), flush=True)
