"""Open-loop inputs defined by the x2-profile r(t) they produce, u = r' + a r (Moreno
Section 5, inputs not given in the paper; implementation notes section 9).

With x2(0) = r(0) = 0 and x2' = -a x2 + u, u = r' + a r gives x2 = r for every a, so runs
with a = 0 and a > 0 see the same sigma = x2. Profiles (``kind``):

* ``bad``: r = 0 (u = 0 for a = 0): the paper's bad input, sigma stays at 0;
* ``pulse``: r = 0 before t_on, a ramp from 0 to ``level`` over [t_on, t_on + tau], then
  ``level`` (default: t_on = 5, tau = 0.5, level = 2, the Fig. 1 input). ``ramp``:
  ``linear`` (default) is the implementation notes' ramp of slope level / tau, whose u
  jumps at the corners; the corners are the controller's break points (:func:`corners`),
  so the engine ends a step at each and never steps over a jump (before break points, an
  embedded pair stepping over it left errors of ~1e-8 at rtol 1e-10 that depended on
  rounding). ``smooth`` is the quintic smoothstep r = level (10 s^3 - 15 s^4 + 6 s^5),
  s = (t - t_on) / tau, so u = r' + a r is continuous with a continuous slope;
* ``pulse_return``: ``pulse``, then back to 0 by a ramp on [t_back, t_back + tau);
* ``sin``: r = amp sin(omega t).

Parameters (by name): constants kind (``KINDS``) and smooth (``RAMPS``); values a, t_on,
tau, level, amp, omega, t_back.
"""

from __future__ import annotations

import math

from hgo.core.components import Controller, Params
from hgo.engine.jit import kernel_helper, record_helper

KINDS = {"bad": 0, "pulse": 1, "pulse_return": 2, "sin": 3}
RAMPS = {"linear": 0, "smooth": 1}


@kernel_helper
def _ramp(t, t0, tau, level, smooth):
    """(value, slope) of a ramp from 0 to level over [t0, t0 + tau]: linear, or the
    quintic smoothstep 10 s^3 - 15 s^4 + 6 s^5 (zero slope and curvature at both ends)."""
    if t < t0:
        return 0.0, 0.0
    if t < t0 + tau:
        s = (t - t0) / tau
        if smooth == 0:
            return level * s, level / tau
        return (level * s * s * s * (10.0 - 15.0 * s + 6.0 * s * s),
                level / tau * 30.0 * s * s * (1.0 - s) * (1.0 - s))
    return level, 0.0


@record_helper
def profile(t, p):
    """(r(t), r'(t)) of the profile of the controller's parameters p (module doc)."""
    if p.kind == 3:
        return p.amp * math.sin(p.omega * t), p.amp * p.omega * math.cos(p.omega * t)
    if p.kind == 0:
        return 0.0, 0.0
    r, dr = _ramp(t, p.t_on, p.tau, p.level, p.smooth)
    if p.kind == 2:
        r2, dr2 = _ramp(t, p.t_back, p.tau, p.level, p.smooth)
        return r - r2, dr - dr2
    return r, dr


def u(t, xhat, y, p, u_out):
    """u = r' + a r."""
    r, dr = profile(t, p)
    u_out[0] = dr + p.a * r


def profile_input(kind: str = "pulse", a: float = 0.0, t_on: float = 5.0, tau: float = 0.5,
                  level: float = 2.0, amp: float = 2.0, omega: float = 1.0,
                  t_back: float = 9.0, ramp: str = "linear", name: str = "profile"
                  ) -> Controller:
    """Input u = r' + a r for the profile ``kind`` (see the module docstring)."""
    if kind not in KINDS:
        raise ValueError(f"controller.kind: '{kind}' not in {sorted(KINDS)}")
    if ramp not in RAMPS:
        raise ValueError(f"controller.ramp: '{ramp}' not in {sorted(RAMPS)}")
    for key, value in (("a", a), ("t_on", t_on), ("level", level), ("amp", amp),
                       ("omega", omega), ("t_back", t_back)):
        if not math.isfinite(value):
            raise ValueError(f"controller.{key} must be finite, got {value}")
    if not tau > 0:
        raise ValueError(f"controller.tau must be > 0 (seconds), got {tau}")
    if kind == "pulse_return" and not t_back >= t_on + tau:
        raise ValueError(f"controller.t_back must be >= t_on + tau = {t_on + tau}, got {t_back}")
    p = Params({"kind": KINDS[kind], "smooth": RAMPS[ramp]}, a=a, t_on=t_on, tau=tau,
               level=level, amp=amp, omega=omega, t_back=t_back)
    return Controller(name=name, p=p, u=u, observer=None, breaks=corners)


def corners(p) -> list[float]:
    """The instants where u jumps (linear ramp) or its higher derivatives do (smooth
    ramp): the ramps' ends, the controller's break points (the engine ends a step at
    each). The same sums as :func:`_ramp` compares t with, so the same floats."""
    t_on, tau, t_back = p.t_on, p.tau, p.t_back
    return {0: [], 1: [t_on, t_on + tau], 2: [t_on, t_on + tau, t_back, t_back + tau],
            3: []}[p.kind]


def breakpoints(c: Controller, t_end: float) -> list[float]:
    """Instants in (0, t_end) where u or its slope has a corner (a reference integrator
    restarts there)."""
    return [t for t in corners(c.p) if 0 < t < t_end]


def input_period(c: Controller | None) -> float | None:
    """The period 2 pi / omega of a ``sin`` profile input; None for any other input."""
    if c is None or c.u is not u or c.p.kind != KINDS["sin"] or c.p.omega == 0:
        return None
    return 2 * math.pi / abs(c.p.omega)
