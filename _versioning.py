"""Which astrocpg this is: the release, or a development build with its commit.

``astrocpg.RELEASE`` (``__init__.py``) is the one version written by hand, the release the
changelog and ``CITATION.cff`` name. What a given copy of the code is, ``astrocpg.__version__``,
follows from where it runs:

* a git checkout (an editable install, or the tree itself): computed from git when first asked.
  At the commit that set ``RELEASE``, with no uncommitted change, it is ``RELEASE``; ``N``
  commits later it is the next patch release's development build, ``0.2.1.devN+g<commit>``
  (the ordering of PEP 440: after 0.2.0, before 0.2.1), and ``.dirty`` marks uncommitted
  changes;
* an installed wheel or sdist: what the build computed, from ``_version.py``, which the build
  backend (``_build_backend/``) writes into the sdist and the wheel, so an install knows its
  version and commit without git;
* anything else (a copy of the files without git): ``RELEASE``, commit unknown.

Only the standard library is used: the build backend loads this file too.
"""

from __future__ import annotations

import re
import subprocess
from pathlib import Path
from typing import Any

ROOT = Path(__file__).resolve().parent

#: how ``__init__.py`` spells the release (the build backend reads it without importing)
RELEASE_LINE = re.compile(r'^RELEASE = "([^"]+)"', re.M)


def release_in(root: Path) -> str:
    """The ``RELEASE`` of the package whose ``__init__.py`` is in ``root``."""
    m = RELEASE_LINE.search((root / "__init__.py").read_text(encoding="utf-8"))
    if m is None:
        raise RuntimeError(f"no RELEASE = \"...\" line in {root / '__init__.py'}")
    return m.group(1)


def _git(root: Path, *args: str) -> str | None:
    try:
        p = subprocess.run(["git", "-C", str(root), *args], capture_output=True, text=True,
                           timeout=20)
    except (OSError, subprocess.SubprocessError):
        return None
    return p.stdout.strip() if p.returncode == 0 else None


def _next_patch(release: str) -> str:
    parts = re.match(r"^(\d+)\.(\d+)\.(\d+)", release)
    if parts is None:
        return release
    major, minor, patch = (int(x) for x in parts.groups())
    return f"{major}.{minor}.{patch + 1}"


def from_git(root: Path = ROOT, release: str | None = None) -> dict[str, Any] | None:
    """``{"version", "commit", "dirty", "source": "git"}`` of the checkout whose top is
    ``root``; None where ``root`` is not the top of a git checkout (an installed package inside
    some other repository is not that repository's commit)."""
    top = _git(root, "rev-parse", "--show-toplevel")
    if not top or Path(top).resolve() != root.resolve():
        return None
    commit = _git(root, "rev-parse", "HEAD")
    if not commit:
        return None
    release = release or release_in(root)
    base = _git(root, "log", "-1", "--pretty=%H", "-G", '^RELEASE = "', "--", "__init__.py")
    count = _git(root, "rev-list", "--count", f"{base}..HEAD" if base else "HEAD")
    n = int(count) if count and count.isdigit() else 0
    dirty = bool(_git(root, "status", "--porcelain"))
    if n == 0 and not dirty:
        version = release
    else:
        version = f"{_next_patch(release)}.dev{n}+g{commit[:9]}" + (".dirty" if dirty else "")
    return {"version": version, "commit": commit, "dirty": dirty, "source": "git"}


def from_build() -> dict[str, Any] | None:
    """What the build wrote into ``_version.py`` (an installed wheel or an unpacked sdist)."""
    try:
        from . import _version  # type: ignore[attr-defined]  # written by the build
    except ImportError:
        return None
    return {"version": _version.version, "commit": _version.commit, "dirty": _version.dirty,
            "source": "build"}


def build_info(release: str) -> dict[str, Any]:
    """This copy's version and commit: from git in a checkout, else from the build, else the
    release with the commit unknown."""
    return (from_git(ROOT, release) or from_build()
            or {"version": release, "commit": None, "dirty": None, "source": "release"})


def version_module(info: dict[str, Any]) -> str:
    """The text of ``_version.py`` the build writes."""
    return ('"""Written by the build (_build_backend/): the version and commit this copy of '
            'astrocpg was built from."""\n\n'
            f"version = {info['version']!r}\ncommit = {info['commit']!r}\n"
            f"dirty = {info['dirty']!r}\n")
