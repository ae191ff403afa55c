"""The fastest hand kernels we could write: DOP853 unrolled, scalar locals (issue 41, item 4).

``hand_dop853`` loops over the stages and the states with the tableau in arrays. These
kernels are the ones a person writes to be fast: every stage written out, the coefficients
as literals (zeros skipped), each state and stage value a scalar local (no arrays in the
step at all), the problem's right-hand side (``hand_papers.dhlm_f``, ``moreno_f``,
``apa_f``: scalars in, the derivative as a tuple out) inlined into every stage, the same
fast-math flags as hgo's kernel (``contract``, ``arcp``). The text is generated here from
scipy's DOP853 coefficients (no one types 82 stage coefficients by hand), one kernel per
problem (:class:`Problem`: its right-hand side, record row, window errors and discrete
update as text); the method is ``hand_dop853``'s, i.e. hgo's ``dop853``: Hairer's starting
step, scipy's error norm and step control, h_max, steps cut at the noise instants
(``noise_dt``; inf: none) and the break points, outputs from the 7th-order continuous
extension, the window metrics by 3-point Gauss-Legendre on each step's extension (and
||x^ - x|| at the nodes and the step ends).

Each computes and records what hgo's call records at every output, checked equal to hgo's
(``hand_bench``): the state z, the discrete state d, y, m, u, x^ and t, in that order:

* DHLM (``dhlm_unrolled``): z (9), d (the first and the last step end at which the HGO's
  saturation was active: the cascade observer's update after every step), y = x1 + m, m,
  u = 5 (sin 2t + cos 3t), x^ = (x^1, x^2), t (``N_REC`` columns);
* Moreno (``moreno_unrolled``): z (4), y = x1 + m, m, u = r' + a r, x^ = (x^1, x^2), t;
* APA (``apa_unrolled(name)``, one observer's part of the split run): z (eta, x^1, x^2, L),
  d = 1 (L set at t = 0), y = eta1 + m, m, u, eta^ = F^{-1} of the saturated x^, t.

The kernel: ``run(z, noise, noise_dt, breaks, t_end, dt_out, h_max, rtol, atol, rec, window,
metrics)`` -> (accepted, rejected; -1: step-size underflow); ``breaks``: the instants where
the input jumps (APA's schedule; read only by problems with ``breaks``: a step ends there,
its stages evaluated just below the jump, the step size restarted after it, as hgo's
``kernel_template``); ``metrics`` (5) gets hgo's
window metrics of the run (its ``acc``: the integrals of the squared errors of x^1, x^2 and
y^, the largest ||x^ - x||, the window's length).
"""

from __future__ import annotations

import hashlib
import importlib.util
import os
import sys
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

import numba
import numpy as np
from hand_dop853 import FASTMATH, GAUSS_NODES, GAUSS_WEIGHTS
from hand_papers import DHLM_S, apa_constants
from scipy.integrate._ivp import dop853_coefficients as dop
from scipy.integrate._ivp.rk import RK45

from hgo.engine.codegen import cache_dir

N_STAGES, N_EXT, N_F = dop.N_STAGES, dop.N_STAGES_EXTENDED, dop.INTERPOLATOR_POWER


@dataclass(frozen=True)
class Method:
    """An embedded Runge-Kutta pair as hgo's ``hgo.engine.tableau`` takes it from scipy:
    ``n_stages`` stages a step (then f at the new state, first same as last), ``n_ext``
    with the continuous extension's extra ones, ``n_f`` coefficients of the extension a
    state, the error exponent's inverse ``order`` (step factor 0.9 err^(-1/order))."""

    name: str
    A: np.ndarray
    B: np.ndarray
    C: np.ndarray
    n_stages: int
    n_ext: int
    n_f: int
    order: float


