"""astrocpg's cache folder: what is kept between processes on this machine (the describe texts
of the built-in models, the measured cost of a trial), never a result.

``$ASTROCPG_CACHE``, default ``$XDG_CACHE_HOME/astrocpg`` or ``~/.cache/astrocpg``. Only the
standard library is imported here, so ``astrocpg describe`` reads its cache without Brian2.
"""

from __future__ import annotations

import os
from pathlib import Path


def cache_dir() -> Path:
    """Where astrocpg's caches live (the folder may not exist yet)."""
    if os.environ.get("ASTROCPG_CACHE"):
        return Path(os.environ["ASTROCPG_CACHE"])
    base = os.environ.get("XDG_CACHE_HOME") or os.path.join(os.path.expanduser("~"), ".cache")
    return Path(base) / "astrocpg"


__all__ = ["cache_dir"]
