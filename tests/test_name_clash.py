"""A model's parameters and an observer's own share one record ``p``: a clash is refused in
one line naming both keys and the reserved names (issue 44, item 3)."""

from __future__ import annotations

import pytest

import hgo
from hgo.core.errors import ConfigError
from hgo.observers.normal_form import lowpower_hgo, standard_hgo


@pytest.mark.parametrize(("factory", "name", "own"), [
    (standard_hgo, "alpha", "the Hurwitz coefficients"),
    (standard_hgo, "eps", "the gain parameter"),
    (lowpower_hgo, "K", "the block gains"),
    (lowpower_hgo, "n", "the order"),
])
def test_a_model_parameter_named_like_the_observers_own_is_one_line(factory, name, own):
    with pytest.raises(ConfigError) as caught:
        factory("obs", 2, eps=0.01, model_params={"mu": 1.0, name: 0.5})
    text = str(caught.value)
    assert text.startswith(f"observer.obs.model_params.{name}: '{name}' is the component's "
                           f"own parameter (observer.obs -> p.{name}: {own}")
    assert "(allowed: any name but " in text and "phi0, sat_level, saturate" in text
    assert "\n" not in text


def test_a_numpy_attribute_name_is_refused_too():
    with pytest.raises(ConfigError, match=r"^observer.obs.model_params.mean: 'mean' is an "
                                          r"attribute of numpy arrays"):
        standard_hgo("obs", 2, eps=0.01, model_params={"mean": 1.0})


def test_the_clash_from_a_config_is_the_same_line():
    """``hgo.run`` of the Van der Pol preset with the textbook name ``alpha`` in the
    observer's model: HgoError with the one line, before anything compiles."""
    with pytest.raises(hgo.HgoError) as caught:
        hgo.run(["experiment=vdp_hgo", "+observer.standard.model_params.alpha=1.0"])
    assert str(caught.value).startswith("observer.standard.model_params.alpha: 'alpha' is "
                                        "the component's own parameter")
