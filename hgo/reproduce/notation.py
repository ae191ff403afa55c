"""The papers' notation in plain text: ``theta^1`` -> θ̂₁, ``Omega2`` -> Ω₂, ``eps`` -> ε.

Claim statements, measured numbers and captions are written in ASCII in the code (they are
also log lines and CSV columns); the report shows them as the papers write them, in
Unicode, so a browser needs no math renderer and the page stays self-contained. Only
whole symbols are rewritten: ``fixed_eps2`` (a configuration name) or ``theory`` stay.
"""

from __future__ import annotations

import re

SUB = str.maketrans("0123456789", "₀₁₂₃₄₅₆₇₈₉")
SUP = str.maketrans("0123456789-", "⁰¹²³⁴⁵⁶⁷⁸⁹⁻")
# x^1, theta^2, eta^2: estimates in the code's ASCII (a hat), as in the papers; any other
# base with ^digit is a power (sigma^2, s^2, z^2)
ESTIMATED = ("x", "theta", "eta")
HAT, TILDE, BAR = "\u0302", "\u0303", "\u0304"
GREEK = {"theta": "θ", "Theta": "Θ", "Omega": "Ω", "omega": "Ω", "eta": "η", "eps": "ε",
         "epsilon": "ε", "mu": "μ", "sigma": "σ", "delta": "δ", "Delta": "Δ", "rho": "ρ",
         "varrho": "ϱ", "kappa": "κ", "phi": "φ", "nu": "ν", "gamma": "γ", "alpha": "α",
         "beta": "β", "tau": "τ", "lambda": "λ", "xi": "ξ", "psi": "ψ"}
_NAMES = "|".join(sorted(GREEK, key=len, reverse=True))
_LETTERS = r"(?<![A-Za-z_\\])"  # a symbol starts after no letter or underscore ...
_END = r"(?![A-Za-z_])"  # ... and ends before none


def _base(name: str) -> str:
    return GREEK.get(name, name)


def _sub(digits: str) -> str:
    return digits.translate(SUB)


_RULES: list[tuple[re.Pattern, object]] = [
    (re.compile(r"([A-Za-z])_\{([^}]*)\}"), lambda m: f"{m[1]}{_sub(m[2])}"),  # B_{1,o}
    (re.compile(r"\bR\^2\b"), "R²"),  # R^2 (23) of Dimassi et al., not an estimate
    (re.compile(rf"{_LETTERS}([A-Za-z])\^(\d)f{_END}"),  # x^2f: a filtered estimate
     lambda m: f"{m[1]}{HAT}{_sub(m[2])}f"),
    (re.compile(rf"{_LETTERS}([a-z])\^(?![\w({{])"), lambda m: f"{m[1]}{HAT}"),  # y^
    (re.compile(r"\+-"), "±"),
    (re.compile(r"<\s*([A-Za-z]+)\^(\d*)\s*>"),  # <x^2>: the average of the estimates
     lambda m: f"⟨{_base(m[1])}{HAT}{_sub(m[2])}⟩"),
    (re.compile(rf"{_LETTERS}({'|'.join(ESTIMATED)})\^_?(\d+){_END}"),  # estimates
     lambda m: f"{_base(m[1])}{HAT}{_sub(m[2])}"),
    (re.compile(r"([A-Za-z)])\^(-?\d+)(?![\d.])"), lambda m: f"{m[1]}{m[2].translate(SUP)}"),
    (re.compile(rf"{_LETTERS}({_NAMES}|[A-Za-z])~_?(\d*){_END}"),  # theta~1, K~1: errors
     lambda m: f"{_base(m[1])}{TILDE}{_sub(m[2])}"),
    (re.compile(rf"{_LETTERS}z_h(\d+){_END}"), lambda m: f"z{HAT}{_sub(m[1])}"),  # z_h12
    (re.compile(rf"{_LETTERS}K(\d)\^?a{_END}"), lambda m: f"K{_sub(m[1])}ᵃ"),  # K1^a, K1a
    (re.compile(r"\bdf(\d)/dx(\d)\b"), lambda m: f"∂f{_sub(m[1])}/∂x{_sub(m[2])}"),
    (re.compile(rf"{_LETTERS}df(\d)max{_END}"), lambda m: f"df{_sub(m[1])},max"),
    (re.compile(rf"{_LETTERS}eps_max{_END}"), lambda m: "ε_max"),
    (re.compile(rf"{_LETTERS}hbar(_o)?{_END}"), lambda m: f"h{BAR}" + ("ₒ" if m[1] else "")),
    (re.compile(rf"{_LETTERS}({_NAMES})_?(\d*){_END}"),  # Omega2, eps1, sigma
     lambda m: f"{GREEK[m[1]]}{_sub(m[2])}"),
    (re.compile(rf"{_LETTERS}([xyezpKlLcbBr])_?(\d{{1,2}})(?![\w.])"),  # x1, e2, p2, l1, z12
     lambda m: f"{m[1]}{_sub(m[2])}"),
    (re.compile(rf"{_LETTERS}z_?(\d{{2}}){_END}"), lambda m: f"z{_sub(m[1])}"),
    (re.compile(r"\^2\b"), "²"),
    (re.compile(r"\bsqrt\((\w+)\)"), r"√\1"),
    (re.compile(r"<="), "≤"),
    (re.compile(r">="), "≥"),
    (re.compile(r"!="), "≠"),
    (re.compile(r"(?<=[,\s-])inf(?=\s*[\])])"), "∞"),  # [1, inf]; not "inf over ..."
    (re.compile(r"M_inf|M∞"), "M∞"),
]


def math_names(text: str) -> str:
    """``text`` with the ASCII names of the papers' symbols in their notation (module
    docstring): ``theta^1`` θ̂₁, ``theta~1`` θ̃₁, ``Omega2`` Ω₂, ``eps`` ε, ``x1`` x₁,
    ``<x^2>`` ⟨x̂₂⟩, ``K1^a`` K₁ᵃ, ``df2/dx2`` ∂f₂/∂x₂, ``<=`` ≤."""
    for pattern, replacement in _RULES:
        text = pattern.sub(replacement, text)
    return text


_EMPHASIS = re.compile(r"(?<![\w*])\*(?!\s)([^*\n]+?)(?<!\s)\*(?![\w*])")
_CODE = re.compile(r"`([^`\n]+)`")


def plain(text: str) -> str:
    """``text`` without inline Markdown (``*title*``, ```code```): for places that show
    text as it is (HTML escapes it, a title is not Markdown)."""
    return _CODE.sub(r"\1", _EMPHASIS.sub(r"\1", text))
