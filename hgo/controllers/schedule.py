"""Piecewise-constant open-loop input u(t), e.g. Andrieu, Praly & Astolfi, Section 3.1.

    u(t) = values[0] for t < times[0], values[k] for times[k-1] <= t < times[k],
           values[-1] for t >= times[-1]   (right-continuous at each switch).

The input ignores every estimate. The switch instants are the controller's break points
(:func:`switches`): every integrator ends a step exactly at each one, the step ending
there sees the value before the switch and everything from the switch on the value after
it, so no step is rejected for the jump and the recorded u(t_k) is values[k]
(right-continuous), whatever the tolerance.

Parameters (by name): constant n (switches), values times (n) and values (n + 1).
"""

from __future__ import annotations

import math
from collections.abc import Sequence

from hgo.core.components import Controller, Params


def u(t, xhat, y, p, u_out):
    """u(t) from the schedule (right-continuous)."""
    k = 0
    while k < p.n and t >= p.times[k]:
        k += 1
    val = p.values[k]
    for i in range(u_out.shape[0]):
        u_out[i] = val


def switches(p):
    """The switch instants (the break points of the schedule in p)."""
    return [float(v) for v in p.times]


def schedule_input(times: Sequence[float], values: Sequence[float],
                   name: str = "schedule") -> Controller:
    """u(t) = values[k] between the increasing switch instants ``times``."""
    times = [float(v) for v in times]
    values = [float(v) for v in values]
    if len(values) != len(times) + 1:
        raise ValueError(f"controller.values must have len(times) + 1 = {len(times) + 1} "
                         f"entries, got {len(values)}")
    if not all(math.isfinite(v) for v in times + values):
        raise ValueError("controller.times and controller.values must be finite")
    if any(b <= a for a, b in zip(times, times[1:], strict=False)) or any(v <= 0 for v in times):
        raise ValueError(f"controller.times must be > 0 and strictly increasing, got {times}")
    p = Params({"n": len(times)}, times=times, values=values)
    return Controller(name=name, p=p, u=u, observer=None, breaks=switches)