DOP853 = Method("dop853", dop.A[:N_EXT, :N_EXT], dop.B, dop.C[:N_EXT], N_STAGES, N_EXT, N_F, 8.0)
DOPRI5 = Method("dopri5", RK45.A, RK45.B, RK45.C, RK45.n_stages, RK45.n_stages + 1, 4, 5.0)


@dataclass(frozen=True)
class Problem:
    """One problem's parts of the kernel text. ``rhs(t, states)``: a call giving the
    derivative tuple at time ``t`` of the comma-joined state expressions (the held noise
    sample is ``m``); ``signals(t, src)``: (lines first, the record row's expressions after
    the state) of the state ``src0, src1, ...``; ``errors(src)``: lines setting ``sq0 ..
    sq2`` (the squared errors of x^1, x^2, y^; the norm ||x^ - x|| from sq0 and sq1);
    ``start``: lines at t = 0 (the discrete state); ``update(ind)``: the discrete update
    after each accepted step."""

    tag: str
    nz: int
    header: str
    rhs: Callable[[str, str], str]
    signals: Callable[[str, str], tuple[list[str], list[str]]]
    errors: Callable[[str], list[str]]
    start: tuple[str, ...] = ()
    update: Callable[[str], list[str]] = lambda ind: []
    method: Method = DOP853
    breaks: bool = False  # the input jumps at the instants ``breaks`` (see ``source``)


N_SQ = 3  # every problem here: x^1, x^2 and y^ errors, metrics = integrals, max norm, length


def _names(prefix: str, n: int) -> list[str]:
    return [f"{prefix}{i}" for i in range(n)]


def _combo(coefs, terms: list[str]) -> str:
    """sum c * term over the non-zero c, as text (exact float literals)."""
    parts = [f"{float(c)!r} * {x}" for c, x in zip(coefs, terms, strict=True) if c != 0.0]
    return " + ".join(parts) if parts else "0.0"


def _time(pb: Problem, t: str) -> str:
    """A stage's time: at most ``t_lim`` (just below a break point ending the step, as hgo's
    ``_left_limit``) where the problem has break points."""
    return f"min({t}, t_lim)" if pb.breaks else t


def _stage(pb: Problem, s: int, t: str, h: str, ind: str, clamp: bool = True) -> list[str]:
    """Stage s: y = z + h sum_j A[s, j] k_j, then k_s = f(t + C[s] h, y) (the time clamped
    below a break point if ``clamp``: the step's stages, not the extension's, as hgo's)."""
    A, C = pb.method.A, pb.method.C
    ts = f"{t} + {float(C[s])!r} * {h}"
    lines = [f"{ind}y{i} = z{i} + {h} * "
             f"({_combo(A[s, :s], [f'k{j}_{i}' for j in range(s)])})" for i in range(pb.nz)]
    lines.append(f"{ind}{', '.join(_names(f'k{s}_', pb.nz))} = "
                 f"{pb.rhs(_time(pb, ts) if clamp else ts, ', '.join(_names('y', pb.nz)))}")
    return lines


def _extension(pb: Problem, x: str, out: str, ind: str) -> list[str]:
    """out_i = the continuous extension at the fraction x (scipy's Horner form; DOPRI5:
    hgo's z + x (f0 + x (f1 + x (f2 + x f3))))."""
    if pb.method is DOPRI5:
        return [f"{ind}{out}{i} = z{i} + {x} * (f0_{i} + {x} * (f1_{i} + {x} * (f2_{i} + {x} "
                f"* f3_{i})))" for i in range(pb.nz)]
    lines = [f"{ind}s_ = 1.0 - {x}"]
    for i in range(pb.nz):
        v = f"f{N_F - 1}_{i}"
        for c in range(N_F - 2, -1, -1):
            v = f"(f{c}_{i} + {'s_' if c % 2 == 0 else x} * {v})"
        lines.append(f"{ind}{out}{i} = z{i} + {x} * {v}")
    return lines


