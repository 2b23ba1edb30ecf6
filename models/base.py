"""The contract every model of astrocpg honours.

A model is its code strings (Brian2 equations and statements, or an expression) plus a parameter
table. Each parameter has a name (used in the code and on the command line), a value with
physical units, the paper's symbol and a one-line meaning.

:class:`Model` is the one contract, as Nengo's ``NeuronType``: ``name``, ``parameters``,
``description``; ``kind`` and ``code_field`` (the name of the main code string), so callers never
branch on class names; :meth:`Model.replace`, :meth:`Model.with_values`, :meth:`Model.with_code`
(validated copies, errors name ``<model>.<attribute>``); :meth:`Model.statements` (every code
string by role) and :meth:`Model.to_json` / :meth:`Model.from_json` (everything needed to rebuild
the model: statements, integration method by registered name, initial values with units,
inputs, the parameter table). :class:`NeuronModel`, :class:`SynapseModel` and
:class:`ExpressionModel` only declare their fields. Models are immutable.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass, field
from typing import Any, Callable, ClassVar, Iterable, Mapping

import numpy as np
from brian2 import Equations
from brian2.units.fundamentalunits import (
    DimensionMismatchError,
    Quantity,
    get_dimensions,
    get_or_create_dimension,
)

from ..errors import InputError, did_you_mean, setting
from .integration import method_name, registered_methods
from .names import check_parameter_names
from .expressions import compile_expression
from .units import example_value, unit_spelling


@dataclass(frozen=True, kw_only=True)
class Parameter:
    """One model parameter.

    name: identifier used in the equation strings (and by an override ``NAME=VALUE``).
    value: the value, a Brian2 quantity or a plain number for dimensionless parameters.
    symbol: the paper's symbol (LaTeX), so the table can be checked against the paper.
    meaning: one line saying what the parameter is, and where the value comes from when it is
        not the paper's table (e.g. docs/model.md).
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

    def to_json(self) -> dict[str, Any]:
        """``value`` (text with unit, for people), ``symbol``, ``meaning``, ``positive``, and the
        exact value: ``si_value`` (in SI) and ``dimensions`` (SI base exponents, quantities
        only)."""
        return {"value": str(self.value), "symbol": self.symbol, "meaning": self.meaning,
                "positive": bool(self.positive), **_exact_json(self.value)}

    @classmethod
    def from_json(cls, name: str, data: Mapping[str, Any], culprit: str) -> "Parameter":
        if not isinstance(data, Mapping):
            raise InputError(f"expected a parameter entry, got {type(data).__name__}",
                             culprit=culprit)
        # as read: ParameterTable checks the types (bool("false") would be True)
        return cls(name=name, value=_value_from_json(data, culprit),
                   symbol=data.get("symbol", ""), meaning=data.get("meaning", ""),
                   positive=data.get("positive", False))


