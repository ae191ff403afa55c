"""A collection of N copies of the Sanfelice & Praly observer, their (21), any N >= 1.

Copy i (i = 1..N) is the observer (5)-(7) with law (6) plus a repulsive injection on the
copies' outputs (Sanfelice & Praly (21), written there for n = 2, N = 3):

    dx^_{i,k}/dt = x^_{i,k+1} + F^_k(x^_i) - k_k r_i^k (y^_i - y)
                   + kbar_k(r_i) sum_{j != i} (y^_i - y^_j),          k = 1..n,
    dr_i/dt     = p1 ((y^_i - y)^2 - p2) r_i^(1-2b) + p1 p2 / r_i^(2n),   y^_i = x^_{i,1},

and the estimate of the component is the average <x^>(t) = (1/N) sum_i x^_i(t), so the
runner's metric rows (mean_sq_error_<x>, mean_sq_output_error) are those of the average.

Injection gains kbar (not given in the paper; see /work/shared/papers/README.md)
--------------------------------------------------------------------------------
``kbar_k(r) = kappa_k * r^(k * q)``:

* ``kbar_scaling = "high_gain"`` (default, q = 1): kbar_k(r) = kappa_k r^k, the same
  Lambda(r) scaling as the correction K(r) = Lambda(r) K~ of (5). The injection is then a
  fixed fraction kappa_k / k_k of the output correction whatever r is, so the copies keep
  being pushed apart at the same relative strength when r rises during the oscillation.
* ``kbar_scaling = "constant"`` (q = 0): kbar_k(r) = kappa_k.

The sign is positive (as printed in (21)): + kbar (y^_i - y^_j) pushes copy i away from the
others ("maximise the smallest distance"). Note sum_{j != i} (y^_i - y^_j) = N (y^_i - <y^>).
Default kappa = [0.1, 0.1], small against K~ = [2, 2] (5 %), so that the injection mainly
selects the phases of the copies on the attractor. Measured on Fig. 5 (N = 3, p2 = 1.5):
kappa = 0 keeps the phases the initial conditions give (<x^2> peak-to-peak 3.7); 0.05 locks
the copies about 1/3 period apart after ~80 s (0.75); 0.1 after ~40 s (0.76, copy period
2.19 s against 2.27 s alone); 0.2 in ~20 s (0.75) but distorts the copies more; 0.5
destroys the attractor (copies' x^2 peak-to-peak 32). kappa = [0, 0] gives N independent
copies of (19).

Initial conditions: copies must start apart, otherwise they coincide for all t (the
injection vanishes when all y^_i are equal). Either an explicit list ``xhat0_copies``
(N rows of n) or the rule x^_i(0) = xhat0 + (i - 1) * spread, i = 1..N (default spread
[1, 0]: x^_{i,1}(0) = 3, 4, 5 for xhat0 = [3, 3]). All copies start at r_i(0) = r0.

State z = [x^_1 (n), r_1, x^_2 (n), r_2, ..., x^_N (n), r_N]; parameters (by name):
constants N, n and high_gain (kbar scaling q = 1, else q = 0); values p1, p2, b, K (n: K~),
kappa (n), M (n x n), c (n).
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from hgo.core.components import Observer, Params
from hgo.core.errors import as_floats

SCALINGS = {"constant": 0.0, "high_gain": 1.0}


def f(t, z, d, y, u, p, dz):
    """Sanfelice & Praly (21) for N copies of dimension n."""
    N, n = p.N, p.n
    m = n + 1
    ysum = 0.0
    for i in range(N):
        ysum += z[i * m]
    for i in range(N):
        o = i * m
        r = z[o + n]
        e = z[o] - y[0]
        spread = N * z[o] - ysum  # sum_{j != i} (y^_i - y^_j)
        r_k = 1.0
        for k in range(n):
            r_k *= r
            model = p.c[k]
            for j in range(k + 1):
                model += p.M[k, j] * z[o + j]
            chain = z[o + k + 1] if k < n - 1 else 0.0
            kbar = p.kappa[k] * r_k if p.high_gain else p.kappa[k]
            dz[o + k] = chain + model - p.K[k] * r_k * e + kbar * spread
        dz[o + n] = p.p1 * ((e * e - p.p2) * r ** (1.0 - 2.0 * p.b) + p.p2 / r ** (2 * n))


def estimate(t, z, d, p, xhat):
    """<x^> = (1/N) sum_i x^_i."""
    N, n = p.N, p.n
    for k in range(n):
        s = 0.0
        for i in range(N):
            s += z[i * (n + 1) + k]
        xhat[k] = s / N


def _check(cond: bool, message: str) -> None:
    if not cond:
        raise ValueError(message)


def initial_states(N: int, xhat0: Sequence[float], spread: Sequence[float] | None,
                   xhat0_copies: Sequence[Sequence[float]] | None) -> np.ndarray:
    """(N, n) initial estimates: the explicit list, or xhat0 + (i - 1) spread."""
    if xhat0_copies is not None:
        return np.asarray(xhat0_copies, float)
    base = np.asarray(xhat0, float)
    step = np.zeros_like(base) if spread is None else np.asarray(spread, float)
    return base[None, :] + np.arange(N)[:, None] * step[None, :]


def sp_collection(name: str, N: int = 3, K: Sequence[float] = (2.0, 2.0),
                  xhat0: Sequence[float] = (3.0, 3.0), spread: Sequence[float] | None = (1.0, 0.0),
                  xhat0_copies: Sequence[Sequence[float]] | None = None, r0: float = 1.0,
                  p1: float = 4 / 3, p2: float = 1.5, b: float = 0.28,
                  kappa: Sequence[float] = (0.1, 0.1), kbar_scaling: str = "high_gain",
                  M: Sequence[Sequence[float]] | None = None,
                  c: Sequence[float] | None = None) -> Observer:
    """Build the collection (21); every parameter is checked before any integration."""
    n = len(K)
    _check(n >= 1, f"observer.{name}: K must have n >= 1 entries")
    _check(int(N) == N and N >= 1, f"observer.{name}.N must be an integer >= 1, got {N}")
    N = int(N)
    M = np.zeros((n, n)) if M is None else as_floats(f"observer.{name}.M", M, (n, n))
    c = np.zeros(n) if c is None else as_floats(f"observer.{name}.c", c, (n,))
    if xhat0_copies is not None:
        as_floats(f"observer.{name}.xhat0_copies", xhat0_copies, (N, n))
    _check(len(xhat0) == n, f"observer.{name}.xhat0 must have n={n} entries, got {len(xhat0)}")
    _check(spread is None or len(spread) == n,
           f"observer.{name}.spread must have n={n} entries")
    x0 = initial_states(N, xhat0, spread, xhat0_copies)
    _check(x0.shape == (N, n), f"observer.{name}.xhat0_copies must be {N} rows of {n} "
           f"entries, got shape {x0.shape}")
    if N > 1:
        _check(len({tuple(row) for row in x0.tolist()}) == N,
               f"observer.{name}: copies must start apart (xhat0_copies or spread), "
               "otherwise they coincide for all t")
    _check(len(kappa) == n, f"observer.{name}.kappa must have n={n} entries")
    _check(kbar_scaling in SCALINGS,
           f"observer.{name}.kbar_scaling: '{kbar_scaling}' not in {sorted(SCALINGS)}")
    _check(M.shape == (n, n), f"observer.{name}.M must be {n}x{n}, got {M.shape}")
    _check(np.allclose(M, np.tril(M)), f"observer.{name}.M must be lower triangular (form (3))")
    _check(c.shape == (n,), f"observer.{name}.c must have n={n} entries")
    _check(r0 >= 1, f"observer.{name}.r0 must be >= 1 (Sanfelice & Praly, Theorem 2.2 C), "
           f"got {r0}")
    _check(p1 > 0, f"observer.{name}.p1 must be > 0, got {p1}")
    _check(p2 > 0, f"observer.{name}.p2 must be > 0, got {p2}")
    _check(0 < b < 0.5, f"observer.{name}.b must be in (0, 1/2), got {b}")
    p = Params({"N": N, "n": n, "high_gain": SCALINGS[kbar_scaling] > 0.5}, p1=p1, p2=p2, b=b,
               K=K, kappa=kappa, M=M, c=c)
    z0 = np.concatenate([np.append(row, r0) for row in x0])
    names, signals = [], {}
    for i in range(N):
        o = i * (n + 1)
        names += [f"copy{i + 1}_xhat{k + 1}" for k in range(n)] + [f"copy{i + 1}_r"]
        signals[f"copy{i + 1}/xhat"] = list(range(o, o + n))
        signals[f"copy{i + 1}/r"] = [o + n]
    return Observer(name=name, state_names=names, disc_names=[],
                    estimated_states=list(range(n)), z0=z0, d0=np.zeros(0), p=p, f=f,
                    estimate=estimate, signals=signals, bounds={})


def copy_states(obs: Observer, z: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Split the collection's state columns (T, N (n+1)) into x^ (T, N, n) and r (T, N)."""
    N, n = obs.p.N, obs.p.n
    zz = z.reshape(z.shape[0], N, n + 1)
    return zz[:, :, :n], zz[:, :, n]


def collection_params(obs: Observer) -> dict:
    """The copy count N and the law-(6) parameters shared by the copies: n, p1, p2, b, K~."""
    p = obs.p
    return {"N": p.N, "n": p.n, "p1": p.p1, "p2": p.p2, "b": p.b, "K": np.array(p.K)}
