"""``hgo reproduce`` end to end on one paper, and its report looked at in a real browser.

The browser check needs Chromium (``.ci/run`` installs Debian's ``chromium`` when missing).
"""

from __future__ import annotations

import re
from pathlib import Path

import browser  # tests/browser.py
import pytest

from hgo.core.registry import all_claims
from hgo.reproduce.run import main, paper_figures, reproduce

ROOT = Path(__file__).resolve().parents[1]
PAPER = "sanfelice_praly"
CHECK_JS = r"""<script>window.addEventListener('load', function () {
  var all = function (q) { return [].slice.call(document.querySelectorAll(q)); };
  var imgs = [].slice.call(document.images);
  var broken = imgs.filter(function (i) { return !(i.complete && i.naturalWidth > 0); });
  var wide = all('table').filter(function (t) {
    return t.getBoundingClientRect().width > t.parentElement.clientWidth + 1 ||
           t.getBoundingClientRect().right > document.documentElement.clientWidth + 1; });
  var links = all('nav.toc a[href^="#"]');
  var dangling = links.filter(function (a) {
    return !document.getElementById(a.getAttribute('href').slice(1)); });
  var cells = all('table.claims > tbody > tr > td');
  var longest = Math.max.apply(null, cells.map(function (c) { return c.innerText.length; }));
  var text = document.body.innerText;
  var markdown = (text.match(/\*\*|`/g) || []).length;
  var out = document.createElement('pre');
  out.textContent = 'CHECK images=' + imgs.length + ' broken=' + broken.length +
                    ' overflowing=' + wide.length + ' toc=' + links.length +
                    ' dangling=' + dangling.length + ' cells=' + cells.length +
                    ' longest=' + longest + ' markdown=' + markdown;
  document.body.appendChild(out); });</script>"""
@pytest.fixture(scope="module")
def report(tmp_path_factory):
    root = tmp_path_factory.mktemp("reproduce")
    return root, reproduce([PAPER], jobs=2, root=root)


def test_report_has_every_claim_and_figure(report):
    _, out = report
    md = (out / "report.md").read_text()
    for c in all_claims([PAPER]):
        assert f"| {c.id} |" in md and c.verdict in md
    # the self-check column is shown only where a check fails (none here)
    assert "self-check" not in md and "| claim | where | statement | deciding numbers" in md
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


SCREENS = {1400: "report-1400.png", 800: "report-800.png"}  # in outputs/, looked at


def test_report_in_a_headless_browser(report, tmp_path):
    """Chromium loads report.html at 1400 and 800 px: every figure decodes, no table is
    wider than the page, every link of the table of contents has its target, no cell of
    a claims table shows more than 400 characters (the rest is in collapsed details), no
    Markdown is left in the text; screenshots at both widths are saved to outputs/."""
    browser.chromium()
    _, out = report
    page = out / "checked.html"  # beside report.html: its PDF links resolve the same
    page.write_text((out / "report.html").read_text().replace("</body>", CHECK_JS + "</body>"))
    n_claims = len(all_claims([PAPER]))
    for width, name in SCREENS.items():
        found = browser.check(page, tmp_path / f"profile{width}", width)
        assert found["images"] == 5 and found["broken"] == 0, found
        assert found["overflowing"] == 0, found
        assert found["toc"] >= 5 and found["dangling"] == 0, found
        assert found["cells"] == 4 * n_claims and found["longest"] <= 400, found
        assert found["markdown"] == 0, found
        browser.screenshot(out / "report.html", ROOT / "outputs" / name, tmp_path / "shot",
                           width, 5000)


def test_readme_what_reproduces_table_is_the_registry():
    from hgo.reproduce.report import registry_table

    readme = (ROOT / "README.md").read_text()
    start, end = "<!-- what-reproduces:start -->\n", "<!-- what-reproduces:end -->"
    assert readme[readme.index(start) + len(start):readme.index(end)] == registry_table()