class ParameterTable(Mapping[str, Parameter]):
    """An ordered, validated table of :class:`Parameter` of one model. Errors name
    ``<owner>.<parameter>``."""

    def __init__(self, owner: str, parameters: Iterable[Parameter]):
        self.owner = owner
        self._parameters: dict[str, Parameter] = {}
        for p in parameters:
            if not isinstance(p, Parameter):
                raise InputError(f"expected a Parameter, got {type(p).__name__}",
                                 culprit=f"{owner}.parameters")
            if p.name in self._parameters:
                raise InputError("is declared twice", culprit=f"{owner}.{p.name}")
            self._parameters[p.name] = p
        for p in self._parameters.values():
            self._check(p)

    def _check(self, p: Parameter) -> None:
        culprit = f"{self.owner}.{p.name}"
        if not isinstance(p.name, str) or not p.name.isidentifier():
            raise InputError(f"a parameter's name must be an identifier, got {p.name!r}",
                             culprit=culprit)
        if isinstance(p.value, (str, bytes)) or np.asarray(p.value).dtype.kind not in "biuf":
            raise InputError(f"must be a number or a quantity, got {p.value!r}", culprit=culprit)
        if not np.all(np.isfinite(np.asarray(p.value, dtype=float))):
            raise InputError(f"must be finite, got {p.value}", culprit=culprit)
        if not isinstance(p.positive, (bool, np.bool_)):
            # bool("false") is True: a flag is a boolean, never text or a number
            raise InputError(f"'positive' must be true or false, got {p.positive!r}",
                             culprit=culprit)
        for key in ("symbol", "meaning"):
            if not isinstance(getattr(p, key), str):
                raise InputError(f"'{key}' must be text, got {getattr(p, key)!r}",
                                 culprit=culprit)
        if p.positive and not float(np.asarray(p.value)) > 0:
            raise InputError(f"must be positive ({p.meaning}), got {p.value}", culprit=culprit)

    def __getitem__(self, name: str) -> Parameter:
        try:
            return self._parameters[name]
        except KeyError:
            raise InputError(f"unknown parameter{did_you_mean(name, self._parameters)}",
                             culprit=f"{self.owner}.{name}") from None

    def __contains__(self, name: object) -> bool:
        return name in self._parameters

    def __iter__(self):
        return iter(self._parameters)

    def __len__(self) -> int:
        return len(self._parameters)

    def __repr__(self) -> str:
        return f"ParameterTable({self.owner!r}, {list(self._parameters.values())!r})"

    def namespace(self) -> dict[str, Any]:
        """The values by name, as Brian2 needs them in a group's namespace."""
        return {name: p.value for name, p in self._parameters.items()}

    def with_values(self, **values: Any) -> "ParameterTable":
        """A copy with some values replaced; units must match the declared ones."""
        new = []
        for name in values:
            if name not in self._parameters:
                raise InputError(f"unknown parameter{did_you_mean(name, self._parameters)}",
                                 culprit=f"{self.owner}.{name}")
        for name, p in self._parameters.items():
            if name in values:
                value = values[name]
                if _dimensions_or_none(value) != p.dimensions:
                    raise InputError(f"needs units of {unit_spelling(p.value)}, e.g. "
                                     f"{example_value(p.value)}; got {value!r}",
                                     culprit=f"{self.owner}.{name}")
                p = dataclasses.replace(p, value=value)
            new.append(p)
        return ParameterTable(self.owner, new)

    def rows(self) -> list[tuple[str, str, str, str]]:
        """(name, value with unit, symbol, meaning) rows, for printing and manifests."""
        return [(p.name, str(p.value), p.symbol, p.meaning) for p in self._parameters.values()]

    def to_json(self) -> dict[str, dict[str, Any]]:
        return {p.name: p.to_json() for p in self._parameters.values()}

    @classmethod
    def from_json(cls, owner: str, data: Mapping[str, Any]) -> "ParameterTable":
        if not isinstance(data, Mapping):
            raise InputError(f"expected a table of parameters, got {type(data).__name__}",
                             culprit=f"{owner}.parameters")
        return cls(owner, [Parameter.from_json(name, entry, f"{owner}.{name}")
                           for name, entry in data.items()])


def _dimensions_or_none(value: Any) -> Any:
    """The value's dimensions, or None when it is not a number or a quantity (e.g. text)."""
    if isinstance(value, (str, bytes)):
        return None
    try:
        return get_dimensions(value)
    except TypeError:
        return None


# ---- values in JSON: the text for people, the exact SI number and base dimensions to rebuild

_BASE_DIMENSIONS = ("m", "kg", "s", "A", "K", "mol", "cd")  # Brian2's order


def _exact_json(value: Any) -> dict[str, Any]:
    """``{"si_value": ..., "dimensions": {...}}`` of a quantity, ``{"si_value": ...}`` of a plain
    number (an int stays an int), ``{"expression": ...}`` of a Brian2 expression string."""
    if isinstance(value, str):
        return {"expression": value}
    arr = np.asarray(value)
    si = arr.tolist()  # exact: Python floats/ints (lists for arrays)
    if not isinstance(value, Quantity):
        return {"si_value": si}
    dims = {}
    for symbol, exponent in zip(_BASE_DIMENSIONS, get_dimensions(value)._dims):
        exponent = float(exponent)
        if exponent:
            dims[symbol] = int(exponent) if exponent.is_integer() else exponent
    return {"si_value": si, "dimensions": dims}


def _value_to_json(value: Any) -> dict[str, Any]:
    """An initial value: its text (with unit) and its exact form (see :func:`_exact_json`)."""
    if isinstance(value, str):
        return {"value": value, "expression": value}
    return {"value": str(value), **_exact_json(value)}


