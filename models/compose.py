"""Model composition: the one place a :class:`~astrocpg.models.ModelSet` is made from what a
user gives: whole model files (``models``: ``NAME=FILE``, TOML), equation texts (``equations``:
``MODEL=FILE``) and ``NAME=VALUE`` overrides (``overrides``), each checked against its slot's
interface (:data:`astrocpg.models.INTERFACES`), plus the record of the model files used
(:func:`model_files_record`, for manifests). Commands compose a set once with
:func:`model_set` and hand it down; they read its values with
:meth:`~astrocpg.models.ModelSet.value`."""

from __future__ import annotations

from typing import Any, Iterable, Mapping, Sequence

from ..errors import Field, InputError, did_you_mean, setting, shown_with
from ..support.reading import read_bytes
from . import DEFAULT_MODELS, ModelSet

Overrides = Mapping[str, Any] | Sequence[str]


def override_items(overrides: Overrides | None) -> list[str]:
    """``NAME=VALUE`` strings from a list of them or a mapping ``{name: value}`` (a value may
    be a quantity, ``9*ms``, or its text, ``"9*ms"``)."""
    if not overrides:
        return []
    if isinstance(overrides, Mapping):
        return [f"{k}={_value_text(v)}" for k, v in overrides.items()]
    if isinstance(overrides, str):
        return [overrides]
    if isinstance(overrides, (bytes, bytearray)) or not isinstance(overrides, Iterable):
        raise InputError(f"expected NAME=VALUE texts or a mapping {{name: value}}, got "
                         f"{type(overrides).__name__}", culprit="overrides")
    items = list(overrides)
    for item in items:
        if not isinstance(item, str):
            raise InputError(f"expected NAME=VALUE texts (e.g. \"tau_motor=9*ms\"), got "
                             f"{item!r}", culprit="overrides")
    return items


def _value_text(value: Any) -> str:
    if isinstance(value, str):
        return value
    # a Brian2 quantity prints as "9. ms": a spelling the value parser reads back
    return repr(value) if isinstance(value, float) else str(value)


def read_equation_files(items: Sequence[str], option: str | Field = setting("equations"),
                        kind: str | None = None) -> dict[str, str]:
    """``MODEL=FILE`` items -> {model: text}; a file that is binary or not UTF-8 is an
    InputError naming the option and the file; one that cannot be read an EnvironmentFault
    (``kind``, of shipped files: a bare name that names none is an InputError naming the
    closest)."""
    out: dict[str, str] = {}
    for item in items:
        name, sep, file = item.partition("=")
        if not sep or not name or not file:
            raise InputError("expected MODEL=FILE", culprit=shown_with(option, f"'{item}'"))
        try:
            raw = read_bytes(file, shown_with(option, name))  # a FIFO is refused, never waited on
        except OSError as e:
            from ..support.shipped import unreadable
            raise unreadable(file, kind, e, culprit=shown_with(option, name)) from None
        try:
            text = raw.decode("utf-8")
        except UnicodeDecodeError:
            raise InputError(f"'{file}' is not UTF-8 text",
                             culprit=shown_with(option, name)) from None
        if "\x00" in text:
            raise InputError(f"'{file}' is a binary file, not an equation string",
                             culprit=shown_with(option, name))
        out[name] = text
    return out


def read_model_files(items: Sequence[str],
                     option: str | Field = setting("models")) -> dict[str, str]:
    """``MODEL=FILE`` items of model files (TOML) -> {model: text}, checked as
    :func:`read_equation_files` checks files, and each file read once as a model so that a
    mistake within it (a reserved or shadowing parameter name, a field of the wrong TOML type,
    a missing interface variable) names the file: ``models astrocyte (a.toml): ...``. What
    involves other models (a parameter another model declares) is checked by
    :func:`model_set`."""
    from . import INTERFACES
    from .files import check_interface, check_parameters_used, model_from_toml

    from ..support.shipped import resolve
    items = [f"{name}={resolve(file, 'model')}" if sep and file else item  # a shipped name
             for item in items for name, sep, file in [item.partition("=")]]
    texts = read_equation_files(items, option=option, kind="model")
    slots = dict(DEFAULT_MODELS.items())
    for item in items:
        name, _, file = item.partition("=")
        if name in slots:
            where = shown_with(option, f"{name} ({file})")
            model = model_from_toml(texts[name], culprit=where, default=slots[name])
            check_interface(model, INTERFACES.get(name, ()), culprit=where)
            try:  # a parameter another model declares
                DEFAULT_MODELS.replace(**{name: model})
            except InputError as e:
                raise InputError(e.raw_line, culprit=where) from None
            check_parameters_used(model, slots[name], culprit=where)
    return texts


