"""Regression tests for defects found in review of the paper-specific modules."""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np

from hgo.plants.sp_linear import sp_linear_plant
from hgo.postprocess.sp_bounds import sp_bounds


def test_sp_bounds_keeps_a_lone_gamma_or_L_override():
    """gamma (or L) given alone in the config must not be silently replaced by the plant's."""
    system = SimpleNamespace(plant=sp_linear_plant(nu1=0.01, nu2=0.01))
    gamma, L = sp_bounds(gamma=[0.5, 0.0])._mismatch(system)
    assert np.allclose(gamma, [0.5, 0.0]) and np.allclose(L, [0.01, 0.0])
    gamma, L = sp_bounds(L=[0.2, 0.0])._mismatch(system)
    assert np.allclose(gamma, [0.01, 0.0]) and np.allclose(L, [0.2, 0.0])
