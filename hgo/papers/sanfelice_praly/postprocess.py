"""Sanfelice & Praly bounds (11)-(15) for every law-(6) observer of a run, as metric rows.

For each observer with the sign-indefinite law (6) (:mod:`hgo.observers.triangular` with
``law: sign_indefinite``, and each copy of :mod:`hgo.observers.collection`):

* K~ and b are the observer's own (``K``/``b`` in this post-processor's config, when given,
  must agree with them: the bound is for the observer that ran); P, d0, d1 come from the
  config (default: the paper's example, Section 3); the margins of (8)-(10) for
  (K~, P, b, d0, d1) are a row (``conditions_8_10_min_margin``, >= 0 iff they hold);
* gamma, L (Lemma 2.1) from the plant: for the plant (18) ``sp_linear``,
  :func:`hgo.plants.sp_linear.mismatch_constants` (gamma = [nu2, 0], L = [nu1, 0]);
  another plant needs ``gamma`` and ``L`` in the config;
* p1, p2 from the observer; M_inf (noise bound ||m||_inf) from the config, interpolated
  from ``${noise.amplitude}`` (0 for noise=none; a Gaussian noise has no finite bound).
  Row ``noise_sup``: the run's max |m| against M_inf (``holds`` iff Theorem 2.2's
  hypothesis ||m||_inf <= M_inf holds); when it does not (Gaussian noise, an M_inf below
  the noise actually applied) no bound of (14) is attached to the mean-error rows: they
  would promise what the theorem does not;
* B_{i,o}(p1, p2) of (14), minimised over s > s_min (interpretation: the literal reading of
  :mod:`hgo.papers.sanfelice_praly.bounds`), fills the ``bound`` column of the runner's
  ``mean_sq_error_<x_i>`` row of a triangular observer; rows ``s_star_<x_i>`` (the minimiser)
  and ``B_io_15_<x_i>`` (the form (15));
* (13): row ``p2_lower_bound_13`` with empirical = the right-hand side of (13) at s = s_min,
  bound = p2, so ``holds`` says whether (13) holds for the run's parameters.

For a collection (21) the injection terms are outside Theorem 2.2, so no bound is given for
the average's rows; the (11) check is made per copy: rows ``mean_sq_output_error_copy<i>``,
(1/T) int (y^_i - y)^2 over the trailing window, with bound p2.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from hgo.engine.simulate import Trajectory
from hgo.engine.system import System
from hgo.observers import collection, triangular
from hgo.papers.sanfelice_praly.bounds import sp_bound_table
from hgo.papers.sanfelice_praly.theory import check_conditions
from hgo.plants import sp_linear
from hgo.postprocess import PostOutput
from hgo.postprocess.notch import window_mean_sq
from hgo.postprocess.oscillation import window_slice

PAPER_P = [[1.0, -0.5], [-0.5, 0.5]]


def law6_parameters(obs) -> dict | None:
    """kind, n, p1, p2, b, K~ (and N for a collection) of a law-(6) observer, else None."""
    if obs.f is triangular.f:
        p = obs.p
        if p.law != triangular.LAWS["sign_indefinite"]:
            return None
        return {"kind": "triangular", "n": p.n, "p1": p.p1, "p2": p.p2, "b": p.b,
                "K": np.array(p.K)}
    if obs.f is collection.f:
        return {"kind": "collection", **collection.collection_params(obs)}
    return None


@dataclass
class SPBounds:
    """Post-processor: Sanfelice & Praly (8)-(15) for the run's law-(6) observers."""

    P: np.ndarray
    d0: float
    d1: float
    M_inf: float
    K: np.ndarray | None = None
    b: float | None = None
    gamma: np.ndarray | None = None
    L: np.ndarray | None = None

    def _mismatch(self, system: System) -> tuple[np.ndarray, np.ndarray]:
        if self.gamma is not None and self.L is not None:
            return self.gamma, self.L
        if system.plant.name == "sp_linear":  # what the config leaves out comes from (18)
            gamma, L = sp_linear.mismatch_constants(*system.plant.p[:2])
            return (gamma if self.gamma is None else self.gamma,
                    L if self.L is None else self.L)
        raise ValueError("postprocess.sp_bounds: give gamma and L (Lemma 2.1) for plant "
                         f"'{system.plant.name}'")

    def check(self, system: System, solver, key: str) -> None:  # noqa: ARG002
        """What apply would refuse, refused before the run: the mismatch constants and the
        agreement of K, b, P with every law-(6) observer."""
        self._mismatch(system)
        for obs in system.observers:
            par = law6_parameters(obs)
            if par is not None:
                self._check_agrees(obs.name, par)

    def apply(self, system: System, traj: Trajectory) -> PostOutput:
        gamma, L = self._mismatch(system)
        out = PostOutput()
        sl = window_slice(traj)
        m_sup = float(np.abs(traj.m).max()) if traj.m.size else 0.0
        bounded = m_sup <= self.M_inf
        out.rows.append({"observer": "", "quantity": "noise_sup", "empirical": m_sup,
                         "bound": self.M_inf,
                         "note": "Theorem 2.2 needs ||m||_inf <= M_inf" + ("" if bounded else
                                 ": it does NOT hold, (14) is not attached")})
        states = system.plant.state_names
        for k, obs in enumerate(system.observers):
            par = law6_parameters(obs)
            if par is None:
                continue
            self._check_agrees(obs.name, par)
            rep = check_conditions(par["K"], self.P, par["b"], self.d0, self.d1)
            margin = min(rep.decay_margin, rep.r_lower_margin, rep.r_upper_margin,
                         rep.lambda_min_P)
            tab = sp_bound_table(par["K"], self.P, par["b"], self.d0, self.d1, gamma, L,
                                 par["p1"], par["p2"], self.M_inf)
            name = obs.name
            out.rows.append({"observer": name, "quantity": "conditions_8_10_min_margin",
                             "empirical": margin,
                             "note": "(8)-(10) hold iff >= 0" + ("" if rep.holds else
                                                                 ": they do NOT hold")})
            out.rows.append({"observer": name, "quantity": "p2_lower_bound_13",
                             "empirical": tab.p2_lower_bound_13, "bound": par["p2"],
                             "note": "holds: p2 satisfies (13) at s = s_min"})
            for st in tab.states:
                x = states[obs.estimated_states[st.i - 1]]
                out.rows += [
                    {"observer": name, "quantity": f"s_star_{x}", "empirical": st.s_star,
                     "note": f"minimiser of (14), s_min = {tab.s_min:.6g}"
                     + ("" if st.attained else ", infimum as s -> inf")},
                    {"observer": name, "quantity": f"B_io_15_{x}", "empirical": st.B_io_15,
                     "note": "bound (15) (valid when (13) holds)"},
                ]
                if par["kind"] == "triangular" and bounded:
                    out.bounds[(name, f"mean_sq_error_{x}")] = st.B_io
                else:
                    out.rows.append({"observer": name, "quantity": f"B_io_{x}",
                                     "empirical": st.B_io,
                                     "note": "(14) for one copy without injection"
                                     if par["kind"] == "collection" else
                                     "(14), not attached: the noise exceeds M_inf"})
            if par["kind"] == "collection":
                za, zb = system.z_slices[1 + k]
                xh, _ = collection.copy_states(obs, traj.z[:, za:zb])
                y = traj.y[:, 0]
                for i in range(par["N"]):
                    value = window_mean_sq(traj.t[sl], xh[sl, i, 0] - y[sl])
                    out.rows.append({"observer": name,
                                     "quantity": f"mean_sq_output_error_copy{i + 1}",
                                     "empirical": value, "bound": par["p2"],
                                     "note": "(11) per copy"})
        return out

    def _check_agrees(self, name: str, par: dict) -> None:
        if self.K is not None and (self.K.shape != np.shape(par["K"])
                                   or not np.allclose(self.K, par["K"])):
            raise ValueError(f"postprocess.sp_bounds.K = {list(self.K)} differs from observer "
                             f"{name}'s K~ = {list(par['K'])}")
        if self.b is not None and not math.isclose(self.b, par["b"]):
            raise ValueError(f"postprocess.sp_bounds.b = {self.b} differs from observer "
                             f"{name}'s b = {par['b']}")
        if self.P.shape != (par["n"], par["n"]):
            raise ValueError(f"postprocess.sp_bounds.P must be {par['n']}x{par['n']} for "
                             f"observer {name}")