def _value_from_json(data: Any, culprit: str) -> Any:
    if not isinstance(data, Mapping):
        raise InputError(f"expected a value entry, got {type(data).__name__}", culprit=culprit)
    if "expression" in data:
        return str(data["expression"])
    if "si_value" not in data:
        raise InputError("has no si_value (the exact value to rebuild it from)", culprit=culprit)
    si = data["si_value"]
    if isinstance(si, bool) or np.asarray(si).dtype.kind not in "iuf":
        raise InputError(f"si_value must be a number, got {si!r}", culprit=culprit)
    if "dimensions" not in data:
        return si if not isinstance(si, list) else np.asarray(si)
    dims = data["dimensions"]
    if not isinstance(dims, Mapping) or set(dims) - set(_BASE_DIMENSIONS) or any(
            isinstance(v, bool) or not isinstance(v, (int, float)) for v in dims.values()):
        raise InputError(f"dimensions must map {', '.join(_BASE_DIMENSIONS)} to exponents, "
                         f"got {dims!r}", culprit=culprit)
    return Quantity(si, dim=get_or_create_dimension(**{k: float(v) for k, v in dims.items()}))


# ---- what a model and the framework agree on

@dataclass(frozen=True)
class TraceSource:
    """A recordable trace of a model: the group's ``variable``, the ``factor`` from Brian2's SI
    value to the stored unit, the stored unit's text (``uM``, ``mV``, ``a.u.`` ...) and what it
    means (the NWB export's description)."""

    variable: str
    factor: float
    unit: str
    meaning: str

    def to_json(self) -> dict[str, Any]:
        return {"variable": self.variable, "factor": self.factor, "unit": self.unit,
                "meaning": self.meaning}


@dataclass(frozen=True)
class Interface:
    """What the framework may touch on a model slot, declared once in the model's module as
    ``INTERFACE`` (NESTML style: the model states what it offers and what it lets the
    framework read). It is the single list the framework reads from: a model file for the slot
    is refused unless it declares every ``variables`` and ``parameters`` name
    (``astrocpg.models.files.check_interface``), and
    :meth:`astrocpg.models.ModelSet.value` refuses a parameter not listed in ``parameters``.

    variables: state variables the network reads or sets on the model's group (Brian2 models).
    inputs: what the network gives an expression model (a file may use no others, and need not
        use all of them).
    parameters: parameters the framework reads by name (``ModelSet.value``) or sets by name
        (the astrocyte ablation, the frozen weights of ``astrocpg power``).
    optional: parameters the framework reads when the model declares them, and does without
        otherwise (the inter-limb delays: a pair of legs without one takes one step).
    traces: the state variables that can be recorded, trace name -> :class:`TraceSource`
        (stored unit, meaning); the population table's rows read them from here, and a model
        file for the slot must declare their variables too.
    """

    variables: tuple[str, ...] = ()
    inputs: tuple[str, ...] = ()
    parameters: tuple[str, ...] = ()
    optional: tuple[str, ...] = ()
    traces: Mapping[str, TraceSource] = field(default_factory=dict, compare=False)

    @property
    def state_variables(self) -> tuple[str, ...]:
        """The variables the network reads, sets or records, each once."""
        return tuple(dict.fromkeys(self.variables + tuple(s.variable for s in
                                                          self.traces.values())))

    def __iter__(self):
        """Every required name of the interface: variables (recorded ones too), inputs, then
        parameters."""
        return iter(self.state_variables + self.inputs + self.parameters)

    def __str__(self) -> str:
        """One line for ``astrocpg models list``: ``variables: ...; parameters: ...``."""
        parts = [f"{label}: {', '.join(names)}" for label, names in (
            ("variables", self.state_variables), ("inputs", self.inputs),
            ("parameters", self.parameters)) if names]
        if self.optional:
            parts.append(f"optional: {len(self.optional)} ({self.optional[0]}, ...)")
        return "; ".join(parts) or "-"

    def readable(self) -> tuple[str, ...]:
        """The parameters :meth:`astrocpg.models.ModelSet.value` may read."""
        return self.parameters + self.optional

    def __bool__(self) -> bool:
        return bool(self.variables or self.inputs or self.parameters or self.optional
                    or self.traces)


# ---- the model contract

_KINDS: dict[str, type["Model"]] = {}


