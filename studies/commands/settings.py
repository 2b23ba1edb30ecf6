"""Settings shared by the experiments: the checks of the numbers every experiment takes
(durations, counts, sampling) and the populations a call adds (:func:`population_rows`). Model
composition lives in :mod:`astrocpg.models.compose`."""

from __future__ import annotations

import contextlib
from typing import Any, Iterator, Mapping

from ...errors import Field, InputError, setting, shown_with
from ...network import populations as _table
from ...network.populations import Population, population_from_toml
from ...network.runlock import RUN_LOCK
from ..settings.checks import MAX_GRID, MAX_SEED, check_grid, number, seed_number  # noqa: F401



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


@contextlib.contextmanager
def added_populations(populations: Any) -> Iterator[tuple[Population, ...]]:
    """The populations of ``populations`` (as :func:`population_rows` takes them: a call's
    files, or what a training's manifest recorded) in the population table for the ``with``
    block, holding the run lock: the table is the process's, so another thread's build must
    not see them (:mod:`astrocpg.network.runlock`). None given: nothing is added and the lock
    is not taken."""
    rows, _ = population_rows(populations)
    if not rows:
        yield ()
        return
    with RUN_LOCK, _table.registered(*rows) as done:
        yield done


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
