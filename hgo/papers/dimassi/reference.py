"""Plain-Python right-hand side of the Dimassi et al. Sec. IV example, written from the paper.

An independent implementation of (24)-(25), (27), the saturation of Sec. IV, (5) and (7)
(reading A2 selectable), for scipy's ``solve_ivp``: the reference of the kernel test
(tests/test_dhlm_components.py) and the baseline of ``benchmarks/dhlm_bench.py``.
State w = [x1, x2, z_h11, z_h12, x^1, x^2, theta^1, theta^2].
"""

from __future__ import annotations

import math
from dataclasses import dataclass


@dataclass(frozen=True)
class Example:
    """Sec. IV values (defaults); psi_at in {"y", "xhat"}."""

    I: float = 0.5  # noqa: E741
    mgl: float = 9.81
    eps: float = 0.006
    g1: float = 6.0
    g2: float = 8.0
    S: float = 150.0
    L: tuple = ((5.0, 0.0), (1.0, 10.0))
    M: tuple = (0.0, 1.0)
    delta: float = 100.0
    sigma: float = 0.01
    psi_at: str = "y"

    def u(self, t: float) -> float:
        return 5.0 * (math.sin(2.0 * t) + math.cos(3.0 * t))

    def rhs(self, t: float, w) -> list[float]:
        x1, x2, zh1, zh2, xh1, xh2, th1, th2 = w
        u = self.u(t)
        e = x1 - zh1
        s1 = min(max(zh1, -self.S), self.S)
        s2 = min(max(zh2, -self.S), self.S)
        i1, i2 = s1 - xh1, s2 - xh2  # z_h^s - H x^, H = I
        arg = x1 if self.psi_at == "y" else xh1  # y = x1
        psi1, psi2 = u, -math.sin(arg)
        (l11, l12), (l21, l22) = self.L
        m = self.M[0] * i1 + self.M[1] * i2
        return [x2, (u - 0.5 * self.mgl * math.sin(x1)) / self.I,
                zh2 + self.g1 / self.eps * e, self.g2 / self.eps ** 2 * e,
                xh2 + l11 * i1 + l12 * i2, psi1 * th1 + psi2 * th2 + l21 * i1 + l22 * i2,
                self.delta * psi1 * m - self.sigma * th1, self.delta * psi2 * m - self.sigma * th2]


X0 = (1.0, 1.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0)
