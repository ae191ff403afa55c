"""Every paper's figures and claims, one report: ``python experiments/reproduce.py [paper ...]
[--jobs N]``, the same as ``hgo reproduce`` (see :mod:`hgo.reproduce.run`)."""

import sys

from hgo.reproduce.run import main

if __name__ == "__main__":
    raise SystemExit(main(sys.argv[1:]))
