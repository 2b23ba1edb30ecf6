"""Reading and writing values with units that users type, without ``eval``, and checking the
numbers of the command line.

* :func:`parse_value` reads a value with units (an override ``tau_motor=9*ms``, a study file's
  ``C_K_chan = "8 volt/second"``): numbers, Brian2 unit names, ``pi``, ``+ - * / **`` and
  parentheses. The text is cut into tokens by a whitelist, parsed by :mod:`ast` and computed by
  walking a whitelist of node types; nothing is ever handed to ``eval``/``exec``.
* :func:`unit_spelling` writes the units of a value or of dimensions in words that
  :func:`parse_value` reads back (``joule``, ``volt/second``, ``umolar``, ``1``), for messages
  such as ``needs units of joule, e.g. 30*joule`` (:func:`example_value` writes the example).
* :func:`finite_number` checks a command-line number (``seconds``, ``trials``), and
  :func:`whole_steps` a duration that must be a whole number of simulation steps.

Model expressions (the reward, the alive indicator...) are compiled in ``expressions.py``.
Every failure is an :class:`~astrocpg.errors.InputError` naming the culprit, in one line.
"""

from __future__ import annotations

import ast
import difflib
import keyword
import math
import numbers
import re
import types
from typing import Any, Mapping

import brian2
import brian2.units
import brian2.units.allunits
import numpy as np
from brian2.units.fundamentalunits import Dimension, DimensionMismatchError, get_dimensions

from ..errors import InputError

# ------------------------------------------------------------------------------------------
# the unit table

def _unit_table() -> dict[str, Any]:
    table: dict[str, Any] = {}
    for module in (brian2.units.allunits, brian2.units):
        for name, value in vars(module).items():
            if isinstance(value, brian2.Unit) and name.isidentifier() and not name.startswith("_"):
                table[name] = value
    return table


UNITS: Mapping[str, Any] = types.MappingProxyType(_unit_table())
"""Every Brian2 unit name :func:`parse_value` accepts (``brian2.units`` and its ``allunits``)."""

CONSTANTS: Mapping[str, float] = types.MappingProxyType({"pi": math.pi})

# SI symbols people type, and the Brian2 name to use instead (``J`` -> ``joule``)
_SYMBOL_HINTS = {
    "J": "joule", "N": "newton", "V": "volt", "s": "second", "sec": "second", "m": "meter",
    "W": "watt", "A": "amp", "ampere": "amp", "K": "kelvin", "rad": "radian", "g": "gram",
    "M": "molar", "mol": "mole", "l": "liter", "L": "liter", "C": "coulomb", "F": "farad",
    "S": "siemens", "Pa": "pascal", "Ohm": "ohm", "Hz": "hertz", "sr": "steradian",
    "Wb": "weber", "T": "tesla", "H": "henry", "Bq": "becquerel", "Gy": "gray", "Sv": "sievert",
    "kat": "katal", "lm": "lumen", "lx": "lux", "min": "60*second", "h": "3600*second",
}
_PREFIXES = ("y", "z", "a", "f", "p", "n", "u", "m", "c", "d", "da", "h", "k", "M", "G", "T",
             "P", "E", "Z", "Y")

MAX_TEXT = 200          # characters in a value
MAX_PARENS = 20         # nesting of parentheses in a value
MAX_DEPTH = 64          # depth of a value's syntax tree
MAX_EXPONENT = 10       # |n| in x**n
MAX_EXACT_INT = 10**18  # larger integers are computed as floats (so that they stay cheap)

_EXAMPLES = ("write a number times Brian2 units, e.g. 9*ms, -70*mV, 8*volt/second, "
             "40*newton*meter, 0.3*umolar, 1e-3*second (numbers, unit names, pi, + - * / **, "
             "parentheses; a space between a number and a unit means *)")


def short_text(text: str, limit: int = 60) -> str:
    shown = text if len(text) <= limit else text[:limit - 3] + "..."
    return ascii(shown) if not shown.isascii() or not shown.isprintable() else repr(shown)


