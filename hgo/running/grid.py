"""Grid ensembles: the Cartesian product of value lists, and shards of a member list.

``ensemble.grid`` maps dotted config keys to value lists; every combination is one
member (first key slowest, the order of Hydra's basic sweeper over the same lists).
``ensemble.shard = "i/N"`` keeps the i-th of N contiguous blocks of the members, so a
large ensemble splits across jobs and the shards' tables concatenate to the whole one.
"""

from __future__ import annotations

import itertools
from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np


def expand_grid(grid: Mapping[str, Sequence[Any]]) -> dict[str, list[Any]]:
    """key -> the value of every grid point (the Cartesian product, first key slowest).

    An empty grid is one point without values. Raises ValueError naming a key whose value
    is not a non-empty list.
    """
    for key, values in grid.items():
        if isinstance(values, str | bytes) or not isinstance(values, Sequence) or not values:
            raise ValueError(f"ensemble.grid.{key}: expected a non-empty list of values, "
                             f"got {values!r}")
    keys = list(grid)
    points = list(itertools.product(*(list(grid[k]) for k in keys)))
    return {k: [p[j] for p in points] for j, k in enumerate(keys)}


def grid_size(grid: Mapping[str, Sequence[Any]]) -> int:
    """Number of grid points (1 for an empty grid)."""
    return int(np.prod([len(v) for v in grid.values()])) if grid else 1


def parse_shard(spec: str | None) -> tuple[int, int]:
    """``"i/N"`` -> (i, N) with 0 <= i < N; None or "" -> (0, 1), the whole ensemble."""
    if spec is None or str(spec).strip() == "":
        return 0, 1
    try:
        i, n = (int(part) for part in str(spec).split("/"))
    except ValueError:
        raise ValueError(f"ensemble.shard must be 'i/N' with integers 0 <= i < N, "
                         f"got {spec!r}") from None
    if not 0 <= i < n:
        raise ValueError(f"ensemble.shard must be 'i/N' with integers 0 <= i < N, "
                         f"got {spec!r}")
    return i, n


def shard_indices(n_members: int, spec: str | None) -> np.ndarray:
    """Indices of the members of shard ``spec`` (contiguous blocks, sizes differ by <= 1)."""
    i, n = parse_shard(spec)
    return np.array_split(np.arange(n_members), n)[i]
