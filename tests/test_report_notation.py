"""The report shows the papers' notation and no Markdown (hgo.reproduce.notation)."""

from __future__ import annotations

import pytest

from hgo.reproduce.notation import math_names, plain
from hgo.reproduce.report import bound_verdict, deciding, first_sentence


@pytest.mark.parametrize("ascii_text, shown", [
    ("theta^1 within 1 %", "θ̂₁ within 1 %"),
    ("RMS theta~1/theta1 on W", "RMS θ̃₁/θ₁ on W"),
    ("rate<=Omega2", "rate≤Ω₂"),
    ("average <x^2>", "average ⟨x̂₂⟩"),
    ("R^2 (23)", "R² (23)"),
    ("[3 sigma^2/4 - 2, inf]", "[3 σ²/4 - 2, ∞]"),  # a power, not an estimate
    ("inf over all gains", "inf over all gains"),  # an infimum, not infinity
    ("K1^a and eps_max", "K₁ᵃ and ε_max"),
    ("max |e2| over [0, 0.5] s, fixed_eps2", "max |e₂| over [0, 0.5] s, fixed_eps2"),
    ("mean df2/dx2 (hbar_o)", "mean ∂f₂/∂x₂ (h̄ₒ)"),
    ("the theory of the observer", "the theory of the observer"),
])
def test_ascii_names_are_shown_in_the_papers_notation(ascii_text, shown):
    assert math_names(ascii_text) == shown


def test_markdown_is_removed_from_plain_text():
    assert plain("Moreno, *Observer design* with `code`") == "Moreno, Observer design with code"
    assert plain("a * b * c") == "a * b * c"  # products are not emphasis


def test_a_bound_against_an_exact_zero_a_vacuous_one_or_itself_never_holds():
    assert bound_verdict(0.0, 3.98e5) == "metric is 0"
    assert bound_verdict(2e-7, 3.98e5) == "vacuous"
    assert bound_verdict(0.5, 1.0) == "✓" and bound_verdict(2.0, 1.0) == "✗"
    assert bound_verdict(1.0, 1.0) == "equals the bound"  # e.g. V / (e^-eta V(0)) at t = 0


def test_a_claim_shows_its_first_sentence_and_a_few_numbers():
    assert first_sentence("The parameters of Fig. 2 satisfy (13). More.") == (
        "The parameters of Fig. 2 satisfy (13).")
    numbers = [(f"quantity {k}", "1.234") for k in range(9)]
    assert len(deciding(numbers)) == 5
    assert len(deciding([("a very long name " * 30, "1")] * 3)) == 1
