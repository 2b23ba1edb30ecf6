"""Model files: one model, whole, as TOML (``astrocpg models dump NAME`` writes one, the
``models`` setting, ``NAME=FILE``, reads one back).

A file holds ``name``, ``kind`` (neuron, synapse, expression), ``description``, the model's code
strings (``equations``, ``threshold``, ``reset``, ``refractory`` of a neuron; ``model``,
``on_pre``, ``weight``, ``on_step`` of a synapse; ``expression`` and ``inputs`` of an expression),
``method``, a ``[senses]`` table of a neuron model (robot senses bound to variables:
:mod:`astrocpg.models.senses`), an ``[initial_values]`` table (``VAR = { value = "0.16*umolar" }`` or ``{ expression
= "rand()" }``) and a ``[parameters]`` table, one inline table per parameter::

    tau_extra = { value = "2*second", symbol = "\\\\tau_x", meaning = "...", positive = true }

Values are parsed (:func:`~astrocpg.models.units.parse_value`), never evaluated. A file may
declare new parameters and new state variables; it must keep the model's *interface*: the names
the network reads or sets (:data:`astrocpg.models.INTERFACES`).
"""

from __future__ import annotations

import dataclasses

import hashlib
import json
import tomllib
from typing import Any, Mapping

import numpy as np
from brian2 import Quantity

from ..errors import InputError, did_you_mean, setting
from ..support.reading import loads_toml
from .base import BrianModel, Interface, Model, Parameter, ParameterTable, model_kinds
from .units import parse_value, unit_spelling


def file_sha256(text: str) -> str:
    return hashlib.sha256(text.encode("utf-8")).hexdigest()


# ---- writing

def _toml_string(text: str) -> str:
    """A TOML string holding ``text`` exactly: a multi-line literal string when that is safe
    (readable equations), else a basic string (JSON escapes are TOML escapes)."""
    if "\n" in text and "'''" not in text and not text.endswith("'") and all(
            c in "\n\t" or (ord(c) >= 0x20 and ord(c) != 0x7f) for c in text):
        return "'''\n" + text + "'''"
    return json.dumps(text, ensure_ascii=False)


def value_text(value: Any) -> str:
    """``value`` written so that :func:`parse_value` reads back the same number: Brian2's own
    spelling (``0.16 * umolar`` style) when it reads back exactly, else the SI number and unit."""
    if not isinstance(value, Quantity):
        if isinstance(value, (bool, np.bool_)):
            value = int(value)
        return repr(value.item() if isinstance(value, np.generic) else value)
    candidates = [str(value)]
    x = float(np.asarray(value))
    for unit, scale in _units_of(value.dim):  # the shortest spelling that reads back exactly
        scaled = x / scale
        if scaled == 0 or 1e-3 <= abs(scaled) < 1e4:
            candidates += [f"{scaled:.{p}g}*{unit}" for p in range(1, 18)]
    candidates.sort(key=len)
    candidates.append(f"{x!r}*{unit_spelling(value.dim)}")
    if value.dim.is_dimensionless:
        candidates = [repr(float(np.asarray(value)))]
    for text in candidates:
        try:
            back = parse_value(text, culprit="value")
        except InputError:
            continue
        if (np.asarray(back).tolist() == np.asarray(value).tolist()
                and getattr(back, "dim", None) == value.dim):
            return text
    # the SI number with the SI base unit spelling
    return f"{float(np.asarray(value))!r}*{unit_spelling(value.dim)}"


_UNITS: dict[Any, list[Any]] = {}


def _units_of(dim: Any) -> list[Any]:
    """Brian2's named units (``umolar``, ``ms``, ``mV``...) of these dimensions."""
    if not _UNITS:
        from brian2 import Unit
        from brian2.units import allunits
        names = {k for k, u in vars(allunits).items() if isinstance(u, Unit)}

        def usual(key: str) -> bool:  # no centi-, deci-, hecto-, exa-... units
            return not ((key[:1] in "cdhazyfEPGTZY" and key[1:] in names)
                        or (key[:2] == "da" and key[2:] in names))

        for key, unit in vars(allunits).items():
            if isinstance(unit, Unit) and key.isidentifier() and usual(key):
                _UNITS.setdefault(unit.dim, []).append((key, float(unit)))
    return _UNITS.get(dim, [])


