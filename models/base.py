"""The contract every model of astrocpg honours.

A model is its Brian2 equation string(s) plus a parameter table. Each parameter has a name (used
in the equations and on the command line), a value with physical units, the paper's symbol and a
one-line meaning. Models are immutable: change one with :meth:`NeuronModel.replace` or
:meth:`ParameterTable.with_values`, which validate and name the culprit when something is wrong.
"""

from __future__ import annotations

import dataclasses
import re
from dataclasses import dataclass, field
from typing import Any, Callable, Iterable, Mapping

import brian2
import numpy as np
from brian2 import Equations
from brian2.units.fundamentalunits import DimensionMismatchError, get_dimensions

from ..errors import InputError
from .values import compile_expression


@dataclass(frozen=True, kw_only=True)
class Parameter:
    """One model parameter.

    name: identifier used in the equation strings (and by ``--set NAME=VALUE``).
    value: the value, a Brian2 quantity or a plain number for dimensionless parameters.
    symbol: the paper's symbol (LaTeX), so the table can be checked against the paper.
    meaning: one line saying what the parameter is, and where the value comes from when it is
        not the paper's table (e.g. SPEC).
    positive: the value must be > 0 (time constants, sizes, rates of decay).
    """

    name: str
    value: Any
    symbol: str
    meaning: str
    positive: bool = False

    @property
    def dimensions(self):
        return get_dimensions(self.value)


class ParameterTable(Mapping[str, Parameter]):
    """An ordered, validated table of :class:`Parameter` of one model."""

    def __init__(self, owner: str, parameters: Iterable[Parameter]):
        self.owner = owner
        self._parameters: dict[str, Parameter] = {}
        for p in parameters:
            if p.name in self._parameters:
                raise InputError(f"{owner}: parameter '{p.name}' is declared twice")
            self._parameters[p.name] = p
        for p in self._parameters.values():
            self._check(p)

    def _check(self, p: Parameter) -> None:
        if not np.all(np.isfinite(np.asarray(p.value, dtype=float))):
            raise InputError(f"{self.owner}: parameter '{p.name}' must be finite, got {p.value}")
        if p.positive and not float(np.asarray(p.value)) > 0:
            raise InputError(
                f"{self.owner}: parameter '{p.name}' ({p.meaning}) must be positive, got {p.value}"
            )

    def __getitem__(self, name: str) -> Parameter:
        try:
            return self._parameters[name]
        except KeyError:
            raise InputError(f"{self.owner}: unknown parameter '{name}'") from None

    def __contains__(self, name: object) -> bool:
        return name in self._parameters

    def __iter__(self):
        return iter(self._parameters)

    def __len__(self) -> int:
        return len(self._parameters)

    def namespace(self) -> dict[str, Any]:
        """The values by name, as Brian2 needs them in a group's namespace."""
        return {name: p.value for name, p in self._parameters.items()}

    def with_values(self, **values: Any) -> "ParameterTable":
        """A copy with some values replaced; units must match the declared ones."""
        new = []
        for name in values:
            if name not in self._parameters:
                raise InputError(f"{self.owner}: unknown parameter '{name}'")
        for name, p in self._parameters.items():
            if name in values:
                value = values[name]
                if get_dimensions(value) != p.dimensions:
                    raise InputError(
                        f"{self.owner}: parameter '{name}' needs units of "
                        f"{_unit_text(p.value)}, got {value!r}"
                    )
                p = dataclasses.replace(p, value=value)
            new.append(p)
        return ParameterTable(self.owner, new)

    def rows(self) -> list[tuple[str, str, str, str]]:
        """(name, value with unit, symbol, meaning) rows, for printing and manifests."""
        return [(p.name, str(p.value), p.symbol, p.meaning) for p in self._parameters.values()]

    def to_json(self) -> dict[str, dict[str, str]]:
        return {
            p.name: {"value": str(p.value), "symbol": p.symbol, "meaning": p.meaning}
            for p in self._parameters.values()
        }


def _unit_text(value: Any) -> str:
    dims = get_dimensions(value)
    return "1 (dimensionless)" if dims.is_dimensionless else str(brian2.get_unit(dims))


