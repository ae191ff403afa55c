"""Constants and mean-error bounds of Sanfelice & Praly (2010), Remark 2.4, (11)-(15).

Notation (Sanfelice & Praly Remark 2.4): with lambda_min, lambda_max the extreme eigenvalues of P,

    c0     = 2 lambda_max(P) / d0,                     c1 = c0 ||K~||^2,
    a1(s)  = 2 c0 sum_i gamma_i^2 / s^(2i),            a2(s) = max{s, s^(b+n-1)}^2 lmax/lmin,
    L^     = (2 / lambda_min(P)) sum_i i L_i^2          (the text also writes it L-bar),
    B2     = 4 a1(1) / (d0 lambda_min(P)),
    B~1(s, p1p2) = max{ [4 c1 s^(1-2b) a2(s) / (d0 lmin (2n+1))] x [2 (d1 p1p2 + c0 L^)^e / d0],
                        2 p1p2 / (d0^2 lmin) },            e = (2n+1)/(1+2b),
    B1(s, p1p2)  = B~1^(1-2b) + (2 d1 + 2 c0 L^/(p1p2)) B~1 + 2,

and, over s > s_min := max{sqrt(c0 L^/d0), 1},

    D(s)  = lmin (d0 s^2 - c0 L^),       G(s) = (B1(s, p1p2) + B2/p2)^(2n/(1-2b)) / s^(2n),
    (14)  B_io = min_s  s^(2i) (a1(s) + 2 c1 M^2) / D(s)  +  2 c1 s^(2i) (1 + G(s)) p2 / D(s),
    (15)  B_io = min_s  2 c1 s^(2i) (2 + G(s)) p2 / D(s),
    (13)  p2 >= max{ 2 M^2 + a1(s)/(2 c1),  4 M^2 (1 + c1/(d0 lmin)) },
    (11)  mean of (y^ - y)^2 <= p2.

Lemma 2.1 constants gamma, L are inputs; for the plant (18), gamma = [nu2, 0], L = [nu1, 0].

Interpretations of the OCR-damaged text (see /work/shared/papers/README.md)
---------------------------------------------------------------------------
I1. (14): the "min" and its subscript were lost; it is min over s > max{sqrt(c0 L^/d0), 1} of
    the braces (first term + second term). The strict inequality means the infimum may not be
    attained (``BoundResult.attained`` is False when the grid minimum sits at its upper end).
I2. (14): the trailing "p2" multiplies the whole second fraction. This is the only grouping
    for which (13) turns (14) into (15): (13) gives a1(s) + 2 c1 M^2 <= 2 c1 p2, so the first
    term is <= 2 c1 s^(2i) p2 / (...), and adding the second term gives the factor
    "2 + (...)/s^(2n)" printed in (15).
I3. First term of (14): numerator a1(s) + 2 c1 M^2 ("2 M^2", as printed in (14) and in the
    constant-gain bound after it). Note (13)'s first entry would make 4 c1 M^2 the exact
    match; ``Reading14.noise_factor`` lets one use 1, 2 or 4. The term is negligible in the
    paper's example (c1 M^2 ~ 4e-4 against a second term ~ 1e5).
I4. "B1(s, p1 p2)": the second argument is the product p1 p2 everywhere (in B~1, d1 p1p2,
    2 p1p2/(d0^2 lmin), and 2 c0 L^/(p1 p2) in B1).
I5. B~1 first entry: read as the product of the two printed brackets, the exponent applying
    to (d1 p1p2 + c0 L^) only, with "2 (...)^e / d0" ("literal"). Alternative "inner":
    2 ((d1 p1p2 + c0 L^)/d0)^e. (Reading "(2 (...)/d0)^e" pushes s* to the boundary s = 1.)
I6. Exponent e in B~1 read as printed, (2n+1)/(1+2b), although (1-2b) appears everywhere else;
    (2n+1)/(1-2b) is available (it makes the first entry negligible: s* -> infinity for i=1).
I7. Exponent on (B1 + B2/p2) read as printed, 2n/(1-2b); "1/p2 B2" is B2/p2.
I8. B1 uses B~1^(1-2b) (printed), and a constant "+ 2".
I9. a2(s): the square applies to the max, max{s, s^(b+n-1)}^2, times lambda_max/lambda_min.
I10. B2 uses a1 evaluated at s = 1 (printed "a1(1)"), not a1(s).
I11. L-bar (example text) and L^ (Remark 2.4) are the same constant.
I12. (13) depends on s through a1(s). a1 is decreasing in s, so its value at s = s_min is the
    supremum over the admissible s: ``p2_lower_bound_13`` in the table uses s = s_min (an
    s-independent sufficient condition); the per-state value at that state's s* is also given.

Paper example (Section 3): n = 2, b = 0.28, d0 = 0.95, d1 = 3, P = [[1, -1/2], [-1/2, 1/2]],
K~ = [2, 2], gamma = L = [0.01, 0], p1 = 4/3, p2 = 0.008, M = 0.004. The paper reports
s* = 1.375 > s_min = 1 and B_1o ~ 4.5e5. With the reading above ("literal"): s_min = 1 (as in
the paper), c0 = 2.7558, c1 = 22.047, L^ = 1.0472e-3, B2 = 0.01215, and (13) holds (lower
bound 7.84e-3 <= 0.008, as the paper states), but the minimiser is the kink of the max in B~1
(where its two entries are equal) at s* = 1.6053, with B_1o = 3.98e5 (B_2o = 1.03e6 at the same
s*). Reading "inner" gives s* = 1.5459, B_1o = 4.63e5 (B_2o = 1.11e6). M = 0 changes B_io only
by ~1e-8 relative (the first term of (14) is tiny here). Variants I3 (noise factor 1, 2, 4)
and I10 (a1(s)) do not move s*; I6 "(1-2b)" sends s* -> infinity for i = 1 (B_1o -> 1.95);
"(2 (...)/d0)^e" puts s* at the boundary 1 (B_1o ~ 4e6). An exploratory sweep of ~2e4
combinations of I3-I10 and two more ad hoc toggles found no principled reading that gives
s* = 1.375 together with ~4.5e5 (only multi-toggle coincidences within ~5-10%). See
tests/test_sp_theory.py (strict xfail).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Literal

import numpy as np

from hgo.core.lmi import MAX_ROUNDS, require_finite

__all__ = [
    "Reading14",
    "SPSetup",
    "BoundResult",
    "StateBound",
    "BoundTable",
    "c0",
    "c1",
    "a1",
    "a2",
    "L_hat",
    "s_lower",
    "sp_setup",
    "B1_tilde",
    "B1",
    "B2",
    "objective_14",
    "objective_15",
    "constant_gain_bound",
    "minimise_over_s",
    "B_io",
    "B_io_15",
    "p2_lower_bound_13",
    "output_bound_11",
    "sp_bound_table",
]

ArrayLike = float | np.ndarray


@dataclass(frozen=True)
class Reading14:
    """Interpretation choices for the OCR-damaged (14) and B~1 (see module docstring I3-I6).

    Attributes
    ----------
    b1_grouping : {"literal", "inner"}
        "literal": 2 (d1 p1p2 + c0 L^)^e / d0; "inner": 2 ((d1 p1p2 + c0 L^)/d0)^e.
    b1_exponent : {"(2n+1)/(1+2b)", "(2n+1)/(1-2b)"}
        Exponent e in B~1.
    noise_factor : float
        Factor k in the first term a1(s) + k c1 M^2 of (14) (printed: 2).
    """

    b1_grouping: Literal["literal", "inner"] = "literal"
    b1_exponent: Literal["(2n+1)/(1+2b)", "(2n+1)/(1-2b)"] = "(2n+1)/(1+2b)"
    noise_factor: float = 2.0

    def exponent(self, n: int, b: float) -> float:
        """Exponent e of B~1 for dimension n and parameter b."""
        if self.b1_exponent == "(2n+1)/(1+2b)":
            return (2 * n + 1) / (1 + 2 * b)
        return (2 * n + 1) / (1 - 2 * b)


# ----------------------------------------------------------------------------- constants


def c0(P: np.ndarray, d0: float) -> float:
    """c0 = 2 lambda_max(P) / d0 (Sanfelice & Praly, Remark 2.4, after (13))."""
    return 2.0 * float(np.linalg.eigvalsh(P)[-1]) / d0


def c1(P: np.ndarray, K: np.ndarray, d0: float) -> float:
    """c1 = c0 ||K~||^2 (Sanfelice & Praly, Remark 2.4, after (13))."""
    return c0(P, d0) * float(np.dot(K, K))


def a1(s: ArrayLike, P: np.ndarray, d0: float, gamma: np.ndarray) -> ArrayLike:
    """a1(s) = 2 c0 sum_i gamma_i^2 / s^(2i) (Sanfelice & Praly, Remark 2.4, after (13)).

    Parameters
    ----------
    s : float or numpy.ndarray
        Analysis parameter(s), s > 0.
    P : numpy.ndarray
        Matrix of (8)-(10).
    d0 : float
        Decay rate of (9).
    gamma : numpy.ndarray
        Lemma 2.1 offsets gamma_i (shape (n,)).
    """
    gamma = np.asarray(gamma, dtype=float)
    i = np.arange(1, gamma.size + 1)
    s_arr = np.asarray(s, dtype=float)
    terms = gamma**2 / np.power.outer(s_arr, 2 * i)
    return 2.0 * c0(P, d0) * terms.sum(axis=-1)


def a2(s: ArrayLike, P: np.ndarray, b: float) -> ArrayLike:
    """a2(s) = max{s, s^(b+n-1)}^2 lambda_max(P)/lambda_min(P) (Sanfelice & Praly, after (14))."""
    lam = np.linalg.eigvalsh(P)
    n = P.shape[0]
    s_arr = np.asarray(s, dtype=float)
    return np.maximum(s_arr, s_arr ** (b + n - 1)) ** 2 * lam[-1] / lam[0]


def L_hat(P: np.ndarray, L: np.ndarray) -> float:
    """L^ = (2/lambda_min(P)) sum_i i L_i^2 (Sanfelice & Praly, after (14); L-bar in Sec. 3)."""
    L = np.asarray(L, dtype=float)
    i = np.arange(1, L.size + 1)
    return 2.0 / float(np.linalg.eigvalsh(P)[0]) * float(np.sum(i * L**2))


def s_lower(c0_: float, L_hat_: float, d0: float) -> float:
    """s_min = max{sqrt(c0 L^/d0), 1}: the domain s > s_min of (14)-(15)."""
    return max(float(np.sqrt(c0_ * L_hat_ / d0)), 1.0)


@dataclass(frozen=True)
class SPSetup:
    """Data and derived constants of Sanfelice & Praly Remark 2.4 (build with ``sp_setup``)."""

    K: np.ndarray
    P: np.ndarray
    b: float
    d0: float
    d1: float
    gamma: np.ndarray
    L: np.ndarray
    n: int
    lam_min: float
    lam_max: float
    c0: float
    c1: float
    L_hat: float
    s_min: float
    reading: Reading14 = field(default_factory=Reading14)


def sp_setup(
    K: np.ndarray,
    P: np.ndarray,
    b: float,
    d0: float,
    d1: float,
    gamma: np.ndarray,
    L: np.ndarray,
    reading: Reading14 | None = None,
) -> SPSetup:
    """Collect (K~, P, b, d0, d1), Lemma 2.1's (gamma, L), and c0, c1, L^, s_min of Remark 2.4."""
    K = np.asarray(K, dtype=float).reshape(-1)
    P = np.asarray(P, dtype=float)
    gamma = np.asarray(gamma, dtype=float).reshape(-1)
    L = np.asarray(L, dtype=float).reshape(-1)
    if not (K.size == gamma.size == L.size == P.shape[0] == P.shape[1]):
        raise ValueError("K, P, gamma, L must have matching dimension n")
    lam = np.linalg.eigvalsh(P)
    c0_, Lh = c0(P, d0), L_hat(P, L)
    return SPSetup(
        K,
        P,
        float(b),
        float(d0),
        float(d1),
        gamma,
        L,
        K.size,
        float(lam[0]),
        float(lam[-1]),
        c0_,
        c1(P, K, d0),
        Lh,
        s_lower(c0_, Lh, d0),
        reading or Reading14(),
    )