def _refuse(what: str, text: str, culprit: str) -> InputError:
    return InputError(f"{what} in {short_text(text)}; {_EXAMPLES}", culprit=culprit)


def _unit_suggestions(name: str) -> list[str]:
    hints = []
    if name in _SYMBOL_HINTS:
        hints.append(_SYMBOL_HINTS[name])
    for prefix in _PREFIXES:
        rest = name[len(prefix):]
        if name.startswith(prefix) and rest in _SYMBOL_HINTS and prefix + _SYMBOL_HINTS[rest] in UNITS:
            hints.append(prefix + _SYMBOL_HINTS[rest])
    lowered = {n.lower(): n for n in UNITS}
    if name.lower() in lowered:
        hints.append(lowered[name.lower()])
    hints += difflib.get_close_matches(name, list(UNITS) + list(CONSTANTS), n=3, cutoff=0.75)
    return list(dict.fromkeys(h for h in hints if h != name))[:4]


def _unknown_name_message(name: str) -> str:
    hints = _unit_suggestions(name)
    did_you_mean = f" (did you mean {' or '.join(hints)}?)" if hints else ""
    return f"unknown unit name '{name}'{did_you_mean}"


# ------------------------------------------------------------------------------------------
# tokens: a whitelist, before any parsing

_DIGITS = r"[0-9](?:_?[0-9])*"
_TOKEN = re.compile(
    rf"(?P<space>[ \t]+)"
    rf"|(?P<number>(?:{_DIGITS}(?:\.(?:{_DIGITS})?)?|\.{_DIGITS})(?:[eE][+-]?{_DIGITS})?)"
    rf"|(?P<name>[A-Za-z_][A-Za-z0-9_]*)"
    rf"|(?P<op>\*\*|[-+*/()])",
    re.ASCII,
)

_CHARACTER_MEANING = {
    "'": "quotes (strings)", '"': "quotes (strings)", ".": "'.' (attribute access)",
    "[": "brackets (lists, subscripts)", "]": "brackets (lists, subscripts)",
    "{": "braces (sets, dicts, f-strings)", "}": "braces (sets, dicts, f-strings)",
    ",": "commas (tuples, arguments)", ":": "':' (lambdas, slices, ':=')",
    "=": "'=' (assignment, comparison)", "<": "comparisons", ">": "comparisons",
    "!": "comparisons", "@": "operator '@'", "%": "operator '%'", "&": "operator '&'",
    "|": "operator '|'", "^": "operator '^'", "~": "operator '~'", ";": "';' (statements)",
    "#": "'#' (comments)", "\\": "backslashes", "`": "backquotes", "$": "'$'", "?": "'?'",
    "\n": "line breaks", "\r": "line breaks", "\x00": "NUL characters",
    "\u00b5": "'\u00b5' (write micro as u: usecond, umolar)",
    "\u03bc": "'\u03bc' (write micro as u: usecond, umolar)",
}


