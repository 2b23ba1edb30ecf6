"""The build backend: setuptools' own, building in a temporary folder.

setuptools writes its intermediate files into the source tree (``build/``, ``*.egg-info``), so
``pip wheel .`` or ``python -m build --wheel`` run in a checkout would leave them there. Here
every hook of :mod:`setuptools.build_meta` runs with an extra distutils configuration
(``DIST_EXTRA_CONFIG``) that points ``build`` and ``egg_info`` at a temporary folder, which is
removed when the hook returns.

Every hook also writes the version: in a git checkout, ``_version.py`` (the version computed
from git, ``0.2.1.devN+g<commit>`` for a development build, and the commit; see
``_versioning.py``) is written beside ``__init__.py`` for the hook's duration, so setuptools
reads the version from it and the sdist and the wheel carry it: an install knows its version
and commit without git. An unpacked sdist (no git) keeps the ``_version.py`` it carries.
"""

from __future__ import annotations

import contextlib
import os
import shutil
import tempfile
from pathlib import Path
from typing import Any, Iterator

from setuptools import build_meta as _setuptools

_SOURCE = Path(__file__).resolve().parents[1]


def _versioning():  # noqa: ANN202
    """The package's ``_versioning.py``, loaded by path (the package itself is not importable
    while it is being built)."""
    import importlib.util

    spec = importlib.util.spec_from_file_location("_astrocpg_versioning",
                                                  _SOURCE / "_versioning.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


@contextlib.contextmanager
def _version_file() -> Iterator[None]:
    """``_version.py`` for the hook's duration: from git in a checkout; an unpacked sdist's own
    otherwise (kept); the release, commit unknown, where there is neither."""
    target = _SOURCE / "_version.py"
    v = _versioning()
    release = v.release_in(_SOURCE)
    info = v.from_git(_SOURCE, release)
    if info is None and target.is_file():
        yield
        return
    info = info or {"version": release, "commit": None, "dirty": None}
    target.write_text(v.version_module(info), encoding="utf-8")
    try:
        yield
    finally:
        target.unlink(missing_ok=True)


@contextlib.contextmanager
def _outside_the_tree() -> Iterator[None]:
    work = Path(tempfile.mkdtemp(prefix="astrocpg-build-"))
    config = work / "setup.cfg"
    config.write_text(f"[build]\nbuild_base = {work / 'build'}\n"
                      f"[egg_info]\negg_base = {work}\n")
    before = os.environ.get("DIST_EXTRA_CONFIG")
    os.environ["DIST_EXTRA_CONFIG"] = str(config)
    try:
        yield
    finally:
        if before is None:
            os.environ.pop("DIST_EXTRA_CONFIG", None)
        else:
            os.environ["DIST_EXTRA_CONFIG"] = before
        shutil.rmtree(work, ignore_errors=True)


def _wrap(name: str):
    hook = getattr(_setuptools, name)

    def wrapped(*args: Any, **kwargs: Any) -> Any:
        with _outside_the_tree(), _version_file():
            return hook(*args, **kwargs)

    wrapped.__name__ = name
    wrapped.__doc__ = hook.__doc__
    return wrapped


build_wheel = _wrap("build_wheel")
build_sdist = _wrap("build_sdist")
build_editable = _wrap("build_editable")
get_requires_for_build_wheel = _wrap("get_requires_for_build_wheel")
get_requires_for_build_sdist = _wrap("get_requires_for_build_sdist")
get_requires_for_build_editable = _wrap("get_requires_for_build_editable")
prepare_metadata_for_build_wheel = _wrap("prepare_metadata_for_build_wheel")
prepare_metadata_for_build_editable = _wrap("prepare_metadata_for_build_editable")
