"""The fastest DHLM hand kernel we could write: DOP853 unrolled, scalar locals (issue 41, item 4).

``hand_dop853`` loops over the stages and the states with the tableau in arrays, as hgo's
integrator does. This kernel is the one a person writes to be fast: every stage written
out, the coefficients as literals (zeros skipped), each state and stage value a scalar
local (no arrays in the step at all), the right-hand side ``hand_papers.dhlm_f`` returning
its derivative as a tuple of scalars inlined into every stage, the same fast-math flags as
hgo's kernel (``contract``, ``arcp``). The text is generated here from scipy's DOP853
coefficients (no one types 82 stage coefficients by hand); the method is
``hand_dop853``'s, i.e. hgo's ``dop853``: Hairer's starting step, scipy's error norm and
step control, h_max, outputs from the 7th-order continuous extension, the window metrics by
3-point Gauss-Legendre on each step's extension (and ||x^ - x|| at the nodes and the step
ends).

It also computes and records what hgo's call records at every output, checked equal to
hgo's (``hand_bench.case_dhlm``): the state z (9), the discrete state d (the first and the
last step end at which the HGO's saturation was active: the cascade observer's update after
every step), y = x1, m = 0, u = 5 (sin 2t + cos 3t), x^ = (x^1, x^2), and t. The run has
no measurement noise (one segment).
"""

from __future__ import annotations

import hashlib
import importlib.util
import os
import sys
from pathlib import Path

import numba
from hand_dop853 import GAUSS_NODES, GAUSS_WEIGHTS
from hand_papers import DHLM_S
from scipy.integrate._ivp import dop853_coefficients as dop

from hgo.engine.codegen import cache_dir

NZ = 9
N_STAGES, N_EXT, N_F = dop.N_STAGES, dop.N_STAGES_EXTENDED, dop.INTERPOLATOR_POWER
N_REC = NZ + 2 + 1 + 1 + 1 + 2 + 1  # z, d, y, m, u, x^, t
FASTMATH = {"contract", "arcp"}  # hgo's kernel flags (hgo.engine.codegen.FASTMATH)


def _names(prefix: str) -> list[str]:
    return [f"{prefix}{i}" for i in range(NZ)]


def _combo(coefs, terms: list[str]) -> str:
    """sum c * term over the non-zero c, as text (exact float literals)."""
    parts = [f"{float(c)!r} * {x}" for c, x in zip(coefs, terms, strict=True) if c != 0.0]
    return " + ".join(parts) if parts else "0.0"


def _stage(s: int, base: str, out: str, t: str, h: str, ind: str) -> list[str]:
    """Stage s: y = base + h sum_j A[s, j] k_j, then k_s = f(t + C[s] h, y)."""
    lines = [f"{ind}y{i} = {base}{i} + {h} * "
             f"({_combo(dop.A[s, :s], [f'k{j}_{i}' for j in range(s)])})" for i in range(NZ)]
    lines.append(f"{ind}{', '.join(f'{out}_{i}' for i in range(NZ))} = dhlm_f({t} + "
                 f"{float(dop.C[s])!r} * {h}, {', '.join(_names('y'))})")
    return lines


def _extension(x: str, out: str, ind: str) -> list[str]:
    """out_i = the continuous extension at the fraction x (scipy's Horner form)."""
    lines = [f"{ind}s_ = 1.0 - {x}"]
    for i in range(NZ):
        v = f"f{N_F - 1}_{i}"
        for c in range(N_F - 2, -1, -1):
            v = f"(f{c}_{i} + {'s_' if c % 2 == 0 else x} * {v})"
        lines.append(f"{ind}{out}{i} = z{i} + {x} * {v}")
    return lines


def _record(k: str, t: str, src: str, ind: str) -> list[str]:
    """Row k of rec: z, d, y, m, u, x^, t (hgo's Trajectory columns)."""
    u = f"5.0 * (math.sin(2.0 * {t}) + math.cos(3.0 * {t}))"
    vals = [f"{src}{i}" for i in range(NZ)] + ["d0", "d1", f"{src}0", "0.0", u, f"{src}4",
                                                f"{src}5", t]
    return [f"{ind}rec[{k}, {j}] = {v}" for j, v in enumerate(vals)]


def _window_point(src: str, ind: str) -> list[str]:
    """The squared errors at one point (x^ - x, then y^ - y), and the largest norm."""
    return [f"{ind}sq0 = ({src}4 - {src}0) ** 2", f"{ind}sq1 = ({src}5 - {src}1) ** 2",
            f"{ind}sq2 = ({src}4 - {src}0) ** 2",
            f"{ind}metrics[3] = max(metrics[3], math.sqrt(sq0 + sq1))"]


