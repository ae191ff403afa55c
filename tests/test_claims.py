"""Every claim of the registry (:mod:`hgo.claims`) as one test.

A claim passes when its function measures that the statement holds; a ``not
reproduced`` claim is a strict xfail (it fails the suite if it starts to hold) whose
reason is the measured numbers.
"""

from __future__ import annotations

import pytest

from hgo.claims import NOT_REPRODUCED, Claim, all_claims


def _param(c: Claim):
    marks = [pytest.mark.slow] if c.slow else []
    if c.verdict == NOT_REPRODUCED:
        marks.append(pytest.mark.xfail(strict=True, reason=f"{c.key}: not reproduced"))
    return pytest.param(c, id=c.key, marks=marks)


@pytest.mark.parametrize("claim", [_param(c) for c in all_claims()])
def test_claim(claim: Claim):
    """The claim's measurement agrees with its declared verdict; the numbers are printed."""
    measured = claim.check()
    print(f"{claim.key} ({claim.verdict}): {measured.describe()}")
    assert measured.holds, f"{claim.key}: {claim.statement} -- measured {measured.describe()}"
