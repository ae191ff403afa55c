"""Building blocks of an experiment: plant, observer, controller.

Each component is a small Python object that carries its parameters (a float64
vector ``p``), its initial state and the *names* of its signals, plus plain Python
functions written in the numba-compatible subset (scalar arithmetic, loops, numpy
indexing). The engine (:mod:`hgo.engine`) composes these functions into one
compiled vector field; a component whose functions numba cannot compile still runs,
on a slower pure-Python path (the engine warns once and says why).

Function signatures (arrays are float64, outputs are written in place):

* Plant   ``f(t, x, u, p, dx)``; ``h(t, x, p, y)`` — measured outputs before noise.
* Observer ``f(t, z, d, y, u, p, dz)`` — continuous dynamics of the observer state z;
  ``update(t, z, d, y, u, p)`` — discrete logic (gain switches, timers, saturation),
  applied between integration steps, may modify z and d;
  ``estimate(t, z, d, p, xhat)`` — the estimate of the plant states listed in
  ``estimated_states``; optional ``stiffness(t, z, d, p) -> float`` — the spectral radius
  of the active dynamics (bounds the RK4 step; default: the constant ``spectral_radius``).
* Controller ``u(t, xhat, y, p, u)`` — input computed from one observer's estimate.
* Plant and controller: optional ``breaks(p) -> sequence of float`` — the instants where
  the component's time dependence jumps (an input schedule's switches, a ramp's corners),
  from its own parameters. The engine ends a step exactly at each one, evaluates the step
  that ends there with the values just before it (left limit) and the rest after it
  (right-continuous), as at noise samples (:mod:`hgo.engine.kernel_template`).

Indices a component reads (``reads_outputs``, ``reads_inputs``, ``reads_estimate``) are
declared, and :class:`hgo.engine.system.System` checks them against the plant when it is
composed: compiled code has no bounds checks.

Why discrete updates between steps: hybrid logic (noise samples, gain switches,
timers, saturations) then never makes a step straddle a discontinuity, and the
vector fields stay smooth and compilable.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np


def no_update(t, z, d, y, u, p):  # noqa: ARG001 - fixed signature
    """Observer without discrete logic."""
    return


@dataclass
class Plant:
    """A plant ``dx/dt = f(t, x, u)``, ``y = h(t, x)`` (noise is added by the engine).

    ``output_state`` is the index of the state that measured channel 0 reads; it
    defines ŷ for the output-error metric (Sanfelice & Praly (11)).
    """

    name: str
    state_names: list[str]
    output_names: list[str]
    input_names: list[str]
    x0: np.ndarray
    p: np.ndarray
    f: object
    h: object
    output_state: int = 0
    spectral_radius: float = 0.0  # of df/dx, bounds the explicit step (RK4 stability)
    breaks: object = None  # optional ``breaks(p)``: instants where f or h jump in t

    @property
    def nx(self) -> int:
        return len(self.state_names)


@dataclass
class Observer:
    """An observer with continuous state z, discrete state d and parameters p."""

    name: str
    state_names: list[str]
    disc_names: list[str]
    estimated_states: list[int]  # plant state indices estimated by ``estimate``
    z0: np.ndarray
    d0: np.ndarray
    p: np.ndarray
    f: object
    estimate: object
    update: object = no_update
    spectral_radius: float = 0.0  # largest |eigenvalue| of the stiffest linear part
    # optional ``stiffness(t, z, d, p) -> float``: the spectral radius *now* (e.g. of the
    # active gain of a switched observer); when given, RK4 caps each substep with it
    # instead of the constant ``spectral_radius`` (which must then bound every mode)
    stiffness: object = None
    # extra names -> state columns, for logging (e.g. {"r": [2]})
    signals: dict[str, list[int]] = field(default_factory=dict)
    # theoretical bounds on metrics, quantity -> value (e.g. Sanfelice & Praly (11):
    # {"mean_sq_output_error": p2}); a missing quantity has no bound from the papers
    bounds: dict[str, float] = field(default_factory=dict)
    # measured channels y[i] and plant inputs u[j] that f / update read: checked against
    # the plant when the system is composed (compiled code never reads past an array)
    reads_outputs: list[int] = field(default_factory=lambda: [0])
    reads_inputs: list[int] = field(default_factory=list)

    @property
    def nz(self) -> int:
        return len(self.state_names)


@dataclass
class Controller:
    """Output feedback ``u = k(t, xhat, y)`` using the estimate of observer ``observer``."""

    name: str
    p: np.ndarray
    u: object
    observer: str | None = None
    # measured channels y[i] and entries xhat[j] of its observer's estimate that ``u`` reads
    # (checked against the plant and the observer when the system is composed); ``u``
    # writes the plant's inputs, so the plant must have at least one
    reads_outputs: list[int] = field(default_factory=list)
    reads_estimate: list[int] = field(default_factory=list)
    # optional ``breaks(p)``: instants where ``u`` jumps in t (or its slope has a corner)
    breaks: object = None
