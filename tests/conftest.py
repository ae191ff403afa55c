"""Shared helpers: compose the project's Hydra config and run it into a temporary folder."""

from __future__ import annotations

import pytest

from hgo.core.config import compose as compose_config
from hgo.core.config import conf_dir

CONF_DIR = str(conf_dir())


@pytest.fixture
def compose():
    return compose_config
