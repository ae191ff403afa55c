"""Reference solution of Moreno's example with scipy: plant (original coordinates of
Section 5) + observer (3) + error system (5), integrated together by ``solve_ivp`` with a
Python right-hand side, restarted at the input's corners (breakpoints).

Used to check the engine (refinement: the engine's run against Radau at rtol 1e-10), the
decomposition (e of (5) against x - x^, Moreno (4)-(5)) and as the benchmark's baseline.
State w = [x (2), x^ (2), e (2)].
"""

from __future__ import annotations

import numpy as np
from scipy.integrate import solve_ivp

from hgo.components import Controller
from hgo.controllers.profile_input import breakpoints, profile
from hgo.observers.circle_criterion import CircleCriterionObserver
from hgo.plants.circle_form import example_rhs


def joint_rhs(obs: CircleCriterionObserver, ctrl: Controller, a: float,
              with_error: bool = True):
    """The Python right-hand side of [x, x^, e]: Section 5 (original coordinates), (3), (5);
    without the error system (5) when ``with_error`` is False (state [x, x^])."""
    pl = obs.plant
    A, G, C, H, B, L, N = pl.A, pl.G, pl.C, pl.H, pl.B, obs.L, obs.N
    A_L, _, H_N = obs.error_matrices()
    cp = ctrl.p

    def rhs(t, w):
        x, xh = w[0:2], w[2:4]
        r, dr = profile(t, cp)
        u = dr + cp[1] * r
        innov = C @ x - C @ xh
        dxh = A @ xh + L * innov + G * pl.psi(H @ xh + N * innov) + B * u
        if not with_error:
            return np.concatenate([example_rhs(x, u, a), dxh])
        e = w[4:6]
        de = A_L @ e + G * pl.phi(H_N @ e, H @ x)
        return np.concatenate([example_rhs(x, u, a), dxh, de])

    return rhs


def reference_run(obs: CircleCriterionObserver, ctrl: Controller, a: float, t_end: float,
                  dt_out: float, method: str = "Radau", rtol: float = 1e-10,
                  atol: float = 1e-12, with_error: bool = True, max_step: float = np.inf
                  ) -> tuple[np.ndarray, np.ndarray, int]:
    """(t, w on the grid k dt_out, number of right-hand-side evaluations)."""
    rhs = joint_rhs(obs, ctrl, a, with_error)
    pl = obs.plant
    w = np.concatenate([pl.x0, obs.z0] + ([pl.x0 - obs.z0] if with_error else []))
    n = int(round(t_end / dt_out)) + 1
    t_grid = np.linspace(0.0, t_end, n)
    out = np.empty((n, w.size))
    edges = [0.0, *breakpoints(ctrl, t_end), t_end]
    nfev = 0
    for t0, t1 in zip(edges[:-1], edges[1:], strict=True):
        sel = (t_grid >= t0) & (t_grid < t1)
        t_eval = np.append(t_grid[sel], t1)
        sol = solve_ivp(rhs, (t0, t1), w, method=method, rtol=rtol, atol=atol, t_eval=t_eval,
                        max_step=max_step)
        if sol.status != 0:
            raise RuntimeError(f"solve_ivp ({method}) failed at t = {sol.t[-1]}: {sol.message}")
        out[sel] = sol.y[:, :-1].T
        w = sol.y[:, -1]
        nfev += sol.nfev
    out[-1] = w
    return t_grid, out, nfev
