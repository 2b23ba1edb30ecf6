"""The finished cells of a command kept beside its output folder until the folder is written
whole (``<out>.parts/``): what lets an interrupted evaluation start again where it stopped."""

from __future__ import annotations

import json
import shutil
from pathlib import Path
from typing import Any

from ...errors import EnvironmentFault
from ...support.reading import read_json
from .writing import atomic_write

PARTS_SUFFIX = ".parts"  # <out>.parts/: finished cells of a command not yet written whole


class CellParts:
    """The finished cells of a command not yet written whole (an evaluation's controller x
    world cells), kept beside its output folder in ``<out>.parts/``, one JSON file each: a
    command interrupted (Ctrl-C, a killed machine) and started again with the same inputs and
    settings reuses them (:meth:`load`: the store :func:`~astrocpg.studies.runtime.cells.pending`
    reads) and runs only the rest. Other settings or other inputs (another ``fingerprint``)
    discard them. The folder goes once the command's folder is written (:meth:`remove`)."""

    def __init__(self, folder: Path, fingerprint: str) -> None:
        self.folder, self.fingerprint = folder, fingerprint
        key = folder / "fingerprint.txt"
        try:
            stale = folder.is_dir() and (not key.is_file() or key.read_text() != fingerprint)
        except OSError:
            stale = True
        if stale:
            shutil.rmtree(folder, ignore_errors=True)

    def _path(self, cell: str) -> Path:
        return self.folder / f"{cell}.json"

    def load(self, cell: str) -> list[dict[str, Any]] | None:
        try:
            return read_json(self._path(cell))
        except (OSError, ValueError):  # absent, or torn by a kill: run it again
            return None

    def save(self, cell: str, rows: list[dict[str, Any]]) -> None:
        try:
            self.folder.mkdir(parents=True, exist_ok=True)
            key = self.folder / "fingerprint.txt"
            if not key.is_file():
                atomic_write(key, lambda f: f.write(self.fingerprint.encode()))
            body = json.dumps(rows).encode()  # NaN (time to fall of a trial that stood) too
            atomic_write(self._path(cell), lambda f: f.write(body))
        except OSError as e:
            raise EnvironmentFault.from_os_error(e, self.folder, "cannot save a cell") from None

    def remove(self) -> None:
        shutil.rmtree(self.folder, ignore_errors=True)


__all__ = ["CellParts", "PARTS_SUFFIX"]
