"""Reference solution of Moreno's example with scipy: plant (original coordinates of
Section 5) + observer (3) + error system (5), integrated together by ``solve_ivp`` with a
Python right-hand side, restarted at the input's corners (breakpoints).

Used to check the engine (refinement: the engine's run against Radau at rtol 1e-10), the
decomposition (e of (5) against x - x^, Moreno (4)-(5)) and as the benchmark's baseline.
State w = [x (2), x^ (2), e (2)]; the baseline's state is [x, x^] and its right-hand side
``plain_rhs`` is written in Python floats (as ``hgo.papers.dimassi.reference``): 1.7 us a
call against 7.5 us for ``joint_rhs``'s small-array numpy, which halved solve_ivp's time.
"""

from __future__ import annotations

import numpy as np
from scipy.integrate import solve_ivp

from hgo.controllers.profile_input import breakpoints, profile
from hgo.core.components import Controller
from hgo.observers.circle_criterion import CircleCriterionObserver
from hgo.plants.circle_form import example_rhs


def joint_rhs(obs: CircleCriterionObserver, ctrl: Controller, a: float,
              with_error: bool = True):
    """The Python right-hand side of [x, x^, e]: Section 5 (original coordinates), (3), (5);
    without the error system (5) when ``with_error`` is False (state [x, x^])."""
    pl = obs.plant
    A, G, C, H, B, L, N = pl.A, pl.G, pl.C, pl.H, pl.B, obs.L, obs.N
    A_L, _, H_N = obs.error_matrices()
    cp = ctrl.p.record()

    def rhs(t, w):
        x, xh = w[0:2], w[2:4]
        r, dr = profile(t, cp)
        u = dr + cp.a * r
        innov = C @ x - C @ xh
        dxh = A @ xh + L * innov + G * pl.psi(H @ xh + N * innov) + B * u
        if not with_error:
            return np.concatenate([example_rhs(x, u, a), dxh])
        e = w[4:6]
        de = A_L @ e + G * pl.phi(H_N @ e, H @ x)
        return np.concatenate([example_rhs(x, u, a), dxh, de])

    return rhs


def plain_rhs(obs: CircleCriterionObserver, ctrl: Controller, a: float):
    """The right-hand side of [x, x^] in plain Python floats: Section 5 (original
    coordinates) and (3) for n = 2 (the benchmark's baseline; ``joint_rhs`` computes the
    same with numpy)."""
    pl = obs.plant
    (a11, a12), (a21, a22) = pl.A.tolist()
    g1, g2 = pl.G.tolist()
    c1, c2 = pl.C.tolist()
    h1, h2 = pl.H.tolist()
    b1, b2 = pl.B.tolist()
    l1, l2 = obs.L.tolist()
    gain_n = obs.N
    coeffs = pl.psi_coeffs.tolist()[::-1]  # highest power first (Horner)
    cp = ctrl.p.record()  # the parameters read once, as plain floats

    def rhs(t, w):
        x1, x2, xh1, xh2 = w.tolist()
        r, dr = profile(t, cp)
        u = dr + cp.a * r
        innov = c1 * (x1 - xh1) + c2 * (x2 - xh2)
        s = h1 * xh1 + h2 * xh2 + gain_n * innov
        psi = 0.0
        for c in coeffs:
            psi = psi * s + c
        return [-x1 + x2 * (x2 * x2 - 1.0), -a * x2 + u,
                a11 * xh1 + a12 * xh2 + l1 * innov + g1 * psi + b1 * u,
                a21 * xh1 + a22 * xh2 + l2 * innov + g2 * psi + b2 * u]

    return rhs


def reference_run(obs: CircleCriterionObserver, ctrl: Controller, a: float, t_end: float,
                  dt_out: float, method: str = "Radau", rtol: float = 1e-10,
                  atol: float = 1e-12, with_error: bool = True, max_step: float = np.inf,
                  plain: bool = False) -> tuple[np.ndarray, np.ndarray, int]:
    """(t, w on the grid k dt_out, number of right-hand-side evaluations); ``plain``:
    ``plain_rhs`` on [x, x^] (``with_error`` is then ignored)."""
    with_error = with_error and not plain
    rhs = plain_rhs(obs, ctrl, a) if plain else joint_rhs(obs, ctrl, a, with_error)
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