def model_kinds() -> dict[str, type["Model"]]:
    """The model classes by kind ("neuron", "synapse", "expression")."""
    return dict(_KINDS)


@dataclass(frozen=True, kw_only=True)
class Model:
    """What every model is and does (subclasses declare their fields only).

    name: the model's name (errors read ``<name>.<attribute>: ...``).
    parameters: its :class:`ParameterTable`.
    description: what it models and where it comes from (the paper, docs/model.md).

    Class attributes: ``kind`` (``"neuron"``, ``"synapse"``, ``"expression"``), ``code_field``
    (the name of the main code string: ``equations``, ``model`` or ``expression``) and
    ``statement_fields`` (every code string, by role).
    """

    kind: ClassVar[str] = ""
    code_field: ClassVar[str] = ""
    statement_fields: ClassVar[tuple[str, ...]] = ()

    name: str
    parameters: ParameterTable
    description: str = ""

    def __init_subclass__(cls, **kwargs: Any) -> None:
        super().__init_subclass__(**kwargs)
        if "kind" in cls.__dict__ and cls.kind:
            _KINDS[cls.kind] = cls

    def __post_init__(self) -> None:
        if not isinstance(self.name, str) or not self.name.isidentifier():
            raise InputError(f"a model's name must be an identifier, got {self.name!r}",
                             culprit=f"{type(self).__name__}.name")
        if not isinstance(self.parameters, ParameterTable):
            raise InputError(f"must be a ParameterTable, got {type(self.parameters).__name__}",
                             culprit=f"{self.name}.parameters")
        if not isinstance(self.description, str):
            raise InputError("must be text", culprit=f"{self.name}.description")
        for role in self.statement_fields:
            value = getattr(self, role)
            if value is None and role != self.code_field:
                continue
            if not isinstance(value, str):
                raise InputError(f"must be a code string, got {type(value).__name__}",
                                 culprit=f"{self.name}.{role}")
            if role != self.code_field and self.kind != "expression":
                _refuse_attribute_access(value, f"{self.name}.{role}")
        self._validate()
        # one name check for every model: a parameter named dt, ms, exp, pi or like one of
        # the model's own variables would never be the value the code reads
        check_parameter_names(self.name, self.parameters, self.own_names())

    def _validate(self) -> None:
        """Checks of the kind (equations parse, the expression compiles...)."""

    def own_names(self) -> dict[str, str]:
        """The names the model's code defines itself (state variables, subexpressions,
        inputs), each with what it is: a parameter may not take one of them."""
        return {}

    # ---- the contract

    @property
    def code(self) -> str:
        """The main code string (``getattr(model, model.code_field)``)."""
        return getattr(self, self.code_field)

    def replace(self, **changes: Any) -> "Model":
        """A validated copy with fields replaced (e.g. ``equations=...``, ``method=...``)."""
        allowed = [f.name for f in dataclasses.fields(self) if f.init]
        for key in changes:
            if key not in allowed:
                raise InputError(f"no such attribute of a {self.kind} model "
                                 f"(attributes: {', '.join(allowed)})",
                                 culprit=f"{self.name}.{key}")
        return dataclasses.replace(self, **changes)

    def with_values(self, **values: Any) -> "Model":
        """A copy with parameter values replaced by name (units must match)."""
        return self.replace(parameters=self.parameters.with_values(**values))

    def with_code(self, text: str) -> "Model":
        """A copy with the main code string (``code_field``) replaced, e.g. an edited equation
        string given as ``equations`` (``MODEL=FILE``), whatever the kind of model."""
        return self.replace(**{self.code_field: text})

    def statements(self) -> dict[str, str]:
        """Every code string of the model by role (equations/model/expression, threshold,
        reset, refractory, on_pre, weight, on_step), only those set."""
        return {role: getattr(self, role) for role in self.statement_fields
                if getattr(self, role)}

    def to_json(self) -> dict[str, Any]:
        """Everything needed to rebuild the model (:meth:`from_json`): ``kind``, ``name``, its
        statements by role, its other fields (``method`` by registered name, ``initial_values``
        with units, ``inputs``), ``description`` and the parameter table."""
        out: dict[str, Any] = {"kind": self.kind, "name": self.name, **self.statements()}
        for f in dataclasses.fields(self):
            if f.name in _BASE_FIELDS or f.name in self.statement_fields:
                continue
            value = getattr(self, f.name)
            if f.name == "initial_values":
                value = {var: _value_to_json(v) for var, v in value.items()}
            elif f.name == "senses":
                if not value:  # no sense bound: the entry as before the field existed
                    continue
                value = {var: b.to_json() for var, b in value.items()}
            elif isinstance(value, tuple):
                value = list(value)
            out[f.name] = value
        out["description"] = self.description
        out["parameters"] = self.parameters.to_json()
        return out

    @classmethod
    def from_json(cls, data: Mapping[str, Any], name: str | None = None) -> "Model":
        """The model :meth:`to_json` wrote. Called on :class:`Model`, ``data["kind"]`` picks the
        class; ``name`` (e.g. the key in a manifest) is used when ``data`` has none."""
        where = name or cls.__name__
        if not isinstance(data, Mapping):
            raise InputError(f"expected a model entry, got {type(data).__name__}", culprit=where)
        name = data.get("name", name)
        if not isinstance(name, str) or not name:
            raise InputError("a model entry needs a name", culprit=where)
        kind = data.get("kind", cls.kind)
        target = _KINDS.get(kind) if isinstance(kind, str) else None
        if target is None or not issubclass(target, cls):
            kinds = ", ".join(k for k, c in _KINDS.items() if issubclass(c, cls))
            raise InputError(f"unknown kind {kind!r}{did_you_mean(kind, kinds.split(', '))} "
                             f"(kinds: {kinds})", culprit=f"{name}.kind")
        fields = {f.name for f in dataclasses.fields(target) if f.init}
        kwargs: dict[str, Any] = {}
        for key, value in data.items():
            if key in ("kind", "name"):
                continue
            if key not in fields:
                raise InputError(f"no such attribute of a {kind} model", culprit=f"{name}.{key}")
            if key == "parameters":
                value = ParameterTable.from_json(name, value)
            elif key == "initial_values":
                if not isinstance(value, Mapping):
                    raise InputError("expected a table of values", culprit=f"{name}.{key}")
                value = {var: _value_from_json(v, f"{name}.initial_values.{var}")
                         for var, v in value.items()}
            kwargs[key] = value
        if "parameters" not in kwargs:
            raise InputError("a model entry needs its parameters", culprit=f"{name}.parameters")
        return target(name=name, **kwargs)


