"""Small C libraries the framework compiles itself: built once per source (and whatever else
their key names, e.g. MuJoCo's version) with the C compiler Python was built with, kept in
``~/.cache/astrocpg`` (``$ASTROCPG_CACHE``) and loaded with ``ctypes``.

A :class:`Library` is one such library and what became of it in this process: built at first
use; a cached file that cannot be loaded (damaged, truncated, of another machine) or lacks a
function is removed and built again, once per process; if that fails too, :attr:`Library.problem`
says so (the caller warns and uses its Python path); without a compiler it is simply not there.
Its users keep a Python path that computes the same values, so that a machine without a C
compiler runs the same science, slower.
"""

from __future__ import annotations

import ctypes
import hashlib
import logging
import os
import subprocess
import sysconfig
import tempfile
from pathlib import Path
from typing import Any, Callable, Mapping, Sequence

log = logging.getLogger("astrocpg.native")

#: a function's ``(argtypes, restype)`` as ``ctypes`` takes them
Signature = tuple[list[Any], Any]


class BadLibrary(OSError):
    """A cached library that cannot be loaded or lacks one of its functions."""


def cache_dir() -> Path:
    return Path(os.environ.get("ASTROCPG_CACHE", Path.home() / ".cache" / "astrocpg"))


def target(stem: str, *key: str) -> Path:
    """Where the library ``stem`` built from ``key`` (its source and whatever else decides
    the binary) is cached."""
    digest = hashlib.sha256("".join(key).encode()).hexdigest()[:16]
    return cache_dir() / f"{stem}_{digest}{sysconfig.get_config_var('SHLIB_SUFFIX') or '.so'}"


def compile_source(path: Path, source: str, args: Sequence[str] = ()) -> None:
    """Compile ``source`` into the shared library ``path`` (``args``: include folders,
    libraries to link), unless it is there; the file appears whole or not at all, whoever
    builds it at the same time."""
    if path.is_file():
        return
    path.parent.mkdir(parents=True, exist_ok=True)
    cc = (sysconfig.get_config_var("CC") or "cc").split()
    with tempfile.TemporaryDirectory(dir=path.parent) as tmp:
        src, out = Path(tmp) / f"{path.stem}.c", Path(tmp) / path.name
        src.write_text(source)
        subprocess.run([*cc, "-O2", "-shared", "-fPIC", "-o", str(out), str(src), *args],
                       check=True, capture_output=True, timeout=120)
        os.replace(out, path)


def load(path: Path, functions: Mapping[str, Signature]) -> ctypes.CDLL:
    """The library at ``path`` with ``functions``' signatures set; BadLibrary when the file is
    not a loadable library or lacks one of them (the handle is closed again: a later load of a
    rebuilt file at the same path must not get this one back from the loader's cache)."""
    try:
        lib = ctypes.CDLL(str(path))
    except OSError as e:
        raise BadLibrary(f"cannot load {path}: {e}") from None
    for name, (argtypes, restype) in functions.items():
        try:
            fn = getattr(lib, name)
        except AttributeError:
            close(lib)
            raise BadLibrary(f"{path} has no {name}") from None
        fn.argtypes, fn.restype = argtypes, restype
    return lib


def close(lib: ctypes.CDLL) -> None:
    try:
        import _ctypes

        _ctypes.dlclose(lib._handle)  # POSIX only; elsewhere the rebuilt file is loaded anew
    except (ImportError, AttributeError, OSError):
        pass


def build(path: Path, compile_to: Callable[[Path], None],
          load_from: Callable[[Path], ctypes.CDLL], what: str) -> ctypes.CDLL:
    """The library at ``path``: the cached one, else built now (``compile_to``); a cached one
    that is bad is removed and built again once (BadLibrary if that one is bad too)."""
    if not path.is_file():
        compile_to(path)
        return load_from(path)
    try:
        return load_from(path)
    except BadLibrary as e:
        bad = e
    log.info("rebuilding %s: %s", what, bad)
    try:
        path.unlink()
    except FileNotFoundError:
        pass
    try:
        compile_to(path)
    except (OSError, subprocess.SubprocessError) as e:
        raise BadLibrary(f"{bad}; building it again failed: {type(e).__name__}") from None
    return load_from(path)


class Library:
    """One compiled library of this process: ``source`` with ``functions``, cached under
    ``stem``, compiled with ``flags``; :meth:`get` builds it at first use."""

    def __init__(self, stem: str, source: str, functions: Mapping[str, Signature],
                 what: str, flags: Sequence[str] = ()) -> None:
        self.stem, self.source, self.functions, self.what = stem, source, functions, what
        self.flags = tuple(flags)  # the compiler's, after -O2 (e.g. -O3: loops vectorised)
        self.lib: Any = None  # the loaded library; False once building it failed
        #: why a bad cached library could not be replaced (None: no such problem)
        self.problem: str | None = None

    def path(self) -> Path:
        return target(self.stem, self.source, *self.flags)

    def get(self) -> ctypes.CDLL | None:
        """The library, built at first use; None where it cannot be built (no compiler; a bad
        cached file that could not be replaced: :attr:`problem`)."""
        if self.lib is None:
            try:
                self.lib = build(self.path(), lambda p: compile_source(p, self.source, self.flags),
                                 lambda p: load(p, self.functions), self.what)
            except BadLibrary as e:
                self.problem = f"{self.what} cannot be used ({e})"
                self.lib = False
            except (OSError, subprocess.SubprocessError) as e:
                log.debug("%s unavailable: %s", self.what, e)
                self.lib = False
        return self.lib or None


__all__ = ["Library", "BadLibrary", "Signature", "cache_dir", "target", "compile_source", "load",
           "close", "build"]