def _tokens(text: str, culprit: str) -> str:
    """The text rebuilt from whitelisted tokens, separated by spaces, with ``*`` written where a
    space separates two operands (``8 volt/second`` -> ``8 * volt / second``).

    Refuses, in this order: characters outside the grammar (quotes, dots, brackets...), Python
    keywords, names starting with ``_``, unknown names, then misplaced numbers and parentheses.
    """
    tokens: list[tuple[str, str, bool]] = []   # (kind, token, whitespace before it)
    spaced = False
    pos = 0
    while pos < len(text):
        match = _TOKEN.match(text, pos)
        if match is None:
            char = text[pos]
            meaning = _CHARACTER_MEANING.get(char, f"the character {ascii(char)}")
            raise _refuse(f"{meaning} not accepted", text, culprit)
        pos = match.end()
        if match.lastgroup == "space":
            spaced = True
            continue
        tokens.append((match.lastgroup, match.group(), spaced))
        spaced = False
    names = [token for kind, token, _ in tokens if kind == "name"]
    for name in names:
        if keyword.iskeyword(name) or keyword.issoftkeyword(name):
            raise _refuse(f"Python keyword '{name}' not accepted", text, culprit)
    for name in names:
        if name.startswith("_"):
            raise _refuse(f"names starting with '_' ('{name}') not accepted", text, culprit)
    for name in names:
        if name.lower() in ("nan", "inf", "infinity"):
            raise _refuse(f"'{name}': values must be finite", text, culprit)
        if name not in UNITS and name not in CONSTANTS:
            raise _refuse(_unknown_name_message(name), text, culprit)
    if not tokens:
        raise _refuse("empty value", text, culprit)
    out: list[str] = []
    previous = None     # "number", "name", "(", ")" or "op"
    depth = 0
    for kind, token, spaced in tokens:
        if kind == "name" and previous == "number" and not spaced:
            raise _refuse(f"write '*' or a space between a number and a unit ('{token}')",
                          text, culprit)
        if kind == "number" and previous == "number":
            raise _refuse("two numbers side by side (write 1000, not 1 000)", text, culprit)
        if kind == "number" and re.fullmatch(r"0[0-9_]+", token):
            token = token.lstrip("0_") or "0"     # 007 -> 7 (Python refuses leading zeros)
        if spaced and previous in ("number", "name", ")") and (kind in ("number", "name")
                                                               or token == "("):
            out.append("*")
        if token == "(":
            depth += 1
            if depth > MAX_PARENS:
                raise _refuse(f"parentheses nested deeper than {MAX_PARENS}", text, culprit)
        elif token == ")":
            depth -= 1
            if depth < 0:
                raise _refuse("unbalanced parentheses", text, culprit)
        out.append(token)
        previous = token if token in ("(", ")") else kind
    if depth:
        raise _refuse("unbalanced parentheses", text, culprit)
    return " ".join(out)


# ------------------------------------------------------------------------------------------
# parse_value

NODE_MEANING = {
    ast.Call: "calls", ast.Attribute: "attribute access", ast.Subscript: "subscripts",
    ast.Lambda: "lambdas", ast.IfExp: "conditional expressions", ast.BoolOp: "'and'/'or'",
    ast.Compare: "comparisons", ast.NamedExpr: "':='", ast.Tuple: "tuples", ast.List: "lists",
    ast.Set: "sets", ast.Dict: "dicts", ast.ListComp: "comprehensions",
    ast.SetComp: "comprehensions", ast.DictComp: "comprehensions",
    ast.GeneratorExp: "generators", ast.JoinedStr: "f-strings", ast.Starred: "'*' unpacking",
    ast.Await: "'await'", ast.Yield: "'yield'", ast.YieldFrom: "'yield'", ast.Slice: "slices",
}
OPERATOR_TEXT = {ast.Add: "+", ast.Sub: "-", ast.Mult: "*", ast.Div: "/", ast.Pow: "**",
                  ast.FloorDiv: "//", ast.Mod: "%", ast.MatMult: "@", ast.BitAnd: "&",
                  ast.BitOr: "|", ast.BitXor: "^", ast.LShift: "<<", ast.RShift: ">>",
                  ast.UAdd: "+", ast.USub: "-", ast.Not: "not", ast.Invert: "~"}


class _Refused(Exception):
    """A reason to refuse the value (turned into an InputError by parse_value)."""


def is_plain(value: Any) -> bool:
    return isinstance(value, (int, float)) and not isinstance(value, bool)


def literal_number(node: ast.AST) -> float | int | None:
    """The number of a literal such as ``3``, ``-0.5`` or ``+2``; None for anything else."""
    sign = 1
    while isinstance(node, ast.UnaryOp) and isinstance(node.op, (ast.UAdd, ast.USub)):
        sign = -sign if isinstance(node.op, ast.USub) else sign
        node = node.operand
    if isinstance(node, ast.Constant) and is_plain(node.value):
        return sign * node.value
    return None


def _dims_text(value: Any) -> str:
    try:
        return unit_spelling(value)
    except Exception:   # pragma: no cover - unit_spelling does not fail on brian2 values
        return str(get_dimensions(value))


