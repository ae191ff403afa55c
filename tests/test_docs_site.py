"""The documentation site: ``mkdocs build --strict`` passes offline, the generated reference
pages hold every config option, schema and command, and the built pages looked at in a real
headless browser render their maths (KaTeX, served from the site itself) and fit their code
blocks at 1400 px.

The browser checks need Chromium (``.ci/run`` installs Debian's ``chromium`` when missing);
the screenshots land in ``outputs/docs-*.png``.
"""

from __future__ import annotations

import os
import re
import subprocess
import sys
from pathlib import Path

import browser  # tests/browser.py
import pytest

ROOT = Path(__file__).resolve().parents[1]
DOCS = ROOT / "docs"
# pages that must have rendered maths; any other page with maths is checked the same way
MATHS_PAGES = ["tutorials/own-plant", "tutorials/own-coordinates", "tutorials/sweep",
               "reference/observers", "reference/components"]
SCREENS = {"tutorials/own-plant": "docs-tutorial-own-plant.png",
           "tutorials/own-coordinates": "docs-tutorial-own-coordinates.png",
           "tutorials/kalman": "docs-tutorial-kalman.png",
           "tutorials/sweep": "docs-tutorial-sweep.png",
           "reference/observers": "docs-reference-observers.png"}  # standard_hgo first
WIDTH = 1400
CHECK_JS = r"""<script>window.addEventListener('load', function () { setTimeout(function () {
  var all = function (q, root) {
    return [].slice.call((root || document).querySelectorAll(q)); };
  var article = document.querySelector('article') || document.body;
  var maths = all('.arithmatex', article);
  var unrendered = maths.filter(function (m) { return !m.querySelector('.katex'); });
  var walker = document.createTreeWalker(article, NodeFilter.SHOW_TEXT);
  var raw = 0;
  while (walker.nextNode()) {
    var node = walker.currentNode;
    if (node.parentElement.closest('pre, code, .katex')) continue;
    raw += (node.nodeValue.match(/\\\(|\\\)|\\\[|\\\]|\$\$/g) || []).length;
  }
  var blocks = all('pre > code', article);
  var wide = blocks.filter(function (c) { return c.scrollWidth > c.clientWidth + 1; });
  var excess = Math.max.apply(null, [0].concat(blocks.map(function (c) {
    return c.scrollWidth - c.clientWidth; })));
  var fonts = [];
  document.fonts.forEach(function (f) { if (/^"?KaTeX/.test(f.family)) fonts.push(f); });
  var loaded = fonts.filter(function (f) { return f.status === 'loaded'; });
  var failed = fonts.filter(function (f) { return f.status === 'error'; });
  var out = document.createElement('pre');
  out.textContent = 'CHECK maths=' + maths.length + ' unrendered=' + unrendered.length +
    ' raw=' + raw + ' blocks=' + blocks.length + ' overflowing=' + wide.length +
    ' excess_px=' + excess +
    ' fonts_loaded=' + loaded.length + ' fonts_failed=' + failed.length;
  document.body.appendChild(out); }, 500); });</script>"""
@pytest.fixture(scope="module")
def site(tmp_path_factory) -> Path:
    """The site, built once for this module with ``mkdocs build --strict``."""
    import mkdocs  # noqa: F401 - the test extra installs the docs extra: never skipped
    import mkdocstrings  # noqa: F401
    out = tmp_path_factory.mktemp("site") / "site"
    done = subprocess.run([sys.executable, "-m", "mkdocs", "build", "--strict", "--site-dir",
                           str(out)], cwd=ROOT, capture_output=True, text=True,
                          env={**os.environ, "PYTHONPATH": str(ROOT), "NO_MKDOCS_2_WARNING": "1"},
                          timeout=600)
    assert done.returncode == 0, done.stderr[-4000:]
    return out


def test_mkdocs_build_strict(site):
    assert (site / "reference" / "api" / "index.html").is_file()
    # the hook generated the reference from the code: every group option and schema is there
    sys.path.insert(0, str(DOCS))
    try:
        from gen_reference import _schemas
    finally:
        sys.path.remove(str(DOCS))
    from hgo.core.config import conf_dir, groups

    page = (site / "reference" / "configuration" / "index.html").read_text()
    for group, options in groups(conf_dir()).items():
        for option in options:
            assert f"<code>{option}</code>" in page, f"{group}/{option}"
    for path in _schemas():
        assert f"/{path}" in page
    cli = (site / "reference" / "cli" / "index.html").read_text()
    assert "usage: hgo view" in cli and "--config-dir" in cli


