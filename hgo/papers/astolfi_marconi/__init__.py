"""Astolfi & Marconi (IEEE TAC 2015): low-power high-gain observer, peaking on the jerk system.

Not one of the five reproduced papers: the observers are hgo's generic ones
(:mod:`hgo.observers.normal_form`, any plant in observability normal form); this package
holds what is measured with them on the jerk system (``experiment=jerk_lowpower``): the
peaking exponents as a claim, and the report of the grid. It sits with the papers so that a
reader finds it where every other claim is (``hgo reproduce``, README's table, the claims
tests), registered by discovery like them.
"""