@dataclass(frozen=True, kw_only=True)
class NeuronModel:
    """A population model: what a Brian2 ``NeuronGroup`` needs, and its parameters.

    equations: the Brian2 equation string.
    parameters: its :class:`ParameterTable`.
    threshold, reset: Brian2 spike condition and reset statements, or None.
    refractory: a parameter name (or expression) for the refractory period, or None.
    method: integration method (a Brian2 method name or a ``StateUpdateMethod``).
    initial_values: initial state by variable name (others start at 0).
    """

    name: str
    equations: str
    parameters: ParameterTable
    threshold: str | None = None
    reset: str | None = None
    refractory: str | None = None
    method: Any = "euler"
    initial_values: Mapping[str, Any] = field(default_factory=dict)
    description: str = ""

    def __post_init__(self) -> None:
        _parse_equations(self.name, self.equations)

    def replace(self, **changes: Any) -> "NeuronModel":
        """A copy with fields replaced (e.g. ``equations=...``) and validated."""
        return dataclasses.replace(self, **changes)

    def with_values(self, **values: Any) -> "NeuronModel":
        return self.replace(parameters=self.parameters.with_values(**values))

    def brian_equations(self) -> Equations:
        return _parse_equations(self.name, self.equations)


@dataclass(frozen=True, kw_only=True)
class SynapseModel:
    """A projection model: what a Brian2 ``Synapses`` needs, and its parameters.

    model: the synapse equation string (may hold ``(summed)`` variables).
    on_pre: statements run for each presynaptic spike, or None.
    weight: an expression for the initial weight ``w`` (evaluated per synapse), or None.
    on_step: statements run once per step after the robot has moved (the weight update of a
        learning rule), or None.
    """

    name: str
    model: str
    parameters: ParameterTable
    on_pre: str | None = None
    weight: str | None = None
    on_step: str | None = None
    method: Any = "euler"
    description: str = ""

    def __post_init__(self) -> None:
        _parse_equations(self.name, self.model)

    def replace(self, **changes: Any) -> "SynapseModel":
        return dataclasses.replace(self, **changes)

    def with_values(self, **values: Any) -> "SynapseModel":
        return self.replace(parameters=self.parameters.with_values(**values))


@dataclass(frozen=True, kw_only=True)
class ExpressionModel:
    """A model evaluated outside Brian2's groups, once per step for all trials (vectorised):
    an expression string over named inputs and its parameters (e.g. the reward).
    """

    name: str
    expression: str
    inputs: tuple[str, ...]
    parameters: ParameterTable
    description: str = ""

    def __post_init__(self) -> None:
        self.compile()

    def replace(self, **changes: Any) -> "ExpressionModel":
        return dataclasses.replace(self, **changes)

    def with_values(self, **values: Any) -> "ExpressionModel":
        return self.replace(parameters=self.parameters.with_values(**values))

    def compile(self) -> Callable[..., Any]:
        """A numpy function of the inputs (keywords), with parameters bound as plain SI
        floats: the expression is parsed against a whitelist and compiled, never evaluated as
        text (:func:`astrocpg.models.values.compile_expression`)."""
        # plain SI floats: the inputs arrive in SI (m/s, rad, rad/s)
        consts = {n: float(np.asarray(p.value)) for n, p in self.parameters.items()}
        return compile_expression(self.expression, owner=self.name, inputs=self.inputs,
                                  constants=consts)


_IDENT = re.compile(r"^\s*d?([A-Za-z_]\w*)")


def _parse_equations(owner: str, text: str) -> Equations:
    try:
        return Equations(text)
    except Exception as e:  # Brian2 raises EquationError / SyntaxError / ValueError
        first = str(e).strip().splitlines()[0] if str(e).strip() else type(e).__name__
        raise InputError(f"{owner}: equation string is invalid: {first}") from None


def brian_error_line(err: BaseException) -> str:
    """The most specific one-line message in a Brian2 exception chain."""
    messages = []
    while err is not None:
        text = str(err).strip()
        if text:
            messages.append(text)
        err = err.__cause__ or err.__context__
    for text in reversed(messages):
        # the root cause usually names the expression and the units
        line = " ".join(text.split())
        if line:
            return line[:400]
    return "unknown error"


__all__ = [
    "Parameter",
    "ParameterTable",
    "NeuronModel",
    "SynapseModel",
    "ExpressionModel",
    "brian_error_line",
    "DimensionMismatchError",
]
