"""The package of the modules generated from plants' equations
(:mod:`hgo.plants.symbolic_source`): its path is the kernel cache folder, so a generated
function (a plant's ``f``, an observer's model) is importable, and pickles by reference,
in any process that uses the same cache (a figure process, an ensemble's worker)."""

from hgo.engine.codegen import cache_dir

__path__.append(str(cache_dir()))  # noqa: F821 - a package's own __path__
