"""Sizes and sha256 of a run's files: recorded when the run completes, checked before they
are trusted.

A completed run's marker ``.hgo_done`` holds a first line (the job config's hash, see
:mod:`hgo.running.job`) and then one line per file of the run directory (not Hydra's
``.hydra/``, not logs): ``<name>\\t<size in bytes>\\t<sha256>``. ``resume=true`` and
``hgo reproduce`` re-run a job whose files no longer match; ``hgo show``, ``export``,
``view`` and ``runs --compare`` refuse a damaged file in one line
(:class:`Damaged`): sizes always, hashes of the files they read anyway.
"""

from __future__ import annotations

import hashlib
from pathlib import Path

from hgo.core.errors import PlainError

DONE = ".hgo_done"  # written last into a run directory: the config's hash, then the files
CHUNK = 1 << 20


class Damaged(PlainError, ValueError):
    """A run's file that no longer matches the size or sha256 recorded when it completed."""


def sha256(path: Path) -> str:
    h = hashlib.sha256()
    with open(path, "rb") as fh:
        while chunk := fh.read(CHUNK):
            h.update(chunk)
    return h.hexdigest()


def manifest(out_dir: Path) -> dict[str, tuple[int, str]]:
    """``name -> (size, sha256)`` of the run's files in ``out_dir`` (not hidden ones, not
    logs, not a ``.partial`` left by an interrupted write)."""
    return {p.name: (p.stat().st_size, sha256(p)) for p in sorted(Path(out_dir).iterdir())
            if p.is_file() and p.suffix not in (".log", ".partial")
            and not p.name.startswith(".")}


def manifest_text(head: str, files: dict[str, tuple[int, str]]) -> str:
    return "\n".join([head, *(f"{n}\t{s}\t{h}" for n, (s, h) in files.items())]) + "\n"


def read_marker(out_dir: Path) -> tuple[str, dict[str, tuple[int, str]] | None] | None:
    """``(first line, files)`` of ``out_dir``'s marker; ``files`` is None for a marker
    without sizes (written by an older hgo), and the whole is None without a readable
    marker (a run that did not complete)."""
    try:
        head, *lines = (Path(out_dir) / DONE).read_text().split("\n")
    except (OSError, UnicodeDecodeError):
        return None
    files = {}
    for line in filter(None, lines):
        name, _, rest = line.partition("\t")
        size, _, digest = rest.partition("\t")
        if not (size.isdigit() and len(digest) == 64):
            return head, None
        files[name] = (int(size), digest)
    return head, files


def check_file(path: Path, size: int, digest: str, hashed: bool = True) -> None:
    """Raise :class:`Damaged` naming ``path`` unless it has ``size`` bytes and (with
    ``hashed``) the sha256 ``digest``."""
    try:
        actual = path.stat().st_size
    except OSError:
        raise Damaged(f"damaged: {path} is missing (the run recorded {size} bytes, "
                      f"sha256 {digest})") from None
    if actual != size:
        raise Damaged(f"damaged: {path} has {actual} bytes, expected {size} (sha256 "
                      f"{digest}; truncated or replaced since the run)")
    if hashed and sha256(path) != digest:
        raise Damaged(f"damaged: {path}, expected sha256 {digest} (same size: changed "
                      "since the run)")


def check_run(out_dir: Path, hashed: set[str] | bool = True, only: set[str] | None = None
              ) -> None:
    """Check the files ``out_dir``'s marker records (``only``: those names): sizes always,
    hashes of the names in ``hashed`` (True: all). Nothing to check without a marker with
    sizes (an interrupted or older run)."""
    marker = read_marker(out_dir)
    if marker is None or marker[1] is None:
        return
    for name, (size, digest) in marker[1].items():
        if only is None or name in only:
            check_file(Path(out_dir) / name, size, digest,
                       hashed if isinstance(hashed, bool) else name in hashed)