def sp_bounds(P: Sequence[Sequence[float]] = PAPER_P, d0: float = 0.95, d1: float = 3.0,
              M_inf: float = 0.0, K: Sequence[float] | None = None, b: float | None = None,
              gamma: Sequence[float] | None = None,
              L: Sequence[float] | None = None) -> SPBounds:
    """Factory for the ``postprocess`` group (defaults: Sanfelice & Praly Section 3)."""
    P = np.asarray(P, float)
    if P.ndim != 2 or P.shape[0] != P.shape[1] or not np.allclose(P, P.T):
        raise ValueError("postprocess.sp_bounds.P must be a symmetric square matrix")
    if not np.all(np.isfinite(P)) or np.linalg.eigvalsh(P).min() <= 0:
        eig = np.linalg.eigvalsh(P) if np.all(np.isfinite(P)) else P.ravel()
        raise ValueError("postprocess.sp_bounds.P must be positive definite (Sanfelice & "
                         f"Praly (8)-(10)), got eigenvalues {np.round(eig, 6).tolist()}")
    if not (d0 > 0 and d1 > 0):
        raise ValueError(f"postprocess.sp_bounds: d0, d1 must be > 0 (8), got {d0}, {d1}")
    if M_inf is None or not M_inf >= 0:
        raise ValueError(f"postprocess.sp_bounds.M_inf must be >= 0, got {M_inf}")
    arr = (lambda v: None if v is None else np.asarray(v, float))  # noqa: E731
    return SPBounds(P, float(d0), float(d1), float(M_inf), arr(K),
                    None if b is None else float(b), arr(gamma), arr(L))
