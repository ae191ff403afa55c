"""Hydra entry point: ``python experiments/run.py experiment=sp_fig1`` (add ``-m`` to sweep);
the same as ``hgo run experiment=sp_fig1`` (see :mod:`hgo.cli.app`; errors are one line, see
:mod:`hgo.running.job`)."""

import sys

from hgo.cli import run_app

if __name__ == "__main__":
    raise SystemExit(run_app(sys.argv[1:], prog=sys.argv[0]))