def _record(pb: Problem, k: str, t: str, src: str, ind: str) -> list[str]:
    """Row k of rec: the state, then the problem's signals."""
    first, values = pb.signals(t, src)
    vals = _names(src, pb.nz) + values
    return [ind + line for line in first] + [f"{ind}rec[{k}, {j}] = {v}"
                                             for j, v in enumerate(vals)]


def _window_point(pb: Problem, src: str, ind: str) -> list[str]:
    """The squared errors at one point, and the largest norm."""
    return [ind + line for line in pb.errors(src)] + [
        f"{ind}metrics[{N_SQ}] = max(metrics[{N_SQ}], math.sqrt(sq0 + sq1))"]


def _initial_step(pb: Problem, ind: str) -> list[str]:
    """Hairer's starting step from k0 = f(t, z) (hand_dop853.initial_step)."""
    nz = pb.nz
    L = [f"{ind}d0_ = 0.0", f"{ind}d1_ = 0.0"]
    for i in range(nz):
        L += [f"{ind}sc = atol + rtol * abs(z{i})", f"{ind}d0_ += (z{i} / sc) ** 2",
              f"{ind}d1_ += (k0_{i} / sc) ** 2"]
    L += [f"{ind}d0_ = math.sqrt(d0_ / {nz})", f"{ind}d1_ = math.sqrt(d1_ / {nz})",
          f"{ind}h0 = 1e-6 if d0_ < 1e-5 or d1_ < 1e-5 else 0.01 * d0_ / d1_",
          f"{ind}h0 = min(h0, h_max)",
          *[f"{ind}y{i} = z{i} + h0 * k0_{i}" for i in range(nz)],
          f"{ind}{', '.join(_names('k1_', nz))} = "
          f"{pb.rhs(_time(pb, 't + h0'), ', '.join(_names('y', nz)))}",
          f"{ind}d2_ = 0.0"]
    L += [f"{ind}d2_ += ((k1_{i} - k0_{i}) / (atol + rtol * abs(z{i}))) ** 2" for i in range(nz)]
    return L + [f"{ind}d2_ = math.sqrt(d2_ / {nz}) / h0", f"{ind}dm = max(d1_, d2_)",
                f"{ind}h1 = max(1e-6, h0 * 1e-3) if dm <= 1e-15 else "
                f"(0.01 / dm) ** {1.0 / pb.method.order!r}",
                f"{ind}h = min(100.0 * h0, h1, h_max)"]


def _trial(pb: Problem, ind: str) -> list[str]:
    """The stages, the new state n, f(t + hh, n) into the last stage, the error norm ``err``
    (DOP853: scipy's combined estimate; DOPRI5: the RMS norm)."""
    nz, me = pb.nz, pb.method
    L = [line for s in range(1, me.n_stages) for line in _stage(pb, s, "t", "hh", ind)]
    L += [f"{ind}n{i} = z{i} + hh * ({_combo(me.B, [f'k{j}_{i}' for j in range(me.n_stages)])})"
          for i in range(nz)]
    L += [f"{ind}{', '.join(_names(f'k{me.n_stages}_', nz))} = "
          f"{pb.rhs(_time(pb, 't + hh'), ', '.join(_names('n', nz)))}"]
    if me is DOPRI5:
        L += [f"{ind}err = 0.0"]
        for i in range(nz):
            ks = [f"k{j}_{i}" for j in range(me.n_stages + 1)]
            L += [f"{ind}e = hh * ({_combo(RK45.E, ks)}) / "
                  f"(atol + rtol * max(abs(z{i}), abs(n{i})))", f"{ind}err += e * e"]
        return L + [f"{ind}err = math.sqrt(err / {nz})"]
    L += [f"{ind}e5 = 0.0", f"{ind}e3 = 0.0"]
    for i in range(nz):
        ks = [f"k{j}_{i}" for j in range(N_STAGES + 1)]
        L += [f"{ind}sc = atol + rtol * max(abs(z{i}), abs(n{i}))",
              f"{ind}e5 += (({_combo(dop.E5, ks)}) / sc) ** 2",
              f"{ind}e3 += (({_combo(dop.E3, ks)}) / sc) ** 2"]
    return L + [f"{ind}err = 0.0 if e5 == 0.0 and e3 == 0.0 else "
                f"abs(hh) * e5 / math.sqrt((e5 + 0.01 * e3) * {nz})"]


