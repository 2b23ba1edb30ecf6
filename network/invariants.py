"""The constants a network's equations compute from its parameters, checked before it runs.

Brian2 computes every sub-expression of an update that depends on constants alone (a
loop-invariant, ``_lio_1 = 1.0 / ((w_max - w_min) ** 2)``) once per step, before the loop over
cells. A parameter of an absurd size can make one leave the floats. Brian2's numpy code computes
it in Python floats and stops with an ``OverflowError`` (:func:`~.divergence.overflowed` turns
that into the refusal); compiled code (Cython) computes ``inf`` or ``0`` without a word and runs
on with it, its result silently wrong. :func:`check_constants` computes the same invariants of
every code object with numpy's floating-point errors raised, whatever the code generation, so a
run whose parameters overflow is refused (exit 2) before its first step on every target: naming
the largest parameter of the expression and quoting it as Brian2 wrote it.
"""

from __future__ import annotations

import weakref
from typing import Any

import numpy as np

from ..errors import InputError

#: Networks whose constants were checked (each network is checked at its first run: its
#: parameters are set when it is built)
_CHECKED: "weakref.WeakSet[Any]" = weakref.WeakSet()


def _runners(net: Any) -> list[Any]:
    """Every code runner of ``net`` (state updaters, thresholds, resets, synaptic pathways,
    ``run_regularly`` operations) with a code object."""
    from brian2.groups.group import CodeRunner

    out, seen = [], set()
    for obj in net.objects:
        for o in [obj, *getattr(obj, "contained_objects", [])]:
            if isinstance(o, CodeRunner) and id(o) not in seen \
                    and getattr(o, "codeobj", None) is not None:
                seen.add(id(o))
                out.append(o)
    return out


def _value(variables: dict[str, Any], name: str, computed: dict[str, float]) -> float | None:
    """A scalar identifier's value as a float (SI units), or None where it is not a constant."""
    from brian2.core.variables import Constant

    if name in computed:
        return computed[name]
    var = variables.get(name)
    if var is None:
        return None
    if isinstance(var, Constant):
        return float(np.asarray(var.value, dtype=float))
    if getattr(var, "scalar", False) and hasattr(var, "get_value"):
        try:
            return float(np.asarray(var.get_value(), dtype=float).reshape(-1)[0])
        except (TypeError, ValueError, IndexError):
            return None
    return None


def _invariants(runner: Any) -> list[tuple[str, str, list[str]]]:
    """``(name, expression, identifiers)`` of each loop-invariant Brian2 pulls out of the
    runner's code, in order."""
    from brian2.codegen.translation import make_statements
    from brian2.utils.stringtools import get_identifiers

    code = runner.abstract_code
    blocks = code if isinstance(code, dict) else {None: code}
    variables = runner.codeobj.variables
    out = []
    for block, text in blocks.items():
        if not text or not str(text).strip():
            continue
        scalar, _ = make_statements(str(text), variables, np.float64, optimise=True,
                                    blockname=block or "")
        for st in scalar:
            if st.var.startswith("_lio_"):
                out.append((st.var, st.expr, sorted(get_identifiers(st.expr))))
    return out


def _evaluate(expr: str, values: dict[str, float]) -> float:
    """``expr`` (a Brian2 expression of constants) with numpy, floating-point errors raised."""
    import sympy

    from brian2.parsing.sympytools import str_to_sympy

    sym = str_to_sympy(expr)
    names = sorted(values)
    fn = sympy.lambdify([sympy.Symbol(n, real=True) for n in names],
                        sym.subs({s: sympy.Symbol(s.name, real=True) for s in sym.free_symbols}),
                        modules="numpy")
    with np.errstate(over="raise", invalid="raise", divide="ignore", under="ignore"):
        return float(fn(*[np.float64(values[n]) for n in names]))


def check_constants(net: Any) -> None:
    """Refuse (InputError naming the largest parameter, exit 2) a network one of whose
    loop-invariant constants overflows; each network once, after ``before_run`` (its code
    objects made)."""
    if net in _CHECKED:
        return
    from .populations import model_of_object

    models = model_of_object(getattr(net, "population_rows", None))
    for runner in _runners(net):
        variables = runner.codeobj.variables
        computed: dict[str, float] = {}
        try:
            invariants = _invariants(runner)
        except Exception:  # noqa: BLE001 - Brian2 made the code; a form this check cannot
            continue       # read is left to the run itself
        for name, expr, idents in invariants:
            values = {i: v for i in idents
                      if (v := _value(variables, i, computed)) is not None}
            if any(i not in values and i not in _FUNCTIONS for i in idents):
                continue  # not all constants known here (a function, an array): not checked
            try:
                computed[name] = _evaluate(expr, {i: values[i] for i in idents if i in values})
            except (OverflowError, FloatingPointError):
                owner = getattr(runner.group, "name", "") or runner.name
                model = models.get(owner, models.get(runner.name, owner or "the network"))
                raise _refusal(model, f"{name} = {expr}", idents, variables) from None
            except Exception:  # noqa: BLE001 - an expression sympy cannot evaluate
                continue
    _CHECKED.add(net)


#: functions a loop-invariant may call that numpy evaluates (through sympy)
_FUNCTIONS = frozenset({"exp", "log", "log10", "sqrt", "sin", "cos", "tan", "sinh", "cosh",
                        "tanh", "arcsin", "arccos", "arctan", "abs", "floor", "ceil", "sign",
                        "int", "clip", "expm1", "log1p"})


def _refusal(model: str, line: str, idents: list[str], variables: dict[str, Any]
             ) -> InputError:
    """The refusal for an overflowing loop-invariant: the parameters of the expression are
    the code object's constants (their values in SI units, their dimensions)."""
    import brian2
    from brian2.core.variables import Constant

    values = {}
    for ident in idents:
        var = variables.get(ident)
        if ident.startswith("_") or not isinstance(var, Constant):
            continue
        dim = getattr(var, "dim", None)
        values[ident] = (brian2.Quantity(var.value, dim=dim) if dim is not None
                         else var.value)
    return overflow_refusal(model, line, values)


def overflow_refusal(model: str, line: str, values: dict[str, Any]) -> InputError:
    """An InputError for ``model``'s expression ``line`` whose arithmetic left the floats:
    naming the largest of its parameters ``values`` (``{name: value}``, a Brian2 quantity or
    a number) with its value and unit, or all of them where none has a size."""
    import brian2

    sizes = []
    for ident, value in values.items():
        try:
            sizes.append((float(np.max(np.abs(np.asarray(value, dtype=float)))), ident))
        except (TypeError, ValueError):
            continue
    where = f"{model}'s '{line}'" if line else f"a computation of {model}"
    if not sizes:
        return InputError(f"the parameters make {where} overflow (beyond 1.8e308); give "
                          f"them values of a plausible size", culprit=model)
    largest = max(sizes)[1]
    value = values[largest]
    shown = f"{float(np.max(np.asarray(value, dtype=float))):g}"
    if not brian2.get_dimensions(value).is_dimensionless:
        shown += f"*{brian2.get_unit(brian2.get_dimensions(value))}"
    return InputError(f"makes {where} overflow (beyond 1.8e308); give it a value of a "
                      f"plausible size", culprit=f"{largest}={shown}")
