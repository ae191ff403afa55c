"""Open-loop sum of sinusoids u(t) = sum_k (a_k sin(omega_k t) + b_k cos(omega_k t)).

Dimassi et al. Sec. IV: u(t) = 5 (sin 2t + cos 3t), i.e. omega = (2, 3), a = (5, 0),
b = (0, 5). No feedback: the observers only estimate.

Parameters (by name): constant K (the number of sinusoids), values omega, a, b (K each).
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np

from hgo.core.components import Controller, Params


def u(t, xhat, y, p, u_out):
    """u(t) on every input channel."""
    val = 0.0
    for i in range(p.K):  # (a term with a zero coefficient costs no sine or cosine)
        w = p.omega[i]
        if p.a[i] != 0.0:
            val += p.a[i] * math.sin(w * t)
        if p.b[i] != 0.0:
            val += p.b[i] * math.cos(w * t)
    for j in range(u_out.shape[0]):
        u_out[j] = val


def input_values(p, t: np.ndarray) -> np.ndarray:
    """u(t) on an array of times (for bounds such as max_t |u|); ``p``: the controller's."""
    t = np.asarray(t, float)[:, None]
    return (p.a * np.sin(p.omega * t) + p.b * np.cos(p.omega * t)).sum(axis=1)


def sinusoids_controller(omega: Sequence[float] = (2.0, 3.0), a: Sequence[float] = (5.0, 0.0),
                         b: Sequence[float] = (0.0, 5.0), name: str = "sinusoids") -> Controller:
    """u = sum_k a_k sin(omega_k t) + b_k cos(omega_k t); defaults: Dimassi et al. Sec. IV."""
    k = len(omega)
    for key, vals in (("omega", omega), ("a", a), ("b", b)):
        if len(vals) != k:
            raise ValueError(f"controller.{key} must have {k} entries (one per omega), "
                             f"got {len(vals)}")
        if not all(math.isfinite(v) for v in vals):
            raise ValueError(f"controller.{key} must be finite, got {list(vals)}")
    p = Params({"K": k}, omega=omega, a=a, b=b)
    return Controller(name=name, p=p, u=u, observer=None)