def test_null_value_override_is_composed_as_hydra_does():
    """``figures.vector=pdf`` (null in config.yaml, set on every reproduce job) is applied
    to the composed preset, not composed by Hydra again; the config is Hydra's."""
    from hgo.core.config import compose
    from hgo.running import in_memory
    from hgo.running.runner import job_config_yaml

    overrides = ("experiment=sp_fig2", "figures.vector=pdf")
    in_memory._compose_base.cache_clear()
    fast = in_memory.compose_cached(overrides)
    assert in_memory._compose_base.cache_info().misses == 1  # the preset alone
    assert fast.figures.vector == "pdf"
    assert job_config_yaml(fast) == job_config_yaml(compose(list(overrides)))


def test_list_value_override_is_composed_as_hydra_does():
    """``plant.x0=[1.0,1.0]`` and ``observer.circle.L=[...]`` (Moreno's claims) replace the
    lists of the composed preset, not composed by Hydra again; the configs are Hydra's."""
    from hgo.core.config import compose
    from hgo.running import in_memory
    from hgo.running.runner import job_config_yaml

    in_memory._compose_base.cache_clear()
    for overrides in (("experiment=moreno_fig1", "plant.x0=[1.0,1.0]", "plant.a=0.5"),
                      ("experiment=moreno_fig1", "observer.circle.L=[200.0,20.0]")):
        fast = in_memory.compose_cached(overrides)
        assert job_config_yaml(fast) == job_config_yaml(compose(list(overrides)))
    assert in_memory._compose_base.cache_info().misses == 1  # the preset alone
    assert list(fast.observer.circle.L) == [200.0, 20.0]


def test_tasks_are_handed_out_longest_first_by_the_last_durations(tmp_path, monkeypatch):
    """The durations a reproduce recorded (in the kernel cache) order the next one: the
    longest first, the never-timed before all (in their given order); a claims task counts
    the seconds of its claims."""
    from hgo.reproduce.run import TaskTimes

    monkeypatch.setenv("HGO_CACHE_DIR", str(tmp_path))
    times = TaskTimes.load()
    assert times.seconds == {}
    times.record("claims of a", {"c1": {"seconds": 1.0}, "c2": {"seconds": 5.0}})
    times.record("job b", {"status": "ok", "seconds": 2.5})
    times.save()
    again = TaskTimes.load()
    assert again.seconds == {"claims of a": 6.0, "job b": 2.5}
    order = again.longest_first(["job b", "new1", "claims of a", "new2"], lambda t: [t])
    assert order == ["new1", "new2", "claims of a", "job b"]
    # a sweep's job counts its combination too (never timed: 0)
    again.record("combine s", {"seconds": 4.0})
    costs = {"job b": ["job b", "combine s"], "claims of a": ["claims of a", "combine x"]}
    assert again.longest_first(["claims of a", "job b"], costs.get) == ["job b", "claims of a"]


def test_a_sweep_is_combined_in_a_worker_even_when_its_combiner_does_not_pickle(tmp_path):
    """Ahrens & Khalil's Fig. 2 combiner is a local function (it cannot be sent to a
    worker): the worker is sent (paper, figure index, job directory, key) and finds the
    figure itself."""
    import pickle
    from pathlib import Path as P

    from hgo.reproduce.run import _figure_index, plan_jobs

    plan = [j for j in plan_jobs(["ahrens_khalil"], tmp_path, "fp") if j.figure.sweep]
    fig2 = [j for j in plan if j.figure.preset == "ak_fig2"]
    with pytest.raises((pickle.PicklingError, AttributeError, TypeError)):
        pickle.dumps(fig2[0].figure.combine)
    sent = pickle.loads(pickle.dumps([(j.paper, _figure_index(j), str(j.dir), j.key)
                                      for j in fig2]))
    for (paper, index, d, key), job in zip(sent, fig2, strict=True):
        assert paper_figures(paper)[index] is job.figure and P(d) == job.dir
        assert key == job.key
