r"""Mean-error metrics of a run against the papers' bounds, as a tidy table.

Empirical quantities are trailing-window time averages over the last $T$ seconds
(``metrics.window``), the finite-horizon estimates of the limsups of Sanfelice & Praly
(11)-(12):

$$\texttt{mean\_sq\_error\_}x_i = \frac{1}{T}\int_{t_{end}-T}^{t_{end}}
|\hat x_i - x_i|^2\,dt, \qquad
\texttt{mean\_sq\_output\_error} = \frac{1}{T}\int_{t_{end}-T}^{t_{end}}
(\hat y - y)^2\,dt$$

($y$ the measured, noisy output; $\hat y = \hat x$ of the plant's ``output_state``), in
the squared units of the state. The kernel computes them with the trapezoid rule over
every integration step and output instant inside the window, so they do not depend on the
output grid. Post-processors (``postprocess``) add their own rows.

Each row of :func:`metrics_table`: ``observer``, ``postprocess``, ``quantity``,
``empirical``, ``bound`` (NaN: no bound from the papers), ``ratio`` = empirical / bound,
``holds``, ``verdict`` (:func:`verdict`), ``window`` (s), ``status``, ``t_stop``,
``message``; some post-processors add a ``note``. The same table is ``metrics.csv`` of a
run directory and ``hgo.run(...).metrics``.

Example:
    ```python
    from hgo.outputs.metrics import verdict

    print(verdict(0.5, 1.0), verdict(2.0, 1.0), verdict(1e-9, 1e3))  # ✓ ✗ vacuous
    ```
"""

from __future__ import annotations

import math

import numpy as np
import pandas as pd

from hgo.engine.simulate import INTERRUPTED, STATUS
from hgo.engine.system import System

COLUMNS = ["observer", "postprocess", "quantity", "empirical", "bound", "ratio", "holds",
           "verdict", "window", "status", "t_stop", "message"]
# a bound larger than the measured value by more than this factor says nothing about it:
# shown as ``vacuous`` rather than ✓ (``metrics.vacuous_factor``)
VACUOUS_FACTOR = 1e6


def status_word(status: int) -> str:
    """``ok``, ``interrupted`` (Ctrl-C) or ``failed`` (any other early stop)."""
    return "ok" if status == 0 else "interrupted" if status == INTERRUPTED else "failed"


def verdict(value: float, bound: float, vacuous_factor: float = VACUOUS_FACTOR) -> str:
    """✓ (value <= bound), ✗, ``vacuous`` (bound > factor x |value|, value not 0), or
    ``""`` when there is no bound."""
    if not (isinstance(bound, int | float) and math.isfinite(bound)):
        return ""
    if not math.isfinite(value) or value > bound:
        return "✗"
    return "vacuous" if 0 < vacuous_factor * abs(value) < bound else "✓"


def metric_row(observer: str, quantity: str, value: float, bound: float | None,
               vacuous_factor: float = VACUOUS_FACTOR) -> dict:
    """One metric row: value against its bound (None or NaN: no bound from the papers);
    ``holds`` is value <= bound, ``verdict`` what a table shows (see :func:`verdict`)."""
    bound = math.nan if bound is None else float(bound)
    ratio = value / bound if bound and math.isfinite(bound) else math.nan
    holds = bool(value <= bound) if math.isfinite(bound) and math.isfinite(value) else None
    return {"observer": observer, "quantity": quantity, "empirical": value, "bound": bound,
            "ratio": ratio, "holds": holds, "verdict": verdict(value, bound, vacuous_factor)}


def window_means(system: System, acc: np.ndarray) -> dict[tuple[str, str], float]:
    """(observer, quantity) -> window mean, from the kernel's accumulators."""
    T = acc[-1]
    means = {}
    for k, (obs, (a, _)) in enumerate(zip(system.observers, system.xh_slices, strict=True)):
        for j, i in enumerate(obs.estimated_states):
            name = system.plant.state_names[i]
            means[(obs.name, f"mean_sq_error_{name}")] = acc[a + j] / T if T > 0 else math.nan
        if system.yhat_columns()[k] >= 0:
            value = acc[system.nxh + k] / T if T > 0 else math.nan
            means[(obs.name, "mean_sq_output_error")] = value
    return means


def window_max_error(system: System, acc: np.ndarray) -> dict[str, float]:
    """Observer -> max over the window of ||x^ - x|| (its estimated states), from the
    kernel's accumulators (taken at every integration step and output instant)."""
    n = len(system.observers)
    return {o.name: float(acc[system.nxh + n + k]) for k, o in enumerate(system.observers)}


def metric_rows(system: System, acc: np.ndarray, status: int, t_stop: float,
                extra_bounds: dict[tuple[str, str], float] | None = None,
                extra_rows: list[dict] | None = None,
                vacuous_factor: float = VACUOUS_FACTOR) -> list[dict]:
    """The rows of :func:`metrics_table` as dicts (an ensemble builds many without a
    DataFrame each)."""
    extra_bounds = extra_bounds or {}
    observers = {o.name: o for o in system.observers}
    rows = []
    for (name, quantity), value in window_means(system, acc).items():
        if status != 0:
            value = math.nan
        bound = extra_bounds.get((name, quantity), observers[name].bounds.get(quantity))
        rows.append({**metric_row(name, quantity, float(value), bound, vacuous_factor),
                     "postprocess": ""})
    for extra in extra_rows or []:
        row = metric_row(extra["observer"], extra["quantity"], float(extra["empirical"]),
                         extra.get("bound"), vacuous_factor)
        rows.append({**extra, **row})
    run = {"window": float(f"{acc[-1]:.12g}"),  # a sum of steps: no round-off digits
           "status": status_word(status), "t_stop": float(t_stop), "message": STATUS[status]}
    return [{**row, **run} for row in rows]


def metrics_table(system: System, acc: np.ndarray, status: int, t_stop: float,
                  extra_bounds: dict[tuple[str, str], float] | None = None,
                  extra_rows: list[dict] | None = None,
                  vacuous_factor: float = VACUOUS_FACTOR) -> pd.DataFrame:
    """One row per (observer, quantity): empirical mean, bound, ratio, holds, verdict, run
    status.

    ``extra_bounds`` fill the bound of the engine's rows, ``extra_rows`` (post-processing:
    observer, postprocess, quantity, empirical, bound) are appended. A failed run
    (status != 0) keeps its rows with ``empirical`` = NaN, the status ``failed``, the
    stop time and the cause.
    """
    table = pd.DataFrame(metric_rows(system, acc, status, t_stop, extra_bounds, extra_rows,
                                     vacuous_factor))
    return table[COLUMNS + [c for c in table.columns if c not in COLUMNS]]
