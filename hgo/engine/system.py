"""A composed experiment: one plant, observers, an optional controller, and its layout.

The layout fixes where each component lives in the flat vectors the kernel works on:
continuous state ``z = [x | z_obs1 | z_obs2 | ...]``, discrete state
``d = [d_obs1 | ...]``, parameters ``P = [p_plant | p_obs1 | ... | p_ctrl]`` and stacked
estimates ``xh = [xhat_obs1 | ...]``.
"""

from __future__ import annotations

import itertools
from dataclasses import dataclass, field

import numpy as np

from hgo.core.components import Controller, Observer, Plant, named
from hgo.core.errors import ConfigError


def _check_indices(key: str, what: str, indices, n: int, names: list[str]) -> None:
    for i in indices:
        if not 0 <= i < n:
            raise ConfigError(key, f"{what} {i}, but there are {n} ({', '.join(names)})",
                              f"0..{n - 1}" if n else "none")


def _offsets(sizes: list[int]) -> list[tuple[int, int]]:
    # plain Python, not np.cumsum: a System is built per ensemble member (10,000 in a grid)
    ends = list(itertools.accumulate(map(int, sizes), initial=0))
    return list(zip(ends[:-1], ends[1:], strict=True))


@dataclass
class System:
    """Plant + observers (+ controller), with the index ranges of each part."""

    plant: Plant
    observers: list[Observer]
    controller: Controller | None = None
    z_slices: list[tuple[int, int]] = field(init=False)
    d_slices: list[tuple[int, int]] = field(init=False)
    p_slices: list[tuple[int, int]] = field(init=False)
    xh_slices: list[tuple[int, int]] = field(init=False)
    # the kernel cache's keys of this system by (method, compiled) (hgo.engine.codegen):
    # a System is not changed once built (its slices above are computed once too), so a
    # sweep's runs do not recompute its layout (~90 us a call)
    kernel_keys: dict = field(init=False, repr=False, compare=False, default_factory=dict)

    def __post_init__(self) -> None:
        if not self.observers:
            raise ValueError("observer: at least one observer is required")
        names = [o.name for o in self.observers]
        if len(set(names)) != len(names):
            raise ValueError(f"observer names must be unique, got {names}")
        obs = self.observers
        self.z_slices = _offsets([self.plant.nx] + [o.nz for o in obs])
        self.d_slices = _offsets([len(o.disc_names) for o in obs])
        ctrl_p = [] if self.controller is None else [len(self.controller.p)]
        self.p_slices = _offsets([len(self.plant.p)] + [len(o.p) for o in obs] + ctrl_p)
        self.xh_slices = _offsets([len(o.estimated_states) for o in obs])
        self.check_compatible()

    def check_compatible(self) -> None:
        """Every index a component reads or writes lies inside the plant's arrays."""
        plant = self.plant
        nx, ny, nu = plant.nx, len(plant.output_names), len(plant.input_names)
        if ny < 1:
            raise ConfigError("plant", f"plant {plant.name} has no measured output")
        if not 0 <= plant.output_state < nx:
            raise ConfigError("plant", f"output_state {plant.output_state} is not a state "
                              f"of plant {plant.name}", f"0..{nx - 1}")
        for o in self.observers:
            key = f"observer.{o.name}"
            bad = [i for i in o.estimated_states if not 0 <= i < nx]
            if bad:
                raise ConfigError(key, f"estimates {len(o.estimated_states)} states "
                                  f"{list(o.estimated_states)} of plant {plant.name}, which "
                                  f"has {nx} ({', '.join(plant.state_names)})",
                                  f"an observer of at most {nx} states")
            _check_indices(key, "reads measured channel", o.reads_outputs, ny,
                           plant.output_names)
            _check_indices(key, "reads plant input", o.reads_inputs, nu, plant.input_names)
        k = self.controlled_observer()
        if k is not None:
            if nu == 0:
                raise ConfigError("controller", f"plant {plant.name} has no input to "
                                  "control", "controller=none")
            ctrl = self.controller
            _check_indices("controller", "reads measured channel", ctrl.reads_outputs, ny,
                           plant.output_names)
            est = [plant.state_names[i] for i in self.observers[k].estimated_states]
            _check_indices("controller", f"reads estimate entry of observer "
                           f"{self.observers[k].name}:", ctrl.reads_estimate, len(est), est)

    @property
    def nz(self) -> int:
        return self.z_slices[-1][1]

    @property
    def nd(self) -> int:
        return self.d_slices[-1][1] if self.d_slices else 0

    @property
    def nxh(self) -> int:
        return self.xh_slices[-1][1]

    def controlled_observer(self) -> int | None:
        """Index of the observer whose estimate feeds the controller."""
        if self.controller is None:
            return None
        names = [o.name for o in self.observers]
        wanted = self.controller.observer or names[0]
        if wanted not in names:
            raise ConfigError("controller.observer", f"'{wanted}' is not an observer",
                              ", ".join(names))
        return names.index(wanted)

    def z0(self) -> np.ndarray:
        return np.concatenate([self.plant.x0] + [o.z0 for o in self.observers]).astype(float)

    def d0(self) -> np.ndarray:
        parts = [o.d0 for o in self.observers]
        return np.concatenate(parts).astype(float) if parts else np.zeros(0)

    def params(self) -> np.ndarray:
        parts = [self.plant.p] + [o.p for o in self.observers]
        if self.controller is not None:
            parts.append(self.controller.p)
        return np.concatenate(parts).astype(float)

    def estimate_map(self) -> np.ndarray:
        """Plant state index estimated by each column of xh."""
        return np.array([i for o in self.observers for i in o.estimated_states], dtype=np.int64)

    def xh_observer(self) -> np.ndarray:
        """Index of the observer of each column of xh."""
        return np.array([k for k, (a, b) in enumerate(self.xh_slices) for _ in range(a, b)],
                        dtype=np.int64)

    def n_acc(self) -> int:
        """Length of the kernel's window-metric vector: squared-error integrals (xh columns,
        then one output error per observer), the max error norm per observer, the window
        length."""
        return self.nxh + 2 * len(self.observers) + 1

    def yhat_columns(self) -> np.ndarray:
        """Column of xh holding each observer's estimate of the measured state (or -1)."""
        cols = []
        for o, (a, _) in zip(self.observers, self.xh_slices, strict=True):
            est = list(o.estimated_states)
            cols.append(a + est.index(self.plant.output_state)
                        if self.plant.output_state in est else -1)
        return np.array(cols, dtype=np.int64)

    def breaks(self, P: np.ndarray, t_end: float) -> np.ndarray:
        """The sorted instants in (0, t_end) where the plant or the controller declares a
        jump (their ``breaks(p)`` hooks, with their slices of the parameter vector ``P``)
        and the measurement instants of sampled observers (``sample_period``): the
        integrators end a step at each one."""
        parts = [(self.plant, self.p_slices[0])]
        if self.controller is not None:
            parts.append((self.controller, self.p_slices[-1]))
        found = [float(b) for comp, (a, e) in parts if comp.breaks is not None
                 for b in comp.breaks(named(comp, P[a:e]))]
        for o in self.observers:  # a sampled observer's instants k * T (k * T exactly)
            if o.sample_period > 0:
                found += (np.arange(1, int(t_end / o.sample_period) + 1)
                          * o.sample_period).tolist()
        return np.array(sorted({b for b in found if 0.0 < b < t_end}), float)

    def spectral_radius(self) -> float:
        return max([self.plant.spectral_radius] + [o.spectral_radius for o in self.observers])