_BASE_FIELDS = ("name", "parameters", "description")


@dataclass(frozen=True, kw_only=True)
class BrianModel(Model):
    """A model Brian2 integrates (a group or a projection).

    method: the integration scheme, by registered name (Brian2's ``"euler"``,
        ``"exponential_euler"``..., or astrocpg's ``"input_then_decay"``). A registered scheme
        object is accepted and stored as its name.
    initial_values: initial state by variable name (others start at 0): numbers, quantities or
        Brian2 expression strings.
    """

    method: str = "euler"
    initial_values: Mapping[str, Any] = field(default_factory=dict)

    def _validate(self) -> None:
        name = method_name(self.method)
        if name is None:
            raise InputError(
                f"unknown integration method {self.method!r}"
                f"{did_you_mean(self.method, registered_methods())} (registered: "
                f"{', '.join(registered_methods())})", culprit=f"{self.name}.method")
        object.__setattr__(self, "method", name)
        equations = self.brian_equations()
        if not isinstance(self.initial_values, Mapping):
            raise InputError("must map variable names to values",
                             culprit=f"{self.name}.initial_values")
        for var, value in self.initial_values.items():
            culprit = f"{self.name}.initial_values.{var}"
            if var not in equations.names:
                raise InputError("is not a variable of the equations", culprit=culprit)
            if isinstance(value, str):
                continue
            dims = _dimensions_or_none(value)
            if dims is None:
                raise InputError(f"must be a number, a quantity or an expression, got "
                                 f"{value!r}", culprit=culprit)
            if dims != equations[var].dim:
                raise InputError(f"needs units of {unit_spelling(equations[var].dim)}, got "
                                 f"{value!r}", culprit=culprit)
        object.__setattr__(self, "initial_values", dict(self.initial_values))

    def own_names(self) -> dict[str, str]:
        from brian2.equations.equations import DIFFERENTIAL_EQUATION, SUBEXPRESSION
        what = {DIFFERENTIAL_EQUATION: "a state variable of the equations",
                SUBEXPRESSION: "a subexpression of the equations"}
        return {name: what.get(eq.type, "a variable declared in the equations")
                for name, eq in self.brian_equations().items()}

    def brian_equations(self) -> Equations:
        """The main code string, parsed by Brian2."""
        return _parse_equations(self.name, self.code, self.code_field)


