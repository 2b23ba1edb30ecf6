"""What every command's settings value shares: it is recorded in the folder it wrote
(:meth:`Recorded.record`, JSON-ready) and read back from that record
(:meth:`Recorded.from_record`, checked again as when built).

A manifest's ``settings`` may also hold what the command *found* while it ran (the trainings an
evaluation read, the cells it reused, the workers it used): those keys are the value's
``FOUND``; they are kept in the manifest but are not settings, and reading back skips them. A
key that is neither a setting nor found is refused, naming it: a manifest written by another
version, or edited by hand, does not pass for this one."""

from __future__ import annotations

import dataclasses
import os
from typing import Any, ClassVar, Mapping

from ...errors import InputError, setting


class Recorded:
    """A frozen dataclass's record and its reading back. ``RECORD``: the fields recorded, in
    the manifest's order; ``KEYS``: a field recorded under another key (``worlds`` as
    ``worlds_source``, where the manifest's ``worlds`` holds the worlds themselves);
    ``FOUND``: the manifest keys that are not settings."""

    RECORD: ClassVar[tuple[str, ...]] = ()
    KEYS: ClassVar[dict[str, str]] = {}
    FOUND: ClassVar[frozenset[str]] = frozenset()

    def record(self) -> dict[str, Any]:
        return {self.KEYS.get(k, k): plain(getattr(self, k)) for k in self.RECORD}

    @classmethod
    def from_record(cls, record: Mapping[str, Any]) -> Any:
        """The value that ``record`` (a manifest's ``settings``) holds, checked again."""
        field_of = {v: k for k, v in cls.KEYS.items()}
        names = {f.name for f in dataclasses.fields(cls)}  # type: ignore[arg-type]
        given: dict[str, Any] = {}
        unknown = []
        for key, value in record.items():
            name = field_of.get(key, key)
            if key in cls.FOUND:
                continue
            if name in names:
                given[name] = value
            else:
                unknown.append(key)
        if unknown:
            raise InputError(f"records settings this version does not know: "
                             f"{', '.join(sorted(unknown))}", culprit="manifest settings")
        return cls(**given)


def plain(value: Any) -> Any:
    """A field's value as JSON holds it (a tuple as a list, a mapping as a dict)."""
    if isinstance(value, tuple):
        return [plain(v) for v in value]
    if isinstance(value, Mapping):
        return {str(k): plain(v) for k, v in value.items()}
    return value


def folder_text(value: Any) -> str:
    """A folder setting (``folder``) as its text; anything but a path or text is refused,
    naming the setting."""
    if not isinstance(value, (str, os.PathLike)):
        raise InputError(f"expected a folder, got {type(value).__name__}",
                         culprit=setting("folder"))
    return os.fspath(value)


def names_tuple(value: Any, name: str) -> tuple[str, ...]:
    """A list setting of names (``conditions``, ``points``): one text is one name, not its
    characters; anything but texts is refused naming the setting."""

    if value is None:
        return ()
    if isinstance(value, str):
        value = [value]
    try:
        items = list(value)
    except TypeError:
        raise InputError(f"expected names as text, got {type(value).__name__}",
                         culprit=setting(name)) from None
    if not all(isinstance(v, str) for v in items):
        raise InputError("expected names as text", culprit=setting(name))
    return tuple(items)


__all__ = ["Recorded", "folder_text", "names_tuple", "plain"]
