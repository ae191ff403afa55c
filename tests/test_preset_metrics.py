"""The metrics of the paper presets equal those stored before issue 24's port (1e-9 rel.).

``tests/preset_metrics.json`` was written by ``python tests/preset_metrics.py --write`` from
the code before the components read their parameters by name (e00e568); every case here
runs again and compares each metric row. The one slow case (``SLOW``) is checked by
``python tests/preset_metrics.py --check`` (the same comparison, all cases).

The Sanfelice & Praly and Ahrens & Khalil presets are unchanged bit for bit. The presets of
the three restructured observers (Andrieu, Praly & Astolfi; Dimassi et al.; Moreno) are
not: compiled without fast-math flags, the port gives the old runs bit for bit
(:func:`test_port_is_exact_without_fused_multiply_adds`), so it changes no arithmetic;
with the kernel's flag ``contract``, LLVM fuses multiply-adds of the inlined right-hand
side in another pattern, the last bits move, and the adaptive steps and the runs amplify
that to the measured differences recorded in ``ROUNDING`` (strict xfails).
"""

from __future__ import annotations

import json

import preset_metrics as pm
import pytest

STORED = json.loads(pm.STORE.read_text())["cases"]
SLOW = {"sp_ensemble"}  # 1000 members over 200 s: 18 s alone; left to --check
#: case -> what moved with the fused multiply-adds: rows beyond 1e-9 relative / rows, and
#: the largest relative difference (measured after b0789e6, load ~8; the last bits, hence
#: these numbers, also differ between a kernel compiled in the process and one loaded from
#: numba's cache, as profile_input's docstring notes for the code before the port: the
#: larger of the two is given)
ROUNDING = {
    **{name: "19-27/88 rows, max 1.1e-4 (df2max mean_sq_error_eta2)" for name in
       ("apa_fig1", "apa_fig2", "apa_readings", "apa_seeds")},
    "apa_model": "42/87 rows, max 3.2e-6 (std_w2, std_late)",
    "apa_noise": "18-23/87 rows, max 1.6e-4 (df2max mean_sq_error_eta2)",
    "apa_nominal": "46-49/90 rows, max 3.9 (omega1 mean_sq_error_eta2, bias_w3: "
                   "round-off-floor values of a noise-free run)",
    "apa_readings_linear": "24-25/88 rows, max 4.3e-4 (df2max mean_sq_error_eta2)",
    **{name: "23/69 rows, max 2.9e-3 (t_sat_last, a step-end time)" for name in
       ("dhlm_delta", "dhlm_eps", "dhlm_example", "dhlm_sigma")},
    "dhlm_psi_at_xhat": "10/67 rows, max 3.3e-4 (t_sat_last)",
    "dhlm_omega_law": "8/69 rows, max 2.0e-4 (t_sat_last)",
    "moreno_fig1": "5/31 rows, max 1.2e-3 (norm_e_t10 ~1e-13: round-off floor)",
    "moreno_sector": "5/123 rows, max 1.2e-3 (norm_e_t10 ~1e-13: round-off floor)",
    "moreno_pe": "2/34 rows, max 1.7e-3 (norm_e_t10 ~1e-13)",
    "moreno_sin": "5/31 rows, max 6.0e-4 (norm_e_t10 ~1e-12)",
}
QUICK = [pytest.param(name, marks=pytest.mark.xfail(
             strict=True, reason=f"fused multiply-adds in another pattern: {ROUNDING[name]}"))
         if name in ROUNDING else name for name in STORED if name not in SLOW]


@pytest.mark.parametrize("name", QUICK)
def test_preset_metrics_unchanged(name):
    """Every metric row of the case equals its stored value to 1e-9 relative."""
    bad = pm.compare(STORED[name]["rows"], pm.run_case(tuple(STORED[name]["overrides"])))
    assert not bad, "\n".join(bad[:20])


EXACT = json.loads(pm.EXACT_STORE.read_text())


@pytest.mark.parametrize("name", list(EXACT))
def test_port_is_exact_without_fused_multiply_adds(name):
    """Compiled without fast-math flags, the ported observers (cascade, homogeneous,
    circle criterion) give the stored states and window metrics of the code before the
    port bit for bit (``preset_exact.json``, written by ``preset_metrics.py
    --write-exact`` at e00e568): the port changes no arithmetic."""
    assert pm.exact_case(tuple(pm.EXACT_CASES[name])) == EXACT[name]