# ------------------------------------------------------------------------ B~1, B1, B2


def B1_tilde(s: ArrayLike, p1p2: float, sp: SPSetup) -> ArrayLike:
    """B~1(s, p1p2) of Sanfelice & Praly (after (14)); reading per ``sp.reading`` (I5, I6)."""
    n, b = sp.n, sp.b
    e = sp.reading.exponent(n, b)
    s_arr = np.asarray(s, dtype=float)
    lead = 4 * sp.c1 * s_arr ** (1 - 2 * b) * a2(s_arr, sp.P, b)
    lead = lead / (sp.d0 * sp.lam_min * (2 * n + 1))
    base = sp.d1 * p1p2 + sp.c0 * sp.L_hat
    if sp.reading.b1_grouping == "literal":
        tail = 2 * base**e / sp.d0
    else:
        tail = 2 * (base / sp.d0) ** e
    return np.maximum(lead * tail, 2 * p1p2 / (sp.d0**2 * sp.lam_min))


def B1(s: ArrayLike, p1p2: float, sp: SPSetup) -> ArrayLike:
    """B1 = B~1^(1-2b) + (2 d1 + 2 c0 L^/(p1p2)) B~1 + 2 (Sanfelice & Praly, after (14))."""
    bt = B1_tilde(s, p1p2, sp)
    return bt ** (1 - 2 * sp.b) + (2 * sp.d1 + 2 * sp.c0 * sp.L_hat / p1p2) * bt + 2


