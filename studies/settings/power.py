"""The settings of ``power`` (``astrocpg power``, ``ac.power``) as one typed value: frozen,
checked when built, recorded in the figures' file (its ``settings``) and read back from it."""

from __future__ import annotations

import dataclasses
from typing import Any, ClassVar

from ...errors import setting
from ...models.compose import override_items
from .checks import number
from .recorded import Recorded, folder_text


@dataclasses.dataclass(frozen=True)
class PowerSettings(Recorded):
    """What one power measurement runs: trial ``trial``'s trained table of the training in
    ``folder``, for ``sessions`` sessions with learning off, with ``overrides``
    (``NAME=VALUE`` texts or a mapping) over the training's models."""

    folder: str
    trial: int = 0
    sessions: int = 10
    overrides: Any = ()

    RECORD: ClassVar[tuple[str, ...]] = ("folder", "trial", "sessions", "overrides")

    def __post_init__(self) -> None:
        set_ = object.__setattr__
        set_(self, "folder", folder_text(self.folder))
        set_(self, "trial", number(self.trial, setting("trial"), integer=True, minimum=0))
        set_(self, "sessions",
             number(self.sessions, setting("sessions"), integer=True, minimum=1))
        set_(self, "overrides", tuple(override_items(self.overrides)))


__all__ = ["PowerSettings"]