@dataclass(frozen=True, kw_only=True)
class NeuronModel(BrianModel):
    """A population model: what a Brian2 ``NeuronGroup`` needs, and its parameters.

    equations: the Brian2 equation string.
    threshold, reset: Brian2 spike condition and reset statements, or None.
    refractory: a parameter name (or expression) for the refractory period, or None.
    senses: robot senses the coupling writes into variables of the equations after every
        physics step, variable -> sense name or ``{sense, only}``
        (:mod:`astrocpg.models.senses`: the senses, their units, ``only``).
    """

    kind: ClassVar[str] = "neuron"
    code_field: ClassVar[str] = "equations"
    statement_fields: ClassVar[tuple[str, ...]] = ("equations", "threshold", "reset",
                                                   "refractory")

    equations: str
    threshold: str | None = None
    reset: str | None = None
    refractory: str | None = None
    senses: Mapping[str, Any] = field(default_factory=dict)

    def _validate(self) -> None:
        super()._validate()
        object.__setattr__(self, "senses", _sense_bindings(self))


@dataclass(frozen=True, kw_only=True)
class SynapseModel(BrianModel):
    """A projection model: what a Brian2 ``Synapses`` needs, and its parameters.

    model: the synapse equation string (may hold ``(summed)`` variables; may be empty).
    on_pre: statements run for each presynaptic spike, or None.
    weight: an expression for the initial weight ``w`` (evaluated per synapse), or None.
    on_step: statements run once per step after the robot has moved (the weight update of a
        learning rule), or None.
    """

    kind: ClassVar[str] = "synapse"
    code_field: ClassVar[str] = "model"
    statement_fields: ClassVar[tuple[str, ...]] = ("model", "on_pre", "weight", "on_step")

    model: str = ""
    on_pre: str | None = None
    weight: str | None = None
    on_step: str | None = None


@dataclass(frozen=True, kw_only=True)
class ExpressionModel(Model):
    """A model evaluated outside Brian2's groups, once per step for all trials (vectorised):
    an expression string over named inputs and its parameters (e.g. the reward).
    """

    kind: ClassVar[str] = "expression"
    code_field: ClassVar[str] = "expression"
    statement_fields: ClassVar[tuple[str, ...]] = ("expression",)

    expression: str
    inputs: tuple[str, ...]

    def _validate(self) -> None:
        inputs = (self.inputs,) if isinstance(self.inputs, str) else self.inputs
        try:
            inputs = tuple(inputs)
        except TypeError:
            raise InputError("must be a sequence of input names",
                             culprit=f"{self.name}.inputs") from None
        for item in inputs:
            if not isinstance(item, str) or not item.isidentifier():
                raise InputError(f"an input name must be an identifier, got {item!r}",
                                 culprit=f"{self.name}.inputs")
        object.__setattr__(self, "inputs", inputs)
        self.compile()

    def own_names(self) -> dict[str, str]:
        # compile_expression lets an input shadow a parameter of the same name
        return {name: "an input of the expression" for name in self.inputs}

    def compile(self) -> Callable[..., Any]:
        """A numpy function of the inputs (keywords), with parameters bound as plain SI
        floats: the expression is parsed against a whitelist and compiled, never evaluated as
        text (:func:`astrocpg.models.expressions.compile_expression`)."""
        # plain SI floats: the inputs arrive in SI (m/s, rad, rad/s)
        consts = {n: float(np.asarray(p.value)) for n, p in self.parameters.items()}
        return compile_expression(self.expression, owner=self.name, inputs=self.inputs,
                                  constants=consts)


@dataclass(frozen=True, kw_only=True)
class WorldModel(Model):
    """The robot's surroundings (ground, gravity, load, disturbances): a parameter table only,
    read by the coupling when it builds the robot and steps it. It has no code string."""

    kind: ClassVar[str] = "world"
    code_field: ClassVar[str] = ""
    statement_fields: ClassVar[tuple[str, ...]] = ()

    @property
    def code(self) -> str:
        return ""

    def with_code(self, text: str) -> "Model":
        raise InputError(f"has no code string to replace (set its values with "
                         f"{setting('overrides')})",
                         culprit=self.name)


