"""Plant class (2) of Moreno: x' = A x + G psi(sigma) + B u, y = C x, sigma = H x.

Moreno (2) with scalar output, scalar sigma and scalar input (m = r = p = 1), psi a
polynomial in sigma (locally Lipschitz, input-independent) and phi(t, y, u) = B u:

    x' = A x + G psi(H x) + B u,   y = C x,   psi(s) = sum_k c_k s^k.

The example of Moreno Section 5 (``moreno_example_plant``):

    x1' = -x1 + g(x2),  x2' = -a x2 + u,  y = x1,  g(s) = s (s^2 - 1),

written in form (2) with the split g(s) = s + psi(s), psi(s) = s^3 - 2 s (reading A2 of
the implementation notes: the only split matching the paper's A_L, the "-2" of phi and
G(s)): A = [[-1, 1], [0, -a]], G = C^T = [1, 0]^T, H = [0, 1], B = [0, 1]^T.

Parameters (by name): constants n, psi (the nonlinearity, called psi(s, psi_c)) and the
supports A_nz, G_nz, C_nz, H_nz, B_nz (row-major flags of the entries that may be nonzero:
the others are compiled out; all True unless the factory knows its structure, as the
Section 5 example does); values A (n x n), G, C, H, B (n each) and psi_c (psi's
parameters: the coefficients [c_0, c_1, ...] of the default polynomial psi,
:func:`polynomial`). A user's psi is any function psi(s, c) numba can compile (or plain
Python, on the slower path), with its global sector lower bound K1 given by the user
(Moreno (6), for the theory rows).
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field

import numpy as np

from hgo.core.components import Params, Plant, user_function
from hgo.engine.jit import kernel_helper, record_helper
from hgo.plants.sector import global_sector_lower


@kernel_helper
def poly(c, s):
    """psi(s) = sum_k c[k] s^k by Horner's rule."""
    acc = 0.0
    for k in range(c.shape[0] - 1, -1, -1):
        acc = acc * s + c[k]
    return acc


@kernel_helper
def polynomial(s, c):
    """The default psi of form (2): psi(s) = sum_k c[k] s^k."""
    return poly(c, s)


@record_helper
def dot(v, support, x, n):
    """sum_j v[j] x[j] over the entries j of the support (the others are zero)."""
    acc = 0.0
    for j in range(n):
        if support[j]:
            acc += v[j] * x[j]
    return acc


@record_helper
def add_input_terms(p, i, psi, u, acc):
    """acc + G_i psi + B_i u (the terms in the support), summed in this order."""
    if p.G_nz[i]:
        acc += p.G[i] * psi
    if p.B_nz[i]:
        acc += p.B[i] * u
    return acc


@record_helper
def add_state_terms(p, i, x, acc):
    """acc + row i of A x (the entries in the support)."""
    for j in range(p.n):
        if p.A_nz[i * p.n + j]:
            acc += p.A[i, j] * x[j]
    return acc


def f(t, x, u, p, dx):
    """Moreno (2): x' = A x + G psi(H x) + B u."""
    psi = p.psi(dot(p.H, p.H_nz, x, p.n), p.psi_c)
    for i in range(p.n):
        dx[i] = add_state_terms(p, i, x, add_input_terms(p, i, psi, u[0], 0.0))


def h(t, x, p, y):
    """y = C x."""
    y[0] = dot(p.C, p.C_nz, x, p.n)


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
        fn = self.p.psi
        if fn is polynomial:
            return np.polynomial.polynomial.polyval(s, self.psi_coeffs)
        return np.vectorize(lambda v: fn(float(v), self.psi_coeffs), otypes=[float])(s)

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


def _supports(given: dict[str, np.ndarray], support: dict | None) -> dict[str, tuple]:
    """The constants ``<name>_nz``: the entries of each matrix that may be nonzero (all,
    unless ``support`` names a structure; a nonzero value outside it is an error)."""
    out = {}
    for name, value in given.items():
        nz = np.ones(value.shape, bool) if support is None else \
            np.asarray(support[name], bool).reshape(value.shape)
        if np.any(value[~nz] != 0.0):
            raise ValueError(f"plant.{name} = {value.tolist()} is nonzero outside its "
                             f"structure {nz.astype(int).tolist()}")
        out[f"{name}_nz"] = tuple(bool(v) for v in nz.ravel())
    return out


