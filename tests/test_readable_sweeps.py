"""Sweeps read at a glance (issue 44, item 4): the summary has one column per swept key,
never cut; each recording is named by its overrides; the viewer's default layout groups
each state with its estimates and error, and x is drawn unlike x^."""

from __future__ import annotations

import json

import pytest

from hgo.running.aggregate import sweep_summary
from hgo.running.viewer_layout import OBSERVER_COLORS, STATE_COLOR, recording_name, short_key

LONG = "observer.a_rather_long_observer_name.eps"


def test_summary_has_one_column_per_swept_key_never_cut(tmp_path):
    """Two swept keys, one of 38 characters and values of 20: the header names both, every
    row shows both values whole; a key every job shares is no column."""
    for k, (eps, std) in enumerate([(0.01, "1e-3"), (0.02, "1e-3"), (0.01, "1e-2")]):
        job = tmp_path / f"job{k}"
        (job / ".hydra").mkdir(parents=True)
        eps_text = f"{eps}000000000000000001"
        (job / ".hydra" / "overrides.yaml").write_text(
            f"- {LONG}={eps_text}\n- noise.std={std}\n- solver.t_end=4\n")
        (job / "run.json").write_text(json.dumps({"status": "ok",
                                                  "metrics": {"a/max_error": 0.5 + k}}))
    lines = sweep_summary(tmp_path).splitlines()
    assert lines[0] == f"sweep: 3 jobs in {tmp_path}: 3 ok"
    assert lines[1].split() == ["job", LONG, "noise.std", "status", "a/max_error"]
    assert lines[2].split() == ["job0", "0.01000000000000000001", "1e-3", "ok", "0.5"]
    assert lines[4].split() == ["job2", "0.01000000000000000001", "1e-2", "ok", "2.5"]
    assert "solver.t_end" not in lines[1]
    # the columns line up: each value starts where its header does
    assert lines[1].index("noise.std") == lines[2].index("1e-3")


def test_recording_name_is_the_overrides_without_the_preset(compose):
    cfg = compose(["experiment=vdp_hgo", "observer.standard.eps=0.01", "noise.std=1e-3"])
    assert recording_name(cfg, "job3") == "standard.eps=0.01 noise.std=1e-3"
    assert recording_name(compose(["experiment=vdp_hgo"]), "job3") == "job3"
    assert short_key("+observer.x.p2") == "x.p2" and short_key("seed") == "seed"


@pytest.fixture(scope="module")
def vdp_run(tmp_path_factory):
    """One short run of vdp_hgo written to a folder (its kernel: the tutorial's)."""
    from hgo.core.config import compose
    from hgo.running.runner import run

    out = tmp_path_factory.mktemp("vdp")
    cfg = compose(["experiment=vdp_hgo", "solver.t_end=1", "metrics.window=0.5",
                   "observer.standard.eps=0.02"], out_dir=out)
    return out, run(cfg, out)


def test_recording_is_named_by_its_overrides_and_colours_x_unlike_xhat(vdp_run):
    from hgo.outputs.recording import read_static

    out, _ = vdp_run
    rrd = out / "recording.rrd"
    assert read_static(rrd, "/__properties", "RecordingInfo:name") == [
        "solver.t_end=1 metrics.window=0.5 standard.eps=0.02"]

    def rgba(rgb):
        return (rgb[0] << 24) | (rgb[1] << 16) | (rgb[2] << 8) | 255

    assert read_static(rrd, "/plant/x", "SeriesLines:colors") == [rgba(STATE_COLOR)] * 2
    for entity in ("/observer/standard/xhat", "/error/standard"):
        assert read_static(rrd, entity, "SeriesLines:colors") == [rgba(OBSERVER_COLORS[0])] * 2
    assert read_static(rrd, "/plant/x", "SeriesLines:widths") == [3.0, 3.0]


def test_default_layout_groups_each_state_with_its_estimates_and_error(vdp_run):
    from hgo.running.viewer_layout import state_groups

    _, result = vdp_run
    groups = state_groups(result.experiment.system, result.series)
    assert groups == [
        ("x1 and its estimates", {"/plant/x": "x1", "/observer/standard/xhat": "x1_hat"}),
        ("estimation error of x1", {"/error/standard": "e_x1"}),
        ("x2 and its estimates", {"/plant/x": "x2", "/observer/standard/xhat": "x2_hat"}),
        ("estimation error of x2", {"/error/standard": "e_x2"})]