def _checked(value: Any) -> Any:
    """Refuse non-finite results; keep integers exact but small."""
    if isinstance(value, bool) or isinstance(value, complex):
        raise _Refused("the result is not a real number")
    if isinstance(value, int):
        if abs(value) <= MAX_EXACT_INT:
            return value
        value = float(value)    # OverflowError beyond 1.8e308
    if isinstance(value, float):
        if not math.isfinite(value):
            raise _Refused("the result is not finite (overflow or division by zero)")
        return value
    if isinstance(value, brian2.Quantity):
        number = np.asarray(value)
        if number.shape != () or not np.isfinite(number).all():
            raise _Refused("the result is not finite (overflow, division by zero or the power "
                           "of a negative number)")
        return value
    raise _Refused(f"the result is not a number ({type(value).__name__})")


def _exponent(value: Any) -> float | int:
    if isinstance(value, brian2.Quantity):
        if not get_dimensions(value).is_dimensionless:
            raise _Refused(f"an exponent must be a plain number, not {_dims_text(value)}")
        value = float(np.asarray(value))
    if not is_plain(value) or abs(value) > MAX_EXPONENT:
        raise _Refused(f"an exponent must be a plain number between -{MAX_EXPONENT} and "
                       f"{MAX_EXPONENT}")
    return value


def _binary(op: ast.operator, left: Any, right: Any) -> Any:
    try:
        if isinstance(op, ast.Add):
            return left + right
        if isinstance(op, ast.Sub):
            return left - right
        if isinstance(op, ast.Mult):
            return left * right
        if isinstance(op, ast.Div):
            if np.all(np.asarray(right) == 0):
                raise _Refused("division by zero")
            return left / right
        if isinstance(op, ast.Pow):
            exponent = _exponent(right)
            if exponent < 0 and np.all(np.asarray(left) == 0):
                raise _Refused("division by zero (0 to a negative power)")
            if isinstance(left, int) and not (isinstance(exponent, int) and exponent >= 0):
                left = float(left)
            if isinstance(left, float) and left < 0 and not float(exponent).is_integer():
                raise _Refused("a negative number to a fractional power")
            return left ** exponent
    except DimensionMismatchError:
        verb = "add" if isinstance(op, ast.Add) else "subtract"
        raise _Refused(f"cannot {verb} {_dims_text(left)} and {_dims_text(right)}: the units "
                       "differ") from None
    raise _Refused(f"operator '{OPERATOR_TEXT.get(type(op), type(op).__name__)}' not accepted")


def _evaluate(node: ast.AST, depth: int = 0) -> Any:
    if depth > MAX_DEPTH:
        raise _Refused(f"the value is nested deeper than {MAX_DEPTH}")
    if isinstance(node, ast.Expression):
        return _evaluate(node.body, depth + 1)
    if isinstance(node, ast.Constant):
        if not is_plain(node.value):
            raise _Refused(f"{type(node.value).__name__} literals not accepted")
        if isinstance(node.value, float) and not math.isfinite(node.value):
            raise _Refused("a number is too large (values must be finite, below 1.8e308)")
        return _checked(node.value)
    if isinstance(node, ast.Name):
        if node.id in UNITS:
            return UNITS[node.id]
        if node.id in CONSTANTS:
            return CONSTANTS[node.id]
        raise _Refused(_unknown_name_message(node.id))
    if isinstance(node, ast.UnaryOp):
        if not isinstance(node.op, (ast.UAdd, ast.USub)):
            raise _Refused(f"'{OPERATOR_TEXT.get(type(node.op), '?')}' not accepted")
        operand = _evaluate(node.operand, depth + 1)
        return _checked(-operand if isinstance(node.op, ast.USub) else +operand)
    if isinstance(node, ast.BinOp):
        if not isinstance(node.op, (ast.Add, ast.Sub, ast.Mult, ast.Div, ast.Pow)):
            raise _Refused(f"operator '{OPERATOR_TEXT.get(type(node.op), '?')}' not accepted")
        left = _evaluate(node.left, depth + 1)
        right = _evaluate(node.right, depth + 1)
        return _checked(_binary(node.op, left, right))
    raise _Refused(f"{NODE_MEANING.get(type(node), type(node).__name__)} not accepted")


