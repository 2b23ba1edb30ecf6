"""The checkpoint file: data only, never code.

A checkpoint (``checkpoint.npz``) is a NumPy ``.npz`` archive read with ``allow_pickle=False``:

* ``meta``: UTF-8 JSON (as a uint8 array): the format's name and version and the small,
  readable part (settings, fingerprint, code-generation target, recording plan);
* ``state``: UTF-8 JSON: the rest as a tree of JSON values whose arrays are references to the
  archive's other entries (``a0``, ``a1``, ...), plain numeric/bool/string arrays.

The tree holds what a training's state is made of (Brian2's stored state with its random
state, MuJoCo's integration states, the session loop's counters and memory): ``None``, bools,
ints, floats (NaN and infinities tagged), strings, lists, tuples (``{"$tuple": [...]}``),
dicts (JSON objects; ``{"$dict": [[key, value], ...]}`` when a key is not a string or starts
with ``$``), NumPy scalars (``{"$np": dtype, "v": value}``), small arrays inline
(``{"$inline": dtype, "shape": [...], "data": [...]}``), larger ones by reference
(``{"$array": "a7"}``), object arrays element by element (``{"$objects": ...}``) and bytes
(``{"$bytes": "a8"}``). Nothing in the file names a type to build or a function to call, so
reading a file from anywhere (a study folder on a shared file system) runs no code; a file
that is not such an archive, is damaged (the archive's CRC-32 checks) or is shaped otherwise
is an :class:`~astrocpg.errors.InputError` naming the file.

Checkpoints of astrocpg before this format (``checkpoint.pkl``, a pickle) are never loaded:
loading one could run code. :func:`refuse_legacy` says so in one line.
"""

from __future__ import annotations

import json
import math
import os
import zipfile
from pathlib import Path
from typing import Any

import numpy as np

from ...errors import EnvironmentFault, InputError, advice, setting
from ...support.reading import check_npy, loads_json, open_regular
from .writing import atomic_write, savez

CHECKPOINT = "checkpoint.npz"
#: The pickled checkpoint of earlier versions: refused, never read.
LEGACY_CHECKPOINT = "checkpoint.pkl"
FORMAT = "astrocpg-checkpoint"
VERSION = 2  # 1 was the pickle (checkpoint.pkl)
_LEGACY_MAGIC = b"ASTROCPG-CHECKPOINT-1\n"
_ZIP_MAGIC = b"PK\x03\x04"
# arrays up to this many elements go into the JSON (a recording holds one small index array
# per step with spikes: thousands of archive entries otherwise)
_INLINE = 64
_KINDS = "biuf"  # bool, signed and unsigned integers, floats: exact in JSON


class CheckpointCorrupt(InputError):
    """A checkpoint that cannot be read as one (damaged, truncated, foreign, shaped otherwise)."""


def _error(path: Path, culprit: Any, text: str, cls: type = CheckpointCorrupt) -> InputError:
    """``<culprit>: <path> <text>``, or ``<path>: <text>`` when the culprit is the file."""
    if culprit is None or str(culprit) == str(path):
        return cls(text, culprit=path)
    return cls(f"{path} {text}", culprit=culprit)


def _old_format(path: Path, culprit: Any = None) -> InputError:
    return _error(path, culprit,
        f"is a checkpoint of an old format (a Python pickle, astrocpg before checkpoint "
        f"format {VERSION}); it is never loaded, because loading a pickle can run code: retrain "
        f"that run ({advice('retrain')}, or the study into a new {setting('out')}) or "
        f"replace the file with a checkpoint this version wrote", cls=InputError)


def refuse_legacy(folder: Path) -> None:
    """An InputError naming the file when ``folder`` holds a checkpoint of the old (pickled)
    format: it is never opened."""
    legacy = Path(folder) / LEGACY_CHECKPOINT
    if legacy.exists() or legacy.is_symlink():
        raise _old_format(legacy)


def holds_checkpoint(folder: Path) -> bool:
    """Whether ``folder`` holds a checkpoint of any format (the current or the old one)."""
    folder = Path(folder)
    return any((folder / n).exists() or (folder / n).is_symlink()
               for n in (CHECKPOINT, LEGACY_CHECKPOINT))


# ---------------------------------------------------------------- the tree <-> JSON + arrays
def _float(x: float) -> Any:
    if math.isfinite(x):
        return x
    return {"$float": "nan" if math.isnan(x) else ("inf" if x > 0 else "-inf")}


