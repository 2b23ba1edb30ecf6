"""Model expressions (the reward, the alive indicator, a world's terrain...) compiled without
``eval``.

:func:`compile_expression` turns an expression into a numpy function of keyword-only inputs:
the text is parsed by :mod:`ast`, every node is checked against a whitelist, the parameters are
folded in as constants, and the validated syntax tree is compiled to a code object whose
globals hold only the allowed numpy functions (:data:`FUNCTIONS`). Every failure is an
:class:`~astrocpg.errors.InputError` naming the expression's owner, in one line.
"""

from __future__ import annotations

import ast
import difflib
import keyword
import math
import types
from typing import Any, Callable, Mapping, Sequence

import numpy as np

from ..errors import InputError
# the value parser's limits and wording, shared so both refuse alike
from .units import MAX_EXPONENT, NODE_MEANING, OPERATOR_TEXT, is_plain, short_text
from .units import literal_number as _literal

# ------------------------------------------------------------------------------------------
# compile_expression

FUNCTIONS: Mapping[str, tuple[Callable[..., Any], int]] = types.MappingProxyType({
    "abs": (np.abs, 1), "exp": (np.exp, 1), "sqrt": (np.sqrt, 1), "tanh": (np.tanh, 1),
    "log": (np.log, 1), "sin": (np.sin, 1), "cos": (np.cos, 1), "clip": (np.clip, 3),
    "minimum": (np.minimum, 2), "maximum": (np.maximum, 2), "where": (np.where, 3),
})
"""The functions a model expression may call: name -> (numpy function, number of arguments)."""


MAX_EXPRESSION = 2000
MAX_EXPRESSION_DEPTH = 100

_EXPRESSION_BINARY = (ast.Add, ast.Sub, ast.Mult, ast.Div, ast.Pow)
_EXPRESSION_COMPARE = (ast.Lt, ast.LtE, ast.Gt, ast.GtE, ast.Eq, ast.NotEq)
_EXPRESSION_GRAMMAR = ("numbers, the inputs, the parameters, + - * / **, unary + -, one "
                       "comparison (< <= > >= == !=), parentheses and the functions "
                       + ", ".join(FUNCTIONS))


class _ExpressionChecker:
    """Walks a model expression's tree; raises InputError at the first node not accepted."""

    def __init__(self, owner: str, expression: str, inputs: set[str], constants: set[str]):
        self.owner, self.expression = owner, expression
        self.inputs, self.constants = inputs, constants

    def refuse(self, what: str) -> InputError:
        return InputError(f"expression {short_text(self.expression, 80)}: {what}; accepted: "
                          f"{_EXPRESSION_GRAMMAR}", culprit=self.owner)

    def check(self, node: ast.AST, depth: int = 0) -> None:
        if depth > MAX_EXPRESSION_DEPTH:
            raise self.refuse(f"nested deeper than {MAX_EXPRESSION_DEPTH}")
        if isinstance(node, ast.Expression):
            return self.check(node.body, depth + 1)
        if isinstance(node, ast.Constant):
            value = node.value
            if not is_plain(value):
                raise self.refuse(f"{type(value).__name__} literals not accepted")
            if isinstance(value, float) and not math.isfinite(value):
                raise self.refuse(f"the number {node.value!r} is not finite")
            return None
        if isinstance(node, ast.Name):
            if node.id in self.inputs or node.id in self.constants:
                return None
            if node.id in FUNCTIONS:
                raise self.refuse(f"the function '{node.id}' must be called, e.g. {node.id}(x)")
            known = sorted(self.inputs) + sorted(self.constants)
            hints = difflib.get_close_matches(node.id, known + list(FUNCTIONS), n=2)
            hint = f" (did you mean {' or '.join(hints)}?)" if hints else ""
            raise self.refuse(f"unknown name '{node.id}'{hint}; inputs: "
                              f"{', '.join(sorted(self.inputs)) or 'none'}; parameters: "
                              f"{', '.join(sorted(self.constants)) or 'none'}")
        if isinstance(node, ast.UnaryOp):
            if not isinstance(node.op, (ast.UAdd, ast.USub)):
                raise self.refuse(f"'{OPERATOR_TEXT.get(type(node.op), '?')}' not accepted")
            return self.check(node.operand, depth + 1)
        if isinstance(node, ast.BinOp):
            if not isinstance(node.op, _EXPRESSION_BINARY):
                raise self.refuse(
                    f"operator '{OPERATOR_TEXT.get(type(node.op), '?')}' not accepted")
            if isinstance(node.op, ast.Pow):
                self.check_power(node)
            self.check(node.left, depth + 1)
            return self.check(node.right, depth + 1)
        if isinstance(node, ast.Compare):
            if len(node.ops) != 1:
                raise self.refuse("chained comparisons (a < b < c) not accepted")
            if not isinstance(node.ops[0], _EXPRESSION_COMPARE):
                raise self.refuse(f"the comparison '{type(node.ops[0]).__name__}' not accepted")
            self.check(node.left, depth + 1)
            return self.check(node.comparators[0], depth + 1)
        if isinstance(node, ast.Call):
            func = node.func
            if not isinstance(func, ast.Name) or func.id not in FUNCTIONS:
                name = func.id if isinstance(func, ast.Name) else "this"
                raise self.refuse(f"calls to {name!r} not accepted (only {', '.join(FUNCTIONS)})"
                                  if isinstance(func, ast.Name) else
                                  "calls are accepted only to a function named directly")
            if node.keywords or any(isinstance(a, ast.Starred) for a in node.args):
                raise self.refuse(f"{func.id}() takes positional arguments only")
            arity = FUNCTIONS[func.id][1]
            if len(node.args) != arity:
                raise self.refuse(f"{func.id}() takes {arity} argument{'s' * (arity > 1)}, "
                                  f"got {len(node.args)}")
            for arg in node.args:
                self.check(arg, depth + 1)
            return None
        raise self.refuse(f"{NODE_MEANING.get(type(node), type(node).__name__)} not accepted")


    def check_power(self, node: ast.BinOp) -> None:
        """``a**b`` where a part without names is a literal number, the exponent at most
        MAX_EXPONENT in size: ``x**2``, ``2**x``, ``10**-3``; not ``(9**9)**10**10`` (a
        tower of integers that would take forever)."""
        exponent = _literal(node.right)
        if not _mentions_name(node.right) and (exponent is None
                                               or abs(exponent) > MAX_EXPONENT):
            raise self.refuse(f"the exponent of '**' must be an input, a parameter or a "
                              f"number between -{MAX_EXPONENT} and {MAX_EXPONENT}")
        if not _mentions_name(node.left) and _literal(node.left) is None:
            raise self.refuse("the base of '**' must be a number, an input or a parameter "
                              "(write 1024 rather than (2**10))")


