"""Code only from where the user put it (issue 40, item 5): every ``_target_`` passes an
allowlist before anything of it is imported or called (:mod:`hgo.core.targets`);
``hydra.callbacks`` only from hgo and Hydra plugins; an option name with ``..`` is refused.
"""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import pytest

import hgo
from hgo.core import targets
from hgo.core.components import Plant
from hgo.core.errors import ConfigError, one_line
from hgo.running.job import check_config
from hgo.running.runner import _instantiate

ROOT = Path(__file__).resolve().parents[1]
SP = "experiment=sp_fig1"


@pytest.fixture
def victim(tmp_path: Path) -> Path:
    """A file a hostile config tries to empty."""
    path = tmp_path / "victim.txt"
    path.write_text("precious\n")
    return path


@pytest.mark.parametrize("make", [
    lambda tmp, victim: ["plant._target_=distutils.spawn.spawn",
                         f"+plant.cmd=[touch,{tmp / 'spawned'}]"],
    lambda tmp, victim: ["plant._target_=builtins.open", f"+plant.file={victim}",
                         "+plant.mode=w"],
    lambda tmp, victim: ["plant._target_=shutil.copyfile", "+plant.src=/dev/null",
                         f"+plant.dst={victim}"],
], ids=["distutils.spawn.spawn", "builtins.open", "shutil.copyfile"])
def test_a_hostile_plant_target_is_refused_before_any_call(make, tmp_path, victim):
    overrides = make(tmp_path, victim)
    cfg = hgo.compose([SP, *overrides])
    with pytest.raises(ConfigError) as err:
        check_config(cfg)
    target = overrides[0].partition("=")[2]
    assert one_line(err.value).startswith(f"plant._target_: {target} is not allowed")
    assert victim.read_text() == "precious\n" and not (tmp_path / "spawned").exists()


def test_the_fast_path_refuses_before_the_call(victim):
    """An ensemble member's node (built without Hydra's instantiate) is checked too."""
    node = {"_target_": "shutil.copyfile", "src": "/dev/null", "dst": str(victim)}
    with pytest.raises(ConfigError, match="plant._target_: shutil.copyfile is not allowed"):
        _instantiate(node, "plant", Plant)
    assert victim.read_text() == "precious\n"


@pytest.mark.parametrize("path", [
    "os.system", "subprocess.run", "builtins.exec", "hgo.running.job.shutil.rmtree",
    "hgo.core.validate.os.system", "numpy.save", "numpy.load", "numpy.ctypeslib.load_library",
    "pickle.loads", "importlib.import_module", "numpy.f2py.run_main", "numpy.testing.assert_",
    "numpy.lib.npyio.savetxt", "numpy.ndarray.tofile", "hgo.cli.main", "hgo.cli.allow_targets",
    "hgo.cli.runs.export", "hgo.engine.codegen._atomic_write", "hgo.api.run",
])
def test_refused(path):
    """Refused by its text, or on the way (a module passed through, where it is defined)."""
    with pytest.raises(ConfigError, match="is not allowed"):
        targets.locate(path, "plant._target_")


@pytest.mark.parametrize("path", [
    "hgo.plants.sp_linear.sp_linear_plant", "numpy.linalg.solve", "numpy.zeros",
    "scipy.linalg.expm", "math.sin", "test_targets.make_nothing",
    "hgo.running.aggregate.aggregate_ensemble", "hgo.papers.moreno.sector_table.sector_table",
])
def test_allowed(path):
    assert callable(targets.locate(path, "plant._target_"))


def make_nothing() -> None:
    """A callable of a module under the working directory (the tests folder)."""


def test_the_environment_widens_the_rule(monkeypatch):
    with pytest.raises(ConfigError, match="is not allowed"):
        targets.locate("json.dumps", "plant._target_")
    monkeypatch.setenv(targets.ENV, "json")
    assert targets.locate("json.dumps", "plant._target_").__name__ == "dumps"


def test_a_module_of_an_environment_inside_the_project_is_not_the_users(tmp_path, monkeypatch):
    """A virtual environment under the working directory: its packages are installed
    code, not the user's (``site-packages`` in the path)."""
    pkg = tmp_path / ".venv" / "lib" / "site-packages" / "hostile_pkg"
    pkg.mkdir(parents=True)
    (pkg / "__init__.py").write_text("def run():\n    raise SystemExit('imported')\n")
    monkeypatch.chdir(tmp_path)
    monkeypatch.syspath_prepend(str(pkg.parent))
    with pytest.raises(ConfigError, match="hostile_pkg.run is not allowed"):
        targets.locate("hostile_pkg.run", "plant._target_")
    assert "hostile_pkg" not in sys.modules