def _plain_if_dimensionless(value: Any) -> Any:
    if isinstance(value, brian2.Quantity) and get_dimensions(value).is_dimensionless:
        return float(np.asarray(value))
    return value


def parse_value(text: str, *, culprit: str) -> brian2.Quantity | float:
    """The value written in ``text``: a Brian2 quantity, or a plain number when dimensionless.

    Accepts numbers (``9``, ``-70``, ``0.3``, ``1e-3``), Brian2 unit names (``ms``, ``mV``,
    ``second``, ``volt``, ``newton``, ``meter``, ``joule``, ``umolar``, ``Hz``...), ``pi``,
    ``+ - * / **`` (the exponent a plain number of at most 10 in size), unary ``+ -`` and
    parentheses; a space between two operands means ``*`` (``8 volt/second``). The result must
    be finite. Anything else raises :class:`InputError` naming ``culprit``; the text is never
    evaluated by Python.
    """
    if not isinstance(text, str):
        raise InputError(f"expected text, got {type(text).__name__}; {_EXAMPLES}",
                         culprit=culprit)
    if len(text) > MAX_TEXT:
        raise InputError(f"the value is longer than {MAX_TEXT} characters ({len(text)}); "
                         f"{_EXAMPLES}", culprit=culprit)
    stripped = text.strip()
    try:
        source = _tokens(stripped, culprit)
        try:
            tree = ast.parse(source, mode="eval")
        except SyntaxError as e:
            raise _Refused(f"cannot read the value ({e.msg})") from None
        with np.errstate(all="ignore"):
            value = _evaluate(tree)
        return _plain_if_dimensionless(value)
    except InputError:
        raise
    except _Refused as e:
        raise _refuse(str(e), stripped, culprit) from None
    except (KeyboardInterrupt, SystemExit):
        raise
    except BaseException as e:  # RecursionError, MemoryError, OverflowError, ZeroDivisionError...
        what = {OverflowError: "the value overflows (larger than 1.8e308)",
                ZeroDivisionError: "division by zero",
                RecursionError: "the value is nested too deeply",
                MemoryError: "the value is too large"}.get(type(e), f"cannot read the value "
                                                                   f"({type(e).__name__})")
        raise _refuse(what, stripped, culprit) from None


# ------------------------------------------------------------------------------------------
# unit spelling

_BASE_UNITS = (("m", "metre"), ("kg", "kilogram"), ("s", "second"), ("A", "amp"),
               ("K", "kelvin"), ("mol", "mole"), ("cd", "candela"))


def _as_dimensions(value_or_dimensions: Any) -> Dimension:
    if isinstance(value_or_dimensions, Dimension):
        return value_or_dimensions
    return get_dimensions(value_or_dimensions)


def _factors(unit_name: str) -> dict[str, float] | None:
    """``{"metre": -1, "second": 1}`` for a Brian2 unit name such as ``metre ** -1 * second``;
    None if the name is anything else."""
    try:
        tree = ast.parse(unit_name, mode="eval").body
    except SyntaxError:
        return None
    factors: dict[str, float] = {}

    number = literal_number

    def walk(node: ast.AST, power: float) -> bool:
        if isinstance(node, ast.Name) and node.id in UNITS:
            factors[node.id] = factors.get(node.id, 0) + power
            return True
        if isinstance(node, ast.BinOp) and isinstance(node.op, (ast.Mult, ast.Div)):
            sign = -1 if isinstance(node.op, ast.Div) else 1
            return walk(node.left, power) and walk(node.right, sign * power)
        if isinstance(node, ast.BinOp) and isinstance(node.op, ast.Pow):
            exponent = number(node.right)
            return exponent is not None and walk(node.left, power * exponent)
        return False

    return factors if walk(tree, 1) else None