def _dense(pb: Problem, ind: str) -> list[str]:
    """The continuous extension's coefficients f (hand_dop853.dense; DOPRI5: hgo's
    f_q = hh sum_j P[j, q] k_j, no extra evaluation)."""
    if pb.method is DOPRI5:
        return [f"{ind}f{q}_{i} = hh * ({_combo(RK45.P[:, q], [f'k{j}_{i}' for j in range(7)])})"
                for i in range(pb.nz) for q in range(4)]
    L = [line for s in range(N_STAGES + 1, N_EXT)
         for line in _stage(pb, s, "t", "hh", ind, clamp=False)]
    for i in range(pb.nz):
        ks = [f"k{j}_{i}" for j in range(N_EXT)]
        L += [f"{ind}dz = n{i} - z{i}", f"{ind}f0_{i} = dz", f"{ind}f1_{i} = hh * k0_{i} - dz",
              f"{ind}f2_{i} = 2.0 * dz - hh * (k0_{i} + k{N_STAGES}_{i})"]
        L += [f"{ind}f{3 + q}_{i} = hh * ({_combo(dop.D[q], ks)})" for q in range(4)]
    return L


def _window_step(pb: Problem, ind: str) -> list[str]:
    """The step's part [max(t, t_win0), t_new] of the window: 3-point Gauss-Legendre."""
    L = [f"{ind}a_ = max(t, t_win0)", f"{ind}w_ = t_new - a_"]
    for node, weight in zip(GAUSS_NODES.tolist(), GAUSS_WEIGHTS.tolist(), strict=True):
        L += [f"{ind}x_ = (a_ + w_ * {node!r} - t) / hh", *_extension(pb, "x_", "o", ind),
              *_window_point(pb, "o", ind)]
        L += [f"{ind}metrics[{j}] += w_ * {weight!r} * sq{j}" for j in range(N_SQ)]
    return L + [f"{ind}metrics[{N_SQ + 1}] += w_"]


def _break_start(pb: Problem, ind: str) -> list[str]:
    """The break points' state at t = 0 (those at or before 0 passed, as hgo's)."""
    if not pb.breaks:
        return []
    return [f"{ind}t_lim = math.inf", f"{ind}restart = False", f"{ind}k_break = 0",
            f"{ind}n_breaks = breaks.shape[0]",
            f"{ind}while k_break < n_breaks and breaks[k_break] <= t + tol:",
            f"{ind}    k_break += 1"]


def _break_segment(pb: Problem, ind: str) -> list[str]:
    """A break point (within tol of) before the next noise instant ends the segment at its
    own value; the step's stages then stay just below it (hgo's ``_next_event``)."""
    if not pb.breaks:
        return []
    return [f"{ind}t_lim = math.inf",
            f"{ind}if k_break < n_breaks and breaks[k_break] <= t_seg + tol:",
            f"{ind}    t_seg = breaks[k_break]",
            f"{ind}    t_lim = t_seg - abs(t_seg) * 4.440892098500626e-16"]


