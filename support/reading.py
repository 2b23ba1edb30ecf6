"""Bounded reading of the files a user hands astrocpg: the one floor every reader stands on.

No file can make astrocpg use more memory or time than its declared content needs:

* only a regular file is read: a FIFO (named pipe), a device or a socket is refused before a
  byte is read from it (opened non-blocking and checked with ``fstat``, so a FIFO with no
  writer cannot hang the command, and a file swapped for one between a check and the open is
  caught too);
* JSON and TOML are parsed with their nesting bounded (:data:`MAX_DEPTH` levels): a document
  nested 100,000 deep would otherwise exhaust Python's stack inside the parser, or in any
  recursive code that walks it afterwards;
* a file is refused by its size before it is read (:data:`MAX_TEXT_BYTES` for a study, model,
  equations, population or worlds file, :data:`MAX_TABLE_BYTES` for a weights table,
  :data:`MAX_JSON_BYTES` for a manifest), and an array file by its header before NumPy
  allocates what the header claims (:func:`check_npy`, :func:`check_npz`).

Each refusal is an :class:`~astrocpg.errors.InputError` naming the file (exit 2).
"""

from __future__ import annotations

import json
import os
import re
import stat
from typing import Any, BinaryIO

from ..errors import InputError

#: The deepest nesting of lists/objects (JSON) or arrays/tables (TOML) astrocpg reads. What
#: astrocpg writes stays far below it (a checkpoint's state tree is refused beyond 64 levels
#: of its own, each at most two JSON levels); Python's default recursion limit (1000 frames)
#: stays well clear of it for any reader that walks the result recursively.
MAX_DEPTH = 200

_KINDS = ((stat.S_ISFIFO, "a FIFO"), (stat.S_ISSOCK, "a socket"),
          (stat.S_ISCHR, "a character device"), (stat.S_ISBLK, "a block device"),
          (stat.S_ISDIR, "a folder"))


def _kind(mode: int) -> str:
    return next((name for test, name in _KINDS if test(mode)), "not a plain file")


def not_regular(path: str | os.PathLike, culprit: Any = None, what: str = "") -> InputError:
    """The InputError for ``path`` that is not a regular file (its kind named)."""
    try:
        kind = _kind(os.stat(path).st_mode)
    except OSError:
        kind = "not a plain file"
    return _refusal(path, culprit, f"is not a regular file ({kind}){what}; astrocpg reads "
                                   f"only regular files")


def _refusal(path: Any, culprit: Any, text: str) -> InputError:
    if culprit is None or str(culprit) == str(path):
        return InputError(text, culprit=str(path))
    return InputError(f"{path} {text}", culprit=culprit)


def check_regular(path: str | os.PathLike, culprit: Any = None) -> None:
    """InputError when ``path`` exists and is not a regular file (a FIFO, device, socket or
    folder; symbolic links are followed). A path that does not exist passes: the reader says
    so in its own words."""
    try:
        mode = os.stat(path).st_mode
    except OSError:
        return
    if not stat.S_ISREG(mode):
        raise _refusal(path, culprit, f"is not a regular file ({_kind(mode)}); astrocpg "
                                      f"reads only regular files")


def open_regular(path: str | os.PathLike, culprit: Any = None) -> BinaryIO:
    """``path`` opened for binary reading, once it is known to be a regular file: stat first,
    then opened non-blocking (a FIFO's open returns at once instead of waiting for a writer)
    and checked again on the open descriptor. OSError (missing, permission) propagates as
    usual, for the caller's own message."""
    check_regular(path, culprit)
    flags = os.O_RDONLY | getattr(os, "O_NONBLOCK", 0) | getattr(os, "O_NOCTTY", 0) \
        | getattr(os, "O_CLOEXEC", 0) | getattr(os, "O_BINARY", 0)
    fd = os.open(path, flags)
    try:
        mode = os.fstat(fd).st_mode
        if not stat.S_ISREG(mode):
            raise _refusal(path, culprit, f"is not a regular file ({_kind(mode)}); astrocpg "
                                          f"reads only regular files")
        if hasattr(os, "set_blocking"):
            os.set_blocking(fd, True)  # a regular file: reads never block anyway
        return os.fdopen(fd, "rb")
    except BaseException:
        os.close(fd)
        raise


# ---------------------------------------------------------------- sizes
#: The largest text file astrocpg reads from a user (a study, model, equations, population
#: or worlds file): the largest it ships is a few kB.
MAX_TEXT_BYTES = 16 << 20
#: The largest weights table astrocpg reads (``.csv``, ``.json``, ``.npy``, ``.npz``, a kept
#: table): a table is 64 numbers per trial, 512 bytes in float64.
MAX_TABLE_BYTES = 64 << 20
#: The largest JSON document astrocpg reads (a manifest, a study's index, a run's status):
#: a training's manifest with hundreds of recorded sessions is about 1 MB.
MAX_JSON_BYTES = 256 << 20
#: The largest results table a study plan reads (``plan_from``: ``results.csv``, or its
#: content once inflated from ``results.csv.gz``): a 100,000-run study's is about 30 MB.
MAX_PLAN_BYTES = 256 << 20