def B2(sp: SPSetup) -> float:
    """B2 = 4 a1(1) / (d0 lambda_min(P)) (Sanfelice & Praly, after (14))."""
    return 4.0 * float(a1(1.0, sp.P, sp.d0, sp.gamma)) / (sp.d0 * sp.lam_min)


# ------------------------------------------------------------------ objectives (log form)


def _log_den(s: np.ndarray, sp: SPSetup) -> np.ndarray:
    with np.errstate(divide="ignore", invalid="ignore"):
        return np.log(sp.lam_min * (sp.d0 * s**2 - sp.c0 * sp.L_hat))


def _log_ratio(s: np.ndarray, p1: float, p2: float, sp: SPSetup) -> np.ndarray:
    """log of (B1 + B2/p2)^(2n/(1-2b)) / s^(2n), the adaptation factor of (14)-(15)."""
    x = B1(s, p1 * p2, sp) + B2(sp) / p2
    return 2 * sp.n / (1 - 2 * sp.b) * np.log(x) - 2 * sp.n * np.log(s)


def _log_objective_14(s, i: int, p1: float, p2: float, M_inf: float, sp: SPSetup):
    s = np.asarray(s, dtype=float)
    log_pre = 2 * i * np.log(s) - _log_den(s, sp)
    with np.errstate(divide="ignore"):
        first = log_pre + np.log(
            a1(s, sp.P, sp.d0, sp.gamma) + sp.reading.noise_factor * sp.c1 * M_inf**2
        )
    second = log_pre + np.log(2 * sp.c1 * p2) + np.logaddexp(0.0, _log_ratio(s, p1, p2, sp))
    return np.logaddexp(first, second)