def _refuse_attribute_access(code: str, culprit: str) -> None:
    """Brian2's statements and conditions (threshold, reset, on_pre, ...) name variables and
    functions directly; ``a.b`` or ``exp.exp(x)`` got as far as Brian2's code generation,
    which failed with "'Attribute' object has no attribute 'id'". Refused here, naming the
    field and the text. Code that is not Python (Brian2's own syntax) is left to Brian2."""
    import ast

    for part in code.replace(";", "\n").splitlines():
        part = part.split("#", 1)[0].strip()
        if not part:
            continue
        try:
            tree = ast.parse(part)
        except (SyntaxError, ValueError, RecursionError, MemoryError):
            continue
        for node in ast.walk(tree):
            if isinstance(node, ast.Attribute):
                raise InputError(f"'{part}': '.{node.attr}' (attribute access) is not part of "
                                 f"Brian2's code strings; name variables and functions "
                                 f"directly, e.g. exp(x)", culprit=culprit)


def _equation_error(e: BaseException) -> str:
    """Brian2's parse error in one line with the text it stopped at: its message is
    "Parsing failed:" then the line, a caret and pyparsing's reason on lines of their own."""
    cause = e.__cause__
    line, col = getattr(cause, "line", None), getattr(cause, "col", None)
    if isinstance(line, str) and isinstance(col, int):  # a pyparsing ParseException
        reason = str(cause).split("  (at char")[0].strip() or "cannot be read"
        at = line[col - 1:col + 19].strip() or "the end"
        return (f"cannot parse line {getattr(cause, 'lineno', '?')}, column {col}: "
                f"'{line.strip()}' ({reason}; at '{at}')")
    text = " ".join(str(e).split())  # every line, not only the first
    return text or type(e).__name__


def _sense_bindings(model: "NeuronModel") -> dict[str, Any]:
    """The model's ``senses`` checked against its equations: each bound variable is a plain
    variable of the equations (no ``d/dt``, no flag: the coupling writes it every step) in the
    sense's unit, and each sense is one the robot offers (:data:`ROBOT_SENSES`)."""
    from brian2.equations.equations import PARAMETER

    from .senses import ROBOT_SENSES, parse_binding

    if not isinstance(model.senses, Mapping):
        raise InputError('must map variables to robot senses (variable = "sense")',
                         culprit=f"{model.name}.senses")
    if not model.senses:
        return {}
    equations = model.brian_equations()
    out = {}
    for var, entry in model.senses.items():
        culprit = f"{model.name}.senses.{var}"
        binding = parse_binding(entry, culprit)
        sense = ROBOT_SENSES[binding.sense]
        if var not in equations.names:
            raise InputError(f"is not a variable of the equations: declare it as "
                             f"'{var} : {sense.unit_text}'", culprit=culprit)
        eq = equations[var]
        if eq.type != PARAMETER or eq.flags:
            raise InputError(f"must be a plain variable ('{var} : {sense.unit_text}', no d/dt, "
                             f"no flag): the coupling writes it every step", culprit=culprit)
        if eq.dim != get_dimensions(sense.unit):
            raise InputError(f"is declared in {unit_spelling(eq.dim)}, but the sense "
                             f"'{binding.sense}' is in {sense.unit_text}", culprit=culprit)
        out[var] = binding
    return out


def _parse_equations(owner: str, text: str, role: str = "equations") -> Equations:
    if not isinstance(text, str):
        raise InputError(f"must be a code string, got {type(text).__name__}",
                         culprit=f"{owner}.{role}")
    try:
        return Equations(text)
    except Exception as e:  # Brian2 raises EquationError / SyntaxError / ValueError
        raise InputError(f"equation string is invalid: {_equation_error(e)}",
                         culprit=f"{owner}.{role}") from None


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
    "Interface",
    "Parameter",
    "ParameterTable",
    "Model",
    "BrianModel",
    "NeuronModel",
    "SynapseModel",
    "ExpressionModel",
    "brian_error_line",
    "DimensionMismatchError",
]
