"""hgo.cli.compose_once: a single run's config composed once is the config Hydra composes
twice (get_mode, then run), and what Hydra refuses it still refuses."""

from __future__ import annotations

import pytest
from hydra import initialize_config_dir
from hydra._internal.config_loader_impl import ConfigLoaderImpl
from hydra.core.global_hydra import GlobalHydra
from hydra.errors import ConfigCompositionException
from hydra.types import RunMode
from omegaconf import OmegaConf

from hgo.cli.compose_once import composed_once
from hgo.core.config import conf_dir, register_configs


def _single_run(overrides: list[str]):
    """What Hydra's _run_hydra and _run_app do for a command line without -m: the mode,
    then the run's composition (with hydra.mode=RUN added when the config sets none)."""
    hydra = GlobalHydra.instance().hydra
    overrides = list(overrides)
    mode = hydra.get_mode(config_name="config", overrides=overrides)
    if mode is None:
        overrides.append("hydra.mode=RUN")
    if mode == RunMode.MULTIRUN:
        return mode, None
    return mode, hydra.compose_config("config", overrides, run_mode=RunMode.RUN,
                                      with_log_configuration=True)


@pytest.fixture
def hydra_app():
    register_configs()
    GlobalHydra.instance().clear()
    with initialize_config_dir(version_base="1.3", config_dir=str(conf_dir())):
        yield
    GlobalHydra.instance().clear()


@pytest.fixture
def count_compositions(monkeypatch):
    calls = []
    load = ConfigLoaderImpl.load_configuration

    def counted(self, *args, **kwargs):
        calls.append(kwargs.get("run_mode"))
        return load(self, *args, **kwargs)

    monkeypatch.setattr(ConfigLoaderImpl, "load_configuration", counted)
    return calls


@pytest.mark.parametrize("overrides", [
    [], ["experiment=sp_fig1"], ["experiment=dhlm_example", "solver.t_end=2"],
    ["experiment=moreno_fig1", "hydra.run.dir=/tmp/somewhere", "seed=3"],
    ["experiment=apa_fig2", "figures={}", "+tags=[a,b]"],
])
def test_a_single_run_is_composed_once_into_the_config_hydra_composes_twice(
        hydra_app, count_compositions, overrides):
    mode, hydras = _single_run(overrides)
    assert len(count_compositions) == 2
    with composed_once():
        mode_once, once = _single_run(overrides)
    assert len(count_compositions) == 3
    assert mode_once == mode
    assert OmegaConf.to_container(once) == OmegaConf.to_container(hydras)
    assert once.hydra.mode == RunMode.RUN


def test_a_sweep_override_without_multirun_is_refused_as_hydra_refuses_it(hydra_app):
    with pytest.raises(ConfigCompositionException) as hydras:
        _single_run(["experiment=sp_fig1", "observer.eps=0.1,0.2"])
    with composed_once(), pytest.raises(ConfigCompositionException) as once:
        _single_run(["experiment=sp_fig1", "observer.eps=0.1,0.2"])
    assert str(once.value) == str(hydras.value)
    assert "Ambiguous value" in str(once.value)


def test_a_config_that_asks_for_multirun_and_a_composition_error_take_hydras_path(
        hydra_app, count_compositions):
    with composed_once():
        assert _single_run(["hydra.mode=MULTIRUN"]) == (RunMode.MULTIRUN, None)
        with pytest.raises(ConfigCompositionException, match="no_such_plant"):
            _single_run(["plant=no_such_plant"])
    # the mode read by RUN rules, and after the error Hydra's get_mode and run compose
    assert count_compositions == [RunMode.RUN, RunMode.RUN, RunMode.MULTIRUN, RunMode.RUN]
