"""Files the package ships, reachable by name: model files, studies and worlds; and the manual
with the files its recipes read.

``astrocpg study compare_astrocytes`` and a model file ``alive=alive_height`` name a shipped file by
its stem; a path that exists is always read as it is, so a name resolves to the shipped file
only when no such path exists. The repository's own spelling (``models/variants/x.toml``)
resolves the same way, so the manual's commands also run from an installed wheel.
"""

from __future__ import annotations

import os
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]  # the package (support/ is one of its folders)
# kind -> folders (relative to the package) whose *.toml files of that kind are shipped
FOLDERS = ("models/variants", "studies/parameter_studies", "studies/commands", "docs/beyond")


def _kind(path: Path) -> str:
    """What a shipped TOML file holds, by its tables (however the file spells their names:
    ``[study]``, ``["study"]``): a study, a worlds file or a model file."""
    import tomllib

    try:
        doc = tomllib.loads(path.read_text(encoding="utf-8", errors="replace"))
    except (tomllib.TOMLDecodeError, RecursionError, OSError):
        return "model"  # its reader says what is wrong with it
    if "study" in doc:
        return "study"
    if "worlds" in doc or "grid" in doc:
        return "worlds"
    return "model"


def shipped(kind: str | None = None) -> dict[str, Path]:
    """{name: path} of the shipped TOML files of ``kind`` (model, study, worlds; None: all)."""
    out: dict[str, Path] = {}
    for folder in FOLDERS:
        for path in sorted((ROOT / folder).glob("*.toml")):
            if kind is None or _kind(path) == kind:
                out.setdefault(path.stem, path)
    return out


def resolve(given: str | Path, kind: str) -> Path:
    """``given`` as a path when it exists, else the shipped file of that name (with or without
    ``.toml``) or of that repository path; else ``given`` unchanged (its reader says why)."""
    p = Path(given)
    if p.exists():
        return p
    files = shipped(kind)
    stem = p.name[:-5] if p.name.endswith(".toml") else p.name
    if stem in files and (len(p.parts) == 1 or
                          files[stem].relative_to(ROOT).as_posix() == p.as_posix()):
        return files[stem]
    return p


#: the manual's folder: its pages (Markdown) and the files its recipes read
#: (``docs/examples/interlimb_table.csv``, the trained tables under ``docs/benchmarks/`` and
#: ``docs/ablation/``), in the repository and in an installed wheel alike
DOCS = ROOT / "docs"


def resolve_data(given: str | os.PathLike) -> str | os.PathLike:
    """``given`` as it is when it exists; else, spelled as the manual spells a file or folder
    it ships (``docs/examples/interlimb_table.csv``, relative), that shipped file or folder;
    else ``given`` unchanged (its reader says why). So the manual's recipes run from any folder
    with an installed wheel."""
    p = Path(given)
    if p.exists() or p.is_absolute() or not p.parts or p.parts[0] != "docs" or ".." in p.parts:
        return given
    shipped_path = ROOT / p
    return str(shipped_path) if shipped_path.exists() else given



def unreadable(given: str | os.PathLike, kind: str | None, err: OSError, culprit: str,
               builtin: tuple[str, ...] = ()) -> Exception:
    """The error for a file the user named that could not be read: a bare name (no folder, no
    ``.toml``) that names no shipped file of ``kind`` is a misspelt name, an InputError (exit 2)
    naming the closest shipped names (and ``builtin`` ones); a path that does not exist or
    cannot be read is the environment's, an EnvironmentFault (exit 1), as docs/errors.md says."""
    from ..errors import EnvironmentFault, InputError, did_you_mean

    p = Path(given)
    if kind is not None and len(p.parts) == 1 and not p.suffix and isinstance(
            err, FileNotFoundError):
        names = [*builtin, *shipped(kind)]
        return InputError(f"unknown {kind} '{given}'{did_you_mean(str(given), names)} (shipped "
                          f"{kind} files: {', '.join(names)}; or a file's path)", culprit=culprit)
    return EnvironmentFault(f"cannot read '{given}' ({err.strerror or type(err).__name__})",
                            culprit=culprit)
