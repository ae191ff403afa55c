"""The user's code in a run's provenance (issue 44, item 7): ``run.json`` records the path
and sha256 of every user module a ``_target_`` loaded and the git commit and dirty flag of
its repository; ``hgo runs --compare`` shows a change of it."""

from __future__ import annotations

import hashlib
import importlib
import json
import subprocess
import sys

import pandas as pd
import pytest

from hgo.cli import main
from hgo.outputs.runs import write_run_json

PLANT = "def make(mu=1.0):\n    return mu\n"


def _git(folder, *args):
    subprocess.run(["git", "-C", str(folder), *args], check=True, capture_output=True,
                   env={"GIT_AUTHOR_NAME": "t", "GIT_AUTHOR_EMAIL": "t@t",
                        "GIT_COMMITTER_NAME": "t", "GIT_COMMITTER_EMAIL": "t@t",
                        "PATH": "/usr/bin:/bin"})


@pytest.fixture
def user_repo(tmp_path, monkeypatch):
    """A user's git repository with one committed module, importable as ``mine_44``."""
    repo = tmp_path / "repo"
    repo.mkdir()
    (repo / "mine_44.py").write_text(PLANT)
    _git(repo, "init", "-q")
    _git(repo, "add", "mine_44.py")
    _git(repo, "commit", "-q", "-m", "plant")
    monkeypatch.syspath_prepend(str(repo))
    monkeypatch.delitem(sys.modules, "mine_44", raising=False)
    importlib.import_module("mine_44")
    return repo


def _run(folder, name):
    """run.json of a run whose plant's _target_ is the user's (hgo's noise factory too)."""
    out = folder / name
    out.mkdir()
    config = {"plant": {"_target_": "mine_44.make", "mu": 1.0},
              "noise": {"_target_": "hgo.noise.noise_model"},
              "observer": {"a": {"_target_": "hgo.observers.normal_form.standard_hgo"}}}
    write_run_json(out, config, "ok", pd.Timestamp.now().to_pydatetime(), {}, None)
    return out, json.loads((out / "run.json").read_text())


def test_run_json_records_the_users_module_only(user_repo, tmp_path):
    head = subprocess.run(["git", "-C", str(user_repo), "rev-parse", "HEAD"],
                          capture_output=True, text=True).stdout.strip()
    _, info = _run(tmp_path, "r1")
    assert info["user_code"] == {"mine_44": {
        "path": str((user_repo / "mine_44.py").resolve()),
        "sha256": hashlib.sha256(PLANT.encode()).hexdigest(),
        "git_commit": head, "git_dirty": False}}  # hgo's own modules are not listed


def test_compare_shows_a_change_of_user_code(user_repo, tmp_path, capsys):
    a, _ = _run(tmp_path, "a")
    (user_repo / "mine_44.py").write_text(PLANT.replace("return mu", "return 2 * mu"))
    b, info = _run(tmp_path, "b")
    assert info["user_code"]["mine_44"]["git_dirty"] is True
    assert main(["runs", "--compare", str(a), str(b)]) == 0
    out = capsys.readouterr().out
    assert "user code: 2 difference(s)" in out
    assert "  mine_44.sha256\n    A: " + hashlib.sha256(PLANT.encode()).hexdigest() in out
    assert "  mine_44.git_dirty\n    A: False\n    B: True" in out
    assert main(["runs", "--compare", str(a), str(a)]) == 0
    assert "user code: 0 difference(s)" in capsys.readouterr().out
