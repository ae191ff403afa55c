"""Circle-criterion observer, Moreno (3), for a plant of form (2) (scalar y, sigma, u):

    x^' = A x^ + L (y - C x^) + G psi(H x^ + N (y - C x^)) + B u,

with (A, G, C, H, B, psi) taken from the plant (:mod:`hgo.plants.circle_form`; psi is the
plant's monotone nonlinearity: its polynomial, or the user's function psi(s, c)), the gains
L (n) and N (scalar; for the example of Section 5, N = k). Error e = x - x^ obeys
Moreno (5): e' = A_L e + G phi(z, sigma), z = H_N e, A_L = A - L C, H_N = H - N C.

Parameters (by name): the plant's (constants n, psi; values A, G, C, H, B, psi_c), then the
gains L (n) and N; state z = x^.

Integrate with an adaptive method (``dopri5``/``dop853``): the declared
``spectral_radius`` is that of A_L only, while psi adds a state-dependent stiffness
(k * 3 z^2 for the example: ~2e5 at Fig. 1's start), which the error control handles and
a fixed RK4 step capped by A_L would not.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np

from hgo.core.components import Observer, Params
from hgo.plants.circle_form import CircleFormPlant, add_input_terms, add_state_terms, dot


def f(t, z, d, y, u, p, dz):
    """Moreno (3): x^' = A x^ + L (y - C x^) + G psi(H x^ + N (y - C x^)) + B u."""
    innov = y[0] - dot(p.C, p.C_nz, z, p.n)
    psi = p.psi(dot(p.H, p.H_nz, z, p.n) + p.N * innov, p.psi_c)
    for i in range(p.n):
        acc = add_input_terms(p, i, psi, u[0], p.L[i] * innov)
        dz[i] = add_state_terms(p, i, z, acc)


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
    r"""The circle-criterion observer, Moreno (3), for a Lur'e plant of form (2).

    Plant (2): $\dot x = A x + G \psi(H x) + B u$, $y = C x$ (scalar $y$, $u$,
    $\sigma = H x$; $\psi$ monotone). Observer:

    $$\dot{\hat x} = A \hat x + L (y - C \hat x)
      + G\, \psi\big(H \hat x + N (y - C \hat x)\big) + B u .$$

    The error $e = x - \hat x$ obeys Moreno (5): $\dot e = A_L e + G \varphi(z, \sigma)$,
    $z = H_N e$, $A_L = A - L C$, $H_N = H - N C$, with
    $\varphi(z, \sigma) = \psi(\sigma) - \psi(\sigma - z)$ in the sector $[K_1, \infty)$.

    Args:
        name: the observer's name.
        plant: the form-(2) plant (:func:`hgo.plants.circle_form.circle_form_plant`); in a
            config it is given the built plant (the factory's parameter named ``plant``).
        L: the output-injection gain, $n$ finite numbers.
        N: the gain inside the nonlinearity, a finite scalar (Moreno's example: $N = k$).
        xhat0: $\hat x(0)$ ($n$ numbers), or
        e0: the initial error $e(0) = x(0) - \hat x(0)$; give exactly one of the two.

    Returns:
        The observer: state $z = \hat x$, the plant's parameters (the model) and the gains
            ``L``, ``N`` by name; ``spectral_radius`` that of $A_L$ only (integrate with an
            adaptive method: $\psi$ adds a state-dependent stiffness).

    Example:
        ```python
        from hgo.observers.circle_criterion import circle_criterion_observer
        from hgo.plants.circle_form import moreno_example_plant

        plant = moreno_example_plant(a=1.0, x0=[1.0, 0.5])
        obs = circle_criterion_observer("circle", plant, L=[2.0, 0.0], N=1.0, e0=[1.0, 0.5])
        A_L, G, H_N = obs.error_matrices()
        print(A_L.tolist(), obs.z0.tolist())  # [[-3.0, 1.0], [0.0, -1.0]] [0.0, 0.0]
        ```
    """
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
        p=_params(plant, L, N), f=f, estimate=estimate,
        spectral_radius=float(np.max(np.abs(np.linalg.eigvals(A_L)))),
        plant=plant, L=L, N=float(N))


def _params(plant: CircleFormPlant, L: np.ndarray, N: float) -> Params:
    """The plant's parameters (the model of (3)) and the gains L, N, by name."""
    pp = plant.p
    supports = {k: pp.spec.constants[k] for k in ("A_nz", "G_nz", "C_nz", "H_nz", "B_nz")}
    return Params({"n": pp.n, "psi": pp.psi, **supports}, A=pp.A, G=pp.G, C=pp.C, H=pp.H,
                  B=pp.B, psi_c=pp.psi_c, L=L, N=N)
