"""hgo installs anywhere (issue 26, item 2): the wheel carries every module and conf/, and every
module hgo imports is a declared dependency. (.ci/run installs the wheel into a fresh venv and
runs hgo from a temporary directory.)"""

from __future__ import annotations

import ast
import re
import subprocess
import sys
import zipfile
from importlib.metadata import packages_distributions
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]


def _normal(name: str) -> str:
    return re.sub(r"[-_.]+", "-", name).lower()


def declared() -> set[str]:
    """The distributions named in ``project.dependencies``."""
    import tomllib

    deps = tomllib.loads((ROOT / "pyproject.toml").read_text())["project"]["dependencies"]
    return {_normal(re.split(r"[\[<>=!~ ;]", d, maxsplit=1)[0]) for d in deps}


def imported_top_level() -> set[str]:
    """Top-level modules the sources of hgo import (function-level imports included)."""
    names: set[str] = set()
    for path in (ROOT / "hgo").rglob("*.py"):
        for node in ast.walk(ast.parse(path.read_text())):
            if isinstance(node, ast.Import):
                names |= {a.name.split(".")[0] for a in node.names}
            elif isinstance(node, ast.ImportFrom) and node.module and node.level == 0:
                names.add(node.module.split(".")[0])
    return names - set(sys.stdlib_module_names) - {"hgo", "__future__"}


@pytest.mark.skipif(sys.version_info < (3, 11), reason="tomllib")
def test_every_imported_module_is_a_declared_dependency():
    owners = packages_distributions()
    missing = {}
    for module in sorted(imported_top_level()):
        dists = {_normal(d) for d in owners.get(module, [])}
        assert dists, f"{module}: imported by hgo but not installed here"
        if not dists & declared():
            missing[module] = sorted(dists)
    assert not missing, f"imported but not declared in pyproject.toml: {missing}"


@pytest.fixture(scope="module")
def wheel(tmp_path_factory) -> zipfile.ZipFile:
    out = tmp_path_factory.mktemp("dist")
    build = tmp_path_factory.mktemp("build")
    done = subprocess.run([sys.executable, "-m", "pip", "wheel", "-q", "--no-deps", "-w",
                           str(out), str(ROOT)], capture_output=True, text=True, cwd=build,
                          timeout=600)
    if done.returncode != 0 and "No matching distribution" in done.stderr:
        pytest.skip("no package index for the build requirements (setuptools)")
    assert done.returncode == 0, done.stderr[-3000:]
    (path,) = out.glob("hgo-*.whl")
    return zipfile.ZipFile(path)


def test_the_wheel_holds_every_module_and_the_configuration(wheel):
    names = set(wheel.namelist())
    modules = {p.relative_to(ROOT).as_posix() for p in (ROOT / "hgo").rglob("*.py")
               if "__pycache__" not in p.parts}
    assert modules - names == set()
    configs = {f"hgo/{p.relative_to(ROOT).as_posix()}" for p in (ROOT / "conf").rglob("*.yaml")}
    assert configs and configs - names == set()
    assert not [n for n in names if "__pycache__" in n or n.endswith((".nbi", ".nbc"))]


def test_the_wheel_declares_pyarrow_and_pyyaml(wheel):
    (meta,) = [n for n in wheel.namelist() if n.endswith(".dist-info/METADATA")]
    requires = {_normal(re.split(r"[\[<>=!~ ;]", line.split(": ", 1)[1], maxsplit=1)[0])
                for line in wheel.read(meta).decode().splitlines()
                if line.startswith("Requires-Dist:") and "extra ==" not in line}
    assert {"pyarrow", "pyyaml", "rerun-sdk", "hydra-core"} <= requires
    (entry,) = [n for n in wheel.namelist() if n.endswith(".dist-info/entry_points.txt")]
    assert "hgo = hgo.cli:main" in wheel.read(entry).decode()