def _log_objective_15(s, i: int, p1: float, p2: float, sp: SPSetup):
    s = np.asarray(s, dtype=float)
    log_pre = 2 * i * np.log(s) - _log_den(s, sp) + np.log(2 * sp.c1 * p2)
    return log_pre + np.logaddexp(np.log(2.0), _log_ratio(s, p1, p2, sp))


def objective_14(
    s: ArrayLike, i: int, p1: float, p2: float, M_inf: float, sp: SPSetup
) -> ArrayLike:
    """The quantity minimised over s in Sanfelice & Praly (14), for state i (1-based)."""
    return np.exp(_log_objective_14(s, i, p1, p2, M_inf, sp))


def objective_15(s: ArrayLike, i: int, p1: float, p2: float, sp: SPSetup) -> ArrayLike:
    """The quantity minimised over s in Sanfelice & Praly (15) (valid when (13) holds)."""
    return np.exp(_log_objective_15(s, i, p1, p2, sp))


def constant_gain_bound(r: float, i: int, M_inf: float, sp: SPSetup) -> float:
    """Constant-gain bound after (14): r^(2i)(a1(r) + 2 c1 M^2)/(lmin (d0 r^2 - c0 L^)).

    Valid for a constant gain r > s_min (Sanfelice & Praly, Remark 2.4); the noise factor
    follows ``sp.reading`` (I3).
    """
    num = r ** (2 * i) * (a1(r, sp.P, sp.d0, sp.gamma) + sp.reading.noise_factor * sp.c1 * M_inf**2)
    return float(num / (sp.lam_min * (sp.d0 * r**2 - sp.c0 * sp.L_hat)))


