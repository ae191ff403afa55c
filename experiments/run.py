"""Hydra entry point: ``python experiments/run.py experiment=sp_fig1`` (add ``-m`` to sweep);
the same as ``hgo run experiment=sp_fig1`` (see :mod:`hgo.app`; errors are one line, see
:mod:`hgo.job`)."""

from hgo.app import cli_main

if __name__ == "__main__":
    cli_main()
