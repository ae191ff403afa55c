"""Timing helpers of the benchmarks: medians of interleaved calls, markdown tables."""

from __future__ import annotations

import time

import numpy as np


def median_time(fn, reps: int) -> tuple[float, object]:
    (result,) = interleaved_median_times([fn], reps)
    return result


def interleaved_median_times(fns: list, reps: int,
                             clock=time.perf_counter) -> list[tuple[float, object]]:
    """(median time, last result) of each function, the functions called in turn.

    Interleaving puts every function into the same stretches of this machine's drifting
    speed, so the ratios of the medians compare code, not moments. ``clock``: wall time
    by default."""
    times: list[list[float]] = [[] for _ in fns]
    outs: list[object] = [None] * len(fns)
    for _ in range(reps):
        for k, fn in enumerate(fns):
            t0 = clock()
            outs[k] = fn()
            times[k].append(clock() - t0)
    return [(float(np.median(t)), out) for t, out in zip(times, outs, strict=True)]


def fmt(x: float) -> str:
    return f"{x:.3g}"


def table(title: str, header: list[str], rows: list[list]) -> None:
    print(f"\n## {title}\n")
    print("| " + " | ".join(header) + " |")
    print("|" + "|".join("---" for _ in header) + "|")
    for r in rows:
        print("| " + " | ".join(fmt(v) if isinstance(v, float) else str(v) for v in r) + " |")




def interleaved_median_cpu(fns: list, reps: int) -> list[tuple[float, object]]:
    """As :func:`interleaved_median_times`, in CPU seconds of the process (every thread:
    the kernel, the Ctrl-C watcher), robust against other processes on a shared machine."""
    return interleaved_median_times(fns, reps, clock=time.process_time)