def _mentions_name(node: ast.AST) -> bool:
    return any(isinstance(n, ast.Name) for n in ast.walk(node))


class _FoldConstants(ast.NodeTransformer):
    """Replaces each parameter name by its value (inputs shadow parameters of the same name)."""

    def __init__(self, constants: Mapping[str, float], inputs: set[str]):
        self.constants, self.inputs = constants, inputs

    def visit_Name(self, node: ast.Name) -> ast.AST:
        if node.id in self.constants and node.id not in self.inputs:
            return ast.copy_location(ast.Constant(self.constants[node.id]), node)
        return node


def compile_expression(expression: str, *, owner: str, inputs: Sequence[str],
                       constants: Mapping[str, float]) -> Callable[..., Any]:
    """A numpy function of the keyword-only ``inputs`` computing ``expression``, with the
    ``constants`` (parameters as plain SI floats) folded in.

    The expression may use numbers, the inputs, the constants, ``+ - * / **``, unary ``+ -``,
    one comparison (``< <= > >= == !=``), parentheses and calls to the numpy functions in
    :data:`FUNCTIONS` (``abs exp sqrt clip minimum maximum where tanh log sin cos``).
    Anything else raises :class:`InputError` naming ``owner``. The function is built from the
    validated syntax tree (``compile`` of an ``ast.Lambda``), never from ``eval``/``exec``; its
    globals hold only the numpy functions, with no builtins.
    """
    if not isinstance(expression, str):
        raise InputError(f"the expression must be text, got {type(expression).__name__}",
                         culprit=owner)
    if len(expression) > MAX_EXPRESSION:
        raise InputError(f"the expression is longer than {MAX_EXPRESSION} characters",
                         culprit=owner)
    names = list(inputs)
    for name in list(names) + list(constants):
        if not isinstance(name, str) or not name.isidentifier() or keyword.iskeyword(name) \
                or name.startswith("__"):
            raise InputError(f"{name!r} cannot name an input or a parameter", culprit=owner)
        if name in FUNCTIONS:
            raise InputError(f"'{name}' names a function; rename the input or parameter",
                             culprit=owner)
    if len(set(names)) != len(names):
        raise InputError(f"inputs named twice: {names}", culprit=owner)
    values: dict[str, float] = {}
    for name, value in constants.items():
        try:
            number = float(np.asarray(value))
        except (TypeError, ValueError):
            raise InputError(f"parameter '{name}' is not a number: {value!r}",
                             culprit=owner) from None
        if not math.isfinite(number):
            raise InputError(f"parameter '{name}' is not finite: {value!r}", culprit=owner)
        values[name] = number
    try:
        tree = ast.parse(expression.strip(), mode="eval")
    except SyntaxError as e:
        raise InputError(f"expression has a syntax error: {e.msg}", culprit=owner) from None
    except (RecursionError, MemoryError, ValueError) as e:
        raise InputError(f"expression cannot be read ({type(e).__name__})",
                         culprit=owner) from None
    _ExpressionChecker(owner, expression, set(names), set(values)).check(tree)

    body = _FoldConstants(values, set(names)).visit(tree.body)
    arguments = ast.arguments(posonlyargs=[], args=[], vararg=None,
                              kwonlyargs=[ast.arg(arg=n) for n in names],
                              kw_defaults=[None] * len(names), kwarg=None, defaults=[])
    function = ast.Expression(body=ast.Lambda(args=arguments, body=body))
    ast.fix_missing_locations(function)
    try:
        code = compile(function, f"<{owner}>", "eval")
    except (SyntaxError, ValueError, TypeError, RecursionError, MemoryError) as e:
        raise InputError(f"expression cannot be compiled ({type(e).__name__})",
                         culprit=owner) from None
    lambda_code = next(c for c in code.co_consts if isinstance(c, types.CodeType))
    namespace = {"__builtins__": {}, **{name: f for name, (f, _) in FUNCTIONS.items()}}
    result = types.FunctionType(lambda_code, namespace, owner)
    result.expression = expression  # type: ignore[attr-defined]
    return result



__all__ = ["compile_expression", "FUNCTIONS", "MAX_EXPRESSION", "MAX_EXPRESSION_DEPTH"]
