"""Hydra entry point: ``python experiments/run.py experiment=sp_fig1`` (add ``-m`` to sweep;
``ensemble.size=N`` runs N members of the config in one compiled call).

Each job writes into its Hydra run directory (under ``outputs/``): ``recording.rrd``
(open with ``rerun <file>``), ``metrics.csv`` and the composed config in ``.hydra/``.

Errors are one line on stderr, ``error: <full.key>: <what is wrong> (allowed: ...)``:
exit code 2 for a configuration error (composition, schema, YAML, interpolation, a
builder's check; its empty run directory is removed), 1 for a run that failed or was
interrupted. ``HYDRA_FULL_ERROR=1`` shows the full traceback instead.
"""

from __future__ import annotations

import hydra
from hydra.core.hydra_config import HydraConfig
from omegaconf import DictConfig

from hgo.config import register_configs
from hgo.job import one_line_errors, run_job

register_configs()


@hydra.main(version_base="1.3", config_path="../conf", config_name="config")
def main(cfg: DictConfig) -> None:
    run_job(cfg, HydraConfig.get().runtime.output_dir)


if __name__ == "__main__":
    with one_line_errors():
        main()
