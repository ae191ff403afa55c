"""Hydra entry point: ``python experiments/run.py experiment=sp_fig1`` (add ``-m`` to sweep);
the same as ``hgo run experiment=sp_fig1`` (see :mod:`hgo.app`)."""

from hgo.app import main

if __name__ == "__main__":
    main()
