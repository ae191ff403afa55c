"""``hgo reproduce`` end to end on one paper, and its report looked at in a real browser.

The browser check needs Chromium (``.ci/run`` installs Debian's ``chromium`` when missing).
"""

from __future__ import annotations

import re
import shutil
import subprocess
from pathlib import Path

import pytest

from hgo.core.registry import all_claims
from hgo.reproduce.run import main, paper_figures, reproduce

ROOT = Path(__file__).resolve().parents[1]
PAPER = "sanfelice_praly"
CHECK_JS = """<script>window.addEventListener('load', function () {
  var imgs = [].slice.call(document.images);
  var broken = imgs.filter(function (i) { return !(i.complete && i.naturalWidth > 0); });
  var wide = [].slice.call(document.querySelectorAll('table')).filter(function (t) {
    return t.getBoundingClientRect().width > t.parentElement.clientWidth + 1 ||
           t.getBoundingClientRect().right > document.documentElement.clientWidth + 1; });
  var out = document.createElement('pre');
  out.textContent = 'CHECK images=' + imgs.length + ' broken=' + broken.length +
                    ' overflowing=' + wide.length;
  document.body.appendChild(out); });</script>"""
CHROMIUM_FLAGS = ["--headless", "--no-sandbox", "--disable-gpu", "--disable-quic",
                  "--no-first-run", "--disable-background-networking",
                  "--disable-component-update", "--disable-sync", "--hide-scrollbars"]


@pytest.fixture(scope="module")
def report(tmp_path_factory):
    root = tmp_path_factory.mktemp("reproduce")
    return root, reproduce([PAPER], jobs=2, root=root)


def test_report_has_every_claim_and_figure(report):
    _, out = report
    md = (out / "report.md").read_text()
    for c in all_claims([PAPER]):
        assert f"| {c.id} |" in md and c.verdict in md
    assert "| agrees |" in md and "DISAGREES" not in md and "| error |" not in md
    n_figures = sum(len(f.captions) for f in paper_figures(PAPER))
    assert len(list((out / "figures").glob("*.png"))) == n_figures == 5
    html = (out / "report.html").read_text()
    assert html.count("data:image/png;base64,") == n_figures  # self-contained
    assert "http://" not in html and "https://" not in html


def test_second_run_reuses_every_result(report, capsys):
    root, _ = report
    assert main([PAPER, "--jobs", "1", "--out", str(root)]) == 0
    assert re.search(r"0 to run, \d+ reused", capsys.readouterr().out)


def test_unknown_paper_is_one_line_error(capsys):
    assert main(["no_such_paper"]) == 2
    err = capsys.readouterr().err.strip()
    assert err.startswith("error: paper: no_such_paper unknown (allowed: ") and "\n" not in err


def test_report_in_a_headless_browser(report, tmp_path):
    """Chromium loads report.html: every figure decodes, no table is wider than the page;
    a screenshot is saved to outputs/report-screenshot.png."""
    chromium = shutil.which("chromium") or shutil.which("chromium-browser")
    if chromium is None:
        pytest.skip("chromium is not installed (.ci/run installs it)")
    _, out = report
    page = tmp_path / "checked.html"
    page.write_text((out / "report.html").read_text().replace("</body>", CHECK_JS + "</body>"))
    args = [chromium, *CHROMIUM_FLAGS, f"--user-data-dir={tmp_path / 'profile'}",
            "--window-size=1280,900"]
    dom = subprocess.run([*args, "--virtual-time-budget=5000", "--dump-dom", page.as_uri()],
                         capture_output=True, text=True, timeout=60).stdout
    found = re.search(r"CHECK images=(\d+) broken=(\d+) overflowing=(\d+)", dom)
    assert found, dom[-2000:]
    assert found.groups() == ("5", "0", "0")
    shot = ROOT / "outputs" / "report-screenshot.png"
    shot.parent.mkdir(exist_ok=True)
    subprocess.run([*args, f"--screenshot={shot}", "--window-size=1280,4000",
                    (out / "report.html").as_uri()], capture_output=True, timeout=60)
    assert shot.stat().st_size > 10_000


def test_readme_what_reproduces_table_is_the_registry():
    from hgo.reproduce.report import registry_table

    readme = (ROOT / "README.md").read_text()
    start, end = "<!-- what-reproduces:start -->\n", "<!-- what-reproduces:end -->"
    assert readme[readme.index(start) + len(start):readme.index(end)] == registry_table()