def as_model_files(models: Any) -> Any:
    """A whole :class:`~astrocpg.models.ModelSet` given where model files are meant (``models=`` of the API) as
    ``{slot: model file text}`` of the slots whose model differs from the built-in one, so it
    is validated, recorded in the manifest and replayed like files; anything else unchanged."""
    if not isinstance(models, ModelSet):
        return models
    from .files import model_to_toml

    defaults = dict(DEFAULT_MODELS.items())
    out = {}
    for slot, model in models.items():
        if slot not in defaults:  # an added population's model: its file adds it
            continue
        text = model_to_toml(model)
        if text != model_to_toml(defaults[slot]):
            out[slot] = text
    return out


def model_files_record(models: Mapping[str, Any] | None) -> dict[str, dict[str, str]]:
    """``{model: {"sha256": ..., "content": ...}}`` of model files' texts, for manifests (a
    :class:`~astrocpg.models.ModelSet` as the files of the models it changes)."""
    from .files import file_sha256
    models = as_model_files(models)
    if models is not None and not isinstance(models, Mapping):
        raise InputError(f"expected a mapping {{model name: model file text}}, got "
                         f"{type(models).__name__}", culprit="models")
    out = {}
    for name, item in (models or {}).items():
        if isinstance(item, Mapping) and isinstance(item.get("content"), str):
            item = item["content"]
        if isinstance(item, str):
            out[name] = {"sha256": file_sha256(item), "content": item}
    return out


def model_set(overrides: Overrides | None = None,
              equations: Mapping[str, str] | None = None,
              base: ModelSet | None = None,
              models: Mapping[str, Any] | None = None, option: str | Field = setting("models"),
              added: Sequence[Any] = ()) -> ModelSet:
    """The model set with whole models swapped in (``models``: ``{slot: model file text}`` or
    ``{slot: Model}``; a file may declare new parameters and variables but must keep the slot's
    interface), the models of added populations joined (``added``: their neuron models,
    :meth:`~astrocpg.models.ModelSet.with_added`), equation texts swapped in (``{model:
    text}``) and parameter values overridden (``NAME=VALUE`` items or ``{name: value}``, an
    added model's parameters too), validated, over ``base`` (None: the built-in models,
    :data:`~astrocpg.models.DEFAULT_MODELS`). Errors about a model file name ``<option>
    <model>``."""
    from . import INTERFACES, Model
    from .files import (check_interface, check_parameters_used, file_sha256,
                                 model_from_toml)

    models = as_model_files(models)
    for given, what in ((models, "models"), (equations, "equations")):
        if given is not None and not isinstance(given, Mapping):
            value = "model file text" if what == "models" else "equation text"
            raise InputError(f"expected a mapping {{model name: {value}}}, got "
                             f"{type(given).__name__}", culprit=what)
    files = models
    models = DEFAULT_MODELS if base is None else base
    known = dict(models.items())
    for name, item in (files or {}).items():
        culprit = shown_with(option, name)
        if name not in known:
            raise InputError(f"unknown model{did_you_mean(name, known)} (models: "
                             f"{', '.join(known)})", culprit=culprit)
        if isinstance(item, Mapping):  # a manifest's record: {"sha256", "content"}
            text = item.get("content")
            if not isinstance(text, str):
                raise InputError("a model file record needs its content", culprit=culprit)
            if "sha256" in item and item["sha256"] != file_sha256(text):
                raise InputError("the recorded content does not match its sha256",
                                 culprit=culprit)
            item = text
        model = item if isinstance(item, Model) else model_from_toml(
            str(item), culprit=culprit, default=known[name])
        if model.kind != known[name].kind:
            raise InputError(f"is a {model.kind} model; {name} is a {known[name].kind} model",
                             culprit=culprit)
        check_interface(model, INTERFACES.get(name, ()), culprit=culprit)
        check_parameters_used(model, getattr(DEFAULT_MODELS, name), culprit=culprit)
        try:
            models = models.replace(**{name: model})
        except InputError as e:
            raise InputError(e.raw_line, culprit=culprit) from None
    if added:
        models = models.with_added(*added)  # a parameter name the set holds: refused
    known = dict(models.items())
    for name, text in (equations or {}).items():
        model = known.get(name)
        if model is None:
            raise InputError(f"unknown model '{name}'{did_you_mean(name, known)} (models: "
                             f"{', '.join(known)})", culprit=setting("equations"))
        model = model.with_code(text)
        check_interface(model, INTERFACES.get(name, ()), culprit=setting("equations", name))
        models = models.replace(**{name: model})
    values = dict(models.parse_assignment(item) for item in override_items(overrides))
    return models.with_values(values) if values else models


__all__ = ["Overrides", "override_items", "read_equation_files", "read_model_files",
           "model_files_record", "model_set"]
