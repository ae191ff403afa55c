"""The documentation cannot drift: every code block of the getting-started page and the
tutorials runs here and the example notebook runs cell by cell (the site's build and its
look in a browser: tests/test_docs_site.py).

Blocks of a page, in order, in one empty folder per page:
* a block with ``title="path"`` is a file the reader creates: it is written there;
* a ``python`` block runs in one namespace per page (as in one Python session);
* a ``bash`` block runs in ``bash -euo pipefail`` with ``hgo`` on the PATH;
* a block whose first line is ``# not run: <why>`` is skipped (install commands, a cluster),
  and the reason must be given.
Other languages (``text``: output shown to the reader) are not run.
"""

from __future__ import annotations

import json
import os
import re
import subprocess
import sys
from dataclasses import dataclass
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
DOCS = ROOT / "docs"
RUN_PAGES = ["getting-started.md", *sorted(p.relative_to(DOCS).as_posix()
                                           for p in (DOCS / "tutorials").glob("*.md"))]
FENCE = re.compile(r'^```(\w+)(?: title="([^"]+)")?\n(.*?)^```$', re.S | re.M)
NOT_RUN = "# not run: "


@dataclass
class Block:
    language: str
    title: str | None
    body: str
    line: int


def blocks(page: Path) -> list[Block]:
    text = page.read_text()
    return [Block(m.group(1), m.group(2), m.group(3), text.count("\n", 0, m.start()) + 1)
            for m in FENCE.finditer(text)]


def environment(folder: Path) -> dict[str, str]:
    """``hgo`` on the PATH (this checkout, this interpreter), matplotlib without a display."""
    bin_dir = folder / ".bin"
    bin_dir.mkdir(exist_ok=True)
    shim = bin_dir / "hgo"
    shim.write_text(f'#!/bin/sh\nexec "{sys.executable}" -m hgo.cli "$@"\n')
    shim.chmod(0o755)
    python = bin_dir / "python"
    if not python.exists():
        python.symlink_to(sys.executable)
    return {**os.environ, "PATH": f"{bin_dir}{os.pathsep}{os.environ['PATH']}",
            "PYTHONPATH": os.pathsep.join([str(ROOT), str(folder)]), "MPLBACKEND": "Agg"}


def run_page(page: Path, folder: Path, monkeypatch) -> int:
    """Run the blocks of ``page`` in ``folder``; the number of blocks run or written."""
    env = environment(folder)
    monkeypatch.chdir(folder)
    monkeypatch.syspath_prepend(str(folder))
    monkeypatch.setenv("MPLBACKEND", "Agg")
    namespace: dict = {"__name__": "__docs__"}
    done = 0
    for block in blocks(page):
        where = f"{page.relative_to(ROOT)}:{block.line}"
        if block.body.startswith(NOT_RUN):
            assert block.body[len(NOT_RUN):].split("\n")[0].strip(), f"{where}: no reason"
            continue
        if block.title:
            path = folder / block.title
            path.parent.mkdir(parents=True, exist_ok=True)
            path.write_text(block.body)
            if path.suffix == ".py":  # this page's module, not one of that name imported before
                monkeypatch.delitem(sys.modules, path.stem, raising=False)
        elif block.language == "python":
            exec(compile(block.body, where, "exec"), namespace)  # noqa: S102 - our own docs
        elif block.language == "bash":
            done_ = subprocess.run(["bash", "-euo", "pipefail", "-c", block.body], cwd=folder,
                                   env=env, capture_output=True, text=True, timeout=900)
            assert done_.returncode == 0, f"{where}\n{done_.stdout[-3000:]}\n{done_.stderr[-3000:]}"
        else:
            continue
        done += 1
    return done


@pytest.mark.parametrize("name", RUN_PAGES)
def test_every_block_of_the_page_runs(name, tmp_path, monkeypatch):
    assert run_page(DOCS / name, tmp_path, monkeypatch) > 0


def test_the_notebook_runs_cell_by_cell(tmp_path, monkeypatch):
    notebook = json.loads((ROOT / "examples" / "quickstart.ipynb").read_text())
    monkeypatch.chdir(tmp_path)
    monkeypatch.setenv("MPLBACKEND", "Agg")
    import matplotlib

    matplotlib.use("Agg")
    namespace: dict = {"__name__": "__notebook__"}
    cells = [c for c in notebook["cells"] if c["cell_type"] == "code"]
    for i, cell in enumerate(cells):
        exec(compile("".join(cell["source"]), f"quickstart.ipynb:cell{i}", "exec"), namespace)
    assert (tmp_path / "outputs" / "quickstart" / "recording.rrd").is_file()
    assert len(namespace["table"]) == 8 and (namespace["table"].status == "ok").all()
