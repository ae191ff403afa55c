"""Circle-criterion observer, Moreno (3), for a plant of form (2) (scalar y, sigma, u):

    x^' = A x^ + L (y - C x^) + G psi(H x^ + N (y - C x^)) + B u,

with (A, G, C, H, B, psi) taken from the plant (:mod:`hgo.plants.circle_form`), the gains
L (n) and N (scalar; for the example of Section 5, N = k). Error e = x - x^ obeys
Moreno (5): e' = A_L e + G phi(z, sigma), z = H_N e, A_L = A - L C, H_N = H - N C.

Parameters p = [plant p (see :mod:`hgo.plants.circle_form`), L (n), N]; state z = x^.

Integrate with an adaptive method (``dopri5``/``dop853``): the declared
``spectral_radius`` is that of A_L only, while psi adds a state-dependent stiffness
(k * 3 z^2 for the example: ~2e5 at Fig. 1's start), which the error control handles and
a fixed RK4 step capped by A_L would not.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np

from hgo.core.components import Observer
from hgo.plants.circle_form import CircleFormPlant, poly


def f(t, z, d, y, u, p, dz):
    """Moreno (3) (p layout in the module docstring)."""
    n = z.shape[0]
    A = p[0:n * n]
    G = p[n * n:n * n + n]
    C = p[n * n + n:n * n + 2 * n]
    H = p[n * n + 2 * n:n * n + 3 * n]
    B = p[n * n + 3 * n:n * n + 4 * n]
    n_c = int(p[n * n + 4 * n])
    coeffs = p[n * n + 4 * n + 1:n * n + 4 * n + 1 + n_c]
    L = p[n * n + 4 * n + 1 + n_c:n * n + 5 * n + 1 + n_c]
    N = p[n * n + 5 * n + 1 + n_c]
    y_hat = 0.0
    sigma_hat = 0.0
    for j in range(n):
        y_hat += C[j] * z[j]
        sigma_hat += H[j] * z[j]
    innov = y[0] - y_hat
    psi = poly(coeffs, sigma_hat + N * innov)
    for i in range(n):
        acc = L[i] * innov + G[i] * psi + B[i] * u[0]
        for j in range(n):
            acc += A[i * n + j] * z[j]
        dz[i] = acc


def estimate(t, z, d, p, xhat):
    """x^ = z."""
    for i in range(xhat.shape[0]):
        xhat[i] = z[i]


@dataclass
class CircleCriterionObserver(Observer):
    """Observer (3) with the plant it was built for and its gains (for the design tools)."""

    plant: CircleFormPlant | None = None
    L: np.ndarray = field(default_factory=lambda: np.zeros(0))
    N: float = 0.0

    def error_matrices(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Moreno (5): A_L = A - L C, G, H_N = H - N C."""
        pl = self.plant
        return pl.A - np.outer(self.L, pl.C), pl.G.copy(), pl.H - self.N * pl.C


def circle_criterion_observer(name: str, plant: CircleFormPlant, L: Sequence[float],
                              N: float, xhat0: Sequence[float] | None = None,
                              e0: Sequence[float] | None = None) -> CircleCriterionObserver:
    """Observer (3) for ``plant``; x^(0) = ``xhat0``, or x(0) - ``e0`` (e = x - x^)."""
    if not isinstance(plant, CircleFormPlant):
        raise ValueError(f"observer.{name}.plant must be a form-(2) plant "
                         f"(hgo.plants.circle_form), got {type(plant).__name__}")
    n = plant.nx
    L = np.asarray(L, float).reshape(-1)
    if L.shape != (n,) or not np.all(np.isfinite(L)):
        raise ValueError(f"observer.{name}.L must have n={n} finite entries, got {L.tolist()}")
    if not np.isfinite(N):
        raise ValueError(f"observer.{name}.N must be finite, got {N}")
    if (xhat0 is None) == (e0 is None):
        raise ValueError(f"observer.{name}: give exactly one of xhat0 and e0")
    start = np.asarray(xhat0 if xhat0 is not None else e0, float).reshape(-1)
    key = "xhat0" if xhat0 is not None else "e0"
    if start.shape != (n,) or not np.all(np.isfinite(start)):
        raise ValueError(f"observer.{name}.{key} must have n={n} finite entries, "
                         f"got {start.tolist()}")
    z0 = start if xhat0 is not None else plant.x0 - start
    A_L = plant.A - np.outer(L, plant.C)
    return CircleCriterionObserver(
        name=name, state_names=[f"xhat{i + 1}" for i in range(n)], disc_names=[],
        estimated_states=list(range(n)), z0=z0, d0=np.zeros(0),
        p=np.concatenate([plant.p, L, [N]]), f=f, estimate=estimate,
        spectral_radius=float(np.max(np.abs(np.linalg.eigvals(A_L)))),
        plant=plant, L=L, N=float(N))
