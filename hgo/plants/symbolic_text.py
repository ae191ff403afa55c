"""Expression text of a plant given by its equations, read without ``eval`` (issue 42).

A config writes ``f.x2: "c*x1*x2 - d*x2"``. The text is first checked token by token
(Python's tokenizer): numbers, the operators ``+ - * / ** ^ ( ) ,``, the declared names
(states, inputs, parameters) and the functions and constants of :data:`FUNCTIONS` and
:data:`CONSTANTS`; anything else (an attribute, a string, a bracket, an unknown name) is
refused in one line naming the key and the token,

    plant.f.x2: unknown name 'dd' (declared: a, b, c, d, x1, x2, u)

Only then does SymPy's ``parse_expr`` build the expression, with a local dictionary of the
declared symbols and a global dictionary of the whitelisted functions and SymPy's number
classes only (no builtins), and no automatic symbols.
"""

from __future__ import annotations

import io
import keyword
import numbers
import tokenize
from collections.abc import Mapping, Sequence

import sympy as sp
from sympy.parsing.sympy_parser import auto_number, convert_xor, parse_expr

from hgo.core.errors import ConfigError

FUNCTIONS = {
    "sin": sp.sin, "cos": sp.cos, "tan": sp.tan, "exp": sp.exp, "log": sp.log,
    "sqrt": sp.sqrt, "tanh": sp.tanh, "sinh": sp.sinh, "cosh": sp.cosh, "atan": sp.atan,
    "asin": sp.asin, "acos": sp.acos, "atan2": sp.atan2, "abs": sp.Abs, "sign": sp.sign,
    "min": sp.Min, "max": sp.Max,
}
"""The functions an expression may call (each prints as a ``math`` call numba compiles)."""
CONSTANTS = {"pi": sp.pi}
OPERATORS = {"+", "-", "*", "/", "**", "^", "(", ")", ","}
RESERVED = {"math", "t"}  # the generated code's module name; time (plants are autonomous)
_SKIP = {tokenize.NEWLINE, tokenize.NL, tokenize.ENDMARKER, tokenize.INDENT, tokenize.DEDENT}


def check_name(key: str, name: object) -> str:
    """``name`` usable as a state, input, output or parameter: an identifier that is no
    keyword, function, constant or reserved word, and does not start with ``_``."""
    if not (isinstance(name, str) and name.isidentifier()) or keyword.iskeyword(name) \
            or name.startswith("_") or name in FUNCTIONS or name in CONSTANTS \
            or name in RESERVED:
        raise ConfigError(key, f"'{name}' cannot name a variable (an identifier, not a "
                          "keyword, function, constant, 't' or 'math', not starting with _)")
    return name


def _tokens(key: str, text: str) -> list[tokenize.TokenInfo]:
    try:
        return [tok for tok in tokenize.generate_tokens(io.StringIO(text).readline)
                if tok.type not in _SKIP]
    except (tokenize.TokenError, SyntaxError, IndentationError) as err:
        raise ConfigError(key, f"cannot read '{text}': {err.args[0]}") from None


def check_tokens(key: str, text: str, declared: Sequence[str]) -> None:
    """Refuse (one line) any token of ``text`` outside the grammar of the module doc."""
    tokens = _tokens(key, text)
    if not tokens:
        raise ConfigError(key, "is empty (an expression is needed)")
    names = set(declared)
    for k, tok in enumerate(tokens):
        after = tokens[k + 1].string if k + 1 < len(tokens) else ""
        if tok.type == tokenize.NUMBER:
            if tok.string[-1] in "jJ":
                raise ConfigError(key, f"complex number '{tok.string}' (real expressions only)")
            continue
        if tok.type == tokenize.OP and tok.string in OPERATORS:
            continue
        if tok.type != tokenize.NAME:
            raise ConfigError(key, f"unexpected '{tok.string}' in '{text}' (numbers, names and "
                              f"{' '.join(sorted(OPERATORS))} only)")
        if tok.string in FUNCTIONS:
            if after != "(":
                raise ConfigError(key, f"function '{tok.string}' must be called: "
                                  f"{tok.string}(...)")
        elif tok.string in names or tok.string in CONSTANTS:
            if after == "(":
                raise ConfigError(key, f"'{tok.string}' is not a function (functions: "
                                  f"{', '.join(FUNCTIONS)})")
        else:
            raise ConfigError(key, f"unknown name '{tok.string}' "
                              f"(declared: {', '.join(declared)})")


def parse(key: str, text: object, symbols: Mapping[str, sp.Symbol]) -> sp.Expr:
    """The SymPy expression of ``text`` (a string or a number) over ``symbols`` (name ->
    symbol, in declaration order); ConfigError naming ``key`` if it is not one."""
    if isinstance(text, bool) or not isinstance(text, (str, numbers.Real)):
        raise ConfigError(key, f"must be an expression (text or a number), got {text!r}")
    if isinstance(text, numbers.Real):
        return sp.Float(float(text)) if isinstance(text, float) else sp.Integer(int(text))
    check_tokens(key, text, list(symbols))
    glob = {**FUNCTIONS, **CONSTANTS, "Integer": sp.Integer, "Float": sp.Float,
            "Rational": sp.Rational, "__builtins__": {}}
    try:
        expr = parse_expr(text, local_dict=dict(symbols), global_dict=glob,
                          transformations=(auto_number, convert_xor))
    except (SyntaxError, TypeError, ValueError, ZeroDivisionError) as err:
        raise ConfigError(key, f"cannot read '{text}': "
                          f"{' '.join(str(err).split()) or type(err).__name__}") from None
    return checked(key, expr, symbols)


def checked(key: str, expr: object, symbols: Mapping[str, sp.Symbol]) -> sp.Expr:
    """``expr`` as an expression over ``symbols`` (a SymPy expression from a Python model
    too: its symbols are matched by name); ConfigError if it is not a finite real
    expression of them and the whitelisted functions."""
    expr = sp.sympify(expr)
    if not isinstance(expr, sp.Expr):
        raise ConfigError(key, f"is not an expression: {expr}")
    by_name = {s.name: s for s in symbols.values()}
    unknown = sorted(s.name for s in expr.free_symbols if s.name not in by_name)
    if unknown:
        raise ConfigError(key, f"unknown name '{unknown[0]}' (declared: {', '.join(symbols)})")
    expr = expr.xreplace({s: by_name[s.name] for s in expr.free_symbols})
    allowed = tuple(v for v in FUNCTIONS.values() if isinstance(v, type))  # (sqrt: a Pow)
    for fn in expr.atoms(sp.Function):
        if not isinstance(fn, allowed):
            raise ConfigError(key, f"function '{fn.func}' is not one of "
                              f"{', '.join(FUNCTIONS)}")
    if expr.has(sp.zoo, sp.oo, -sp.oo, sp.nan, sp.I):
        raise ConfigError(key, f"is not a finite real expression: {expr}")
    return expr
