"""Headless Chromium for the tests that look at a page (the reproduce report, the docs site):
find it, load a page whose injected script prints ``CHECK key=int ...``, take a screenshot."""

from __future__ import annotations

import re
import shutil
import subprocess
from pathlib import Path

import pytest

FLAGS = ["--headless", "--no-sandbox", "--disable-gpu", "--disable-quic", "--no-first-run",
         "--disable-background-networking", "--disable-component-update", "--disable-sync",
         "--hide-scrollbars"]


def chromium() -> str:
    """Chromium's path; the test is skipped without one (``.ci/run`` installs it)."""
    found = shutil.which("chromium") or shutil.which("chromium-browser")
    if found is None:
        pytest.skip("chromium is not installed (.ci/run installs it)")
    return found


def check(page: Path, profile: Path, width: int) -> dict[str, int]:
    """The numbers a page's script wrote as ``CHECK a=1 b=2`` in its DOM after load."""
    dom = subprocess.run([chromium(), *FLAGS, f"--user-data-dir={profile}",
                          f"--window-size={width},900", "--virtual-time-budget=5000",
                          "--dump-dom", page.as_uri()],
                         capture_output=True, text=True, timeout=60).stdout
    found = re.search(r"CHECK ((?:\w+=\d+ ?)+)", dom)
    assert found, dom[-2000:]
    return {k: int(v) for k, v in (f.split("=") for f in found.group(1).split())}


def screenshot(page: Path, shot: Path, profile: Path, width: int, height: int) -> None:
    """``page`` at ``width`` x ``height`` px saved to ``shot`` (a PNG of some content)."""
    shot.parent.mkdir(parents=True, exist_ok=True)
    subprocess.run([chromium(), *FLAGS, f"--user-data-dir={profile}", f"--screenshot={shot}",
                    f"--window-size={width},{height}", "--virtual-time-budget=5000",
                    page.as_uri()], capture_output=True, timeout=60)
    assert shot.stat().st_size > 10_000