class _Encoder:
    def __init__(self) -> None:
        self.arrays: dict[str, np.ndarray] = {}

    def _ref(self, a: np.ndarray) -> str:
        key = f"a{len(self.arrays)}"
        self.arrays[key] = a
        return key

    def encode(self, x: Any) -> Any:
        if x is None or isinstance(x, (bool, str)):
            return x
        if isinstance(x, int) and not isinstance(x, np.generic):
            return int(x)
        if isinstance(x, float) and not isinstance(x, np.generic):
            return _float(float(x))
        if isinstance(x, np.generic):
            if x.dtype.kind in _KINDS:
                v = x.item()
                return {"$np": x.dtype.str, "v": _float(v) if isinstance(v, float) else v}
            if x.dtype.hasobject:
                raise TypeError(f"a checkpoint holds no Python objects ({type(x).__name__})")
            return {"$scalar": self._ref(np.asarray(x))}
        if isinstance(x, np.ndarray):
            if hasattr(x, "dim"):  # a Brian2 Quantity: its unit would be lost
                raise TypeError("a checkpoint holds plain arrays, not quantities")
            a = np.asarray(x)
            if a.dtype.hasobject:
                return {"$objects": {"shape": list(a.shape),
                                     "items": [self.encode(v) for v in a.ravel().tolist()]}}
            if a.dtype.kind in _KINDS and a.size <= _INLINE:
                data = [(_float(v) if isinstance(v, float) else v) for v in a.ravel().tolist()]
                return {"$inline": a.dtype.str, "shape": list(a.shape), "data": data}
            return {"$array": self._ref(np.ascontiguousarray(a))}
        if isinstance(x, (bytes, bytearray)):
            return {"$bytes": self._ref(np.frombuffer(bytes(x), dtype=np.uint8))}
        if isinstance(x, tuple):
            return {"$tuple": [self.encode(v) for v in x]}
        if isinstance(x, list):
            return [self.encode(v) for v in x]
        if isinstance(x, dict):
            if all(isinstance(k, str) and not k.startswith("$") for k in x):
                return {k: self.encode(v) for k, v in x.items()}
            return {"$dict": [[self.encode(k), self.encode(v)] for k, v in x.items()]}
        raise TypeError(f"a checkpoint holds data only, not {type(x).__name__}")


class _Decoder:
    def __init__(self, arrays: Any, path: Path, culprit: str) -> None:
        self.arrays, self.path, self.culprit = arrays, path, culprit

    def bad(self, why: str) -> CheckpointCorrupt:
        return _error(self.path, self.culprit, f"is corrupt ({why})")

    def _dtype(self, text: Any) -> np.dtype:
        if not isinstance(text, str):
            raise self.bad("a dtype is not a string")
        try:
            dtype = np.dtype(text)
        except (TypeError, ValueError):
            raise self.bad(f"unknown dtype {text!r}") from None
        if dtype.kind not in _KINDS:
            raise self.bad(f"dtype {text!r} is not a plain number")
        return dtype

    def _array(self, key: Any) -> np.ndarray:
        if not isinstance(key, str) or not key.startswith("a") or key not in self.arrays:
            raise self.bad(f"no array {key!r}")
        try:
            return self.arrays[key]
        except ValueError:  # an object array: numpy refuses it (allow_pickle=False)
            raise self.bad(f"array {key} holds Python objects") from None

    def _number(self, v: Any) -> Any:
        if isinstance(v, dict):
            if set(v) != {"$float"} or v["$float"] not in ("nan", "inf", "-inf"):
                raise self.bad("a number is not a number")
            return float(v["$float"])
        if isinstance(v, bool) or isinstance(v, (int, float)):
            return v
        raise self.bad("a number is not a number")

    def decode(self, x: Any, depth: int = 0) -> Any:
        if depth > 64:
            raise self.bad("nested too deep")
        if x is None or isinstance(x, (bool, int, float, str)):
            return x
        if isinstance(x, list):
            return [self.decode(v, depth + 1) for v in x]
        if not isinstance(x, dict):
            raise self.bad(f"unexpected {type(x).__name__}")
        tags = [k for k in x if k.startswith("$")]
        if not tags:
            return {k: self.decode(v, depth + 1) for k, v in x.items()}
        tag = tags[0]
        try:
            if tag == "$float" and len(x) == 1:
                return self._number(x)
            if tag == "$tuple" and len(x) == 1 and isinstance(x[tag], list):
                return tuple(self.decode(v, depth + 1) for v in x[tag])
            if tag == "$dict" and len(x) == 1 and isinstance(x[tag], list):
                out = {}
                for pair in x[tag]:
                    if not isinstance(pair, list) or len(pair) != 2:
                        raise self.bad("a dict entry is not a pair")
                    key = self.decode(pair[0], depth + 1)
                    out[key] = self.decode(pair[1], depth + 1)
                return out
            if tag == "$np" and set(x) == {"$np", "v"}:
                return self._dtype(x["$np"]).type(self._number(x["v"]))
            if tag == "$scalar" and len(x) == 1:
                a = self._array(x[tag])
                if a.ndim != 0:
                    raise self.bad("a scalar is not 0-d")
                return a[()]
            if tag == "$array" and len(x) == 1:
                return self._array(x[tag])
            if tag == "$bytes" and len(x) == 1:
                a = self._array(x[tag])
                if a.dtype != np.uint8 or a.ndim != 1:
                    raise self.bad("bytes are not uint8")
                return a.tobytes()
            if tag == "$inline" and set(x) == {"$inline", "shape", "data"}:
                dtype = self._dtype(x["$inline"])
                shape, data = x["shape"], x["data"]
                if (not isinstance(shape, list) or not isinstance(data, list)
                        or not all(isinstance(n, int) and n >= 0 for n in shape)
                        or math.prod(shape) != len(data)):
                    raise self.bad("an inline array has the wrong size")
                return np.array([self._number(v) for v in data], dtype=dtype).reshape(shape)
            if tag == "$objects" and len(x) == 1 and isinstance(x[tag], dict):
                shape, items = x[tag].get("shape"), x[tag].get("items")
                if (not isinstance(shape, list) or not isinstance(items, list)
                        or not all(isinstance(n, int) and n >= 0 for n in shape)
                        or math.prod(shape) != len(items)):
                    raise self.bad("an object array has the wrong size")
                a = np.empty(len(items), dtype=object)
                for i, v in enumerate(items):
                    a[i] = self.decode(v, depth + 1)
                return a.reshape(shape)
        except (OverflowError, ValueError, TypeError) as e:
            if isinstance(e, InputError):
                raise
            raise self.bad(f"a value does not fit its type ({e})") from None
        raise self.bad(f"unknown entry {tag!r}")


