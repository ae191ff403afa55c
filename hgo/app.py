"""The Hydra application: ``hgo run <overrides>`` and ``python experiments/run.py <overrides>``
(``-m`` to sweep; ``ensemble.size=N`` or ``ensemble.grid`` runs the members of the config in
one compiled call).

Each job writes into its Hydra run directory (under ``outputs/``): ``recording.rrd``
(open with ``rerun <file>``), ``metrics.csv`` and the composed config in ``.hydra/``.
"""

from __future__ import annotations

import hydra
from hydra.core.hydra_config import HydraConfig
from omegaconf import DictConfig

from hgo.config import conf_dir, register_configs
from hgo.ensemble_runner import is_ensemble, run_ensemble
from hgo.runner import run

register_configs()


@hydra.main(version_base="1.3", config_path=str(conf_dir()), config_name="config")
def main(cfg: DictConfig) -> None:
    out_dir = HydraConfig.get().runtime.output_dir
    if is_ensemble(cfg):
        run_ensemble(cfg, out_dir)
    else:
        run(cfg, out_dir)
