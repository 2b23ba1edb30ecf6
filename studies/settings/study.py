"""The settings of ``study`` (``astrocpg study``, ``ac.study``) as one typed value: the study
file and what the command changes in it (``seeds``, ``sessions``, ``overrides``), frozen,
checked when built, recorded in the study folder and read back from it: a study folder keeps
the settings it was started with, and continuing it with others is refused."""

from __future__ import annotations

import dataclasses
import os
import re
from dataclasses import dataclass
from typing import Any, ClassVar, Mapping

from ...errors import InputError, setting
from ...models.compose import override_items
from .checks import MAX_GRID, MAX_SEED, number
from .recorded import Recorded

MAX_SEEDS = MAX_GRID  # trainings of a study (and seeds): the bound of every grid


@dataclass(frozen=True)
class StudyOverrides:
    """What a study's ``seeds``, ``sessions`` and ``overrides`` settings change in the study
    as loaded: ``seeds`` (the seeds, or
    ``count``: that many from the file's first seed), ``sessions`` per trial, ``sets``
    (``NAME=VALUE`` items, each replacing the file's ``[base]`` value or added to it). They
    are recorded in the study folder: a rerun with other ones is refused."""

    seeds: tuple[int, ...] | None = None
    count: int | None = None
    sessions: int | None = None
    sets: tuple[str, ...] = ()
    seeds_text: str | None = None  # as given, for the record and the messages

    def record(self) -> dict[str, Any]:
        """The options given, as ``study.json`` and the manifest record them."""
        out: dict[str, Any] = {}
        if self.seeds_text is not None:
            out["seeds"] = self.seeds_text
        if self.sessions is not None:
            out["sessions"] = self.sessions
        if self.sets:
            out["set"] = list(self.sets)
        return out


#: ``seeds``: ``FIRST-LAST`` (inclusive), ``A,B,C`` (a list) or ``N`` (a count: N seeds from
#: the study's first seed).
SEEDS_GRAMMAR = ("FIRST-LAST (e.g. 1-3), a list A,B,C (e.g. 1,4,9), or a count N (N seeds "
                 "from the study's first seed)")


def study_overrides(seeds: Any = None, sessions: Any = None,
                    sets: Any = None) -> StudyOverrides:
    """The overrides checked (an InputError naming the ``seeds``, ``sessions`` or ``overrides``
    setting).
    ``seeds``: text in the grammar of :data:`SEEDS_GRAMMAR`, an int (a count) or a list of
    ints; ``sets``: ``NAME=VALUE`` texts or a mapping {name: value} (checked against the
    study's models when it is parsed)."""
    seeds_list: tuple[int, ...] | None = None
    count: int | None = None
    text: str | None = None
    if seeds is not None:
        if isinstance(seeds, bool):
            raise InputError(f"expected {SEEDS_GRAMMAR}, got {seeds!r}", culprit=setting("seeds"))
        if isinstance(seeds, int):
            seeds = str(seeds)
        if isinstance(seeds, (list, tuple)):
            if not seeds or not all(isinstance(x, int) and not isinstance(x, bool)
                                    for x in seeds):
                raise InputError(f"expected a non-empty list of integers, got {seeds!r}",
                                 culprit=setting("seeds"))
            seeds_list, text = tuple(seeds), ",".join(map(str, seeds))
        elif isinstance(seeds, str):
            text = seeds.strip()
            m = re.fullmatch(r"(\d+)-(\d+)", text)
            if m:
                first, last = int(m.group(1)), int(m.group(2))
                if last < first:
                    raise InputError(f"{text}: the last seed is before the first",
                                     culprit=setting("seeds"))
                if last - first + 1 > MAX_SEEDS:
                    raise InputError(f"{text}: {last - first + 1} seeds is more than "
                                     f"{MAX_SEEDS}", culprit=setting("seeds"))
                seeds_list = tuple(range(first, last + 1))
            elif re.fullmatch(r"\d+(\s*,\s*\d+)+\s*,?", text):
                seeds_list = tuple(int(x) for x in text.split(",") if x.strip())
            elif re.fullmatch(r"\d+", text):
                count = int(text)
                if not 1 <= count <= MAX_SEEDS:
                    raise InputError(f"a count of seeds must be 1 to {MAX_SEEDS}, got {count}",
                                     culprit=setting("seeds"))
            else:
                raise InputError(f"expected {SEEDS_GRAMMAR}, got {seeds!r}",
                                 culprit=setting("seeds"))
        else:
            raise InputError(f"expected {SEEDS_GRAMMAR}, got {type(seeds).__name__}",
                             culprit=setting("seeds"))
        if seeds_list is not None:
            if len(set(seeds_list)) != len(seeds_list):
                raise InputError(f"{text} lists a seed twice", culprit=setting("seeds"))
            if len(seeds_list) > MAX_SEEDS:
                raise InputError(f"{len(seeds_list)} seeds is more than {MAX_SEEDS}",
                                 culprit=setting("seeds"))
            if min(seeds_list) < 0 or max(seeds_list) > MAX_SEED:
                raise InputError(f"seeds must be 0 to {MAX_SEED}, got {text}",
                                 culprit=setting("seeds"))
            seeds_list = tuple(sorted(seeds_list))
    if isinstance(sessions, str):  # the command line's text: parsed, never eval-ed
        try:
            sessions = int(sessions, 10)
        except ValueError:
            raise InputError(f"expected a whole number, got {sessions!r}",
                             culprit=setting("sessions")) from None
    n = None if sessions is None else number(sessions, setting("sessions"), integer=True, minimum=1)
    items = override_items(sets)
    for item in items:
        name, eq, value = item.partition("=")
        if not eq or not name.strip() or not value.strip():
            raise InputError(f"expected NAME=VALUE, got {item!r}", culprit=setting("overrides"))
    names = [i.partition("=")[0].strip() for i in items]
    twice = next((x for x in names if names.count(x) > 1), None)
    if twice is not None:
        raise InputError(f"{twice} is set twice", culprit=setting("overrides", twice))
    return StudyOverrides(seeds=seeds_list, count=count, sessions=n, sets=tuple(items),
                          seeds_text=text)