# ---------------------------------------------------------------- the file
def write_checkpoint(path: Path, meta: dict[str, Any], state: Any) -> None:
    """Write ``meta`` (JSON values) and ``state`` (the tree described in the module's
    docstring) to ``path`` atomically (a temporary beside it, synced, renamed)."""
    enc = _Encoder()
    state_json = json.dumps(enc.encode(state), allow_nan=False, separators=(",", ":"))
    meta_json = json.dumps({"format": FORMAT, "version": VERSION} | meta, allow_nan=False,
                           separators=(",", ":"))
    arrays = {"meta": np.frombuffer(meta_json.encode(), dtype=np.uint8),
              "state": np.frombuffer(state_json.encode(), dtype=np.uint8)} | enc.arrays
    # uncompressed: a checkpoint is written often and its arrays are mostly noise-like floats
    atomic_write(Path(path), lambda f: savez(f, arrays))


def _open(path: Path, culprit: str) -> tuple[Any, Any]:
    """``(file, archive)``: the checkpoint opened (a regular file only: a FIFO, device or
    socket is refused before it is read, never waited on) and read as an ``.npz``; the caller
    closes both."""
    if path.is_dir():
        raise _error(path, culprit, "is a folder, not a checkpoint")
    try:
        f = open_regular(path, culprit)
    except FileNotFoundError:
        raise _error(path, culprit, "does not exist", cls=InputError) from None
    except OSError as e:
        raise EnvironmentFault.from_os_error(e, path, "cannot read the checkpoint") from None
    try:
        try:
            head = f.read(len(_LEGACY_MAGIC))
            f.seek(0)
        except OSError as e:
            raise EnvironmentFault.from_os_error(e, path, "cannot read the checkpoint") from None
        if head.startswith(_LEGACY_MAGIC) or head[:1] == b"\x80":  # astrocpg's old one, a pickle
            raise _old_format(path, culprit)
        if not head.startswith(_ZIP_MAGIC):
            raise _error(path, culprit, "is not an astrocpg checkpoint")
        try:
            _check_sizes(f, path, culprit)
            f.seek(0)
            return f, np.load(f, allow_pickle=False)
        except (OSError, ValueError, EOFError, zipfile.BadZipFile, zipfile.LargeZipFile) as e:
            if isinstance(e, InputError):
                raise
            if isinstance(e, OSError) and not isinstance(e, zipfile.BadZipFile) and e.errno:
                raise EnvironmentFault.from_os_error(e, path,
                                                     "cannot read the checkpoint") from None
            raise _error(path, culprit, "is corrupt (not a whole archive)") from None
    except BaseException:
        f.close()
        raise