def source() -> str:
    """The kernel's text."""
    z, ind2, ind3, ind4 = _names("z"), " " * 8, " " * 12, " " * 16
    k = lambda s: ", ".join(f"k{s}_{i}" for i in range(NZ))  # noqa: E731
    L = ["def run(z, t_end, dt_out, h_max, rtol, atol, rec, window, metrics):",
         f"    {', '.join(z)} = {', '.join(f'z[{i}]' for i in range(NZ))}",
         "    d0 = -1.0", "    d1 = -1.0",
         "    n_out = int(round(t_end / dt_out)) + 1", "    tol = 1e-12 * max(1.0, t_end)",
         "    t_win0 = t_end - window", "    for j in range(5):", "        metrics[j] = 0.0",
         "    t = 0.0"]
    # the update at t = 0 (saturation active at the start: not for z_h(0) = 0, kept general)
    L += [f"    if abs(z2) > {DHLM_S!r} or abs(z3) > {DHLM_S!r}:", "        d0 = 0.0",
          "        d1 = 0.0"]
    L += _record("0", "0.0", "z", "    ")
    L += ["    k_out = 1", f"    {k(0)} = dhlm_f(t, {', '.join(z)})"]
    # Hairer's starting step (hand_dop853.initial_step)
    L += ["    d0_ = 0.0", "    d1_ = 0.0"]
    for i in range(NZ):
        L += [f"    sc = atol + rtol * abs(z{i})", f"    d0_ += (z{i} / sc) ** 2",
              f"    d1_ += (k0_{i} / sc) ** 2"]
    L += [f"    d0_ = math.sqrt(d0_ / {NZ})", f"    d1_ = math.sqrt(d1_ / {NZ})",
          "    h0 = 1e-6 if d0_ < 1e-5 or d1_ < 1e-5 else 0.01 * d0_ / d1_",
          "    h0 = min(h0, h_max)",
          *[f"    y{i} = z{i} + h0 * k0_{i}" for i in range(NZ)],
          f"    {k(1)} = dhlm_f(t + h0, {', '.join(_names('y'))})", "    d2_ = 0.0"]
    L += [f"    d2_ += ((k1_{i} - k0_{i}) / (atol + rtol * abs(z{i}))) ** 2" for i in range(NZ)]
    L += [f"    d2_ = math.sqrt(d2_ / {NZ}) / h0", "    dm = max(d1_, d2_)",
          "    h1 = max(1e-6, h0 * 1e-3) if dm <= 1e-15 else (0.01 / dm) ** 0.125",
          "    h = min(100.0 * h0, h1, h_max)"]
    L += [f"    f{c}_{i} = 0.0" for c in range(N_F) for i in range(NZ)]
    L += ["    retried = False", "    accepted = 0", "    rejected = 0", "    t_seg = t_end",
          "    while True:",
          "        hh = min(h, h_max)",
          "        last = t + hh >= t_seg - min(tol, 0.01 * hh)",
          "        if last:", "            hh = t_seg - t",
          "        if not hh >= 1e-14 * max(1.0, abs(t)):", "            return accepted, -1"]
    for s in range(1, N_STAGES):
        L += _stage(s, "z", f"k{s}", "t", "hh", ind2)
    L += [f"{ind2}n{i} = z{i} + hh * ({_combo(dop.B, [f'k{j}_{i}' for j in range(N_STAGES)])})"
          for i in range(NZ)]
    L += [f"{ind2}{k(N_STAGES)} = dhlm_f(t + hh, {', '.join(_names('n'))})",
          f"{ind2}e5 = 0.0", f"{ind2}e3 = 0.0"]
    for i in range(NZ):
        ks = [f"k{j}_{i}" for j in range(N_STAGES + 1)]
        L += [f"{ind2}sc = atol + rtol * max(abs(z{i}), abs(n{i}))",
              f"{ind2}e5 += (({_combo(dop.E5, ks)}) / sc) ** 2",
              f"{ind2}e3 += (({_combo(dop.E3, ks)}) / sc) ** 2"]
    L += [f"{ind2}err = 0.0 if e5 == 0.0 and e3 == 0.0 else "
          f"abs(hh) * e5 / math.sqrt((e5 + 0.01 * e3) * {NZ})",
          f"{ind2}if not err <= 1.0:",
          f"{ind3}h = hh * (0.2 if not math.isfinite(err) else max(0.2, 0.9 * err ** -0.125))",
          f"{ind3}retried = True", f"{ind3}rejected += 1", f"{ind3}continue",
          f"{ind2}accepted += 1", f"{ind2}t_new = t_seg if last else t + hh",
          f"{ind2}if t_new > t_win0 + tol or (k_out < n_out and k_out * dt_out < t_new - tol):"]
    # the continuous extension's coefficients (hand_dop853.dense), once per step that needs it
    for s in range(N_STAGES + 1, N_EXT):
        L += _stage(s, "z", f"k{s}", "t", "hh", ind3)
    for i in range(NZ):
        ks = [f"k{j}_{i}" for j in range(N_EXT)]
        L += [f"{ind3}dz = n{i} - z{i}", f"{ind3}f0_{i} = dz", f"{ind3}f1_{i} = hh * k0_{i} - dz",
              f"{ind3}f2_{i} = 2.0 * dz - hh * (k0_{i} + k{N_STAGES}_{i})"]
        L += [f"{ind3}f{3 + q}_{i} = hh * ({_combo(dop.D[q], ks)})" for q in range(4)]
    L += [f"{ind2}if t_new > t_win0 + tol:", f"{ind3}a_ = max(t, t_win0)",
          f"{ind3}w_ = t_new - a_"]
    for node, weight in zip(GAUSS_NODES.tolist(), GAUSS_WEIGHTS.tolist(), strict=True):
        L += [f"{ind3}x_ = (a_ + w_ * {node!r} - t) / hh", *_extension("x_", "o", ind3),
              *_window_point("o", ind3)]
        L += [f"{ind3}metrics[{j}] += w_ * {weight!r} * sq{j}" for j in range(3)]
    L += [f"{ind3}metrics[4] += w_",
          f"{ind2}while k_out < n_out and k_out * dt_out < t_new - tol:",
          f"{ind3}t_o = k_out * dt_out", f"{ind3}x_ = (t_o - t) / hh",
          *_extension("x_", "o", ind3), *_record("k_out", "t_o", "o", ind3),
          f"{ind3}k_out += 1"]
    L += [f"{ind2}{', '.join(z)} = {', '.join(_names('n'))}",
          f"{ind2}{k(0)} = {k(N_STAGES)}", f"{ind2}t = t_new",
          f"{ind2}if abs(z2) > {DHLM_S!r} or abs(z3) > {DHLM_S!r}:  # the observer's update",
          f"{ind3}if d0 < 0.0:", f"{ind4}d0 = t", f"{ind3}d1 = t",
          f"{ind2}if t >= t_win0 - tol:", *_window_point("z", ind3),
          f"{ind2}fac = 10.0 if err == 0.0 else min(10.0, max(0.2, 0.9 * err ** -0.125))",
          f"{ind2}if retried:", f"{ind3}fac = min(1.0, fac)", f"{ind3}retried = False",
          f"{ind2}h = max(h, hh * fac) if last else hh * fac",
          f"{ind2}while k_out < n_out and k_out * dt_out <= t + tol:",
          *_record("k_out", "k_out * dt_out", "z", ind3), f"{ind3}k_out += 1",
          f"{ind2}if last:", f"{ind3}break",
          *[f"    z[{i}] = z{i}" for i in range(NZ)],
          "    return accepted, rejected"]
    return "\n".join(L) + "\n"


