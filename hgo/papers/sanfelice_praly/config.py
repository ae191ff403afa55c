"""Structured-config schemas of the Sanfelice & Praly components beyond the foundation.

Stored from :data:`SCHEMAS` by :func:`hgo.core.config.register_configs`:

* ``schema/observer/sp_collection``: the collection (21) of N observers
  (:func:`hgo.observers.collection.sp_collection`);
* ``schema/postprocess/notch``: the notch filter T(s) of Section 3
  (:func:`hgo.postprocess.notch.notch`);
* ``schema/postprocess/oscillation``: period and amplitude of the steady oscillation
  (:func:`hgo.postprocess.oscillation.oscillation`);
* ``schema/postprocess/sp_bounds``: the bounds (11)-(15) and conditions (8)-(10), (13)
  (:func:`hgo.papers.sanfelice_praly.postprocess.sp_bounds`).

A YAML option extends one of them through its defaults list, e.g.
``- /schema/postprocess/notch@notch``.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any


@dataclass
class SPCollectionConf:
    """Sanfelice & Praly (21): N copies with injection kbar_k(r) = kappa_k r^(k q)."""

    _target_: str = "hgo.observers.collection.sp_collection"
    N: int = 3
    K: list[float] = field(default_factory=lambda: [2.0, 2.0])
    xhat0: list[float] = field(default_factory=lambda: [3.0, 3.0])
    spread: list[float] | None = field(default_factory=lambda: [1.0, 0.0])
    xhat0_copies: list[Any] | None = None  # rows of numbers
    r0: float = 1.0
    p1: float = 4 / 3
    p2: float = 1.5
    b: float = 0.28
    kappa: list[float] = field(default_factory=lambda: [0.1, 0.1])
    kbar_scaling: str = "high_gain"
    M: list[Any] | None = None  # rows of numbers (ints accepted)
    c: list[float] | None = None


@dataclass
class NotchConf:
    """T(s) = (s^2 + 2 phi1 w0 s + w0^2)/(s^2 + 2 phi2 w0 s + w0^2); w0 = 2 pi/period if null."""

    _target_: str = "hgo.postprocess.notch.notch"
    w0: float | None = None
    period: float = 2.23
    phi1: float = 0.0
    phi2: float = 1.0
    method: str = "foh"
    init: str = "steady"


@dataclass
class OscillationConf:
    """Period and peak-to-peak amplitude over the trailing window (null: metrics.window)."""

    _target_: str = "hgo.postprocess.oscillation.oscillation"
    window: float | None = None
    spectrum: bool = True


@dataclass
class SPBoundsConf:
    """Sanfelice & Praly (8)-(15); K, b default to the observer's, gamma/L to the plant's."""

    _target_: str = "hgo.papers.sanfelice_praly.postprocess.sp_bounds"
    P: list[Any] = field(default_factory=lambda: [[1.0, -0.5], [-0.5, 0.5]])
    d0: float = 0.95
    d1: float = 3.0
    M_inf: float = 0.0
    K: list[float] | None = None
    b: float | None = None
    gamma: list[float] | None = None
    L: list[float] | None = None


# what hgo.core.config.register_configs stores: "<group>/<name>" -> schema, under schema/
SCHEMAS = {
    "observer/sp_collection": SPCollectionConf,
    "postprocess/notch": NotchConf,
    "postprocess/oscillation": OscillationConf,
    "postprocess/sp_bounds": SPBoundsConf,
}
