"""Tests for hgo.outputs.recording: columnar Rerun logging and reading it back."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
import rerun.blueprint as rrb

from hgo.outputs.recording import (
    Series,
    read_arrays,
    read_recording,
    time_series_blueprint,
    write_recording,
)

N = 10_000


def _run(n: int = N) -> tuple[np.ndarray, list[Series]]:
    rng = np.random.default_rng(0)
    t = np.linspace(0.0, 10.0, n)
    series = [
        Series("/plant/x", ["x1", "x2", "x3"], rng.standard_normal((n, 3))),
        Series("/observer/sp6/xhat", ["xhat1", "xhat2"], rng.standard_normal((n, 2))),
    ]
    return t, series


def test_round_trip(tmp_path: Path) -> None:
    t, series = _run()
    path = write_recording(tmp_path / "run.rrd", t, series, recording_id="rt_1")
    back = read_arrays(path)
    assert set(back) == {"sim_time", "/plant/x", "/observer/sp6/xhat"}
    np.testing.assert_array_equal(np.round(back["sim_time"] * 1e9), np.round(t * 1e9))
    np.testing.assert_allclose(back["sim_time"], t, rtol=0, atol=1e-9)
    for s in series:
        np.testing.assert_array_equal(back[s.entity], s.values)


def test_file_complete_on_return(tmp_path: Path) -> None:
    t, series = _run(100)
    path = write_recording(
        tmp_path / "sub" / "run.rrd",
        t,
        series,
        recording_id="done",
        text={"/run/status": "failed at t=3.2 s: non-finite state"},
    )
    assert path.is_file() and path.stat().st_size > 0
    assert read_arrays(path)["/plant/x"].shape == (100, 3)


def test_overwrite_and_nan_kept(tmp_path: Path) -> None:
    t, series = _run(50)
    path = tmp_path / "run.rrd"
    write_recording(path, t, series, recording_id="first")
    values = series[0].values.copy()
    values[20:] = np.nan
    write_recording(path, t, [Series("/plant/x", ["x1", "x2", "x3"], values)], recording_id="b")
    back = read_arrays(path)
    assert set(back) == {"sim_time", "/plant/x"}
    np.testing.assert_array_equal(back["/plant/x"], values)


@pytest.mark.parametrize("bad_id", ["has space", "a/b", "", "ü"])
def test_bad_recording_id(tmp_path: Path, bad_id: str) -> None:
    t, series = _run(10)
    with pytest.raises(ValueError, match=f"recording_id {bad_id!r}"):
        write_recording(tmp_path / "x.rrd", t, series, recording_id=bad_id)
    assert not (tmp_path / "x.rrd").exists()


def test_shape_mismatch_names_entity(tmp_path: Path) -> None:
    t, series = _run(10)
    short = Series("/error/sp6", ["e1", "e2"], np.zeros((7, 2)))
    with pytest.raises(ValueError, match="/error/sp6.*stopped early"):
        write_recording(tmp_path / "x.rrd", t, [*series, short], recording_id="r")
    wrong_cols = Series("/input/u", ["u"], np.zeros((10, 2)))
    with pytest.raises(ValueError, match="/input/u"):
        write_recording(tmp_path / "x.rrd", t, [wrong_cols], recording_id="r")


def test_early_stop_with_sliced_t(tmp_path: Path) -> None:
    t, _ = _run(10)
    y = Series("/measurement/y", ["y"], np.arange(6.0)[:, None])
    back = read_arrays(write_recording(tmp_path / "x.rrd", t[:6], [y], recording_id="r"))
    np.testing.assert_array_equal(back["/measurement/y"], y.values)


def test_bad_time_grid(tmp_path: Path) -> None:
    with pytest.raises(ValueError, match="strictly increasing"):
        write_recording(tmp_path / "x.rrd", np.array([0.0, 1.0, 1.0]), [], recording_id="r")


def test_blueprint_accepted(tmp_path: Path) -> None:
    t, series = _run(100)
    bp = time_series_blueprint(
        {
            "state": ["/plant/x", "/observer/**"],
            "aux": ["/observer/**/r", "-/observer/sp6/xhat"],
        },
        entities=["/plant/x", "/observer/sp6/r", "/observer/sp4/r", "/observer/sp6/xhat"],
    )
    assert isinstance(bp, rrb.Blueprint)
    path = write_recording(tmp_path / "bp.rrd", t, series, recording_id="bp", blueprint=bp)
    np.testing.assert_array_equal(read_arrays(path)["/plant/x"], series[0].values)


def test_inner_wildcard_needs_entities() -> None:
    with pytest.raises(ValueError, match="/observer/\\*\\*/r"):
        time_series_blueprint({"aux": ["/observer/**/r"]})


def test_rerun_off_writes_nothing(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setenv("RERUN", "off")
    t, series = _run(10)
    with pytest.warns(RuntimeWarning, match="disabled"):
        path = write_recording(tmp_path / "off.rrd", t, series, recording_id="off")
    assert not path.exists()


def test_inner_wildcard_expansion() -> None:
    from hgo.outputs.recording import _view_contents

    entities = ["/observer/sp6/r", "/observer/a/b/r", "/observer/sp6/xhat", "/error/sp6"]
    got = _view_contents(["/observer/**/r", "-/error/sp*", "/plant/**"], entities, "v")
    assert got == ["+ /observer/sp6/r", "+ /observer/a/b/r", "- /error/sp6", "+ /plant/**"]


def test_zero_samples(tmp_path: Path) -> None:
    empty = Series("/plant/x", ["x1"], np.zeros((0, 1)))
    path = write_recording(
        tmp_path / "e.rrd", np.zeros(0), [empty], recording_id="e", text={"/run/status": "failed"}
    )
    back = read_arrays(path)
    assert set(back) == {"sim_time"} and back["sim_time"].shape == (0,)


def test_blocks_and_strided_values(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """Several send_columns blocks (last one partial), column slices of a wider array."""
    import hgo.outputs.recording as recording

    monkeypatch.setattr(recording, "CHUNK_ROWS", 4)
    n = 11
    z = np.random.default_rng(1).standard_normal((n, 5))
    t = np.linspace(0.0, 1.0, n)
    series = [
        Series("/plant/x", ["x1", "x2"], z[:, ::2][:, :2]),  # strided, not contiguous
        Series("/input/u", ["u"], z[:, 4:5]),
        Series("/measurement/y", ["y1", "y2", "y3"], z[:, 1:4]),
    ]
    back = read_arrays(write_recording(tmp_path / "b.rrd", t, series, recording_id="blk"))
    np.testing.assert_allclose(back["sim_time"], t, rtol=0, atol=1e-9)
    for s in series:
        np.testing.assert_array_equal(back[s.entity], s.values)


def test_read_recording_gives_the_series_names_as_columns_indexed_by_sim_time(tmp_path):
    """The user-facing reader: one column per logged series name, ``sim_time`` index,
    the same values as :func:`read_arrays`."""
    t = np.linspace(0.0, 1.0, 11)
    x = Series("/plant/x", ["x1", "x2"], np.column_stack([np.sin(t), np.cos(t)]))
    path = write_recording(tmp_path / "n.rrd", t, [x], recording_id="names")
    df = read_recording(path)
    assert df.index.name == "sim_time"
    np.testing.assert_allclose(df.index.to_numpy(), t, rtol=0, atol=1e-9)  # ns timeline
    assert list(df.columns) == ["/plant/x/x1", "/plant/x/x2"]
    np.testing.assert_array_equal(df.to_numpy(), read_arrays(path)["/plant/x"])


def test_a_run_without_recording_never_imports_rerun(tmp_path: Path) -> None:
    """``hgo run`` of sp_fig1 over 6 s with ``recording.mode=off`` and its figure dropped:
    complete, no recording file, and the run's process has not imported Rerun (its
    blueprint, ~0.4 s of imports, is built only for a recording)."""
    import os
    import subprocess
    import sys
    import textwrap

    script = textwrap.dedent('''
        import sys
        from hgo.cli import main
        try:
            main(["run", *sys.argv[1:]])
        finally:
            print("rerun imported:", "rerun" in sys.modules)
    ''')
    out = tmp_path / "run"
    env = {k: v for k, v in os.environ.items() if k != "HYDRA_FULL_ERROR"}
    proc = subprocess.run([sys.executable, "-c", script, "experiment=sp_fig1", "solver.t_end=6",
                           "metrics.window=2", "figures.fig1=null", "recording.mode=off",
                           f"hydra.run.dir={out}"], cwd=tmp_path, env=env,
                          capture_output=True, text=True, timeout=300)
    assert proc.returncode == 0, proc.stderr[-2000:]
    assert "rerun imported: False" in proc.stdout
    assert (out / ".hgo_done").is_file() and not (out / "recording.rrd").exists()