def _unprefixed(factors: Mapping[str, float]) -> dict[str, float] | None:
    """``{"mvolt": 1, "msecond": -1}`` -> ``{"volt": 1, "second": -1}``: each factor as the
    unscaled unit of its dimensions; None if one has none."""
    out: dict[str, float] = {}
    for name, power in factors.items():
        if float(np.asarray(UNITS[name])) == 1.0:  # already unscaled (metre or meter)
            out[name] = out.get(name, 0) + power
            continue
        unscaled = getattr(brian2.get_unit(get_dimensions(UNITS[name])), "name", None)
        if not isinstance(unscaled, str) or unscaled not in UNITS:
            return None
        out[unscaled] = out.get(unscaled, 0) + power
    return {n: e for n, e in out.items() if e}


# the short Brian2 names people type (both spellings are in UNITS)
_SHORT_NAMES = {"msecond": "ms", "mvolt": "mV", "hertz": "Hz"}


def _power_text(name: str, exponent: float) -> str:
    name = _SHORT_NAMES.get(name, name)
    if exponent == 1:
        return name
    shown = int(exponent) if float(exponent).is_integer() else exponent
    return f"{name}**{shown}"


def _format_factors(factors: Mapping[str, float]) -> str:
    upper = [_power_text(n, e) for n, e in factors.items() if e > 0]
    lower = [_power_text(n, -e) for n, e in factors.items() if e < 0]
    text = "*".join(upper) or "1"
    if lower:
        text += "/" + (lower[0] if len(lower) == 1 else "(" + "*".join(lower) + ")")
    return text


def _spells(text: str, dims: Dimension) -> bool:
    try:
        return get_dimensions(parse_value(text, culprit="unit_spelling")) == dims
    except InputError:
        return False


def unit_spelling(value_or_dimensions: Any) -> str:
    """Units for these dimensions (or the dimensions of this value) as :func:`parse_value`
    reads them: ``joule``, ``volt/second``, ``umolar`` (the unit Brian2 would print the value
    in), ``second/metre``, ``1`` when dimensionless. ``parse_value(unit_spelling(d))`` has the
    dimensions ``d``."""
    dims = _as_dimensions(value_or_dimensions)
    if dims.is_dimensionless:
        return "1"
    candidates = []
    if isinstance(value_or_dimensions, brian2.Quantity):
        try:
            number = np.asarray(value_or_dimensions)
            if number.shape == () and np.isfinite(number) and number != 0:
                candidates.append(value_or_dimensions.get_best_unit())
        except Exception:   # pragma: no cover - brian2 finds a unit for every finite scalar
            pass
    candidates.append(brian2.get_unit(dims))
    for unit in candidates:
        name = getattr(unit, "name", None)
        if isinstance(name, str):
            factors = _factors(name)
            if factors is not None and len(factors) > 1:
                # a combined unit is whichever one this process happened to create last for
                # these dimensions (``mV/ms`` or ``volt/second``): spell it unprefixed, so the
                # answer does not depend on what ran before
                factors = _unprefixed(factors)
            if factors is not None:
                text = _format_factors(factors)
                if _spells(text, dims):
                    return text
    # from the SI base units, e.g. metre**2*kilogram/second**3
    factors = {name: dims.get_dimension(symbol) for symbol, name in _BASE_UNITS}
    return _format_factors({n: e for n, e in factors.items() if e})


def example_value(value: Any) -> str:
    """``value`` written so that :func:`parse_value` reads it back, e.g. ``30*joule`` or
    ``0.5``: for messages such as ``needs units of joule, e.g. 30*joule``."""
    dims = _as_dimensions(value)
    if dims.is_dimensionless:
        number = float(np.asarray(value))
        return str(int(number)) if number.is_integer() and abs(number) < 1e15 else f"{number:.12g}"
    spelling = unit_spelling(value)
    unit = parse_value(spelling, culprit="example_value")
    number = float(np.asarray(value / unit))
    shown = str(int(number)) if number.is_integer() and abs(number) < 1e15 else f"{number:.12g}"
    return f"{shown}*{spelling}"


