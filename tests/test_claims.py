"""Every claim of the registry (:mod:`hgo.core.registry`) as one test.

A claim passes when its function measures that the statement holds. A ``not reproduced``
claim is an xfail whose reason is the measured numbers, and strict: it fails the suite if
it starts to hold (its declared verdict is then wrong).
"""

from __future__ import annotations

import pytest

from hgo.core.registry import NOT_REPRODUCED, Claim, all_claims


def _param(c: Claim):
    return pytest.param(c, id=c.key, marks=[pytest.mark.slow] if c.slow else [])


@pytest.mark.parametrize("claim", [_param(c) for c in all_claims()])
def test_claim(claim: Claim):
    """The claim's measurement agrees with its declared verdict; the numbers are printed."""
    measured = claim.check()
    print(f"{claim.key} ({claim.verdict}): {measured.describe()}")
    if claim.verdict == NOT_REPRODUCED:
        assert not measured.holds, (f"{claim.key} is declared not reproduced but holds: "
                                    f"{measured.describe()}")
        pytest.xfail(f"{claim.key} not reproduced: {measured.describe()}")
    assert measured.holds, f"{claim.key}: {claim.statement} -- measured {measured.describe()}"
