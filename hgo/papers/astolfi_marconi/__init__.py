"""Astolfi & Marconi (IEEE TAC 2015): low-power high-gain observer, hgo's measurements.

Not one of the five reproduced papers: the observers are hgo's generic ones
(:mod:`hgo.observers.normal_form`, any plant in observability normal form, the low-power one
checked against the 2015 equations in tests/test_normal_form.py); this package holds what
hgo measures with them on the jerk system, as entries of kind "hgo's measurement" (not
claims of the paper): the gain power, the peak of x^n and the sensitivity of x^n to
measurement noise against ell, and the report of the ``jerk_lowpower`` grid. It sits with
the papers so that a reader finds it where every other ledger entry is (``hgo reproduce``,
README's table, the claims tests), registered by discovery like them.
"""