def _segment_end(pb: Problem, ind: str) -> list[str]:
    """After a segment: the next noise sample holds; after a break point, the right-hand side
    afresh and the step size chosen anew (hgo's restart)."""
    noise = [f"{ind}    k_noise += 1", f"{ind}    m = noise[min(k_noise, n_noise - 1)]",
             f"{ind}    fsal = False"]
    if not pb.breaks:
        return [f"{ind}if t_seg < t_end:  # the next noise sample holds from here on", *noise]
    return [f"{ind}if t_seg < t_end:",
            f"{ind}    if (k_noise + 1) * noise_dt <= t_seg + tol:  # the next noise sample",
            *["    " + line for line in noise],
            f"{ind}    if k_break < n_breaks and breaks[k_break] <= t_seg + tol:  # a jump",
            f"{ind}        while k_break < n_breaks and breaks[k_break] <= t_seg + tol:",
            f"{ind}            k_break += 1",
            f"{ind}        fsal = False", f"{ind}        restart = True"]


def source(pb: Problem) -> str:
    """The kernel's text."""
    nz, z = pb.nz, _names("z", pb.nz)
    i1, i2, i3, i4 = (" " * (4 * n) for n in range(1, 5))
    k0 = ", ".join(_names("k0_", nz))
    exp = repr(-1.0 / pb.method.order)
    L = ["def run(z, noise, noise_dt, breaks, t_end, dt_out, h_max, rtol, atol, rec, window, "
         "metrics):",
         f"{i1}{', '.join(z)} = {', '.join(f'z[{i}]' for i in range(nz))}",
         f"{i1}n_out = int(round(t_end / dt_out)) + 1", f"{i1}tol = 1e-12 * max(1.0, t_end)",
         f"{i1}t_win0 = t_end - window", f"{i1}for j in range({N_SQ + 2}):",
         f"{i2}metrics[j] = 0.0", f"{i1}t = 0.0", f"{i1}k_noise = 0",
         f"{i1}n_noise = noise.shape[0]", f"{i1}m = noise[0]",
         *[i1 + line for line in pb.start], *_record(pb, "0", "0.0", "z", i1),
         f"{i1}if t_win0 <= tol:", *_window_point(pb, "z", i2),
         f"{i1}k_out = 1", *_break_start(pb, i1), f"{i1}{k0} = {pb.rhs('t', ', '.join(z))}",
         *_initial_step(pb, i1)]
    me = pb.method
    L += [f"{i1}f{c}_{i} = 0.0" for c in range(me.n_f) for i in range(nz)]
    L += [f"{i1}retried = False", f"{i1}fsal = True", f"{i1}accepted = 0", f"{i1}rejected = 0",
          f"{i1}while True:  # segments between noise instants",
          f"{i2}t_seg = (k_noise + 1) * noise_dt", *_break_segment(pb, i2),
          f"{i2}if t_seg >= t_end - tol:", f"{i3}t_seg = t_end",
          *([f"{i3}t_lim = math.inf"] if pb.breaks else []),
          f"{i2}while True:  # steps inside [t, t_seg]",
          f"{i3}if not fsal:", f"{i4}{k0} = {pb.rhs('t', ', '.join(z))}", f"{i4}fsal = True",
          *([f"{i3}if restart:  # after a jump: Hairer's starting step, as hgo",
             *_initial_step(pb, i4), f"{i4}restart = False"] if pb.breaks else []),
          f"{i3}hh = min(h, h_max)", f"{i3}last = t + hh >= t_seg - min(tol, 0.01 * hh)",
          f"{i3}if last:", f"{i4}hh = t_seg - t",
          f"{i3}if not hh >= 1e-14 * max(1.0, abs(t)):", f"{i4}return accepted, -1",
          *_trial(pb, i3), f"{i3}if not err <= 1.0:",
          f"{i4}h = hh * (0.2 if not math.isfinite(err) else max(0.2, 0.9 * err ** {exp}))",
          f"{i4}retried = True", f"{i4}rejected += 1", f"{i4}continue",
          f"{i3}accepted += 1", f"{i3}t_new = t_seg if last else t + hh",
          f"{i3}if t_new > t_win0 + tol or (k_out < n_out and k_out * dt_out < t_new - tol):",
          *_dense(pb, i4), f"{i3}if t_new > t_win0 + tol:", *_window_step(pb, i4),
          f"{i3}while k_out < n_out and k_out * dt_out < t_new - tol:",
          f"{i4}t_o = k_out * dt_out", f"{i4}x_ = (t_o - t) / hh",
          *_extension(pb, "x_", "o", i4), *_record(pb, "k_out", "t_o", "o", i4),
          f"{i4}k_out += 1",
          f"{i3}{', '.join(z)} = {', '.join(_names('n', nz))}",
          f"{i3}{k0} = {', '.join(_names(f'k{me.n_stages}_', nz))}", f"{i3}t = t_new",
          *pb.update(i3), f"{i3}if t >= t_win0 - tol:", *_window_point(pb, "z", i4),
          f"{i3}fac = 10.0 if err == 0.0 else min(10.0, max(0.2, 0.9 * err ** {exp}))",
          f"{i3}if retried:", f"{i4}fac = min(1.0, fac)", f"{i4}retried = False",
          f"{i3}h = max(h, hh * fac) if last else hh * fac",
          f"{i3}if last:", f"{i4}break",
          f"{i3}while k_out < n_out and k_out * dt_out <= t + tol:  # an output at the step end",
          *_record(pb, "k_out", "k_out * dt_out", "z", i4), f"{i4}k_out += 1",
          *_segment_end(pb, i2),
          f"{i2}while k_out < n_out and k_out * dt_out <= t + tol:  # at the instant, after it",
          *_record(pb, "k_out", "k_out * dt_out", "z", i3), f"{i3}k_out += 1",
          f"{i2}if k_out >= n_out:", f"{i3}break",
          *[f"{i1}z[{i}] = z{i}" for i in range(nz)], f"{i1}return accepted, rejected"]
    return "\n".join(L) + "\n"