def test_site_loads_nothing_from_the_network(site):
    """No page links a stylesheet, script or font from another host: the maths renderer and
    its fonts are files of the site (docs/assets/katex)."""
    external = re.compile(r'<(?:link|script)[^>]*(?:href|src)="(?:https?:)?//[^"]*"')
    for page in site.rglob("*.html"):
        found = external.findall(page.read_text())
        assert not found, f"{page.relative_to(site)}: {found}"
    assert (site / "assets" / "katex" / "fonts" / "KaTeX_Main-Regular.woff2").is_file()


def _pages(site: Path) -> list[str]:
    """Every page of the site with maths or a code block, as ``tutorials/sweep``."""
    found = []
    for page in sorted(site.rglob("index.html")):
        text = page.read_text()
        if 'class="arithmatex"' in text or "<pre" in text:
            found.append(page.parent.relative_to(site).as_posix() or ".")
    return found


def test_pages_in_a_headless_browser(site, tmp_path):
    """Chromium at 1400 px loads every page with maths or code: every formula is rendered by
    KaTeX (no raw ``\\(``, ``\\[`` or ``$$`` left in the text), KaTeX's fonts load from the
    site and none fails, no code block is wider than its box; screenshots of a tutorial and
    of the observers' reference page are saved to outputs/."""
    browser.chromium()
    pages = _pages(site)
    assert set(MATHS_PAGES) <= set(pages), pages
    results = {}
    for name in pages:
        html = site / name / "index.html"
        checked = html.with_name("checked.html")  # beside the page: its links resolve the same
        checked.write_text(html.read_text().replace("</body>", CHECK_JS + "</body>"))
        results[name] = browser.check(checked, tmp_path / "profile", WIDTH)
    for name, found in results.items():
        assert found["unrendered"] == 0 and found["raw"] == 0, (name, found)
        assert found["overflowing"] == 0, f"{name}: {found}"
        assert found["fonts_failed"] == 0, (name, found)
        if found["maths"]:
            assert found["fonts_loaded"] >= 2, (name, found)  # KaTeX_Main and KaTeX_Math
    for name in MATHS_PAGES:
        assert results[name]["maths"] > 0, (name, results[name])
    for name, file in SCREENS.items():
        if name not in results:
            continue
        browser.screenshot(site / name / "index.html", ROOT / "outputs" / file,
                           tmp_path / "shot", WIDTH, 2400)


# ------------------------------------------------------------- the reference's examples
OBJECT = re.compile(r"^::: ([\w.]+)$", re.M)
EXAMPLE = re.compile(r"```python\n(.*?)```", re.S)
PRINTED = re.compile(r"^\s*print\(.*\)\s+# (.*)$", re.M)
# what the reference must show with a runnable example (issue 44)
MUST_HAVE_EXAMPLES = {"hgo.core.components.Plant", "hgo.core.components.Params",
                      "hgo.plants.symbolic", "hgo.observers.symbolic_hgo",
                      "hgo.observers.ekf", "hgo.observers.ukf",
                      "hgo.observers.normal_form.standard_hgo",
                      "hgo.observers.normal_form.lowpower_hgo",
                      "hgo.observers.circle_criterion.circle_criterion_observer",
                      "hgo.plants.normal_form.normal_form_plant",
                      "hgo.plants.circle_form.circle_form_plant", "hgo.noise.NoiseModel",
                      "hgo.outputs.metrics"}


def _object(path: str):
    import importlib

    module, _, name = path.rpartition(".")
    try:
        return getattr(importlib.import_module(module), name)
    except (ImportError, AttributeError):
        return importlib.import_module(path)


def reference_examples() -> dict[str, list[str]]:
    """Object shown on a reference page (``::: path``) -> the python blocks of its
    docstring."""
    import inspect

    found = {}
    for page in sorted((DOCS / "reference").glob("*.md")):
        for path in OBJECT.findall(page.read_text()):
            doc = inspect.getdoc(_object(path)) or ""
            found[path] = EXAMPLE.findall(doc)
    return found


def test_every_example_of_the_reference_runs_and_prints_what_it_says(capsys):
    """Every python block in the docstring of an object on a reference page runs, and each
    ``print(...)  # text`` prints ``text``."""
    import textwrap

    examples = reference_examples()
    missing = sorted(p for p in MUST_HAVE_EXAMPLES if not examples.get(p))
    assert not missing, f"no example in the docstring of {missing}"
    for path, blocks in examples.items():
        for body in blocks:
            code = textwrap.dedent(body)
            capsys.readouterr()
            exec(compile(code, f"<example of {path}>", "exec"), {"__name__": "__example__"})
            printed = capsys.readouterr().out.splitlines()
            said = PRINTED.findall(code)
            assert printed == said, f"{path}: printed {printed}, its comments say {said}"
