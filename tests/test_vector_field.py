"""hgo.postprocess.vector_field: the plant's f at many samples, compiled or in Python alike."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from hgo.plants.robot_arm import robot_arm_plant
from hgo.postprocess import vector_field as vf


def _samples(n: int = 2000):
    rng = np.random.default_rng(3)
    z = rng.uniform(-5.0, 5.0, (n, 4))
    return np.linspace(0.0, 20.0, n), z[:, :2], rng.uniform(-10.0, 10.0, (n, 1))


def test_the_compiled_loop_gives_the_python_loops_bits(monkeypatch) -> None:
    """Above COMPILE_ROWS samples the loop is compiled: the robot arm's x' equals the Python
    loop's bit for bit (the same arithmetic, no fast-math), on a strided x as a post-
    processor passes it."""
    plant = robot_arm_plant()
    t, x, u = _samples()
    monkeypatch.setattr(vf, "COMPILE_ROWS", 10 ** 9)
    python = vf.vector_field(plant, t, x, u)
    monkeypatch.setattr(vf, "COMPILE_ROWS", 1)
    compiled = vf.vector_field(plant, t, x, u)
    np.testing.assert_array_equal(compiled, python)
    assert vf._rows().signatures  # (the compiled loop ran)


def test_a_plant_numba_cannot_compile_runs_in_python(monkeypatch) -> None:
    """A plant whose f uses a Python object numba cannot type gets the Python loop."""
    table = {"gain": 2.0}

    def f(t, x, u, p, dx):
        dx[0] = table["gain"] * x[1]
        dx[1] = u[0]

    plant = replace(robot_arm_plant(), f=f)
    t, x, u = _samples(50)
    monkeypatch.setattr(vf, "COMPILE_ROWS", 1)
    dx = vf.vector_field(plant, t, x, u)
    assert dx == pytest.approx(np.column_stack([2.0 * x[:, 1], u[:, 0]]), rel=0, abs=0)