def circle_form_plant(A: Sequence[Sequence[float]], G: Sequence[float], C: Sequence[float],
                      H: Sequence[float], B: Sequence[float], psi: Sequence[float] | Callable,
                      x0: Sequence[float], name: str = "circle_form",
                      psi_c: Sequence[float] = (), K1: float | None = None,
                      support: dict | None = None) -> CircleFormPlant:
    r"""A Lur'e plant, Moreno (2), from its matrices and $\psi$:

    $$\dot x = A x + G\, \psi(H x) + B u, \qquad y = C x .$$

    Args:
        A: $n \times n$. G, C, H, B: $n$ each (scalar $\psi$, $y$, $u$).
        psi: the coefficients $[c_0, c_1, \dots]$ (ascending) of a polynomial, or a
            numba-compilable function ``psi(s, c)`` with its parameters ``psi_c``.
        x0: $x(0)$ ($n$).
        name: the plant's name (default ``circle_form``).
        psi_c: the parameters of a function ``psi``.
        K1: the global sector lower bound of
            $\varphi(z, s) = \psi(s) - \psi(s - z)$ (Moreno (6)); computed for a
            polynomial, $-\infty$ when a function's is not given (the theory rows then have
            no sector).
        support: for a factory that knows its structure, per matrix name the flags (its
            shape) of the entries that may be nonzero; the kernel leaves the others out.
            Default: every entry.

    Example:
        ```python
        from hgo.plants.circle_form import circle_form_plant

        plant = circle_form_plant(A=[[-1.0, 1.0], [0.0, -1.0]], G=[1.0, 0.0], C=[1.0, 0.0],
                                  H=[0.0, 1.0], B=[0.0, 1.0], psi=[0.0, -2.0, 0.0, 1.0],
                                  x0=[0.0, 0.0])
        # the global sector lower bound of psi = s^3 - 2 s
        print(plant.K1)  # -2.0
        ```
    """
    A = np.asarray(A, float)
    n = A.shape[0]
    if A.ndim != 2 or A.shape != (n, n) or n < 1 or not np.all(np.isfinite(A)):
        raise ValueError(f"plant.A must be a finite square matrix, got shape {A.shape}")
    G, C, H, B, x0 = (_vector(k, v, n) for k, v in
                      (("G", G), ("C", C), ("H", H), ("B", B), ("x0", x0)))
    if callable(psi) or hasattr(psi, "func"):
        fn = user_function("plant.psi", psi)
        coeffs = np.asarray(psi_c, float).reshape(-1)
        sector = -math.inf if K1 is None else float(K1)
    else:
        fn = polynomial
        coeffs = np.asarray(psi, float).reshape(-1)
        if coeffs.size < 1 or not np.all(np.isfinite(coeffs)):
            raise ValueError(f"plant.psi must be >= 1 finite coefficients, got "
                             f"{coeffs.tolist()}")
        sector = global_sector_lower(coeffs) if K1 is None else float(K1)
    given = {"A": A, "G": G, "C": C, "H": H, "B": B}
    p = Params({"n": n, "psi": fn, **_supports(given, support)}, psi_c=coeffs, **given)
    lin = float(np.max(np.abs(np.linalg.eigvals(A))))
    return CircleFormPlant(
        name=name, state_names=[f"x{i + 1}" for i in range(n)], output_names=["y"],
        input_names=["u"], x0=x0, p=p, f=f, h=h, output_state=int(np.argmax(np.abs(C))),
        spectral_radius=lin, A=A, G=G, C=C, H=H, B=B, psi_coeffs=coeffs, K1=sector)


def moreno_example_plant(a: float = 0.0, x0: Sequence[float] = (0.0, 0.0)) -> CircleFormPlant:
    """Moreno Section 5 in form (2): psi = s^3 - 2 s, phi(z, s) = z (z^2 - 3 s z + 3 s^2 - 2).

    ``a`` >= 0 (a = 0: not detectable, bad input u = 0); x0 = (0, 0) is Fig. 1's (A9)."""
    if not (math.isfinite(a) and a >= 0):
        raise ValueError(f"plant.a must be a finite number >= 0, got {a}")
    return circle_form_plant(A=[[-1.0, 1.0], [0.0, -a]], G=[1.0, 0.0], C=[1.0, 0.0],
                             H=[0.0, 1.0], B=[0.0, 1.0], psi=[0.0, -2.0, 0.0, 1.0], x0=x0,
                             name="moreno_example", support=EXAMPLE_SUPPORT)


#: the zeros of Section 5's matrices for every a (A[1, 1] = -a stays in: a may be 0 or not
#: within one sweep or ensemble, which then shares one kernel)
EXAMPLE_SUPPORT = {"A": [[1, 1], [0, 1]], "G": [1, 0], "C": [1, 0], "H": [0, 1], "B": [0, 1]}


def example_rhs(x: np.ndarray, u: float, a: float) -> np.ndarray:
    """Moreno Section 5 in its original coordinates: (-x1 + g(x2), -a x2 + u), an
    independent check of the form-(2) decomposition."""
    return np.array([-x[0] + x[1] * (x[1] ** 2 - 1.0), -a * x[1] + u])
