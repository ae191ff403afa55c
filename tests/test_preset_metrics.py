"""The metrics of the paper presets equal those stored before issue 24's port (1e-9 rel.).

``tests/preset_metrics.json`` was written by ``python tests/preset_metrics.py --write`` from
the code before the components read their parameters by name; every case here runs again
and compares each metric row. The one slow case (``SLOW``) is checked by
``python tests/preset_metrics.py --check`` (the same comparison, all cases).
"""

from __future__ import annotations

import json

import preset_metrics as pm
import pytest

STORED = json.loads(pm.STORE.read_text())["cases"]
SLOW = {"sp_ensemble"}  # 1000 members over 200 s: 18 s alone; left to --check
QUICK = [name for name in STORED if name not in SLOW]


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
