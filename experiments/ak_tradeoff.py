"""Fit the noise trade-off (25) of Ahrens & Khalil to an ``ak_tradeoff`` sweep.

    python experiments/run.py -m experiment=ak_tradeoff      # the sweep (ends with this report)
    python experiments/ak_tradeoff.py outputs/multirun/ak_tradeoff/<date_time> [--out DIR]

Reads every job's ``metrics.csv`` (``ultimate_bound_err`` = max over the late window of
||x - x^||) and ``.hydra/config.yaml`` (eps, mu = noise.amplitude, r), fits
F_r(eps, mu) = eps c1 + mu c2 / eps^(r-1) globally and per mu, takes eps*(mu) from each
per-mu fit (and, model-free, from the measured minimum on the eps grid), fits
eps* = C mu^q with the standard error of q, and writes ``tradeoff_points.csv``,
``tradeoff_fit.csv``, ``tradeoff.md`` and ``tradeoff.png``. Failed jobs are skipped and
listed (Hydra skips the sweep's own end-of-run report when a job fails: run this then).
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
if str(ROOT) not in sys.path:  # run from a checkout without installing
    sys.path.insert(0, str(ROOT))


def main(argv: list[str] | None = None) -> int:
    from hgo.papers.ahrens_khalil.figures import tradeoff_report

    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("sweep", help="sweep directory (outputs/multirun/ak_tradeoff/<date_time>)")
    parser.add_argument("--out", help="output directory (default: the sweep directory)")
    args = parser.parse_args(argv)
    if not Path(args.sweep).is_dir():
        raise SystemExit(f"ak_tradeoff: {args.sweep} is not a directory")
    report = tradeoff_report(args.sweep, args.out)
    for line in report["skipped"]:
        print(f"ak_tradeoff: skipped {line}", file=sys.stderr)
    print(report["paths"]["md"].read_text())
    print("wrote " + ", ".join(str(p) for p in report["paths"].values()))
    return 0 if report["analysis"] is not None else 1


if __name__ == "__main__":
    raise SystemExit(main())