def _mb(n: int) -> str:
    return f"{n / (1 << 20):g} MiB"


def too_large(path: Any, culprit: Any, size: int, limit: int, what: str = "bytes") -> InputError:
    """The InputError of a file larger than astrocpg reads of its kind (size and bound)."""
    return _refusal(path, culprit, f"holds {size:,} {what}, more than the {_mb(limit)} "
                                   f"astrocpg reads from such a file")


def read_bytes(path: str | os.PathLike, culprit: Any = None, *,
               limit: int = MAX_TEXT_BYTES) -> bytes:
    """The bytes of the regular file ``path`` (see :func:`open_regular`), at most ``limit``:
    a larger file is refused by its size before a byte is read (InputError naming it and the
    bound); one that grows past the bound while being read is refused too."""
    with open_regular(path, culprit) as f:
        size = os.fstat(f.fileno()).st_size
        if size > limit:
            raise too_large(path, culprit, size, limit, "bytes (refused unread)")
        data = f.read(limit + 1)
        if len(data) > limit:
            raise too_large(path, culprit, len(data), limit)
        return data


def read_text(path: str | os.PathLike, culprit: Any = None, *,
              limit: int = MAX_TEXT_BYTES) -> str:
    """The UTF-8 text of the regular file ``path`` (at most ``limit`` bytes:
    :func:`read_bytes`); UnicodeDecodeError (a ValueError) propagates for the caller's own
    message."""
    return read_bytes(path, culprit, limit=limit).decode("utf-8")


def check_npy(f: BinaryIO, room: int, path: Any, culprit: Any, member: str = "") -> None:
    """Check the ``.npy`` header at the position of ``f`` before any array is made: a plain
    dtype (no Python objects) and a shape whose bytes fit in the ``room`` bytes left after the
    header (the rest of the file, or of its ``.npz`` member). NumPy would otherwise allocate
    what a header claims (a 1 TB shape in a 100-byte file: "out of memory") before it reads a
    byte of data. InputError naming the file (and the member)."""
    import numpy as np

    fmt = np.lib.format
    where = f" (entry {member})" if member else ""
    start = f.tell()
    try:
        version = fmt.read_magic(f)
        if version == (1, 0):
            shape, _, dtype = fmt.read_array_header_1_0(f)
        else:
            shape, _, dtype = fmt.read_array_header_2_0(f)
    except (ValueError, EOFError, OSError) as e:
        raise _refusal(path, culprit, f"is not a NumPy array file{where} ({e})") from None
    if dtype.hasobject:
        raise _refusal(path, culprit, f"holds Python objects{where}; astrocpg reads only "
                                      f"numbers") from None
    need = dtype.itemsize
    for n in shape:
        need *= int(n)
    left = room - (f.tell() - start)
    if need > left:
        raise _refusal(path, culprit, f"declares an array of shape {tuple(shape)}{where} "
                                      f"({need:,} bytes) in {max(left, 0):,} bytes of data: "
                                      f"damaged or not astrocpg's (refused unread)")


def check_npz(f: BinaryIO, path: Any, culprit: Any, *, limit: int | None = None,
              stored: bool = False) -> None:
    """Check the ``.npz`` archive open in ``f`` before NumPy reads it: its members' declared
    sizes add up to at most ``limit`` (and, with ``stored``, each is stored as is: no
    compression bomb), and each ``.npy`` member's header fits its member (:func:`check_npy`).
    Leaves ``f`` at its start. InputError naming the file."""
    import zipfile

    f.seek(0)
    try:
        with zipfile.ZipFile(f) as zf:
            infos = zf.infolist()
            total = sum(i.file_size for i in infos)
            if limit is not None and total > limit:
                raise too_large(path, culprit, total, limit, "bytes once unpacked")
            for info in infos:
                if stored and info.compress_type != zipfile.ZIP_STORED:
                    raise _refusal(path, culprit, f"is not astrocpg's (entry {info.filename} "
                                                  f"is compressed)")
                if info.filename.endswith(".npy"):
                    with zf.open(info) as m:
                        check_npy(m, info.file_size, path, culprit, info.filename)
    except (zipfile.BadZipFile, zipfile.LargeZipFile, EOFError, ValueError) as e:
        if isinstance(e, InputError):
            raise
        raise _refusal(path, culprit, f"is not a whole .npz archive ({e})") from None
    finally:
        f.seek(0)


# ---------------------------------------------------------------- nesting
_JSON_STRING = re.compile(rb'"[^"\\]*(?:\\.[^"\\]*)*"', re.S)
_NOT_BRACKET = re.compile(rb"[^\[\]{}]+")