# ----------------------------------------------------------------------- minimisation


@dataclass(frozen=True)
class BoundResult:
    """A bound minimised over s: value, minimiser s*, and whether the minimum is attained.

    ``attained`` is False when the grid minimum lies at the grid's upper end (the infimum is
    then approached as s -> infinity and ``value`` is the value there).
    """

    value: float
    s_star: float
    attained: bool


def minimise_over_s(
    log_f: Callable[[np.ndarray], np.ndarray],
    s_min: float,
    s_max_factor: float = 1e4,
    n_grid: int = 4000,
) -> BoundResult:
    """Minimise exp(log_f(s)) over s in (s_min, s_min*s_max_factor]: log grid + bounded refine.

    Parameters
    ----------
    log_f : callable
        Vectorised log of the objective.
    s_min : float
        Open lower end of the domain (Sanfelice & Praly (14): max{sqrt(c0 L^/d0), 1}).
    s_max_factor : float
        The grid spans [s_min (1 + 1e-9), s_min s_max_factor].
    n_grid : int
        Number of log-spaced grid points.
    """
    require_finite("the bound's domain (Sanfelice & Praly (14): s > s_min)", s_min=s_min)
    u = np.linspace(np.log(s_min) + 1e-9, np.log(s_min * s_max_factor), n_grid)
    k, grid_v = _grid_min(log_f, u)
    best_u, best_v = _zoom(log_f, u[max(k - 1, 0)], u[min(k + 1, n_grid - 1)])
    if not best_v < grid_v:
        best_u, best_v = u[k], grid_v
    return BoundResult(float(np.exp(best_v)), float(np.exp(best_u)), k < n_grid - 1)


def _zoom(log_f: Callable[[np.ndarray], np.ndarray], lo: float, hi: float,
          xatol: float = 1e-12, n: int = 65) -> tuple[float, float]:
    """Minimiser and minimum of ``log_f(exp(u))`` over ``u`` in ``[lo, hi]``, by zooming:
    ``n`` points per round, the bracket shrunk to the two cells around the smallest value
    (a factor (n - 1) / 2 per round) until narrower than ``xatol``. Vectorised, so a
    handful of calls instead of scipy's ~50 scalar ones (and no scipy.optimize import).
    Stops after :data:`hgo.core.lmi.MAX_ROUNDS` rounds or when float spacing is reached; a
    NaN/inf bracket raises (``hi - lo < xatol`` is never true for NaN: it looped forever)."""
    require_finite("minimising the bound over s (Sanfelice & Praly (14))", lo=lo, hi=hi)
    for _ in range(MAX_ROUNDS):
        u = np.linspace(lo, hi, n)
        k, v = _grid_min(log_f, u)
        if hi - lo < xatol:
            break
        new_lo, new_hi = u[max(k - 1, 0)], u[min(k + 1, n - 1)]
        if (new_lo, new_hi) == (lo, hi):  # float spacing reached
            break
        lo, hi = new_lo, new_hi
    return float(u[k]), float(v)


def _grid_min(log_f: Callable[[np.ndarray], np.ndarray], u: np.ndarray) -> tuple[int, float]:
    """Index and value of the smallest ``log_f(exp(u))`` (NaN counts as +inf)."""
    vals = np.where(np.isnan(v := log_f(np.exp(u))), np.inf, v)
    k = int(np.argmin(vals))
    return k, vals[k]


def B_io(i: int, p1: float, p2: float, M_inf: float, sp: SPSetup) -> BoundResult:
    """B_{i,o}(p1, p2) of Sanfelice & Praly (14): bound (12) on the mean of |x^_i - x_i|^2."""
    return minimise_over_s(lambda s: _log_objective_14(s, i, p1, p2, M_inf, sp), sp.s_min)


def B_io_15(i: int, p1: float, p2: float, sp: SPSetup) -> BoundResult:
    """B_{i,o}(p1, p2) in the form (15) of Sanfelice & Praly (an upper bound of (14) under (13))."""
    return minimise_over_s(lambda s: _log_objective_15(s, i, p1, p2, sp), sp.s_min)


