"""``solver.split_observers``: each observer integrated with its own copy of the plant.

The split run must be exactly the observers' own runs (one observer each, same plant,
input and noise) put back in the whole system's layout, in single runs and in ensembles;
it is refused where the observers are coupled through the input.
"""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from hgo.controllers.dc_motor_speed import dc_motor_speed_controller
from hgo.controllers.open_loop import open_loop_controller
from hgo.core.errors import ConfigError
from hgo.engine.simulate import Noise, SolverSettings, simulate, simulate_ensemble
from hgo.engine.system import System
from hgo.observers.switched_hgo import switched_hgo
from hgo.plants.dc_motor import dc_motor_plant

T_END, NOISE_DT = 2.0, 0.01


def _observers() -> list:
    """A stiff observer and a slow one (their error controls want different steps)."""
    return [switched_hgo("stiff", alpha1=(71.0, 70.0), eps1=5e-3),
            switched_hgo("slow", alpha1=(3.0, 2.0), eps1=0.2)]


def _open_loop() -> System:
    # the input names the second observer but reads no estimate: the parts are independent
    ctrl = dataclasses.replace(open_loop_controller(1.0, 0.5, 1.0), observer="slow")
    return System(dc_motor_plant(), _observers(), ctrl)


def _noise() -> Noise:
    rng = np.random.default_rng(3)
    return Noise(0.01 * rng.standard_normal((int(T_END / NOISE_DT) + 1, 2)), NOISE_DT)


def _solver(split: bool, method: str = "dop853") -> SolverSettings:
    return SolverSettings(t_end=T_END, dt_out=0.01, method=method, rtol=1e-7, atol=1e-9,
                          split_observers=split)


def test_split_run_is_each_observer_run_alone():
    """Every observer's columns (z, d, x^) and window metrics equal its own run with the
    plant alone, bit for bit; the plant, y and u are the first observer's run; the whole
    (unsplit) run differs (its steps are shared)."""
    system, noise = _open_loop(), _noise()
    split = simulate(system, _solver(True), noise)
    assert split.ok
    whole = simulate(system, _solver(False), noise)
    assert not np.array_equal(split.z, whole.z)
    ctrl = open_loop_controller(1.0, 0.5, 1.0)
    n_xh, n_obs = system.nxh, len(system.observers)
    for k, obs in enumerate(system.observers):
        alone = simulate(System(system.plant, [obs], ctrl), _solver(False), noise)
        (za, zb), (da, db), (xa, xb) = (system.z_slices[k + 1], system.d_slices[k],
                                        system.xh_slices[k])
        np.testing.assert_array_equal(split.z[:, za:zb], alone.z[:, system.plant.nx:])
        np.testing.assert_array_equal(split.d[:, da:db], alone.d)
        np.testing.assert_array_equal(split.xh[:, xa:xb], alone.xh)
        acc = split.acc[np.r_[xa:xb, n_xh + k, n_xh + n_obs + k, n_xh + 2 * n_obs]]
        np.testing.assert_array_equal(acc, alone.acc)
        if k == 0:
            np.testing.assert_array_equal(split.z[:, :system.plant.nx],
                                          alone.z[:, :system.plant.nx])
            np.testing.assert_array_equal(split.y, alone.y)
            np.testing.assert_array_equal(split.u, alone.u)


def test_interrupted_split_run_keeps_the_parts_run_and_leaves_the_others_nan(monkeypatch):
    """A Ctrl-C during the first observer's part (its run returned status 6 after half of
    the output samples): the second part is not run, the merged run is interrupted at the
    first part's stop with its samples, and the second observer's z, d, x^ and metrics are
    NaN, not zeros or another run's values."""
    import hgo.engine.simulate as sim

    system, noise = _open_loop(), _noise()
    full = simulate(system, _solver(True), noise)
    k = len(full.t) // 2
    real, parts_run = sim.simulate, []

    def interrupted_halfway(part_system, *args):
        run = real(part_system, *args)
        parts_run.append(part_system)
        return dataclasses.replace(
            run, t=run.t[:k], z=run.z[:k], d=run.d[:k], y=run.y[:k], m=run.m[:k],
            u=run.u[:k], xh=run.xh[:k], status=sim.INTERRUPTED, t_stop=float(run.t[k - 1]))

    monkeypatch.setattr(sim, "simulate", interrupted_halfway)  # (the parts' calls only)
    split = simulate(system, _solver(True), noise)
    assert len(parts_run) == 1
    assert split.status == sim.INTERRUPTED and split.t_stop == full.t[k - 1]
    np.testing.assert_array_equal(split.t, full.t[:k])
    (za, zb), (da, db), (xa, xb) = system.z_slices[1], system.d_slices[0], system.xh_slices[0]
    first = np.r_[0:system.plant.nx, za:zb]
    np.testing.assert_array_equal(split.z[:, first], full.z[:k, first])
    np.testing.assert_array_equal(split.d[:, da:db], full.d[:k, da:db])
    np.testing.assert_array_equal(split.xh[:, xa:xb], full.xh[:k, xa:xb])
    (za, zb), (da, db), (xa, xb) = system.z_slices[2], system.d_slices[1], system.xh_slices[1]
    assert np.isnan(split.z[:, za:zb]).all() and np.isnan(split.d[:, da:db]).all()
    assert np.isnan(split.xh[:, xa:xb]).all()
    n_xh, n_obs = system.nxh, len(system.observers)
    assert np.isnan(split.acc[np.r_[xa:xb, n_xh + 1, n_xh + n_obs + 1]]).all()