def test_a_nested_target_through_a_users_module_is_refused(tmp_path, monkeypatch):
    """``usermod.os.system``: the user's module is allowed, ``os`` it imported is not,
    in a nested node (Hydra's instantiate) too."""
    (tmp_path / "usermod40.py").write_text("import os\n\ndef make(phi):\n    return phi\n")
    monkeypatch.chdir(tmp_path)
    monkeypatch.syspath_prepend(str(tmp_path))
    node = {"_target_": "usermod40.make",
            "phi": {"_target_": "usermod40.os.system", "command": f"touch {tmp_path}/x"}}
    with pytest.raises(ConfigError, match=r"^plant\.phi\._target_: usermod40\.os\.system is "
                       r"not allowed \(it passes through module os\)"):
        _instantiate(node, "plant", Plant)
    assert not (tmp_path / "x").exists()


def test_a_figure_target_is_refused_before_its_module_is_read():
    cfg = hgo.compose([SP, "+figures.x._target_=distutils.spawn.spawn"])
    with pytest.raises(ConfigError, match=r"^figures\.x\._target_: distutils\.spawn\.spawn is "
                       "not allowed"):
        check_config(cfg)


@pytest.mark.parametrize("entry", [
    ["distutils.spawn.spawn", "+hydra.callbacks.x.cmd=[touch,{tmp}/spawned]"],
    ["builtins.open", "+hydra.callbacks.x.file={victim}", "+hydra.callbacks.x.mode=w"],
    ["shutil.copyfile", "+hydra.callbacks.x.src=/dev/null", "+hydra.callbacks.x.dst={victim}"],
    ["hgo.cli.main"],
], ids=lambda entry: entry[0])
def test_a_hostile_callback_is_refused_when_the_config_is_composed(entry, tmp_path, victim):
    target, *args = entry
    with pytest.raises(hgo.HgoError, match=rf"^hydra\.callbacks\.x\._target_: {target} is "
                       "not allowed"):
        hgo.compose([SP, f"+hydra.callbacks.x._target_={target}",
                     *(a.format(tmp=tmp_path, victim=victim) for a in args)])
    assert victim.read_text() == "precious\n" and not (tmp_path / "spawned").exists()


def test_a_config_cannot_widen_its_own_rights():
    with pytest.raises(hgo.HgoError, match=r"^hydra\.job\.env_set\.HGO_ALLOW_TARGETS: a config "
                       "cannot widen"):
        hgo.compose([SP, "+hydra.job.env_set.HGO_ALLOW_TARGETS=os"])


def test_a_logging_factory_outside_logging_is_refused():
    for factory in ("os.system", "hydra.utils.instantiate", "logging.config.dictConfig"):
        hydra_node = {"job_logging": {"handlers": {"x": {"()": factory, "command": "true"}}}}
        with pytest.raises(ConfigError, match=rf"hydra\.job_logging\.handlers\.x\.\(\): "
                           rf"{factory} is not allowed"):
            targets.check_hydra_node(hydra_node)
    targets.check_hydra_node({"job_logging": {"handlers": {"console": {
        "class": "logging.StreamHandler"}}}})


def test_an_option_with_dot_dot_is_refused(tmp_path):
    outside = tmp_path / "outside.yaml"
    outside.write_text("# @package _global_\nrun_name: outside\n")
    rel = os.path.relpath(outside.with_suffix(""), ROOT / "conf" / "experiment")
    with pytest.raises(hgo.HgoError, match=r"option '.*' has '\.\.' in it"):
        hgo.compose([f"experiment={rel}"])


def test_a_sweep_never_runs_a_hostile_callback(tmp_path):
    """The case of the issue: ``distutils.spawn.spawn`` as a ``hydra.callbacks`` entry of a
    sweep ran its command and the sweep reported ok."""
    marker = tmp_path / "spawned"
    env = {**os.environ, "PYTHONPATH": str(ROOT)}
    env.pop("HYDRA_FULL_ERROR", None)
    done = subprocess.run(
        [sys.executable, "-m", "hgo.cli", "run", "-m", SP, "solver.t_end=1",
         "+hydra.callbacks.x._target_=distutils.spawn.spawn",
         f"+hydra.callbacks.x.cmd=[touch,{marker}]", f"hydra.sweep.dir={tmp_path / 'sweep'}"],
        cwd=tmp_path, env=env, capture_output=True, text=True, timeout=300)
    assert done.returncode == 2, done.stderr
    assert done.stderr.strip().splitlines()[-1].startswith(
        "error: hydra.callbacks.x._target_: distutils.spawn.spawn is not allowed")
    assert not marker.exists() and "Traceback" not in done.stderr


def test_the_command_line_flag_widens_the_rule_and_leaves_hydras_arguments(monkeypatch):
    from hgo.cli import allow_targets

    monkeypatch.setenv(targets.ENV, "mypkg")
    rest = allow_targets(["--allow-targets", "json", SP, "--allow-targets=csv.writer", "-m"])
    assert rest == [SP, "-m"] and os.environ[targets.ENV] == "mypkg,json,csv.writer"
    assert targets.locate("json.dumps", "plant._target_").__name__ == "dumps"
