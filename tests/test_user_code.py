"""A user's own code and configs (issue 26, item 3): ``_target_`` finds modules in the current
directory, ``--config-dir`` adds the user's groups and presets, ``hgo list`` shows them."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import pytest

import hgo

ROOT = Path(__file__).resolve().parents[1]

VDP = '''"""Van der Pol, x1' = x2, x2' = mu (1 - x1^2) x2 - x1, y = x1."""
import numpy as np
from hgo.core.components import Plant


def vdp_f(t, x, u, p, dx):
    dx[0] = x[1]
    dx[1] = p[0] * (1.0 - x[0] * x[0]) * x[1] - x[0]


def vdp_h(t, x, p, y):
    y[0] = x[0]


def make_vdp(mu: float = 1.0, x0: tuple = (2.0, 0.0)) -> Plant:
    return Plant(name="vdp", state_names=["x1", "x2"], output_names=["y"], input_names=[],
                 x0=np.asarray(x0, float), p=np.array([mu]), f=vdp_f, h=vdp_h)
'''

PRESET = """# @package _global_
# Van der Pol under a constant-gain triangular observer.
defaults:
  - override /plant: vdp
  - override /observer: sp_single
run_name: vdp_demo
observer:
  sign_indefinite: {law: constant, r0: 5.0, M: null}
solver: {t_end: 4.0}
metrics: {window: 2.0}
"""


@pytest.fixture
def project(tmp_path: Path) -> Path:
    """A user's folder: ``vdp.py`` and ``mine/{plant,experiment}/``."""
    (tmp_path / "vdp.py").write_text(VDP)
    (tmp_path / "mine" / "plant").mkdir(parents=True)
    (tmp_path / "mine" / "experiment").mkdir()
    (tmp_path / "mine" / "plant" / "vdp.yaml").write_text(
        "_target_: vdp.make_vdp\nmu: 1.0\nx0: [2.0, 0.0]\n")
    (tmp_path / "mine" / "experiment" / "vdp_demo.yaml").write_text(PRESET)
    return tmp_path


def hgo_command(project: Path, *args: str) -> subprocess.CompletedProcess:
    """``hgo <args>`` as the console script runs it: through a launcher in another folder,
    so ``sys.path[0]`` is not the current directory (as ``bin/hgo``'s is not)."""
    launcher = project / "bin" / "hgo_launcher.py"
    launcher.parent.mkdir(exist_ok=True)
    launcher.write_text("import sys\nfrom hgo.cli import main\nraise SystemExit(main())\n")
    env = {**os.environ, "PYTHONPATH": str(ROOT)}
    return subprocess.run([sys.executable, str(launcher), *args], cwd=project, env=env,
                          capture_output=True, text=True)


def test_run_finds_the_users_module_and_config_dir(project):
    done = hgo_command(project, "run", "--config-dir", "mine", "experiment=vdp_demo")
    assert done.returncode == 0, done.stderr
    assert f"ok: outputs in {project}/outputs/vdp_demo/" in done.stdout
    (run_dir,) = (project / "outputs" / "vdp_demo").iterdir()
    rec = hgo.read_recording(run_dir / "recording.rrd")
    # Van der Pol from (2, 0): x1' = x2 = 0 and x2' = -2 at t = 0
    x2 = rec["/plant/x/x2"]
    assert x2.iloc[1] == pytest.approx(-2 * rec.index[1], rel=0.02)


def test_a_missing_module_is_one_line_naming_the_target(project):
    (project / "vdp.py").unlink()
    done = hgo_command(project, "run", "--config-dir", "mine", "experiment=vdp_demo")
    assert done.returncode == 2
    assert done.stderr.strip().splitlines()[-1].startswith("error: ")
    assert "vdp.make_vdp" in done.stderr and "Traceback" not in done.stderr


def test_list_shows_the_users_groups_and_presets(project):
    done = hgo_command(project, "list", "--config-dir", "mine")
    assert done.returncode == 0, done.stderr
    lines = done.stdout.splitlines()
    assert any(line.split()[:1] == ["vdp_demo"] and line.endswith("(yours)") and
               "Van der Pol" in line for line in lines)
    (plant,) = [line for line in lines if line.split()[:1] == ["plant"]]
    assert "vdp (yours)" in plant and "sp_linear," in plant
    assert "(yours)" not in hgo_command(project, "list").stdout


def test_compose_with_config_dir(project, monkeypatch):
    monkeypatch.chdir(project)
    monkeypatch.syspath_prepend(str(project))
    monkeypatch.delitem(sys.modules, "vdp", raising=False)  # restored (absent) afterwards
    cfg = hgo.compose(["experiment=vdp_demo"], config_dir=project / "mine")
    assert cfg.plant._target_ == "vdp.make_vdp" and cfg.solver.t_end == 4.0
    result = hgo.run(cfg)
    assert result.ok and "/plant/x/x1" in result.signals
    with pytest.raises(hgo.HgoError, match="config_dir: .* is not a directory"):
        hgo.compose([], config_dir=project / "nope")