def compile_kernel(pb: Problem, cache: bool = True):
    """The kernel, from a module file of its text in hgo's kernel cache folder (named by the
    problem and the hash of the text, this file and ``hand_papers``), so that numba's
    on-disk cache keeps it (``cache=False``: compiled in each process, for a kernel whose
    compiled code holds this process's addresses)."""
    here = Path(__file__).resolve().parent
    text = pb.header + "\n\n" + source(pb)
    digest = hashlib.sha256(text.encode() + (here / "hand_unrolled.py").read_bytes()
                            + (here / "hand_papers.py").read_bytes()).hexdigest()[:16]
    path = cache_dir() / f"hand_{pb.tag}_unrolled_{digest}.py"
    if not path.exists():
        tmp = path.with_suffix(f".{os.getpid()}.tmp")
        tmp.write_text(text)
        os.replace(tmp, path)
    spec = importlib.util.spec_from_file_location(path.stem, path)
    module = importlib.util.module_from_spec(spec)
    sys.modules[path.stem] = module  # (numba's cache finds the function's module by name)
    spec.loader.exec_module(module)
    return numba.njit(error_model="numpy", fastmath=FASTMATH, cache=cache)(module.run)


# ---------------------------------------------------------------------- DHLM
def _dhlm_signals(t: str, src: str) -> tuple[list[str], list[str]]:
    u = f"5.0 * (math.sin(2.0 * {t}) + math.cos(3.0 * {t}))"
    return [], ["d0", "d1", f"{src}0 + m", "m", u, f"{src}4", f"{src}5", t]


def _dhlm_errors(src: str) -> list[str]:
    """x^ of (5) against x, y^ = x^1 against y = x1 + m."""
    return [f"sq0 = ({src}4 - {src}0) ** 2", f"sq1 = ({src}5 - {src}1) ** 2",
            f"sq2 = ({src}4 - ({src}0 + m)) ** 2"]


DHLM_SATURATED = f"abs(z2) > {DHLM_S!r} or abs(z3) > {DHLM_S!r}"  # the HGO's saturation


