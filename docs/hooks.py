"""mkdocs hook (``hooks:`` in mkdocs.yml): before every build, write the generated reference
pages (``docs/gen_reference.py``: the CLI's help, the configuration schemas, groups and
presets), so the site always shows the code of the checkout it is built from. A page is
rewritten only when its text changed (``mkdocs serve`` watches docs/: no rebuild loop)."""

from __future__ import annotations

import sys
from pathlib import Path

DOCS = Path(__file__).resolve().parent


def on_pre_build(config, **kwargs) -> None:  # noqa: ARG001 - mkdocs' hook signature
    if str(DOCS) not in sys.path:
        sys.path.insert(0, str(DOCS))
    from gen_reference import write_pages

    write_pages()