def model_to_toml(model: Model) -> str:
    """The model as a model file (see the module's doc); :func:`model_from_toml` reads it
    back to an equal model."""
    lines = [f"name = {_toml_string(model.name)}", f"kind = {_toml_string(model.kind)}"]
    for role in model.statement_fields:
        value = getattr(model, role)
        if value is not None:
            lines.append(f"{role} = {_toml_string(value)}")
    if isinstance(model, BrianModel):
        lines.append(f"method = {_toml_string(model.method)}")
    inputs = getattr(model, "inputs", None)
    if inputs is not None:
        lines.append("inputs = [" + ", ".join(_toml_string(i) for i in inputs) + "]")
    lines.append(f"description = {_toml_string(model.description)}")
    if isinstance(model, BrianModel):
        lines += ["", "[initial_values]"]
        for var, value in model.initial_values.items():
            key = "expression" if isinstance(value, str) else "value"
            text = value if isinstance(value, str) else value_text(value)
            lines.append(f"{var} = {{ {key} = {_toml_string(text)} }}")
    senses = getattr(model, "senses", None)
    if senses:
        lines += ["", "[senses]"]
        for var, binding in senses.items():
            only = ", ".join(_toml_string(x) for x in binding.only)
            lines.append(f"{var} = {_toml_string(binding.sense)}" if not binding.only else
                         f"{var} = {{ sense = {_toml_string(binding.sense)}, only = [{only}] }}")
    lines += ["", "[parameters]"]
    for p in model.parameters.values():
        entry = (f"value = {_toml_string(value_text(p.value))}, "
                 f"symbol = {_toml_string(p.symbol)}, meaning = {_toml_string(p.meaning)}")
        if p.positive:
            entry += ", positive = true"
        lines.append(f"{p.name} = {{ {entry} }}")
    return "\n".join(lines) + "\n"


# ---- reading

def _text_value(entry: Any, culprit: str) -> Any:
    if isinstance(entry, bool):
        raise InputError(f"must be a number or text with units, got {entry!r}", culprit=culprit)
    if isinstance(entry, (int, float)):
        return entry
    if not isinstance(entry, str):
        raise InputError(f"must be text with units such as \"2*second\", got {entry!r}",
                         culprit=culprit)
    return parse_value(entry, culprit=culprit)


def _typed(entry: Mapping[str, Any], key: str, kind: type, what: str, culprit: str) -> None:
    """Refuse ``entry[key]`` (when present) unless it is of TOML type ``kind``: a flag is a
    boolean, never the text "false" (which Python's ``bool`` reads as true)."""
    if key in entry and not isinstance(entry[key], kind):
        raise InputError(f"'{key}' must be {what}, got {entry[key]!r}", culprit=culprit)


def _declared_twice(text: str) -> str | None:
    """``table.key`` of the first key written twice in a table (TOML refuses it; we name it)."""
    import re
    section, seen = "", set()
    in_string = False
    for line in text.splitlines():
        if line.count("'''") % 2 or line.count('"""') % 2:
            in_string = not in_string
            continue
        if in_string:
            continue
        head = re.match(r"\s*\[([^\]]+)\]\s*(#.*)?$", line)
        if head:
            section = head.group(1).strip()
            continue
        key = re.match(r"\s*([A-Za-z_][A-Za-z0-9_]*)\s*=", line)
        if key:
            name = f"{section}.{key.group(1)}" if section else key.group(1)
            if name in seen:
                return name
            seen.add(name)
    return None


