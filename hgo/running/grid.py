"""Grid ensembles: the Cartesian product of value lists, and shards of a member list.

``ensemble.grid`` maps dotted config keys to value lists; every combination is one
member (first key slowest, the order of Hydra's basic sweeper over the same lists).
``ensemble.shard = "i/N"`` keeps the i-th of N contiguous blocks of the members, so a
large ensemble splits across jobs and the shards' tables concatenate to the whole one.
"""

from __future__ import annotations

import itertools
import math
from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np


def check_grid(grid: Mapping[str, Sequence[Any]]) -> None:
    """Raise ValueError naming a key whose value is not a non-empty list."""
    for key, values in grid.items():
        if isinstance(values, str | bytes) or not isinstance(values, Sequence) or not values:
            raise ValueError(f"ensemble.grid.{key}: expected a non-empty list of values, "
                             f"got {_short(values)}")


def _short(value: Any, limit: int = 80) -> str:
    text = repr(value)
    return text if len(text) <= limit else f"{text[:limit]}... ({len(text)} characters)"


def expand_grid(grid: Mapping[str, Sequence[Any]]) -> dict[str, list[Any]]:
    """key -> the value of every grid point (the Cartesian product, first key slowest).

    An empty grid is one point without values. Raises ValueError naming a key whose value
    is not a non-empty list.
    """
    check_grid(grid)
    keys = list(grid)
    points = list(itertools.product(*(list(grid[k]) for k in keys)))
    return {k: [p[j] for p in points] for j, k in enumerate(keys)}


def grid_size(grid: Mapping[str, Sequence[Any]]) -> int:
    """Number of grid points (1 for an empty grid)."""
    return math.prod(len(v) for v in grid.values()) if grid else 1  # (exact: no overflow)


def parse_shard(spec: str | None) -> tuple[int, int]:
    """``"i/N"`` -> (i, N) with 0 <= i < N; None or "" -> (0, 1), the whole ensemble."""
    if spec is None or str(spec).strip() == "":
        return 0, 1
    try:
        i, n = (int(part) for part in str(spec).split("/"))
    except ValueError:
        raise ValueError(f"ensemble.shard must be 'i/N' with integers 0 <= i < N, "
                         f"got {str(spec)[:40]!r}") from None
    if not 0 <= i < n:
        raise ValueError(f"ensemble.shard must be 'i/N' with integers 0 <= i < N, "
                         f"got {spec!r}")
    return i, n


def _checked_shard(n_members: int, spec: str | None) -> tuple[int, int]:
    """``parse_shard``, and no empty shard: N at most the member count (``0/10000000000``
    gave "object of type 'int' has no len()", ``3/4`` of 3 members "at least one member
    is required")."""
    i, n = parse_shard(spec)
    if n > n_members:
        raise ValueError(f"ensemble.shard: '{spec}' splits {n_members:,} member(s) into "
                         f"{n:,} shards, so some are empty (allowed: 'i/N' with N at most "
                         f"{n_members:,})")
    return i, n


def shard_size(n_members: int, spec: str | None) -> int:
    """Number of members of shard ``spec`` (as :func:`shard_indices`, without the array)."""
    i, n = _checked_shard(n_members, spec)
    return n_members // n + (1 if i < n_members % n else 0)


def shard_indices(n_members: int, spec: str | None) -> np.ndarray:
    """Indices of the members of shard ``spec`` (contiguous blocks, sizes differ by <= 1)."""
    i, n = _checked_shard(n_members, spec)
    return np.array_split(np.arange(n_members), n)[i]
