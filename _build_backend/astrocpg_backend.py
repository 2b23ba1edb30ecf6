"""The build backend: setuptools' own, building in a temporary folder.

setuptools writes its intermediate files into the source tree (``build/``, ``*.egg-info``), so
``pip wheel .`` or ``python -m build --wheel`` run in a checkout would leave them there. Here
every hook of :mod:`setuptools.build_meta` runs with an extra distutils configuration
(``DIST_EXTRA_CONFIG``) that points ``build`` and ``egg_info`` at a temporary folder, which is
removed when the hook returns. The wheel and the sdist are setuptools' unchanged.
"""

from __future__ import annotations

import contextlib
import os
import shutil
import tempfile
from pathlib import Path
from typing import Any, Iterator

from setuptools import build_meta as _setuptools


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
        with _outside_the_tree():
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
