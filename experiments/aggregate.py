"""Combine the jobs of a Hydra sweep (see :mod:`hgo.aggregate`):

    python experiments/aggregate.py outputs/multirun/sp_fig3/<date_time> [--out DIR]
"""

from hgo.aggregate import main

if __name__ == "__main__":
    raise SystemExit(main())
