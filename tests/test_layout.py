"""The package's import graph has one reading order (issue 23): no cycle between files or
between rooms of ``hgo`` (function-level imports included), none in ``benchmarks``, and no
reusable layer imports a paper."""

from __future__ import annotations

import re
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
SCRIPT = ROOT.parent / "shared" / "tools" / "import_graph.py"
REUSABLE = ["core", "engine", "plants", "observers", "controllers", "postprocess", "outputs",
            "running", "noise.py"]


@pytest.mark.skipif(not SCRIPT.exists(), reason="needs ../shared/tools/import_graph.py")
@pytest.mark.parametrize("package", ["hgo", "benchmarks"])
def test_import_graph_has_no_cycle(package):
    """The shared script prints 0 cycles between files and 0 between rooms."""
    out = subprocess.run([sys.executable, str(SCRIPT), package], cwd=ROOT,
                         capture_output=True, text=True, check=False).stdout
    assert "cycles between files: 0" in out, out
    assert "cycles between rooms: 0" in out, out


def test_reusable_layers_import_no_paper():
    """No module outside hgo/papers/ (and above it: cli, reproduce) names hgo.papers in an
    import; the registry finds the papers by name."""
    offenders = []
    for part in REUSABLE:
        pattern = part if part.endswith(".py") else f"{part}/**/*.py"
        for path in sorted((ROOT / "hgo").glob(pattern)):
            for n, line in enumerate(path.read_text().splitlines(), 1):
                if re.match(r"\s*(from|import)\s+hgo\.papers\b", line):
                    offenders.append(f"{path.relative_to(ROOT)}:{n}: {line.strip()}")
    assert not offenders, "\n".join(offenders)
