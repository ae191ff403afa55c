"""High-gain observer for the triangular form, Sanfelice & Praly (5)-(7), any n >= 1.

    dx^/dt = A x^ + F^(x^) - K(r) (y^ - y),   y^ = x^1,   K(r) = Lambda(r) K~,
    Lambda(r) = diag(r, r^2, ..., r^n),

with the gain r driven by one of three laws (``law``):

* ``constant``: dr/dt = 0 (a classical high-gain observer with gain r(0)).
* ``sign_indefinite``: Sanfelice & Praly (6),
  dr/dt = p1 * ((y^ - y)^2 - p2) * r^(1-2b) + p1 * p2 / r^(2n).
  r increases when (y^ - y)^2 > p2 and decreases when (y^ - y)^2 < p2 (1 - r^-(2n+1-2b));
  [1, inf) is forward invariant.
* ``dead_zone``: Sanfelice & Praly (4), dr/dt = p1 * max{0, (y^ - y)^2 - p2} * r^(1-2b):
  r never decreases.

The model F^ is affine, F^(x^) = M x^ + c with M lower triangular (the triangular
structure of (3)); Sanfelice & Praly (19) is M = [[nu1, 0], [0, 0]], c = 0.

State z = [x^1, ..., x^n, r]; parameters (by name): constants n and law (``LAWS``), values
p1, p2, b, K (n: K~), M (n x n), c (n).
"""

from __future__ import annotations

import functools
import math
from collections.abc import Sequence

import numpy as np

from hgo.core.components import Observer, Params
from hgo.core.errors import as_floats
from hgo.engine.jit import kernel_helper

LAWS = {"constant": 0, "sign_indefinite": 1, "dead_zone": 2}


@kernel_helper
def _rate(law, e, r, r2n, p1, p2, b):
    """dr/dt given r2n = r^(2n) (computed by the caller by multiplication).

    r^(1-2b) as exp((1-2b) log r) (r >= 1): 20 ns against 25 ns for pow here, and the
    dominant cost of every right-hand side of (6)."""
    if law == 1:
        return p1 * ((e * e - p2) * math.exp((1.0 - 2.0 * b) * math.log(r)) + p2 / r2n)
    if law == 2:
        return p1 * max(0.0, e * e - p2) * math.exp((1.0 - 2.0 * b) * math.log(r))
    return 0.0


@kernel_helper
def gain_rate(law, e, r, n, p1, p2, b):
    """dr/dt of the chosen law for output error e = y^ - y (Sanfelice & Praly (4), (6))."""
    rn = 1.0
    for _ in range(n):
        rn *= r
    return _rate(law, e, r, rn * rn, p1, p2, b)


def f(t, z, d, y, u, p, dz):
    """Sanfelice & Praly (5)-(7) with the law p.law (a constant of the kernel)."""
    n = p.n
    r = z[n]
    e = z[0] - y[0]
    r_i = 1.0
    for i in range(n):
        r_i *= r
        model = p.c[i]
        for j in range(i + 1):
            model += p.M[i, j] * z[j]
        chain = z[i + 1] if i < n - 1 else 0.0
        dz[i] = chain + model - p.K[i] * r_i * e
    dz[n] = _rate(p.law, e, r, r_i * r_i, p.p1, p.p2, p.b)  # r_i = r^n here


def estimate(t, z, d, p, xhat):
    """x^ = z[:n]."""
    n = xhat.shape[0]
    for i in range(n):
        xhat[i] = z[i]


@functools.cache
def _strictly_upper(n: int) -> np.ndarray:
    """Mask of the entries above the diagonal of an n x n matrix."""
    return np.triu(np.ones((n, n), bool), 1)


def _problem(n: int, law: str, n_xhat0: int, M: np.ndarray, r0: float, p1: float,
             p2: float, b: float) -> str | None:
    """What is out of range, as the message after ``observer.<name>``, or None. Messages are
    formatted only when a check fails: one observer is built per member of an ensemble."""
    if n < 1:
        return ": K must have n >= 1 entries"
    if law not in LAWS:
        return f".law: '{law}' not in {sorted(LAWS)}"
    if n_xhat0 != n:
        return f".xhat0 must have n={n} entries, got {n_xhat0}"
    if (np.abs(M[_strictly_upper(n)]) > 1e-8).any():  # |M_ij| <= 1e-8 above the diagonal
        return ".M must be lower triangular (form (3))"
    if not r0 >= 1:
        return f".r0 must be >= 1 (Sanfelice & Praly, Theorem 2.2 C), got {r0}"
    if law == "constant":
        return None
    if not p1 > 0:
        return f".p1 must be > 0, got {p1}"
    if not p2 > 0:
        return f".p2 must be > 0, got {p2}"
    if not 0 < b < 0.5:
        return f".b must be in (0, 1/2), got {b}"
    return None


def triangular_hgo(name: str, K: Sequence[float], xhat0: Sequence[float], r0: float = 1.0,
                   law: str = "sign_indefinite", p1: float = 4 / 3, p2: float = 0.008,
                   b: float = 0.28, M: Sequence[Sequence[float]] | None = None,
                   c: Sequence[float] | None = None) -> Observer:
    """Build the observer; every parameter is checked before any integration."""
    n = len(K)
    M = np.zeros((n, n)) if M is None else as_floats(f"observer.{name}.M", M, (n, n))
    c = np.zeros(n) if c is None else as_floats(f"observer.{name}.c", c, (n,))
    problem = _problem(n, law, len(xhat0), M, r0, p1, p2, b)
    if problem:
        raise ValueError(f"observer.{name}{problem}")
    p = Params({"n": n, "law": LAWS[law]}, p1=p1, p2=p2, b=b, K=K, M=M, c=c)
    return Observer(name=name, state_names=[f"xhat{i + 1}" for i in range(n)] + ["r"],
                    disc_names=[], estimated_states=list(range(n)),
                    z0=np.array([*xhat0, r0], float), d0=np.zeros(0), p=p, f=f,
                    estimate=estimate, signals={"r": [n]}, bounds=_bounds(law, p2))


def _bounds(law: str, p2: float) -> dict[str, float]:
    """Theorem 2.2 (11): with law (6), limsup mean (y^ - y)^2 <= p2."""
    return {"mean_sq_output_error": p2} if law == "sign_indefinite" else {}
