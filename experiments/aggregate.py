"""Combine the jobs of a Hydra sweep (see :mod:`hgo.running.aggregate`):

    python experiments/aggregate.py outputs/multirun/sp_fig3/<date_time> [--out DIR]
"""

from hgo.running.aggregate import main

if __name__ == "__main__":
    raise SystemExit(main())
