"""``hgo plot <sweep or run>``: the trade-off figure of a sweep (:mod:`hgo.outputs.tradeoff`),
or the default figure of one run (:mod:`hgo.outputs.states_figure`), as png and pdf."""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from hgo.core.errors import ConfigError


def parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(
        prog="hgo plot", description="A sweep directory: a metric against one swept key, one "
        "line per value of another, log-log where positive, the minimum of each line marked "
        "and, with >= 3 lines, the power law of the minimiser fitted (x* ∝ by^k). One run: "
        "its states with their estimates, and the errors on a log scale. Writes png and pdf.")
    p.add_argument("path", help="a sweep directory (every run.json below it) or one run")
    p.add_argument("--metric", help="a quantity (max_error), or observer/quantity; default "
                   "the first of the runs")
    p.add_argument("--x", help="the swept key on the horizontal axis (default: the first)")
    p.add_argument("--by", help="the swept key with one line per value (default: the second)")
    p.add_argument("--out", help="the files' path without suffix (default: in PATH)")
    return p


def main(args: list[str]) -> int:
    ns = parser().parse_args(args)
    path = Path(ns.path)
    if not path.is_dir():
        print(f"error: path: {path} is not a directory", file=sys.stderr)
        return 2
    try:
        if (path / "run.json").is_file():
            from hgo.outputs.states_figure import states_figure

            files = states_figure(path, ns.out)
        else:
            from hgo.outputs.tradeoff import plot

            result = plot(path, ns.metric, ns.x, ns.by, ns.out)
            print(result.minima.to_string(index=False))
            for fit in result.fits:
                print(fit.text(result.x, result.by))
            files = result.files
    except ConfigError as err:
        print(f"error: {err}", file=sys.stderr)
        return 2
    for file in files:
        print(f"wrote {file}")
    return 0