def _compile():
    """The kernel, from a module file of its text in hgo's kernel cache folder (named by the
    hash of this file and ``hand_papers``), so that numba's on-disk cache keeps it."""
    here = Path(__file__).resolve().parent
    digest = hashlib.sha256(source().encode() + (here / "hand_unrolled.py").read_bytes()
                            + (here / "hand_papers.py").read_bytes()).hexdigest()[:16]
    path = cache_dir() / f"hand_dhlm_unrolled_{digest}.py"
    if not path.exists():
        header = "import math\n\nfrom hand_papers import dhlm_f\n\n\n"
        tmp = path.with_suffix(f".{os.getpid()}.tmp")
        tmp.write_text(header + source())
        os.replace(tmp, path)
    spec = importlib.util.spec_from_file_location(path.stem, path)
    module = importlib.util.module_from_spec(spec)
    sys.modules[path.stem] = module  # (numba's cache finds the function's module by name)
    spec.loader.exec_module(module)
    return numba.njit(error_model="numpy", fastmath=FASTMATH, cache=True)(module.run)


dhlm_unrolled = _compile()
"""``dhlm_unrolled(z, t_end, dt_out, h_max, rtol, atol, rec, window, metrics)`` -> (accepted,
rejected): ``rec`` (n_out, N_REC) gets z, d, y, m, u, x^, t at each output; ``metrics`` (5)
hgo's window metrics of the run (its ``acc``)."""