def _dhlm_update(ind: str) -> list[str]:
    """The cascade observer's update: the first and the last step end with the HGO saturated."""
    return [f"{ind}if {DHLM_SATURATED}:", f"{ind}    if d0 < 0.0:", f"{ind}        d0 = t",
            f"{ind}    d1 = t"]


DHLM = Problem(
    "dhlm", 9, "import math\n\nfrom hand_papers import dhlm_f\n",
    lambda t, states: f"dhlm_f({t}, {states})", _dhlm_signals, _dhlm_errors,
    # the update at t = 0 (saturation active at the start: not for z_h(0) = 0, kept general)
    start=("d0 = -1.0", "d1 = -1.0", f"if {DHLM_SATURATED}:", "    d0 = 0.0", "    d1 = 0.0"),
    update=_dhlm_update)
N_REC = DHLM.nz + 2 + 1 + 1 + 1 + 2 + 1  # z, d, y, m, u, x^, t


# ---------------------------------------------------------------------- Moreno
MORENO = Problem(
    "moreno", 4, "import math\n\nfrom hand_papers import moreno_f, moreno_u\n",
    lambda t, states: f"moreno_f({t}, m, {states})",
    lambda t, src: ([], [f"{src}0 + m", "m", f"moreno_u({t})", f"{src}2", f"{src}3", t]),
    lambda src: [f"sq0 = ({src}2 - {src}0) ** 2", f"sq1 = ({src}3 - {src}1) ** 2",
                 f"sq2 = ({src}2 - ({src}0 + m)) ** 2"])
MORENO_REC = MORENO.nz + 1 + 1 + 1 + 2 + 1  # z, y, m, u, x^, t (no d)


# ---------------------------------------------------------------------- APA
APA_REC = 5 + 1 + 1 + 1 + 1 + 2 + 1  # z, d, y, m, u, eta^, t


def apa_problem(name: str) -> Problem:
    """The observer ``name``'s part of apa_fig2, its constants as literals in the text."""
    c = apa_constants(name)
    args = ", ".join(repr(c[k]) for k in ("kind", "q", "dynamic", "eps1", "eps2", "dfmax"))
    est = f"{c['eps1']!r}, {c['eps2']!r}"

    def estimate(src: str) -> str:
        return f"e1_, e2_ = apa_estimate({src}2, {src}3, {est})"

    return Problem(
        f"apa_{name}", 5,
        "import math\n\nfrom hand_papers import apa_estimate, apa_f, apa_input\n",
        lambda t, states: f"apa_f({t}, m, {states}, {args})",
        lambda t, src: ([estimate(src)], ["1.0", f"{src}0 + m", "m", f"apa_input({t})", "e1_",
                                          "e2_", t]),
        lambda src: [estimate(src), f"sq0 = (e1_ - {src}0) ** 2", f"sq1 = (e2_ - {src}1) ** 2",
                     f"sq2 = (e1_ - ({src}0 + m)) ** 2"], breaks=True)


# ---------------------------------------------------------------------- B
def b_problem(p2: float) -> Problem:
    """Problem B (``problems.b_system``: plant and observer, 5 states), DOPRI5, p2 literal."""
    return Problem(
        "b", 5, "import math\n\nfrom baselines import b_f\n",
        lambda t, states: f"b_f({p2!r}, m, {states})",
        lambda t, src: ([], [f"{src}0 + m", "m", f"{src}2", f"{src}3", t]),
        lambda src: [f"sq0 = ({src}2 - {src}0) ** 2", f"sq1 = ({src}3 - {src}1) ** 2",
                     f"sq2 = ({src}2 - ({src}0 + m)) ** 2"], method=DOPRI5)


dhlm_unrolled = compile_kernel(DHLM)
moreno_unrolled = compile_kernel(MORENO)


def apa_unrolled(name: str):
    """The compiled kernel of the APA observer ``name``'s part (see the module doc)."""
    return compile_kernel(apa_problem(name))