def p2_lower_bound_13(s: float, M_inf: float, sp: SPSetup) -> float:
    """Right-hand side of Sanfelice & Praly (13) at s.

    max{2 M^2 + a1(s)/(2 c1), 4 M^2 (1 + c1/(d0 lambda_min(P)))}; a1 decreases in s, so
    s = s_min gives the largest value over the admissible s (interpretation I12).
    """
    first = 2 * M_inf**2 + float(a1(s, sp.P, sp.d0, sp.gamma)) / (2 * sp.c1)
    second = 4 * M_inf**2 * (1 + sp.c1 / (sp.d0 * sp.lam_min))
    return max(first, second)


def output_bound_11(p2: float) -> float:
    """Bound (11) of Sanfelice & Praly on the mean of (y^ - y)^2: p2."""
    return float(p2)


# ------------------------------------------------------------------------------ table


@dataclass(frozen=True)
class StateBound:
    """Bounds for state i (1-based): (14) with its s*, (15), and (13) at this s*."""

    i: int
    B_io: float
    s_star: float
    attained: bool
    B_io_15: float
    s_star_15: float
    p2_lower_bound_13_at_s_star: float


@dataclass(frozen=True)
class BoundTable:
    """Sanfelice & Praly (11)-(15) for one parameter set (see ``sp_bound_table``)."""

    states: list[StateBound]
    output_bound: float
    p2_lower_bound_13: float
    condition_13_holds: bool
    s_min: float
    c0: float
    c1: float
    L_hat: float
    B2: float
    reading: Reading14

    def as_dict(self) -> dict:
        """Plain-dict view (e.g. for a pandas DataFrame or a YAML dump)."""
        return {
            "states": [vars(st) for st in self.states],
            "output_bound": self.output_bound,
            "p2_lower_bound_13": self.p2_lower_bound_13,
            "condition_13_holds": self.condition_13_holds,
            "s_min": self.s_min,
            "c0": self.c0,
            "c1": self.c1,
            "L_hat": self.L_hat,
            "B2": self.B2,
            "reading": vars(self.reading),
        }


def _state_bound(i: int, p1: float, p2: float, M_inf: float, sp: SPSetup) -> StateBound:
    r14 = B_io(i, p1, p2, M_inf, sp)
    r15 = B_io_15(i, p1, p2, sp)
    lb = p2_lower_bound_13(r14.s_star, M_inf, sp)
    return StateBound(i, r14.value, r14.s_star, r14.attained, r15.value, r15.s_star, lb)


def sp_bound_table(
    K: np.ndarray,
    P: np.ndarray,
    b: float,
    d0: float,
    d1: float,
    gamma: np.ndarray,
    L: np.ndarray,
    p1: float,
    p2: float,
    M_inf: float,
    reading: Reading14 | None = None,
) -> BoundTable:
    """All bounds of Sanfelice & Praly Remark 2.4 for states i = 1..n.

    Parameters
    ----------
    K, P, b, d0, d1 :
        Data satisfying (8)-(10) (see ``hgo.papers.sanfelice_praly.theory.check_conditions``).
    gamma, L : numpy.ndarray
        Lemma 2.1 constants; plant (18): gamma = [nu2, 0], L = [nu1, 0].
    p1, p2 : float
        Parameters of the adaptation law (6).
    M_inf : float
        Bound on the measurement noise, ||m||_inf <= M_inf.
    reading : Reading14, optional
        Interpretation of the damaged (14) (default: the literal reading).

    Returns
    -------
    BoundTable
        Per state: B_io (14) with s*, (15); globally: output bound (11) = p2, the (13) lower
        bound at s = s_min (sup over admissible s), whether p2 satisfies it, c0, c1, L^, B2.
    """
    sp = sp_setup(K, P, b, d0, d1, gamma, L, reading)
    states = [_state_bound(i, p1, p2, M_inf, sp) for i in range(1, sp.n + 1)]
    lb = p2_lower_bound_13(sp.s_min, M_inf, sp)
    return BoundTable(
        states,
        output_bound_11(p2),
        lb,
        bool(p2 >= lb),
        sp.s_min,
        sp.c0,
        sp.c1,
        sp.L_hat,
        B2(sp),
        sp.reading,
    )
