"""Reliability, second round (issue 28): iterative routines that must stop, inputs that
must be refused, failures that must not exit 0, commands that survive bad files.

Each test names the case of the issue it covers and the one line (or result) the user
gets now instead of a hang, a traceback or a silent accept.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

# --- iterative numerics stop on NaN/inf ----------------------------------------------


def test_zoom_refuses_a_nan_bracket_instead_of_looping():
    """``_zoom`` waited for ``hi - lo < xatol``, never true for NaN (P not positive
    definite gave s_min = NaN): now one error naming the values."""
    from hgo.core.lmi import NonFiniteError
    from hgo.papers.sanfelice_praly.bounds import _zoom, minimise_over_s

    with pytest.raises(NonFiniteError, match="lo = nan"):
        _zoom(np.log, math.nan, 1.0)
    with pytest.raises(NonFiniteError, match="s_min = nan"):
        minimise_over_s(np.log, math.nan)


def test_zoom_ends_where_float_spacing_stops_the_bracket():
    """A tolerance below the spacing of floats (xatol = 0) used to loop forever: the
    bracket stops shrinking, and the zoom returns the minimiser."""
    from hgo.papers.sanfelice_praly.bounds import _zoom

    u, v = _zoom(lambda s: (np.log(s) - 1.25) ** 2, 1.0, 2.0, xatol=0.0)
    assert abs(u - 1.25) < 1e-12 and v < 1e-24


def test_bisection_refuses_nan_and_stops_at_float_spacing():
    """A NaN end used to return ``good`` unchanged (NaN comparisons are false); an rtol
    below float spacing now ends at adjacent floats."""
    from hgo.core.lmi import NonFiniteError, bisect

    with pytest.raises(NonFiniteError, match="bad = nan"):
        bisect(lambda x: x < 1, 0.0, math.nan, 1e-6)
    with pytest.raises(NonFiniteError, match="good = inf"):
        bisect(lambda x: x < 1, math.inf, 2.0, 1e-6)
    x = bisect(lambda x: x < 0.3, 0.0, 1.0, 1e-30)
    assert x < 0.3 and np.nextafter(x, 1.0) >= 0.3


def test_sp_bounds_refuses_a_p_that_is_not_positive_definite():
    """``postprocess.sp_bounds.P=[[1,0],[0,-1]]`` looped forever in the bound's zoom."""
    from hgo.papers.sanfelice_praly.postprocess import sp_bounds

    with pytest.raises(ValueError, match=r"P must be positive definite .*\[-1.0, 1.0\]"):
        sp_bounds(P=[[1, 0], [0, -1]])


# --- a corpus of inputs: one line each, checked before any integration --------------

SP = "experiment=sp_fig1"
ENS = "experiment=sp_ensemble"
SI = "observer.sign_indefinite"
GRID10 = "[" + ",".join(str(k) for k in range(10)) + "]"

CORPUS: list[tuple[tuple[str, ...], str]] = [
    # members estimated up front (MemoryError after 1-20 s before)
    ((ENS, "ensemble.size=100000000"), "ensemble.size: the ensemble has 1e+08 members"),
    ((ENS, "ensemble.size=1000000000000"), "over half the free memory"),
    ((ENS, "ensemble.size=1", "++ensemble.grid={" + ",".join(f"{key}:{GRID10}" for key in (
        "seed", "plant.nu1", "plant.nu2", "noise.amplitude", *(f"{SI}.{k}" for k in (
            "p1", "p2", "b", "r0")))) + f",{SI}.xhat0:[" + ",".join(["[0,0]"] * 10) + "]}"),
     "ensemble.grid: the ensemble has 1e+09 members"),
    ((ENS, "ensemble.size=1000000", "solver.h_max=0.001"), "over solver.max_steps"),
    # iterative numerics fed a NaN (looped forever in the bound's zoom)
    ((SP, "postprocess.sp_bounds.P=[[1,0],[0,-1]]"), "P must be positive definite"),
]


def _config_line(overrides: tuple[str, ...]) -> str:
    from hgo.core.config import compose
    from hgo.core.errors import one_line
    from hgo.running.job import check_config

    try:
        check_config(compose(list(overrides)))
    except Exception as err:  # noqa: BLE001 - any error is what the case looks at
        return one_line(err)
    return "(accepted)"


@pytest.mark.parametrize("case", CORPUS, ids=lambda c: " ".join(c[0])[:60])
def test_bad_input_gives_one_line(case):
    overrides, expected = case
    line = _config_line(overrides)
    assert expected in line and "\n" not in line and len(line) < 600, line


LAUGHS = "# @package _global_\ndefaults:\n  - sp_fig1\na: &a [1, 1, 1, 1, 1, 1, 1, 1, 1, 1]\n" + \
    "".join(f"{b}: &{b} [{', '.join(['*' + a] * 10)}]\n" for a, b in zip("abcdefgh", "bcdefghi",
                                                                      strict=True))


def test_nested_yaml_aliases_in_a_user_preset_are_refused(tmp_path):
    """A "billion laughs" (9 levels of 10 aliases: 1e9 values) ran for minutes and
    exhausted memory; now one line with the file, at once."""
    import time

    (tmp_path / "experiment").mkdir()
    (tmp_path / "experiment" / "laughs.yaml").write_text(LAUGHS)
    t0 = time.perf_counter()
    line = _config_line((f"hydra.searchpath=[file://{tmp_path}]", "experiment=laughs"))
    assert time.perf_counter() - t0 < 10
    assert line.startswith(f"{tmp_path}/experiment/laughs.yaml:") and \
        "aliases expand to more than 100,000 values" in line, line


def test_a_few_yaml_aliases_still_work(tmp_path):
    (tmp_path / "experiment").mkdir()
    (tmp_path / "experiment" / "alias.yaml").write_text(
        "# @package _global_\ndefaults:\n  - sp_fig1\nplant:\n  x0: &x0 [1.0, 2.0]\n"
        "observer:\n  sign_indefinite:\n    xhat0: *x0\n")
    from hgo.core.config import compose

    cfg = compose([f"hydra.searchpath=[file://{tmp_path}]", "experiment=alias"])
    assert list(cfg.observer.sign_indefinite.xhat0) == [1.0, 2.0]
