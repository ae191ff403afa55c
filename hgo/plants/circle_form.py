"""Plant class (2) of Moreno: x' = A x + G psi(sigma) + B u, y = C x, sigma = H x.

Moreno (2) with scalar output, scalar sigma and scalar input (m = r = p = 1), psi a
polynomial in sigma (locally Lipschitz, input-independent) and phi(t, y, u) = B u:

    x' = A x + G psi(H x) + B u,   y = C x,   psi(s) = sum_k c_k s^k.

The example of Moreno Section 5 (``moreno_example_plant``):

    x1' = -x1 + g(x2),  x2' = -a x2 + u,  y = x1,  g(s) = s (s^2 - 1),

written in form (2) with the split g(s) = s + psi(s), psi(s) = s^3 - 2 s (reading A2 of
the implementation notes: the only split matching the paper's A_L, the "-2" of phi and
G(s)): A = [[-1, 1], [0, -a]], G = C^T = [1, 0]^T, H = [0, 1], B = [0, 1]^T.

Parameters p = [A (n*n, row-major), G (n), C (n), H (n), B (n), n_c, c_0 .. c_{n_c-1}].
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np

from hgo.core.components import Plant
from hgo.engine.jit import kernel_helper
from hgo.plants.sector import global_sector_lower


@kernel_helper
def poly(c, s):
    """psi(s) = sum_k c[k] s^k by Horner's rule."""
    acc = 0.0
    for k in range(c.shape[0] - 1, -1, -1):
        acc = acc * s + c[k]
    return acc


def f(t, x, u, p, dx):
    """Moreno (2): x' = A x + G psi(H x) + B u (p layout in the module docstring)."""
    n = x.shape[0]
    A = p[0:n * n]
    G = p[n * n:n * n + n]
    H = p[n * n + 2 * n:n * n + 3 * n]
    B = p[n * n + 3 * n:n * n + 4 * n]
    coeffs = p[n * n + 4 * n + 1:n * n + 4 * n + 1 + int(p[n * n + 4 * n])]
    sigma = 0.0
    for j in range(n):
        sigma += H[j] * x[j]
    psi = poly(coeffs, sigma)
    for i in range(n):
        acc = G[i] * psi + B[i] * u[0]
        for j in range(n):
            acc += A[i * n + j] * x[j]
        dx[i] = acc


def h(t, x, p, y):
    """y = C x."""
    n = x.shape[0]
    C = p[n * n + n:n * n + 2 * n]
    acc = 0.0
    for j in range(n):
        acc += C[j] * x[j]
    y[0] = acc


@dataclass
class CircleFormPlant(Plant):
    """A plant of form (2) that also exposes its matrices and psi (the observer (3) and
    the sector computations need them). ``K1`` is the global sector lower bound of
    phi(z, sigma) = psi(sigma) - psi(sigma - z) w.r.t. z (Moreno (6) with K2 = inf)."""

    A: np.ndarray = field(default_factory=lambda: np.zeros((0, 0)))
    G: np.ndarray = field(default_factory=lambda: np.zeros(0))
    C: np.ndarray = field(default_factory=lambda: np.zeros(0))
    H: np.ndarray = field(default_factory=lambda: np.zeros(0))
    B: np.ndarray = field(default_factory=lambda: np.zeros(0))
    psi_coeffs: np.ndarray = field(default_factory=lambda: np.zeros(0))
    K1: float = -math.inf

    def psi(self, s: np.ndarray | float) -> np.ndarray:
        """psi(s) (vectorised)."""
        return np.polynomial.polynomial.polyval(s, self.psi_coeffs)

    def phi(self, z, sigma):
        """Moreno (4): phi(z, sigma) = psi(sigma) - psi(sigma - z)."""
        return self.psi(sigma) - self.psi(np.asarray(sigma) - z)


def _vector(name: str, value: Sequence[float], n: int) -> np.ndarray:
    arr = np.asarray(value, float).reshape(-1)
    if arr.shape != (n,):
        raise ValueError(f"plant.{name} must have n={n} entries, got {arr.size}")
    if not np.all(np.isfinite(arr)):
        raise ValueError(f"plant.{name} must be finite, got {arr.tolist()}")
    return arr


def circle_form_plant(A: Sequence[Sequence[float]], G: Sequence[float], C: Sequence[float],
                      H: Sequence[float], B: Sequence[float], psi: Sequence[float],
                      x0: Sequence[float], name: str = "circle_form") -> CircleFormPlant:
    """Plant (2) from its matrices and psi's coefficients [c_0, c_1, ...] (ascending)."""
    A = np.asarray(A, float)
    n = A.shape[0]
    if A.ndim != 2 or A.shape != (n, n) or n < 1 or not np.all(np.isfinite(A)):
        raise ValueError(f"plant.A must be a finite square matrix, got shape {A.shape}")
    G, C, H, B, x0 = (_vector(k, v, n) for k, v in
                      (("G", G), ("C", C), ("H", H), ("B", B), ("x0", x0)))
    coeffs = np.asarray(psi, float).reshape(-1)
    if coeffs.size < 1 or not np.all(np.isfinite(coeffs)):
        raise ValueError(f"plant.psi must be >= 1 finite coefficients, got {coeffs.tolist()}")
    p = np.concatenate([A.ravel(), G, C, H, B, [coeffs.size], coeffs])
    lin = float(np.max(np.abs(np.linalg.eigvals(A))))
    return CircleFormPlant(
        name=name, state_names=[f"x{i + 1}" for i in range(n)], output_names=["y"],
        input_names=["u"], x0=x0, p=p, f=f, h=h, output_state=int(np.argmax(np.abs(C))),
        spectral_radius=lin, A=A, G=G, C=C, H=H, B=B, psi_coeffs=coeffs,
        K1=global_sector_lower(coeffs))


def moreno_example_plant(a: float = 0.0, x0: Sequence[float] = (0.0, 0.0)) -> CircleFormPlant:
    """Moreno Section 5 in form (2): psi = s^3 - 2 s, phi(z, s) = z (z^2 - 3 s z + 3 s^2 - 2).

    ``a`` >= 0 (a = 0: not detectable, bad input u = 0); x0 = (0, 0) is Fig. 1's (A9)."""
    if not (math.isfinite(a) and a >= 0):
        raise ValueError(f"plant.a must be a finite number >= 0, got {a}")
    return circle_form_plant(A=[[-1.0, 1.0], [0.0, -a]], G=[1.0, 0.0], C=[1.0, 0.0],
                             H=[0.0, 1.0], B=[0.0, 1.0], psi=[0.0, -2.0, 0.0, 1.0], x0=x0,
                             name="moreno_example")


def example_rhs(x: np.ndarray, u: float, a: float) -> np.ndarray:
    """Moreno Section 5 in its original coordinates: (-x1 + g(x2), -a x2 + u), an
    independent check of the form-(2) decomposition."""
    return np.array([-x[0] + x[1] * (x[1] ** 2 - 1.0), -a * x[1] + u])
