"""What a run tells its user (issue 44, item 6): the console table keeps the notes, the end
of a run lists what it wrote and how to look at it, a compile says what it compiles, and a
numba failure names the function it failed on with numba's first error line."""

from __future__ import annotations

import json
import logging

import numba
import pandas as pd
import pytest

from hgo.engine.simulate import numba_failure
from hgo.outputs.console import compact_table, outputs_listing


def _table(notes: list[str] | None) -> pd.DataFrame:
    data = {"observer": ["a", "a", "b"], "quantity": ["q1", "q2", "q3"],
            "empirical": [1.0, 2.0, 3.0], "bound": [float("nan")] * 3,
            "ratio": [float("nan")] * 3}
    if notes is not None:
        data["note"] = notes
    return pd.DataFrame(data)


def test_console_table_marks_rows_with_notes_and_prints_them_whole():
    long = "bound (15) of Sanfelice & Praly, valid only when (13) holds at s = s_min " * 2
    text = compact_table(_table(["short note", None, long]))
    lines = text.splitlines()
    assert "q1 [1]" in lines[2] and "[" not in lines[3] and "q3 [2]" in lines[4]
    assert lines[5:7] == ["notes:", "  [1] short note"]
    assert " ".join(ln.strip() for ln in lines[7:]) == f"[2] {long.strip()}"  # whole
    assert all(len(ln) <= 100 for ln in lines) and lines[8].startswith("      Sanfelice")
    assert "notes:" not in compact_table(_table(None))


def test_end_of_run_lists_what_it_wrote_and_how_to_look_at_it(tmp_path):
    for name, size in (("fig1.png", 2048), ("recording.rrd", 3 * 1024 ** 2),
                       ("metrics.csv", 100), ("run.json", 10)):
        (tmp_path / name).write_bytes(b"x" * size)
    lines = outputs_listing(tmp_path)
    assert lines == ["wrote:", "  figures    fig1.png",
                     "  recording  recording.rrd (3.0 MB)", "  metrics    metrics.csv (100 B)",
                     "  provenance run.json (10 B)",
                     f"view:  hgo view {tmp_path}   (no display: --web)"]
    (tmp_path / "fig1.png").unlink()  # no figure: the command that draws the default one
    assert outputs_listing(tmp_path)[-1] == (f"plot:  hgo plot {tmp_path}   (states, "
                                             "estimates and errors)")


def test_a_compile_says_what_it_compiles(caplog):
    from numba.core.event import end_event, start_event

    from hgo.running.progress import compile_progress

    with caplog.at_level(logging.INFO, logger="hgo.running.progress"), \
            compile_progress("dop853", "the kernel of plant vdp with observers std"):
        for _ in range(2):  # said once
            start_event("numba:compile")
            end_event("numba:compile")
    said = [r.getMessage() for r in caplog.records if "compiling" in r.getMessage()]
    assert len(said) == 1
    assert said[0].startswith("compiling the kernel of plant vdp with observers std with "
                              "dop853 (once: later runs load it from the kernel cache")


def _integrate():
    """Stands for a generated integrator's ``integrate`` in a compile event."""


def test_the_composition_and_the_integrator_each_have_their_own_compile_time(
        caplog, monkeypatch, tmp_path):
    """A composition compiled with its integrator: one line for each (the integrator's
    names its size), and each part's time kept under its own key; the next compile of a
    composition alone quotes the composition's last time, not the integrator's."""
    import time
    import types

    from numba.core.event import end_event, start_event

    from hgo.running.progress import compile_progress

    monkeypatch.setenv("HGO_CACHE_DIR", str(tmp_path))
    module = {"__name__": "hgo_integrator_0123", "NZ": 6}
    integrator = types.SimpleNamespace(py_func=types.FunctionType(_integrate.__code__, module))

    def compile_for(seconds: float, dispatcher=None) -> None:
        start_event("numba:compile", data={"dispatcher": dispatcher})
        time.sleep(seconds)
        end_event("numba:compile", data={"dispatcher": dispatcher})

    what = "the kernel of plant vdp with observers std"
    with caplog.at_level(logging.INFO, logger="hgo.running.progress"):
        with compile_progress("dop853", what):
            compile_for(0.3)
            compile_for(0.6, integrator)
        said = [r.getMessage() for r in caplog.records]
        assert [line.split(" (once")[0] for line in said] == [
            f"compiling {what} with dop853", "compiling the integrator for 6 states with dop853"]
        times = json.loads((tmp_path / "compile_seconds.json").read_text())
        assert 0.3 <= times["dop853 composition"] < 0.6 <= times["dop853 integrator"]
        caplog.clear()
        with compile_progress("dop853", what):
            compile_for(0.3)
        said = caplog.records[0].getMessage()
        assert said.endswith(f"about {times['dop853 composition']:.1f} s last time)"), said


class _Gains:
    mu = 1.0


GAINS = _Gains()


def _helper(x):
    return GAINS.mu * x  # a Python object: numba cannot type it


def _model(x):
    return _helper(x) + 1.0


def test_numba_failure_names_the_function_and_numbas_first_error_line():
    """A real numba error (a model calling a helper numba cannot compile): the line names
    the helper's caller, its file and line, and numba's reason."""
    with pytest.raises(numba.core.errors.TypingError) as caught:
        numba.njit(_model)(1.0)
    line = numba_failure(str(caught.value))
    assert line.startswith("_model (") and "test_run_messages.py, line " in line, line
    assert line.endswith("Untyped global name '_helper': Cannot determine Numba type of "
                         "<class 'function'>"), line
    assert "\x1b" not in line and "\n" not in line