def model_from_toml(text: str, *, culprit: str, default: Model | None = None) -> Model:
    """The model a model file holds. ``culprit`` (e.g. ``models astrocyte``) heads every
    error; ``default`` (the built-in model of that slot) gives the kind when the file has
    none. Every mistake is an :class:`InputError` of one line."""
    try:
        data = loads_toml(text, culprit)  # nesting bounded: refused before tomllib recurses
    except tomllib.TOMLDecodeError as e:
        twice = _declared_twice(text)
        if twice:
            raise InputError("is declared twice", culprit=f"{culprit}: {twice}") from None
        raise InputError(f"is not valid TOML: {e}", culprit=culprit) from None
    name = data.get("name", default.name if default else None)
    if not isinstance(name, str) or not name.isidentifier():
        raise InputError(f"'name' must be an identifier, got {name!r}", culprit=culprit)
    kind = data.get("kind", default.kind if default else None)
    kinds = model_kinds()
    target = kinds.get(kind) if isinstance(kind, str) else None
    if target is None:
        raise InputError(f"unknown kind {kind!r}{did_you_mean(kind, kinds)} (kinds: "
                         f"{', '.join(kinds)})", culprit=f"{culprit}: kind")
    fields = {f.name for f in dataclasses.fields(target) if f.init}
    kwargs: dict[str, Any] = {}
    for key, value in data.items():
        if key in ("name", "kind"):
            continue
        where = f"{culprit}: {key}"
        if key not in fields:
            raise InputError(f"no such attribute of a {kind} model (attributes: "
                             f"{', '.join(sorted(fields - {'name'}))})", culprit=where)
        if key == "parameters":
            if not isinstance(value, Mapping):
                raise InputError("must be a table of parameters", culprit=where)
            params = []
            for pname, entry in value.items():
                pwhere = f"{culprit}: parameters.{pname}"
                if not isinstance(entry, Mapping) or "value" not in entry:
                    raise InputError('expected { value = "...", symbol = "...", meaning = '
                                     '"..." }', culprit=pwhere)
                unknown = set(entry) - {"value", "symbol", "meaning", "positive"}
                if unknown:
                    keys = ("value", "symbol", "meaning", "positive")
                    first = sorted(unknown)[0]
                    raise InputError(f"unknown keys {sorted(unknown)}{did_you_mean(first, keys)} "
                                     f"({', '.join(keys)})", culprit=pwhere)
                _typed(entry, "symbol", str, "text", pwhere)
                _typed(entry, "meaning", str, "text", pwhere)
                _typed(entry, "positive", bool, "true or false (a TOML boolean)", pwhere)
                params.append(Parameter(name=pname, value=_text_value(entry["value"], pwhere),
                                        symbol=entry.get("symbol", ""),
                                        meaning=entry.get("meaning", ""),
                                        positive=entry.get("positive", False)))
            try:
                value = ParameterTable(name, params)
            except InputError as e:
                raise InputError(e.raw_line, culprit=culprit) from None
        elif key == "initial_values":
            if not isinstance(value, Mapping):
                raise InputError("must be a table of values", culprit=where)
            out = {}
            for var, entry in value.items():
                vwhere = f"{culprit}: initial_values.{var}"
                if isinstance(entry, Mapping) and set(entry) - {"value", "expression"}:
                    extra = sorted(set(entry) - {"value", "expression"})
                    raise InputError(f"unknown keys {extra}"
                                     f"{did_you_mean(extra[0], ('value', 'expression'))}"
                                     f" (value or expression)", culprit=vwhere)
                if isinstance(entry, Mapping) and "expression" in entry:
                    _typed(entry, "expression", str, "text (a Brian2 expression)", vwhere)
                    out[var] = entry["expression"]
                elif isinstance(entry, Mapping) and "value" in entry:
                    out[var] = _text_value(entry["value"], vwhere)
                else:
                    out[var] = _text_value(entry, vwhere)
            value = out
        elif key == "senses":
            if not isinstance(value, Mapping):
                raise InputError('must be a table of bindings (variable = "sense" or '
                                 '{ sense = "...", only = [...] })', culprit=where)
            value = dict(value)
        elif key == "inputs":
            if not isinstance(value, list) or not all(isinstance(v, str) for v in value):
                raise InputError("must be a list of input names (text)", culprit=where)
            value = tuple(value)
        elif not isinstance(value, str):  # description, method and every code string
            raise InputError(f"must be text, got {type(value).__name__} {value!r}",
                             culprit=where)
        kwargs[key] = value
    if "parameters" not in kwargs:
        kwargs["parameters"] = ParameterTable(name, [])
    try:
        return target(name=name, **kwargs)
    except InputError as e:
        raise InputError(e.raw_line, culprit=culprit) from None
    except TypeError as e:  # a required field is missing
        raise InputError(f"incomplete model: {e}", culprit=culprit) from None


def check_interface(model: Model, interface: Interface | None, *, culprit: str) -> None:
    """Refuse a model that does not honour its slot's ``interface``
    (:data:`astrocpg.models.INTERFACES`): one that lacks a variable the network reads or sets
    or a parameter the framework reads by name, or uses an input the network does not give.
    One line naming the first missing names."""
    if not interface:
        return
    inputs = getattr(model, "inputs", None)
    if inputs is not None:
        extra = [i for i in inputs if i not in interface.inputs]
        if extra:
            raise InputError(f"uses inputs {extra} the network does not give (inputs: "
                             f"{', '.join(interface.inputs)})", culprit=culprit)
    names = set(model.brian_equations().names) if isinstance(model, BrianModel) else set()
    missing = [n for n in interface.state_variables if n not in names]
    missing += [n for n in interface.parameters if n not in model.parameters]
    if missing:
        raise InputError(f"lacks {', '.join(missing)}, which the framework reads or sets "
                         f"(interface: {', '.join(interface)})", culprit=culprit)


def check_parameters_used(model: Model, default: Model | None, *, culprit: str) -> None:
    """Refuse a parameter the model declares that nothing reads: not one of the built-in
    slot's parameters (``default``: those the network reads by name) and named by none of the
    model's code strings. An override of such a parameter would change nothing, yet the manifest
    would record the value."""
    from brian2.utils.stringtools import get_identifiers

    known = set(default.parameters) if default is not None else set()
    used: set[str] = set()
    for text in model.statements().values():
        used |= get_identifiers(text)
    for name in model.parameters:
        if name not in known and name not in used:
            raise InputError("is declared but no code string of the model reads it (nor does "
                             f"the network): {setting('overrides')} on it would change nothing; "
                             f"use it or drop it",
                             culprit=f"{culprit}: parameters.{name}")


__all__ = ["model_to_toml", "model_from_toml", "check_interface", "check_parameters_used",
           "value_text", "file_sha256"]
