"""The metrics of the paper presets equal those stored (1e-9 relative).

``tests/preset_metrics.json`` was written by ``python tests/preset_metrics.py --write`` from
the code before the components read their parameters by name (main at ea54a97,
the last merged); every case here
runs again and compares each metric row. The one slow case (``SLOW``) is checked by
``python tests/preset_metrics.py --check`` (the same comparison, all cases).

The Sanfelice & Praly and Ahrens & Khalil presets are unchanged bit for bit. The presets of
the three restructured observers (Andrieu, Praly & Astolfi; Dimassi et al.; Moreno) are
not: compiled without fast-math flags, the port gives the old runs bit for bit
(:func:`test_port_is_exact_without_fused_multiply_adds`), so it changes no arithmetic;
with the kernel's flag ``contract``, LLVM fuses multiply-adds of the inlined right-hand
side in another pattern, the last bits move, and the adaptive steps and the runs amplify
that to the measured differences recorded in ``ROUNDING`` (strict xfails).

The eight Andrieu, Praly & Astolfi cases (apa_*) were stored again by issue 45 from the code
of the moment (``--write apa_fig1 ...``): their ``t1_<thr>`` rows (first time |e| < thr) now
count a zero crossing of e between two scan points as an entry (the former scan of |e|
missed the crossings of the df2max and Omega1 observers' e, e.g. apa_fig2 df2max t1_0.01
0.0686 -> 0.00782, omega1 t1_0.1 0.436 -> 0.207; apa_model omega2 t1_0.01 2.158 -> 0.802,
each checked against a root of a tight dense output in tests/test_apa_numerics.py); the
other rows had moved with the fused multiply-adds (at most 2e-4 relative, 7e-4 for
apa_readings_linear, and apa_nominal's round-off-floor values of a noise-free run), so
they are compared at 1e-9 against today's code, with no tolerance for threshold times.
The six Dimassi et al. cases with an HGO (dhlm_*, not dhlm_ideal) were stored again then
too: they gained the rows ``lag_zerr<k>_W`` (the quasi-static lag, formerly the bound of
``max_abs_zerr<k>_W``), and their other rows had moved with the fused multiply-adds (at
most 2.9e-3 relative: ``t_sat_last``, a step-end time).
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import preset_metrics as pm
import pytest

STORED = json.loads(pm.STORE.read_text())["cases"]
SLOW = {"sp_ensemble"}  # 1000 members over 200 s: 18 s alone; left to --check
#: case -> what moved with the fused multiply-adds against main at ea54a97: rows beyond
#: 1e-9 relative / stored rows, and the largest relative difference (measured with the
#: noiseless kernels, the cascade observer's exact psi argument and the circle-form
#: supports, 2026-11-27; since
#: a624e71 a kernel compiled in the process and one loaded from numba's cache give the same
#: bits, tests/test_kernel_cache.py).
#: The largest are a threshold functional (gamma, the largest rise of varrho above alpha1)
#: and round-off-floor values, which a last-bit change may move far.
ROUNDING = {
    "moreno_fig1": "6/34 rows, max 0.067 (gamma, the largest rise above alpha1)",
    "moreno_sector": "6/126 rows, max 0.6 (gamma)",
    "moreno_pe": "2/34 rows, max 0.012 (norm_e_t10 ~1e-13: round-off floor)",
    "moreno_sin": "5/34 rows, max 1.4e-3 (norm_e_t10 ~1e-12)",
}
QUICK = [pytest.param(name, marks=pytest.mark.xfail(
             strict=True, reason=f"fused multiply-adds in another pattern: {ROUNDING[name]}"))
         if name in ROUNDING else name for name in STORED if name not in SLOW]


#: Cases whose rows are not the same bits in every build of the same code (2026-12-01): the
#: APA presets' kernel gave two sets of values, one in a fresh clone with a fresh venv and
#: kernel cache (the CI run), the other in a worktree of the same commit with its own fresh
#: kernel cache, and the set followed an edit of homogeneous_dynamic.py in a branch the
#: presets never take (cause not found; fused multiply-adds in another pattern is the
#: likeliest). Between the two: df2max's rows up to 1.2e-4 relative (apa_readings_linear
#: 6.7e-4; its switch of e in ~15 us amplifies the last bits), omega1/omega2 rows <= 1.6e-6
#: relative above 1e-12, and the noiseless apa_nominal's round-off-floor rows (|value| <
#: 1e-12) anywhere. case -> (rtol, atol) for those cases; 1e-9 relative for every other.
BUILD_SENSITIVE = {name: (1e-3, 1e-12) for name in (
    "apa_fig1", "apa_fig2", "apa_model", "apa_noise", "apa_nominal", "apa_readings",
    "apa_readings_linear", "apa_seeds")}


def _differs(stored: dict, now: dict, name: str) -> list[str]:
    if name not in BUILD_SENSITIVE:
        return pm.compare(stored, now)
    rtol, atol = BUILD_SENSITIVE[name]
    close = {f"{k}: " for k in stored.keys() & now.keys() if stored[k] is not None
             and now[k] is not None and abs(stored[k] - now[k]) <= atol}
    return [line for line in pm.compare(stored, now, rtol=rtol)
            if not line.startswith(tuple(close))]


@pytest.mark.parametrize("name", QUICK)
def test_preset_metrics_unchanged(name):
    """Every metric row of the case equals its stored value to 1e-9 relative (the cases of
    BUILD_SENSITIVE: to 1e-3 relative or 1e-12 absolute)."""
    bad = _differs(STORED[name]["rows"], pm.run_case(tuple(STORED[name]["overrides"])), name)
    assert not bad, "\n".join(bad[:20])


EXACT = json.loads(pm.EXACT_STORE.read_text())
FRESH_RUNS = (
    "import json, preset_metrics as pm\n"
    "print(json.dumps({k: pm.exact_case(v) for k, v in pm.EXACT_CASES.items()}))\n")


def test_port_is_exact_without_fused_multiply_adds(tmp_path):
    """Compiled without fast-math flags, the ported observers (cascade, homogeneous,
    circle criterion) give the stored states and window metrics of the code before the
    port bit for bit (``preset_exact.json``, written by ``preset_metrics.py
    --write-exact`` at main ea54a97): the port changes no arithmetic. One deliberate change
    since: the cascade observer evaluates psi at y itself where C selects x1 (was x^1 +
    (y - x^1), which rounds), so dhlm_example's entry was rewritten then (it moved by at
    most 7.8e-10 relative; apa_fig1's and moreno_fig1's were written again unchanged). Both
    sides compile every kernel and helper afresh (empty caches, another process)."""
    root = Path(__file__).resolve().parents[1]
    env = {**os.environ, "HGO_CACHE_DIR": str(tmp_path / "kernels"),
           "NUMBA_CACHE_DIR": str(tmp_path / "numba"),
           "PYTHONPATH": os.pathsep.join([str(root), str(root / "tests")])}
    out = subprocess.run([sys.executable, "-c", FRESH_RUNS], env=env, cwd=root, check=True,
                         capture_output=True, text=True, timeout=1200)
    assert json.loads(out.stdout.strip().splitlines()[-1]) == EXACT