# ------------------------------------------------------------------------------------------
# command-line numbers

_FLOAT_TEXT = re.compile(r"[+-]?(?:[0-9]+(?:\.[0-9]*)?|\.[0-9]+)(?:[eE][+-]?[0-9]+)?", re.ASCII)
_INT_TEXT = re.compile(r"[+-]?[0-9]+", re.ASCII)


def finite_number(text: Any, *, culprit: str, kind: type = float, minimum: float | None = None,
                  strictly_positive: bool = False) -> float | int:
    """A finite number from a command-line option (``seconds`` 2.5, ``trials`` 8).

    kind: ``float`` (decimal or scientific notation) or ``int`` (digits only).
    minimum: the smallest value accepted; strictly_positive: the value must be > 0.
    Raises :class:`InputError` naming ``culprit`` for anything else (``nan``, ``inf``,
    ``1e309``, words, out of range)."""
    if kind not in (int, float):
        raise TypeError("finite_number: kind must be int or float")
    noun = "an integer" if kind is int else "a finite number"
    if isinstance(text, numbers.Real) and not isinstance(text, bool):
        shown = repr(text)
        if kind is int and not isinstance(text, numbers.Integral):
            raise InputError(f"expected {noun}, got {shown}", culprit=culprit)
        number: float | int = int(text) if kind is int else float(text)
    elif isinstance(text, str):
        shown = short_text(text.strip())
        stripped = text.strip()
        pattern = _INT_TEXT if kind is int else _FLOAT_TEXT
        if len(stripped) > 100 or not pattern.fullmatch(stripped):
            example = "8" if kind is int else "2.5 or 1e-3"
            raise InputError(f"expected {noun} (e.g. {example}), got {shown}", culprit=culprit)
        number = int(stripped) if kind is int else float(stripped)
    else:
        raise InputError(f"expected {noun}, got {type(text).__name__}", culprit=culprit)
    if kind is float and not math.isfinite(number):
        raise InputError(f"expected a finite number, got {shown}", culprit=culprit)
    if strictly_positive and not number > 0:
        raise InputError(f"must be greater than 0, got {shown}", culprit=culprit)
    if minimum is not None and number < minimum:
        raise InputError(f"must be at least {minimum:g}, got {shown}", culprit=culprit)
    return number


def whole_steps(value: float, step: float, *, culprit: str, unit: str = "s",
                minimum: int = 1) -> int:
    """The number of ``step``-long steps in ``value`` (both in ``unit``), when it is a whole
    number of at least ``minimum``; else an :class:`InputError` naming ``culprit`` and the
    nearest valid values.

    Every duration the simulation takes (``seconds``, ``trace_dt``, a session's
    ``L_max``...) is run as a number of steps; one that is not a whole number of them would
    run a rounded number of steps while the manifest, the labels and the summary showed the
    value as typed (``seconds`` 0.0015 ran 2 steps and recorded 0.0015 s)."""
    value, step = float(value), float(step)
    if not math.isfinite(value) or not step > 0:
        raise InputError(f"must be a finite number of {unit}, got {value:g}", culprit=culprit)
    n = value / step
    k = round(n)
    if k >= minimum and abs(n - k) <= 1e-6 * max(1.0, abs(n)):
        return int(k)
    low, high = max(minimum, math.floor(n)), max(minimum, math.ceil(n))
    nearest = " or ".join(f"{m * step:.10g}" for m in sorted({low, high}))
    step_text = f"{step * 1e3:g} ms" if unit == "s" else f"{step:g} {unit}"
    raise InputError(f"{value:.10g} {unit} is not a whole number of {step_text} steps (at "
                     f"least {minimum}): it would be rounded to whole steps while labelled "
                     f"{value:.10g} {unit}; nearest valid: {nearest} {unit}", culprit=culprit)



__all__ = ["parse_value", "unit_spelling", "example_value", "finite_number", "whole_steps",
           "UNITS", "CONSTANTS"]