def _json_depth(data: bytes) -> int:
    """The deepest nesting of ``[`` / ``{`` in the JSON text ``data`` (strings skipped): a
    linear scan in C-speed steps, before the parser recurses."""
    return _bracket_depth(_NOT_BRACKET.sub(b"", _JSON_STRING.sub(b"", data)))


def _bracket_depth(brackets: bytes) -> int:
    """The deepest running count of ``[``/``{`` minus ``]``/``}`` (NumPy: a few ms per MB)."""
    import numpy as np

    if not brackets:
        return 0
    b = np.frombuffer(brackets, dtype=np.uint8)
    steps = np.where((b == ord("[")) | (b == ord("{")), 1, -1).astype(np.int64)
    return int(np.cumsum(steps).max())


def too_deep(culprit: Any, path: Any = None) -> InputError:
    """The InputError of a document nested beyond :data:`MAX_DEPTH`."""
    text = f"is nested too deeply (more than {MAX_DEPTH} levels of lists or tables)"
    if path is None:
        return InputError(text, culprit=culprit)
    return _refusal(path, culprit, text)


def loads_json(data: bytes | str, culprit: Any, path: Any = None) -> Any:
    """``json.loads(data)`` with its nesting bounded by :data:`MAX_DEPTH`: deeper is an
    InputError naming ``culprit`` (the file) "nested too deeply". Invalid JSON raises
    json's ValueError as ``json.loads`` does, for the caller's own message."""
    raw = data.encode("utf-8", "surrogatepass") if isinstance(data, str) else bytes(data)
    if _json_depth(raw) > MAX_DEPTH:
        raise too_deep(culprit, path)
    try:
        return json.loads(raw)
    except RecursionError:  # the stack was already deep: still the document's fault
        raise too_deep(culprit, path) from None


def _depth(obj: Any) -> int:
    """The nesting depth of lists/dicts in ``obj``, walked without recursion."""
    deepest, stack = 0, [(obj, 0)]
    while stack:
        x, d = stack.pop()
        if isinstance(x, dict):
            x = list(x.values())
        elif not isinstance(x, (list, tuple)):
            continue
        d += 1
        if d > MAX_DEPTH:
            return d
        deepest = max(deepest, d)
        stack.extend((v, d) for v in x)
    return deepest


_TOML_SKIP = re.compile(r'"""[\s\S]*?"""|\'\'\'[\s\S]*?\'\'\'|"(?:[^"\\\n]|\\.)*"|\'[^\'\n]*\'|#[^\n]*')
_TOML_DOTTED = re.compile(r"[\w\-]+(?:[ \t]*\.[ \t]*[\w\-]+)+")


def _toml_depth(text: str) -> int:
    """An upper bound of the nesting of the TOML ``text`` before it is parsed: the deepest
    nesting of ``[`` / ``{`` and the most parts of a dotted key (``a.b.c``), strings and
    comments skipped. tomllib recurses once per nested array and copies a dotted key's prefix
    once per part (time and memory quadratic in its length): both are bounded before it runs."""
    bare = _TOML_SKIP.sub("s", text)
    deepest = _bracket_depth(re.sub(r"[^\[\]{}]+", "", bare).encode())
    parts = max((m.group().count(".") + 1 for m in _TOML_DOTTED.finditer(bare)), default=0)
    return max(deepest, parts)


def loads_toml(text: str, culprit: Any, path: Any = None) -> dict[str, Any]:
    """``tomllib.loads(text)`` with its nesting bounded by :data:`MAX_DEPTH` (nested arrays
    and inline tables, and tables nested by dotted keys, ``[a.b.c...]``): deeper is an
    InputError naming ``culprit`` "nested too deeply". tomllib's TOMLDecodeError propagates
    for the caller's own message."""
    import tomllib

    if _toml_depth(text) > MAX_DEPTH:
        raise too_deep(culprit, path)
    try:
        doc = tomllib.loads(text)
    except RecursionError:  # tomllib recurses once per nested array or inline table
        raise too_deep(culprit, path) from None
    if _depth(doc) > MAX_DEPTH:
        raise too_deep(culprit, path)
    return doc


def read_json(path: str | os.PathLike, culprit: Any = None) -> Any:
    """The JSON document in the regular file ``path``, nesting and size bounded
    (:func:`loads_json`, :data:`MAX_JSON_BYTES`)."""
    return loads_json(read_bytes(path, culprit, limit=MAX_JSON_BYTES),
                      culprit if culprit is not None else path, path)


__all__ = ["MAX_DEPTH", "MAX_TEXT_BYTES", "MAX_TABLE_BYTES", "MAX_JSON_BYTES",
           "MAX_PLAN_BYTES", "check_regular", "open_regular", "read_bytes", "read_text",
           "check_npy", "check_npz", "too_large", "loads_json", "loads_toml", "read_json",
           "not_regular", "too_deep"]
