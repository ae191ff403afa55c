"""Packaging beyond pyproject.toml: ``conf/`` (the top-level folder of the repository, where
users and Hydra find it in a checkout) ships inside the distribution as ``hgo/conf``, so an
installed wheel finds its configuration (:func:`hgo.core.config.conf_dir`). pyproject.toml's
``packages.find`` cannot add packages from outside ``hgo/``, hence this file. Each folder of
``conf/`` is listed as a (data-only) package so setuptools ships its YAML files without
warning about directories it would otherwise skip."""

from setuptools import find_namespace_packages, setup

CONF = ["hgo.conf", *(f"hgo.conf.{name}" for name in find_namespace_packages(where="conf"))]

setup(
    # namespace-aware: a folder of hgo without __init__.py (hgo/outputs) is shipped too
    packages=[*find_namespace_packages(include=["hgo", "hgo.*"],
                                       exclude=["*.__pycache__", "hgo.conf*"]), *CONF],
    package_dir={"hgo.conf": "conf"},
    package_data={**{name: ["*.yaml"] for name in CONF},
                  "hgo.reproduce": ["templates/*.j2"]},  # the report's Jinja2 templates
)
