"""The populations a command adds to the network, as values: the rows of the model files
given as ``populations`` (:func:`population_rows`), the table a network of them is built from
(:func:`population_table`), their models (:func:`population_models`) and whether a training
was made with the same (:func:`same_populations`)."""

from __future__ import annotations

from typing import Any, Mapping

from ...errors import Field, InputError, setting, shown_with
from ...network.populations import Population, population_from_toml, with_added


def population_rows(populations: Any, option: str | Field = setting("populations")
                    ) -> tuple[tuple[Population, ...], dict[str, Any]]:
    """The rows of ``populations`` (model files with a ``[population]`` table: their texts, or
    ``{file: text}``, or a manifest's record ``{name: {"sha256", "content"}}``), and the
    manifest's record of them (``{name: {"sha256", "content"}}``). Bad input: InputError
    naming the file (after ``option``, where it was given)."""
    from ...models.files import file_sha256

    if not populations:
        return (), {}
    if isinstance(populations, str) or not isinstance(populations, (Mapping, list, tuple)):
        raise InputError(f"expected model file texts (a list, or {{file: text}}), got "
                         f"{type(populations).__name__}", culprit=setting("populations"))
    items = populations.items() if isinstance(populations, Mapping) else \
        ((f"populations[{k}]", text) for k, text in enumerate(populations))
    rows, record = [], {}
    for where, text in items:
        if isinstance(text, Mapping):  # a manifest's record
            text = text.get("content")
        if not isinstance(text, str):
            raise InputError("expected a model file's text", culprit=shown_with(option, where))
        row = population_from_toml(text, culprit=shown_with(option, where))
        if row.name in record:
            raise InputError("is given twice", culprit=f"population {row.name}")
        rows.append(row)
        record[row.name] = {"sha256": file_sha256(text), "content": text}
    return tuple(rows), record



def population_models(populations: Any) -> tuple[Any, ...]:
    """The neuron models of ``populations`` (as :func:`population_rows` takes them), for
    ``model_set(..., added=...)``: the set then holds them, so that ``overrides`` reach their
    parameters and the manifest's models record them."""
    return tuple(row.model for row in population_rows(populations)[0])


def population_table(populations: Any) -> tuple[Population, ...]:
    """The population table a network of ``populations`` (as :func:`population_rows` takes
    them: a call's files, or what a training's manifest recorded) is built from: the
    built-in rows, then these, each checked (a name the table holds already is refused). A
    value: given to the build, the recording and the checks of what may be recorded."""
    return with_added(population_rows(populations)[0])


def same_populations(recorded: Mapping[str, Any], given: Mapping[str, Any]) -> str | None:
    """The name of the first population of ``given`` (a record ``{name: {"sha256",
    "content"}}``, :func:`population_rows`) that ``recorded`` lacks or holds from another file
    (a file that differs only in comments or spelling, i.e. defines the same row and model, is
    the same), else None."""
    from ...models.files import model_to_toml

    def defined(record: Mapping[str, Any]) -> tuple[Any, str]:
        row = population_from_toml(record["content"], culprit=setting("populations", name))
        return row.to_json(1), model_to_toml(row.model)

    for name, record in given.items():
        was = recorded.get(name)
        if was is None:
            return name
        if was.get("sha256") != record.get("sha256") and defined(was) != defined(record):
            return name
    return None


__all__ = ["population_models", "population_rows", "population_table", "same_populations"]