@dataclass(frozen=True)
class StudySettings(Recorded):
    """What one ``study`` runs: the study ``file`` (a path or a shipped study's name), and in
    place of the file's own, the ``seeds`` (as given: a text, a count or a list of ints),
    ``sessions`` per trial and ``overrides`` (``NAME=VALUE`` texts or a mapping over the file's
    ``[base]``). Built, it holds the same overrides however they were spelt (``"1,2,3"`` and
    ``[1, 2, 3]`` are one value); :attr:`changes` is what they change in the study as loaded."""

    file: str
    seeds: Any = None
    sessions: Any = None
    overrides: Any = ()
    changes: StudyOverrides = dataclasses.field(init=False, repr=False, compare=False)

    RECORD: ClassVar[tuple[str, ...]] = ("file", "seeds", "sessions", "overrides")
    #: what the study's manifest holds beside its settings: the file's text, how it ran
    FOUND: ClassVar[frozenset[str]] = frozenset(
        {"study_text", "workers", "scheduler", "batch", "batch_choice", "worker_count"})

    def __post_init__(self) -> None:
        set_ = object.__setattr__
        if not isinstance(self.file, (str, os.PathLike)):
            raise InputError(f"expected a study file or a shipped study's name, got "
                             f"{type(self.file).__name__}", culprit=setting("file"))
        set_(self, "file", str(self.file))
        changes = study_overrides(self.seeds, self.sessions, self.overrides)
        set_(self, "changes", changes)
        set_(self, "seeds", changes.seeds_text)
        set_(self, "sessions", changes.sessions)
        set_(self, "overrides", changes.sets)

    def record(self) -> dict[str, Any]:
        """The manifest's record: the file as ``study`` and the changes as ``overrides``
        (``study.json`` records the same changes)."""
        return {"study": self.file, "overrides": self.changes.record()}

    @classmethod
    def from_record(cls, record: Mapping[str, Any]) -> "StudySettings":
        unknown = sorted(set(record) - {"study", "overrides"} - cls.FOUND)
        if unknown:
            raise InputError(f"records settings this version does not know: "
                             f"{', '.join(unknown)}", culprit="manifest settings")
        changes = record.get("overrides") or {}
        if not isinstance(changes, Mapping):
            raise InputError(f"expected a mapping, got {type(changes).__name__}",
                             culprit="manifest settings overrides")
        return cls(file=record.get("study", ""), seeds=changes.get("seeds"),
                   sessions=changes.get("sessions"), overrides=changes.get("set") or ())


__all__ = ["MAX_SEEDS", "SEEDS_GRAMMAR", "StudyOverrides", "StudySettings", "study_overrides"]