def _check_sizes(f: Any, path: Path, culprit: Any) -> None:
    """Bounded reading: a checkpoint is written uncompressed (``np.savez``), so each entry must
    be stored as is (its declared size equal to the bytes it takes in the file) and the sizes
    must add up to no more than the file: nothing in it can make the reader use more memory
    than the file's own size (a compressed entry, a compression bomb, a declared size larger
    than the file is refused before anything is decompressed), nor can an array's header
    claim more than its entry holds (:func:`~astrocpg.support.reading.check_npy`)."""
    size = os.fstat(f.fileno()).st_size
    with zipfile.ZipFile(f) as zf:
        total = 0
        for info in zf.infolist():
            if info.compress_type != zipfile.ZIP_STORED or info.file_size != info.compress_size:
                raise _error(path, culprit, f"is not an astrocpg checkpoint (entry "
                                            f"{info.filename} is compressed: {info.file_size} "
                                            f"bytes declared in {info.compress_size})")
            total += info.file_size
            if total > size:
                raise _error(path, culprit, f"is corrupt (entry {info.filename} declares "
                                            f"{info.file_size} bytes, more than the file holds)")
        for info in zf.infolist():  # each array's header against its entry's bytes, before
            if info.filename.endswith(".npy"):  # NumPy allocates what a header claims
                with zf.open(info) as member:
                    try:
                        check_npy(member, info.file_size, path, path, info.filename)
                    except InputError as e:
                        raise _error(path, culprit, f"is corrupt ({e.raw_message})") from None


def _referenced(tree: Any, found: set[str], depth: int = 0) -> set[str]:
    """The archive entries the state tree refers to (``$array``, ``$scalar``, ``$bytes``)."""
    if depth > 64:
        return found
    if isinstance(tree, list):
        for v in tree:
            _referenced(v, found, depth + 1)
    elif isinstance(tree, dict):
        for k, v in tree.items():
            if k in ("$array", "$scalar", "$bytes") and isinstance(v, str):
                found.add(v)
            else:
                _referenced(v, found, depth + 1)
    return found


def _json_entry(z: Any, name: str, path: Path, culprit: str) -> Any:
    if name not in z.files:
        raise _error(path, culprit, f"is not an astrocpg checkpoint (no {name})")
    a = z[name]
    if a.dtype != np.uint8 or a.ndim != 1:
        raise _error(path, culprit, f"is corrupt ({name} is not text)")
    try:
        # bounded: a JSON entry nested 100,000 deep is refused before the parser recurses
        return loads_json(a.tobytes().decode("utf-8"), culprit if culprit is not None else path,
                          path)
    except InputError:
        raise
    except (UnicodeDecodeError, ValueError):
        raise _error(path, culprit, f"is corrupt ({name} is not JSON)") from None


def _meta(z: Any, path: Path, culprit: str) -> dict[str, Any]:
    meta = _json_entry(z, "meta", path, culprit)
    if not isinstance(meta, dict) or meta.get("format") != FORMAT:
        raise _error(path, culprit, "is not an astrocpg checkpoint")
    if meta.get("version") != VERSION:
        raise _error(path, culprit, f"is a checkpoint of format version "
                                f"{meta.get('version')!r}; this astrocpg reads version {VERSION}")
    return meta


_DAMAGE = (OSError, ValueError, EOFError, KeyError, zipfile.BadZipFile)


def read_checkpoint(path: Path, culprit: Any = None) -> tuple[dict[str, Any], Any]:
    """``(meta, state)`` of the checkpoint at ``path``: every entry read and checked against
    the archive's CRC-32. Any file that is not a whole checkpoint of this format is an
    InputError (old pickled checkpoints included: refused, never loaded)."""
    path = Path(path)
    f, z = _open(path, culprit)
    try:
        meta = _meta(z, path, culprit)
        tree = _json_entry(z, "state", path, culprit)
        names = set(z.files) - {"meta", "state"}
        unreferenced = sorted(names - _referenced(tree, set()))
        if unreferenced:  # never read: refused before a byte of it is decompressed
            more = f" and {len(unreferenced) - 1} more" if len(unreferenced) > 1 else ""
            raise _error(path, culprit, f"is not an astrocpg checkpoint (entry "
                                        f"{unreferenced[0]}{more} is not part of its state)")
        arrays = {}
        for name in names:  # read every entry now: a damaged one fails here, as a whole
            try:
                arrays[name] = z[name]
            except ValueError as e:
                if "pickle" in str(e):
                    raise _error(path, culprit, f"is corrupt (entry {name} holds Python "
                                            f"objects)") from None
                raise
        state = _Decoder(arrays, path, culprit).decode(tree)
        return meta, state
    except _DAMAGE as e:
        if isinstance(e, InputError):
            raise
        raise _error(path, culprit, f"is corrupt ({type(e).__name__}: "
                                f"{str(e)[:80] or 'unreadable'})") from None
    finally:
        z.close()
        f.close()
