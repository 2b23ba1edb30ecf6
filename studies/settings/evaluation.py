"""The settings of ``evaluate`` (``astrocpg evaluate``, ``ac.evaluate``) as one typed value:
frozen, checked when built, recorded in the evaluation's manifest and read back from it."""

from __future__ import annotations

import dataclasses
import os
from typing import Any, ClassVar, Mapping

from ...errors import InputError, setting
from .checks import STEP, check_duration, number, seed_number
from .recorded import Recorded, folder_text, names_tuple

#: The parts of a model variant an evaluation may put over each controller's own models.
VARIANT_PARTS = ("overrides", "equations", "models", "populations")


@dataclasses.dataclass(frozen=True)
class EvaluateSettings(Recorded):
    """What one evaluation runs: the trained controllers under ``folder`` (a training, a run or
    a study; ``conditions``: only a study's runs of these conditions; ``points``: only its runs
    at these grid points; ``session``: the tables after that session, None: the final ones),
    each in every world of ``worlds`` (a worlds file or a built-in name) for ``seconds``,
    ``repeats`` times from ``seed``, with ``variant`` (a model variant over each controller's
    own models: its ``overrides``, ``equations``, ``models`` and ``populations``) and
    ``baseline`` (a world the others are compared with)."""

    folder: str
    worlds: str = "robustness"
    seconds: float = 10.0
    repeats: int = 5
    seed: int = 1
    conditions: tuple[str, ...] = ()
    points: tuple[str, ...] = ()
    baseline: str | None = None
    variant: dict[str, Any] | None = None
    session: int | None = None

    RECORD: ClassVar[tuple[str, ...]] = (
        "folder", "worlds", "seconds", "repeats", "seed", "conditions", "points", "baseline",
        "variant", "session")
    #: the manifest's ``worlds`` holds the worlds themselves; the setting is where they came from
    KEYS: ClassVar[dict[str, str]] = {"worlds": "worlds_source"}
    #: what the evaluation found or how it ran, beside its settings in the manifest
    FOUND: ClassVar[frozenset[str]] = frozenset(
        {"worlds", "axes", "tables", "trainings", "workers", "scheduler", "cells_reused"})

    def __post_init__(self) -> None:
        set_ = object.__setattr__
        set_(self, "folder", folder_text(self.folder))
        if not isinstance(self.worlds, (str, os.PathLike)):
            raise InputError(f"expected a worlds file or 'robustness', got "
                             f"{type(self.worlds).__name__}", culprit=setting("worlds"))
        set_(self, "worlds", str(self.worlds))
        set_(self, "seconds", number(self.seconds, setting("seconds"), positive=True))
        check_duration(self.seconds, STEP)
        set_(self, "repeats", number(self.repeats, setting("repeats"), integer=True, minimum=1))
        set_(self, "seed", seed_number(self.seed, setting("seed")))
        set_(self, "conditions", names_tuple(self.conditions, "conditions"))
        set_(self, "points", names_tuple(self.points, "points"))
        if self.baseline is not None and not isinstance(self.baseline, str):
            raise InputError("expected a world's name", culprit=setting("baseline"))
        if self.session is not None:
            set_(self, "session",
                 number(self.session, setting("session"), integer=True, minimum=1))
        set_(self, "variant", _variant(self.variant))


def _variant(variant: Any) -> dict[str, Any] | None:
    """The variant's given parts (None: none given); a part it cannot have is refused."""
    if not variant:
        return None
    if not isinstance(variant, Mapping):
        raise InputError(f"expected a mapping, got {type(variant).__name__}",
                         culprit=setting("variant"))
    unknown = sorted(set(variant) - set(VARIANT_PARTS))
    if unknown:
        raise InputError(f"a model variant has no {', '.join(unknown)} (it has: "
                         f"{', '.join(VARIANT_PARTS)})", culprit=setting("variant"))
    given = {k: variant[k] for k in VARIANT_PARTS if variant.get(k)}
    return given or None


__all__ = ["EvaluateSettings", "VARIANT_PARTS"]
