"""Compare the numbers of two ``hgo reproduce`` output roots (``--out`` folders).

    python benchmarks/reproduce_diff.py OLD NEW

A change that only makes ``hgo reproduce`` faster must leave every number as it was:
every figure job's ``metrics.csv`` (and each sweep's ``metrics_all.csv``) byte for byte,
matched by the job's overrides (its directory name hashes the code, so it differs), and
every claim's verdict, ``numbers`` and ``measured`` text, matched by paper and claim id
(the claims file name holds the code's fingerprint). Prints one line per difference (for
numbers: both values and their relative difference) and a summary; exit status 1 when
anything differs or is missing on one side.
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path


def figure_files(root: Path) -> dict[str, bytes]:
    """``<overrides>: <file>`` -> the bytes of each job's metrics.csv and each sweep's
    metrics_all.csv (a sweep named by its jobs' overrides)."""
    out: dict[str, bytes] = {}
    sweeps: dict[Path, list[str]] = {}
    for info in sorted((root / "runs").rglob("reproduce.json")):
        job = info.parent
        name = " ".join(json.loads(info.read_text())["overrides"])
        if (job / "metrics.csv").exists():
            out[f"{name}: metrics.csv"] = (job / "metrics.csv").read_bytes()
        if job.name.startswith("job"):
            sweeps.setdefault(job.parent, []).append(name)
    for sweep, names in sweeps.items():
        if (sweep / "metrics_all.csv").exists():
            out[f"sweep of {' | '.join(sorted(names))}: metrics_all.csv"] = \
                (sweep / "metrics_all.csv").read_bytes()
    return out


def claims(root: Path) -> dict[str, dict]:
    """``<paper>/<claim id>`` -> its entry (holds, numbers, measured)."""
    out = {}
    for path in sorted((root / "claims").glob("*.json")):
        paper = path.stem.rsplit("-", 1)[0]
        for cid, entry in json.loads(path.read_text()).items():
            out[f"{paper}/{cid}"] = entry
    return out


def _same(a, b) -> bool:
    """Equal, NaN equal to NaN (a claim's "never" is a NaN)."""
    return a == b or (isinstance(a, float) and isinstance(b, float) and a != a and b != b)


def _number_diff(key: str, a, b) -> str:
    if isinstance(a, float) and isinstance(b, float) and a != 0:
        return f"  {key}: {a!r} -> {b!r} (relative {abs(b - a) / abs(a):.3g})"
    return f"  {key}: {a!r} -> {b!r}"


def compare(old: Path, new: Path) -> list[str]:
    """One line per difference between the roots ``old`` and ``new``."""
    lines = []
    fa, fb = figure_files(old), figure_files(new)
    for name in sorted(fa.keys() | fb.keys()):
        if name not in fa or name not in fb:
            lines.append(f"only in {'new' if name in fb else 'old'}: {name}")
        elif fa[name] != fb[name]:
            la, lb = fa[name].decode().splitlines(), fb[name].decode().splitlines()
            rows = [f"    - {x}\n    + {y}" for x, y in zip(la, lb, strict=False) if x != y]
            lines.append(f"differs: {name} ({len(la)} / {len(lb)} lines)\n" + "\n".join(rows))
    ca, cb = claims(old), claims(new)
    for cid in sorted(ca.keys() | cb.keys()):
        if cid not in ca or cid not in cb:
            lines.append(f"only in {'new' if cid in cb else 'old'}: claim {cid}")
            continue
        a, b = ca[cid], cb[cid]
        diffs = [_number_diff(k, a["numbers"].get(k), b["numbers"].get(k))
                 for k in sorted(a.get("numbers", {}).keys() | b.get("numbers", {}).keys())
                 if not _same(a["numbers"].get(k), b["numbers"].get(k))]
        if a.get("holds") != b.get("holds"):
            diffs.append(f"  holds: {a.get('holds')} -> {b.get('holds')}")
        if a.get("measured") != b.get("measured") and not diffs:
            diffs.append("  measured text differs")
        if diffs:
            lines.append(f"differs: claim {cid}\n" + "\n".join(diffs))
    return lines


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("old", type=Path)
    parser.add_argument("new", type=Path)
    args = parser.parse_args()
    lines = compare(args.old, args.new)
    for line in lines:
        print(line)
    n_fig, n_claims = len(figure_files(args.old)), len(claims(args.old))
    print(f"reproduce_diff: {n_fig} metrics files, {n_claims} claims compared; "
          f"{len(lines)} difference(s)")
    return 1 if lines else 0


if __name__ == "__main__":
    sys.exit(main())
