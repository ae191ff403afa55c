"""Speed tracking of the field-controlled DC motor by feedback linearisation.

Khalil, Nonlinear Systems (2002), field-controlled DC motor; Ahrens & Khalil Section 4.
With dx2/dt = -a x2 + b x3 u (Ahrens & Khalil (38)), the state feedback

    u = (v + a x^2) / (b x3),   v = r''(t) - k (x^2 - r'(t)),

gives the velocity error e2 = x2 - r' the dynamics de2/dt = -k e2 when x^2 = x2. The
controller uses the (saturated) velocity estimate x^2 of its observer and the measured
armature current x3 = y[1]. Guard: |x3| is floored at ``x3_min`` (sign kept, 0 -> +)
so u stays finite; ``u_max`` (inf by default) optionally clips the field current. With
x^2 saturated (Ahrens & Khalil, Section 4) and x3 floored, u is globally bounded in x^
(Assumption 2(2)).

Velocity reference (the paper's Fig. 1 reference is not given; this one is a choice):

    r'(t) = w0 + w_step S((t - t_step) / T_rise) + a_sin sin(omega_sin t),
    S(s) = 0 (s <= 0), 3 s^2 - 2 s^3 (0 < s < 1), 1 (s >= 1),

a C1 smoothed step (so r'' is continuous) plus an optional sinusoid. Default: a smoothed
step from rest to 10 rad/s over the first second (r'(0) = r''(0) = 0 match the motor at
rest), no sinusoid. Default gain k = 5 1/s (velocity-loop time constant 0.2 s, 20 times
slower than the eps2 = 0.01 observer, so the observer is the fast subsystem). a = b = 0.1
are the motor's true coefficients (the observer's phi0 carries the model error).

Parameters (by name): a, b, k, x3_min, u_max, w0, w_step, t_step, T_rise, a_sin, omega_sin.
"""

from __future__ import annotations

import math

import numpy as np

from hgo.core.components import Controller, Params
from hgo.engine.jit import kernel_helper


@kernel_helper
def reference(t, w0, w_step, t_step, t_rise, a_sin, omega):
    """(r'(t), r''(t)): smoothed step plus sinusoid (the module doc's r')."""
    s = (t - t_step) / t_rise
    if s <= 0.0:
        step, dstep = 0.0, 0.0
    elif s >= 1.0:
        step, dstep = 1.0, 0.0
    else:
        step = s * s * (3.0 - 2.0 * s)
        dstep = 6.0 * s * (1.0 - s) / t_rise
    rd = w0 + w_step * step
    rdd = w_step * dstep
    if a_sin != 0.0:
        rd += a_sin * math.sin(omega * t)
        rdd += a_sin * omega * math.cos(omega * t)
    return rd, rdd


def u(t, xhat, y, p, u_out):
    """u = (v + a x^2) / (b x3), v = r'' - k (x^2 - r') (feedback linearisation)."""
    rd, rdd = reference(t, p.w0, p.w_step, p.t_step, p.T_rise, p.a_sin, p.omega_sin)
    v = rdd - p.k * (xhat[1] - rd)
    x3 = y[1]
    if abs(x3) < p.x3_min:
        x3 = p.x3_min if x3 >= 0.0 else -p.x3_min
    val = (v + p.a * xhat[1]) / (p.b * x3)
    u_out[0] = min(max(val, -p.u_max), p.u_max)


def velocity_reference(p, t: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """r'(t) and r''(t) on the times t, for logging the reference next to x2 (``p``: the
    controller's parameters)."""
    t = np.atleast_1d(np.asarray(t, float))
    out = np.empty((t.size, 2))
    # one compiled loop, not a call per sample
    _reference_grid(t, p.w0, p.w_step, p.t_step, p.T_rise, p.a_sin, p.omega_sin, out)
    return out[:, 0], out[:, 1]


@kernel_helper
def _reference_grid(t, w0, w_step, t_step, t_rise, a_sin, omega, out):
    for k in range(t.shape[0]):
        out[k, 0], out[k, 1] = reference(t[k], w0, w_step, t_step, t_rise, a_sin, omega)


def dc_motor_speed_controller(observer: str | None = None, k: float = 5.0, w0: float = 0.0,
                              w_step: float = 10.0, t_step: float = 0.0, T_rise: float = 1.0,
                              a_sin: float = 0.0, omega_sin: float = 0.0, a: float = 0.1,
                              b: float = 0.1, x3_min: float = 1.0, u_max: float = math.inf,
                              name: str = "dc_motor_speed") -> Controller:
    """The speed-tracking controller fed by observer ``observer`` (None: the first one)."""
    for key, value in (("k", k), ("T_rise", T_rise), ("b", b), ("x3_min", x3_min)):
        if not (value > 0 and math.isfinite(value)):
            raise ValueError(f"controller.{key} must be in (0, inf), got {value}")
    if not u_max > 0:
        raise ValueError(f"controller.u_max must be in (0, inf] (inf: no clip), "
                         f"got {u_max}")
    for key, value in (("w0", w0), ("w_step", w_step), ("t_step", t_step), ("a_sin", a_sin),
                       ("omega_sin", omega_sin), ("a", a)):
        if not math.isfinite(value):
            raise ValueError(f"controller.{key} must be finite, got {value}")
    p = Params(a=a, b=b, k=k, x3_min=x3_min, u_max=u_max, w0=w0, w_step=w_step,
               t_step=t_step, T_rise=T_rise, a_sin=a_sin, omega_sin=omega_sin)
    return Controller(name=name, p=p, u=u, observer=observer, reads_outputs=[1],
                      reads_estimate=[1])  # x3 = y[1], x^2 = xhat[1]