def test_split_ensemble_members_equal_split_single_runs():
    """An ensemble (two initial states) split per observer: each member's metrics and
    recorded states equal its split single run."""
    system, noise = _open_loop(), _noise()
    z0 = np.stack([system.z0(), system.z0() + 0.1])
    params = np.tile(system.params(), (2, 1))
    out = simulate_ensemble(system, _solver(True), noise, params, z0, record=True)
    for i in range(2):
        single = simulate(system, _solver(True), noise, z0=z0[i])
        assert out["status"][i] == 0 and single.ok
        np.testing.assert_array_equal(out["acc"][i], single.acc)
        np.testing.assert_array_equal(out["trajectories"][i].z, single.z)


def test_members_of_an_interrupted_split_ensemble_are_all_marked_interrupted(monkeypatch):
    """A Ctrl-C during the first observer's part of a split ensemble, member 0 stopped
    (status 6) and member 1 already done: the second part runs for no member, so both
    members are interrupted (member 1 was marked ok with the second observer's metrics
    NaN), in the statuses and in the recorded trajectories; the parts that ran keep their
    metrics."""
    import hgo.engine.simulate as sim

    system, noise = _open_loop(), _noise()
    z0 = np.stack([system.z0(), system.z0() + 0.1])
    params = np.tile(system.params(), (2, 1))
    full = simulate_ensemble(system, _solver(True), noise, params, z0, record=True)
    real, parts_run = sim.simulate_ensemble, []

    def member_0_interrupted(part_system, *args, **kwargs):
        out = real(part_system, *args, **kwargs)
        parts_run.append(part_system)
        out["status"][0] = sim.INTERRUPTED
        out["trajectories"][0] = dataclasses.replace(out["trajectories"][0],
                                                     status=sim.INTERRUPTED)
        return out

    monkeypatch.setattr(sim, "simulate_ensemble", member_0_interrupted)  # (the parts only)
    out = simulate_ensemble(system, _solver(True), noise, params, z0, record=True)
    assert len(parts_run) == 1
    assert out["status"].tolist() == [sim.INTERRUPTED] * 2
    assert [tr.status for tr in out["trajectories"]] == [sim.INTERRUPTED] * 2
    xa, xb = system.xh_slices[0]
    n_xh, n_obs = system.nxh, len(system.observers)
    ran = np.r_[xa:xb, n_xh, n_xh + n_obs]
    np.testing.assert_array_equal(out["acc"][:, ran], full["acc"][:, ran])
    xa, xb = system.xh_slices[1]
    assert np.isnan(out["acc"][:, np.r_[xa:xb, n_xh + 1, n_xh + n_obs + 1]]).all()


def test_split_is_refused_when_the_input_reads_an_estimate():
    system = System(dc_motor_plant(), _observers(), dc_motor_speed_controller("slow"))
    with pytest.raises(ConfigError, match="solver.split_observers"):
        simulate(system, _solver(True), _noise())


def test_split_rk4_ensemble_is_refused():
    """RK4 members' step caps are their whole systems' (``rho``), a split run's are the
    parts': refused rather than silently different from the single runs."""
    system = _open_loop()
    with pytest.raises(ConfigError, match="solver.split_observers"):
        simulate_ensemble(system, _solver(True, "rk4"), _noise(), system.params()[None],
                          system.z0()[None])
