"""The settings of ``train`` as one typed value (:class:`TrainSettings`): frozen, recorded by
the training's manifest and its checkpoint (:meth:`TrainSettings.record`) and read back from
them (:meth:`TrainSettings.from_record`), so that a resume continues the value that trained."""

from __future__ import annotations

import hashlib
from dataclasses import dataclass, field
from typing import Any


@dataclass(frozen=True)
class TrainSettings:
    """What defines a training run (a resumed run must have the same): one value, which cannot
    change once built; the manifest and the checkpoint record it (:meth:`record`), and a
    resume reads it back (:meth:`from_record`)."""

    n_sessions: int
    seed: int
    n_trials: int
    astrocytes: bool
    overrides: list[str] = field(default_factory=list)
    equations: dict[str, str] = field(default_factory=dict)  # model -> equation text
    # model -> {"sha256", "content"} of a model file (TOML)
    models: dict[str, dict[str, str]] = field(default_factory=dict)
    # population -> {"sha256", "content"} of the model file that added it (``populations``)
    populations: dict[str, dict[str, str]] = field(default_factory=dict)

    def fingerprint(self) -> str:
        # an added population's file is part of what the checkpoint belongs to; a training
        # without one keeps the fingerprint it always had
        text = repr((self.n_sessions, self.seed, self.n_trials, self.astrocytes,
                     sorted(self.overrides), sorted(self.equations.items()))
                    + ((sorted((k, v["sha256"]) for k, v in self.models.items()),)
                       if self.models else ())
                    + ((("populations", sorted((k, v["sha256"])
                                               for k, v in self.populations.items())),)
                       if self.populations else ()))
        return hashlib.sha256(text.encode()).hexdigest()

    def record(self) -> dict[str, Any]:
        """The settings as the manifest and the checkpoint record them (``populations`` only
        where one was added: a training without one records what it always did)."""
        out = dict(self.__dict__)
        if not out["populations"]:
            del out["populations"]
        return out

    #: what a training's manifest records beside its settings: how it records, what it replays
    NOT_SETTINGS = ("record", "replay_of")

    @classmethod
    def from_record(cls, record: dict[str, Any]) -> "TrainSettings":
        """The settings a manifest's or a checkpoint's ``settings`` record (:meth:`record`),
        without what the manifest records beside them (:data:`NOT_SETTINGS`)."""
        return cls(**{k: v for k, v in record.items() if k not in cls.NOT_SETTINGS})


__all__ = ["TrainSettings"]
