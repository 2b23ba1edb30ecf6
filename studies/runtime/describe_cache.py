"""``astrocpg describe`` without Brian2 when nothing is changed: the text of the built-in models
is kept in a cache file named by a hash of the model sources (every file under ``models/``)
and the versions of Brian2 and sympy (they write the LaTeX), so a later ``describe`` reads it
in milliseconds instead of importing Brian2 (about a second). Any edit of a model file gives a
new hash, hence a fresh text; ``overrides``/``models``/``equations`` bypass the cache.

Only the standard library is imported here; the cache lives in astrocpg's cache folder
(:func:`~astrocpg.studies.runtime.caches.cache_dir`); a cache that cannot be written is simply
not used.
"""

from __future__ import annotations

import hashlib
import os
import tempfile
from importlib import metadata
from pathlib import Path
from typing import Callable

from .caches import cache_dir

_MODELS = Path(__file__).resolve().parents[2] / "models"
# the code that writes the texts: a new renderer gives fresh texts too
_RENDERER = Path(__file__).resolve().parents[1] / "figures" / "describe.py"


def models_key() -> str:
    """sha256 over every model source file (path and bytes), the renderer's source and the text
    writers' versions."""
    h = hashlib.sha256()
    h.update(_RENDERER.read_bytes())
    for path in sorted(p for p in _MODELS.rglob("*") if p.is_file()
                       and p.suffix in (".py", ".toml")):
        h.update(str(path.relative_to(_MODELS)).encode())
        h.update(path.read_bytes())
    for package in ("brian2", "sympy"):
        try:
            h.update(f"{package}={metadata.version(package)}".encode())
        except metadata.PackageNotFoundError:
            h.update(f"{package}=none".encode())
    return h.hexdigest()[:32]


def cached_text(name: str | None, fmt: str, render: Callable[[], str]) -> str:
    """The describe text of the built-in models (``name``: one model, None: all) in ``fmt``,
    from the cache, or ``render()`` (which imports Brian2) stored for next time."""
    path = cache_dir() / f"describe-{models_key()}-{name or 'all'}.{fmt}"
    try:
        return path.read_text(encoding="utf-8")
    except (OSError, UnicodeDecodeError):
        pass
    text = render()
    try:  # atomic: a concurrent describe reads a whole text or none
        path.parent.mkdir(parents=True, exist_ok=True)
        fd, tmp = tempfile.mkstemp(dir=path.parent, prefix=".describe-")
        with os.fdopen(fd, "w", encoding="utf-8") as f:
            f.write(text)
        os.replace(tmp, path)
    except OSError:
        pass
    return text
