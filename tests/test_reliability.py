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
    from hgo.lmi import NonFiniteError
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
    from hgo.lmi import NonFiniteError, bisect

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
