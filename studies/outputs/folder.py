"""One invocation's result folder: whole or nothing, listed in its manifest, owned while in use.

* :class:`OutputFolder` -- a command writes into a hidden temporary sibling
  (``.<name>.partial-<pid>-<random>``) that is renamed into place only when the command
  finishes; on an exception, Ctrl-C or ``SystemExit`` the temporary is deleted. A folder that
  holds files is refused unless ``overwrite``, which replaces it whole (never merges).
* :func:`check_output_path` / :func:`check_replaceable` -- the one rule of every ``out``: it
  is never the current folder, a folder or file the command reads, nor holds one, nor lies
  inside one but at a derived place (``figures/``, ``report/``, ...); and ``overwrite``
  replaces only an astrocpg output folder (it has astrocpg's ``manifest.json``) that holds
  nothing but what astrocpg wrote and recorded (``sort_out``: never a user's file, link or
  empty folder), never a folder of the user's own files, nor a file an output folder's
  manifest lists, nor a training or study but by the same command.
* :func:`inventory` / :func:`verify` -- the manifest's ``"inventory"`` lists every file
  astrocpg wrote with its size and sha256 (a folder written in place never adopts a user's
  file); readers refuse a folder whose files do not match it.
* :class:`FolderLock` -- a running ``train`` or ``study`` owns its folder; a second process on
  the same folder stops with one line naming the holder.
* :func:`clean_stale_temporaries` -- hidden temporaries (folders and files) whose name carries
  the pid of a process that no longer exists are removed on the next start.

Temporary names (one scheme for folders and files, made by :func:`temp_prefix`)::

    .<name>.partial-<pid>-<token>            a folder being written by OutputFolder
    .<name>.replaced-<pid>-<token>           an old folder set aside by an overwrite
    .<stem>.tmp-<pid>-<token><suffix>        a file being written by an atomic writer

``<token>`` is 6 to 32 characters of ``[A-Za-z0-9_]`` (what ``tempfile.mkstemp`` appends).
Every such name fits in :data:`NAME_MAX` (255) bytes: a ``<name>`` or ``<stem>`` too long for
that (a legal name of 235-255 bytes) is shortened to its start, ``~`` and 8 hex digits of its
sha256; a long ``<suffix>`` is dropped (:func:`temp_prefix`, :func:`temp_suffix`). Hidden
temporaries are nobody's files: :func:`inventory` does not list them, :func:`verify` does not
count them.
"""

from __future__ import annotations

import ctypes
import hashlib
import errno
import fnmatch
import json
import os
import re
import secrets
import shutil
import socket
import sys
import tempfile
import time
from pathlib import Path
from typing import Any, Iterable, Iterator, Mapping

from ...errors import EnvironmentFault, Field, InputError, setting, shown_with
from ...support.reading import open_regular, read_json

MANIFEST = "manifest.json"
LOCK_NAME = ".astrocpg.lock"
OWNER_NAME = ".astrocpg.lock.owner"
#: Top-level names that :func:`inventory` does not list and :func:`verify` does not count as
#: extra files: the manifest itself and a lock (left behind by a killed holder).
UNLISTED = frozenset({MANIFEST, LOCK_NAME, OWNER_NAME})
#: What later commands write into a finished folder beside the files its manifest lists (plot:
#: figures/, report: report/, evaluate: evaluation/ and, while unfinished, evaluation.parts/,
#: video: video_trialTT.mp4, power: power_trialK.json). A strict :func:`verify` does not count
#: them as extra files; the listed files must still match.
DERIVED = ("figures/*", "report/*", "evaluation/*", "evaluation.parts/*", "video_trial*.mp4",
           "power_trial*.json")

TEMP_KINDS = ("partial", "replaced", "tmp")
_TEMP_RE = re.compile(r"^\.(?P<name>.+)\.(?P<kind>partial|replaced|tmp)-(?P<pid>[0-9]{1,10})-"
                      r"(?P<token>[A-Za-z0-9_]{6,32})(?P<suffix>\.[^.]*)?$")


def _now() -> str:
    return time.strftime("%Y-%m-%dT%H:%M:%S%z")


def as_path(value: Any, culprit: str) -> Path:
    """A path argument of the API as a Path: text or an os.PathLike; anything else (a number,
    a list, None) is an InputError naming ``culprit`` instead of a TypeError from inside."""
    if isinstance(value, (str, os.PathLike)) and not isinstance(value, bytes):
        return Path(value)
    raise InputError(f"expected a path (text or a pathlib.Path), got {type(value).__name__}",
                     culprit=culprit)


# ---------------------------------------------------------------- temporaries
#: the longest file name most file systems take (bytes): a temporary's name must fit too
NAME_MAX = 255
#: what ``tempfile`` (and ``secrets.token_hex(4)``) appends to a prefix
TOKEN_LENGTH = 8
_SHORTENED = re.compile(r"~[0-9a-f]{8}$")


def _fit(stem: str, room: int) -> str:
    """``stem``, or when its UTF-8 bytes exceed ``room``, its start and ``~`` and 8 hex digits
    of its sha256 (a shortened stem: unique per stem, and still recognisable)."""
    raw = os.fsencode(stem)
    if len(raw) <= room:
        return stem
    digest = hashlib.sha256(raw).hexdigest()[:8]
    head = raw[:max(0, room - 9)].decode("utf-8", "ignore")  # never half a character
    return f"{head}~{digest}"


def temp_suffix(suffix: str) -> str:
    """The suffix a temporary keeps: ``suffix`` if it is short (``.npz``, ``.nwb``, ``.mp4``),
    else none (a long "suffix" is part of a name, and no library checks it)."""
    return suffix if len(os.fsencode(suffix)) <= 16 else ""


def temp_prefix(stem: str, kind: str = "tmp", suffix: str = "") -> str:
    """``.<stem>.<kind>-<pid>-``: the start of a hidden temporary's name, for ``tempfile``.

    An atomic file writer uses
    ``tempfile.mkstemp(dir=path.parent, prefix=temp_prefix(path.stem, suffix=s), suffix=s)``
    with ``s = temp_suffix(path.suffix)``, which makes ``.<stem>.tmp-<pid>-<8 random><suffix>``
    (the suffix kept for libraries that check it, e.g. pynwb); :func:`clean_stale_temporaries`
    recognises it. The whole name fits in :data:`NAME_MAX` bytes: a long stem (a legal name of
    up to 255 bytes leaves no room for the rest) is shortened to its start, ``~`` and a hash of
    it; the temporary's name then no longer says the target's whole name (see
    :func:`clean_stale_temporaries`)."""
    if kind not in TEMP_KINDS:
        raise ValueError(f"kind must be one of {TEMP_KINDS}, got {kind!r}")
    fixed = len(os.fsencode(f"...{kind}-{os.getpid()}-{suffix}")) + TOKEN_LENGTH
    return f".{_fit(stem, NAME_MAX - fixed)}.{kind}-{os.getpid()}-"


def parse_temp_name(name: str) -> dict[str, Any] | None:
    """``{"name", "kind", "pid", "suffix"}`` of a hidden temporary's name, else None."""
    m = _TEMP_RE.match(name)
    if m is None:
        return None
    return {"name": m["name"], "kind": m["kind"], "pid": int(m["pid"]), "suffix": m["suffix"] or ""}


def pid_alive(pid: int) -> bool:
    """Whether a process ``pid`` exists (on this machine). Only a definite "no such process"
    counts as dead: a process of another user, or an unusable pid, counts as alive."""
    if pid <= 0:
        return True
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except (OSError, OverflowError):
        return True
    return True


def _remove(path: Path) -> None:
    """Delete a file, a link or a folder tree; a path already gone is fine."""
    try:
        if path.is_dir() and not path.is_symlink():
            shutil.rmtree(path)
        else:
            path.unlink()
    except FileNotFoundError:
        pass


def clean_stale_temporaries(parent: str | os.PathLike) -> list[Path]:
    """Remove the hidden temporaries in ``parent`` (not below it) left by processes that no
    longer exist; returns what was removed. Temporaries of live processes are kept.

    An old folder that a killed overwrite had set aside (``.<name>.replaced-<pid>-...``)
    while ``<name>`` is absent is renamed back to ``<name>``: the interrupted overwrite did not
    happen. (Where ``<name>`` was too long to fit, the aside name holds a shortened one and the
    folder is left as it is, hidden but whole: never deleted.) Best effort: what cannot be removed (a read-only folder, another process cleaning at
    the same moment) is left for the next start."""
    parent = Path(parent)
    try:
        with os.scandir(parent) as it:
            names = [e.name for e in it]
    except OSError:
        return []
    removed: list[Path] = []
    for name in sorted(names):
        tmp = parse_temp_name(name)
        if tmp is None or tmp["pid"] == os.getpid() or pid_alive(tmp["pid"]):
            continue
        path = parent / name
        try:
            if tmp["kind"] == "replaced" and path.is_dir() and not path.is_symlink():
                original = parent / tmp["name"]
                if not os.path.lexists(original):
                    if _SHORTENED.search(tmp["name"]):
                        continue  # its name was shortened: keep the old folder, never delete it
                    os.rename(path, original)
                    continue
            _remove(path)
            removed.append(path)
        except OSError:
            continue
    return removed


# ---------------------------------------------------------------- what an output may replace
def _real(path: str | os.PathLike) -> str:
    return os.path.realpath(os.path.abspath(os.fspath(path)))


def _below(path: str, folder: str) -> bool:
    """Is the real path ``path`` strictly inside the real path ``folder``?"""
    return path != folder and path.startswith(folder.rstrip(os.sep) + os.sep)


def _derived(rel: str, *, folder: bool) -> bool:
    """Is ``rel`` (POSIX, relative to an input folder) one of the places :data:`DERIVED` names,
    where later commands write beside an output folder's own files?"""
    probe = rel + "/x" if folder else rel
    return any(fnmatch.fnmatchcase(probe, p) for p in DERIVED)


def _derived_places() -> str:
    return ", ".join(dict.fromkeys(p[:-2] + "/" if p.endswith("/*") else p for p in DERIVED))


def is_astrocpg_output(folder: str | os.PathLike) -> bool:
    """Does ``folder`` hold an astrocpg output: a ``manifest.json`` that astrocpg wrote (a JSON
    object with ``"astrocpg_command"``), or nothing but astrocpg's own lock files and hidden
    temporaries (what a process killed before its first manifest leaves)?"""
    root = Path(folder)
    try:
        manifest = read_json(root / MANIFEST)
    except FileNotFoundError:
        try:
            names = os.listdir(root)
        except OSError:
            return False
        return all(n in UNLISTED or parse_temp_name(n) is not None for n in names)
    except (OSError, ValueError):
        return False
    return isinstance(manifest, dict) and isinstance(manifest.get("astrocpg_command"), str)


def check_output_path(target: str | os.PathLike, inputs: Iterable[str | os.PathLike] = (), *,
                      culprit: str, file: bool = False) -> None:
    """The rule of every ``out`` (a folder, or with ``file`` a file) against what the command
    reads (``inputs``: folders and files; None and paths that do not exist are skipped).
    InputError naming ``culprit`` when the output

    * is the current folder, or holds it (replacing it would pull the folder from under the
      user's shell);
    * is an input, or holds one (writing ``out`` would delete what the command reads);
    * lies inside an input folder anywhere but at a place later commands write into
      (:data:`DERIVED`: ``figures/``, ``report/``, ``evaluation/``, ``video_trial*.mp4``, ...):
      elsewhere it would change the input, which would then no longer match its manifest.

    Applies whether or not ``overwrite`` is given; what ``overwrite`` may replace on top of
    this: :func:`check_replaceable`."""
    real = _real(target)
    cwd = _real(os.getcwd())
    if not file and (real == cwd or _below(cwd, real)):
        where = "is the current folder" if real == cwd else "holds the current folder"
        raise InputError(f"{where}; the output must go to a folder of its own, beside or "
                         "inside it", culprit=culprit)
    for given in inputs:
        if given is None or not os.path.lexists(given):
            continue
        src = _real(given)
        if real == src:
            raise InputError(f"is {os.fspath(given)}, which this command reads; write the output "
                             "elsewhere", culprit=culprit)
        if _below(src, real):
            raise InputError(f"holds {os.fspath(given)}, which this command reads; write the "
                             "output elsewhere", culprit=culprit)
        if _below(real, src) and os.path.isdir(src) \
                and not _derived(Path(os.path.relpath(real, src)).as_posix(), folder=not file):
            raise InputError(f"is inside {os.fspath(given)}, which this command reads (only "
                             f"{_derived_places()} may be written there)", culprit=culprit)


def _refuse_part_of_output(path: Path, culprit: str) -> None:
    """InputError when the folder ``path`` lies inside another astrocpg output folder (a run
    folder inside a study's ``runs/``, a recorded session inside a training): that output
    holds it, and replacing it would change that output behind its back."""
    for folder in path.parents:
        if (folder / MANIFEST).is_file() and is_astrocpg_output(folder):
            if _derived(path.relative_to(folder).as_posix(), folder=True):
                return  # figures/, report/, ...: the places later commands write into
            try:
                manifest = read_json(folder / MANIFEST)
                command = manifest.get("astrocpg_command")
            except (OSError, ValueError, AttributeError):
                command = None
            what = f"the astrocpg {command} folder" if isinstance(command, str) \
                else "the astrocpg output folder"
            raise InputError(f"is part of {what} {folder}; {setting('overwrite')} never "
                             f"replaces a part "
                             f"of another output (rerun that {command or 'command'} instead, "
                             f"or write to a folder of its own)", culprit=culprit)


def _astrocpg_manifest(folder: Path) -> dict[str, Any] | None:
    """``folder/manifest.json`` when astrocpg wrote it (a JSON object naming its command),
    else None (no manifest, unreadable, not astrocpg's)."""
    try:
        manifest = read_json(folder / MANIFEST)
    except (OSError, ValueError):
        return None
    if isinstance(manifest, dict) and isinstance(manifest.get("astrocpg_command"), str):
        return manifest
    return None


def _listing(manifest: dict[str, Any] | None) -> dict[str, Any] | None:
    """A manifest's inventory, when it has a well-formed one."""
    listed = None if manifest is None else manifest.get("inventory")
    return listed if isinstance(listed, dict) else None


def _as_recorded(path: Path, st: os.stat_result, entry: Any) -> bool:
    """Is the file ``path`` (stat ``st``) the one an inventory ``entry`` records: the same size
    and, where the entry has it, the same mtime; else the same sha256."""
    if not (isinstance(entry, dict) and entry.get("bytes") == st.st_size):
        return False
    if entry.get("mtime_ns") == st.st_mtime_ns:
        return True
    try:
        return file_sha256(path) == entry.get("sha256")
    except (OSError, InputError):
        return False


#: Derived single files that carry no manifest of their own: astrocpg's by their names.
_DERIVED_BY_NAME = ("video_trial*.mp4", "power_trial*.json", "evaluation.parts/*")


def sort_out(root: str | os.PathLike,
             only: Iterable[str] | None = None) -> tuple[list[Path], list[str]]:
    """What in the folder ``root`` astrocpg wrote and recorded, and what it did not.

    Returns (astrocpg's files, the user's entries as relative POSIX paths, folders ending in
    ``/``). A file is astrocpg's when an astrocpg inventory lists it as it is (name, and size
    with mtime or sha256): ``root``'s own manifest's, or the manifest of a folder inside it
    (a figures/, a recorded session, a study's run); manifests (astrocpg's) and lock files and
    hidden temporaries are astrocpg's too, and so are a video or a power estimate at the top
    (``video_trial*.mp4``, ``power_trial*.json``, ``evaluation.parts/``). Everything else is
    the user's: a file no inventory lists or one changed since, a link (to a file or a
    folder), a folder that holds nothing of astrocpg's (an empty one included). Nothing is
    followed through a link. Where ``root``'s manifest has no inventory (an older astrocpg's),
    the files at its top that the manifest's ``"files"`` names are astrocpg's, nothing else.
    ``only``: look at just these names at the top of ``root`` (nothing else is read)."""
    root = Path(root)
    top = None if only is None else set(only)
    own: list[Path] = []
    foreign: list[str] = []

    def walk(folder: Path, rel: str, listings: list[tuple[str, dict[str, Any]]]) -> bool:
        manifest = _astrocpg_manifest(folder)
        listed = _listing(manifest)
        if listed is not None:
            listings = [*listings, (rel, listed)]
        try:
            with os.scandir(folder) as it:
                entries = sorted(it, key=lambda e: e.name)
        except OSError as e:
            raise EnvironmentFault.from_os_error(e, folder, "cannot read") from None
        holds_own = False
        for entry in entries:
            name = entry.name
            if rel == "" and top is not None and name not in top:
                continue
            sub = f"{rel}{name}"
            path = folder / name
            if name in (LOCK_NAME, OWNER_NAME) or parse_temp_name(name) is not None:
                holds_own = True  # astrocpg's own bookkeeping: never the user's
                continue
            if entry.is_symlink():
                foreign.append(sub)
                continue
            if entry.is_dir():
                before = len(foreign)
                if walk(path, sub + "/", listings):
                    holds_own = True
                elif len(foreign) == before:
                    foreign.append(sub + "/")  # an empty folder: the user's
                continue
            if name == MANIFEST and manifest is not None:
                own.append(path)
                holds_own = True
                continue
            st = entry.stat(follow_symlinks=False)
            mine = any(_as_recorded(path, st, inv.get(sub[len(at):]))
                       for at, inv in reversed(listings) if sub[len(at):] in inv)
            if not mine:
                mine = any(fnmatch.fnmatchcase(sub, p) for p in _DERIVED_BY_NAME)
            if not mine and rel == "" and listed is None and manifest is not None:
                # an older astrocpg's manifest (no inventory): the files it names, no more
                files = manifest.get("files")
                mine = isinstance(files, dict) and name in files
            if mine:
                own.append(path)
                holds_own = True
            else:
                foreign.append(sub)
        return holds_own

    walk(root, "", [])
    return own, foreign


def _remove_files(root: Path, paths: Iterable[Path]) -> None:
    """Delete ``paths`` (files inside ``root``), then the folders that held them, up to
    ``root`` itself, that are empty once they are gone."""
    dirs: set[Path] = set()
    try:
        for path in paths:
            _remove(path)
            dirs.update(p for p in path.parents if p == root or root in p.parents)
        for d in sorted(dirs, key=lambda p: len(p.parts), reverse=True):
            if d.is_dir() and not d.is_symlink() and not any(d.iterdir()):
                os.rmdir(d)
    except OSError as e:
        raise EnvironmentFault.from_os_error(e, e.filename or root, "cannot remove") from None


def remove_own(folder: str | os.PathLike) -> list[str]:
    """Delete what astrocpg wrote and recorded in ``folder`` (``sort_out``), and the
    folders that held it once they are empty (``folder`` itself included); the user's entries
    stay, and with them the folders that hold them. Returns the user's entries left
    (relative POSIX paths)."""
    root = Path(folder)
    if root.is_symlink() or not root.is_dir():
        return []
    own, foreign = sort_out(root)
    _remove_files(root, own)
    return foreign


def _refuse_foreign_files(path: Path, culprit: str) -> None:
    """InputError naming the first entry (and how many there are) of the astrocpg output
    folder ``path`` that astrocpg did not write and record (``sort_out``: a file its
    manifest's inventory does not list, or one changed since; a link; an empty folder): a
    thing the user added is never deleted by ``overwrite``. A manifest without an inventory
    (an older astrocpg's, or not astrocpg's) claims nothing but itself."""
    manifest = _astrocpg_manifest(path)
    _, foreign = sort_out(path)
    if not foreign:
        return
    more = f" and {len(foreign) - 1} more" if len(foreign) > 1 else ""
    if manifest is not None and _listing(manifest) is None:
        raise InputError(f"holds {foreign[0]}{more}, and its {MANIFEST} lists no files (no "
                         f"\"inventory\": an older astrocpg's?), so astrocpg cannot tell its "
                         f"files from yours; {setting('overwrite')} replaces only what astrocpg "
                         f"wrote: delete the folder yourself, or choose another", culprit=culprit)
    raise InputError(f"holds {foreign[0]}{more} that astrocpg did not write (not listed in "
                     f"its {MANIFEST}, or changed since); {setting('overwrite')} replaces only "
                     f"what astrocpg wrote: move your files out first, or choose another folder",
                     culprit=culprit)


#: Outputs that hold work a later command continues (a training, a study): ``overwrite``
#: replaces them only with the same command's output, never with a plot or a run.
_KEPT_WORK = ("train", "study")


def _refuse_other_command(path: Path, command: str | None, culprit: str) -> None:
    manifest = _astrocpg_manifest(path)
    made_by = None if manifest is None else manifest.get("astrocpg_command")
    if made_by in _KEPT_WORK and made_by != command:
        raise InputError(f"holds an astrocpg {made_by} output (its {MANIFEST} says so); "
                         f"{setting('overwrite')} replaces it only with another {made_by}: "
                         f"choose another folder, or delete it yourself", culprit=culprit)


#: How the files astrocpg writes alone (an export, a video) begin, by suffix: ``overwrite``
#: replaces an existing file only when it is of the kind the command writes.
_MAGIC = {".nwb": (0, b"\x89HDF\r\n\x1a\n"), ".npz": (0, b"PK\x03\x04"),
          ".mp4": (4, b"ftyp")}


def _refuse_foreign_file(path: Path, culprit: str) -> None:
    """InputError when the existing file ``path`` is not of the kind astrocpg writes under its
    suffix (an NWB, an .npz, an MP4 by its first bytes): your ``notes.txt`` or a file renamed
    is never replaced by an export or a video."""
    offset, magic = _MAGIC.get(path.suffix.lower(), (0, b""))
    head = b""
    if magic:
        try:
            with open_regular(path, culprit) as f:
                head = f.read(offset + len(magic))[offset:]
        except OSError:
            head = b""
    if not magic or head != magic:
        kind = f"an {path.suffix[1:]} file" if magic else "a file of a kind astrocpg writes"
        raise InputError(f"exists and is not {kind}; {setting('overwrite')} replaces only a "
                         f"file of the "
                         f"kind astrocpg writes there: choose another name, or remove it "
                         f"yourself", culprit=culprit)


def check_replaceable(target: str | os.PathLike, *, culprit: str,
                      command: str | None = None) -> None:
    """What ``overwrite`` may replace: an existing folder that :func:`is_astrocpg_output`
    and holds nothing but what astrocpg wrote and recorded (``sort_out``), and that is
    no training or study unless ``command`` (the command writing) is the same (an existing
    file: one that no astrocpg output folder around it lists in its manifest). Anything else,
    e.g. a folder of the user's own files, is refused (InputError naming ``culprit``) and left
    as it is. Call it after :func:`check_output_path`. A folder another astrocpg process is
    writing is refused as in use first, whatever it holds yet."""
    refuse_in_use(target, culprit=culprit)
    path = Path(_real(target))
    if path.is_dir():
        if not is_astrocpg_output(path):
            raise InputError(f"holds files that are not an astrocpg output (no astrocpg "
                             f"{MANIFEST}); {setting('overwrite')} replaces only a folder "
                             f"astrocpg wrote: choose another folder, or empty this one yourself",
                             culprit=culprit)
        _refuse_part_of_output(path, culprit)
        _refuse_foreign_files(path, culprit)
        _refuse_other_command(path, command, culprit)
        return
    if not path.exists():
        return
    for folder in path.parents:  # the astrocpg output folder the file belongs to, if any
        if (folder / MANIFEST).is_file() and is_astrocpg_output(folder):
            rel = path.relative_to(folder).as_posix()
            try:
                listed = read_json(folder / MANIFEST).get("inventory") or {}
            except (OSError, ValueError):
                listed = {}
            if rel == MANIFEST or rel in listed:
                raise InputError(f"is a file of the astrocpg output folder {folder} (listed in "
                                 f"its {MANIFEST}); {setting('overwrite')} never replaces part "
                                 f"of a folder", culprit=culprit)
            if any(fnmatch.fnmatchcase(rel, p) for p in _DERIVED_BY_NAME):
                return  # a video or power estimate of the folder: astrocpg's by its name
            break
    _refuse_foreign_file(path, culprit)


# ---------------------------------------------------------------- the output folder
def _fsync_dir(path: Path) -> None:
    try:
        fd = os.open(path, os.O_RDONLY | getattr(os, "O_DIRECTORY", 0))
    except OSError:
        return
    try:
        os.fsync(fd)
    except OSError:
        pass
    finally:
        os.close(fd)


_RENAME_EXCHANGE = 2
_AT_FDCWD = -100
_renameat2_fn: Any = None


def _renameat2() -> Any:
    """glibc's ``renameat2`` (Linux >= 3.15, glibc >= 2.28), or False where there is none."""
    global _renameat2_fn
    if _renameat2_fn is None:
        _renameat2_fn = False
        if sys.platform.startswith("linux"):
            try:
                fn = ctypes.CDLL(None, use_errno=True).renameat2
            except (OSError, AttributeError):
                pass
            else:
                fn.argtypes = [ctypes.c_int, ctypes.c_char_p, ctypes.c_int, ctypes.c_char_p,
                               ctypes.c_uint]
                fn.restype = ctypes.c_int
                _renameat2_fn = fn
    return _renameat2_fn


def exchange(a: Path, b: Path) -> bool:
    """Swap two paths in one atomic step (``renameat2(RENAME_EXCHANGE)``). False where the
    system or the file system cannot; an OSError for any other failure."""
    fn = _renameat2()
    if not fn:
        return False
    if fn(_AT_FDCWD, os.fsencode(a), _AT_FDCWD, os.fsencode(b), _RENAME_EXCHANGE) == 0:
        return True
    err = ctypes.get_errno()
    if err in (errno.ENOSYS, errno.EINVAL, errno.ENOTSUP, errno.EOPNOTSUPP, errno.EPERM):
        return False
    raise OSError(err, os.strerror(err), os.fspath(b))


class OutputFolder:
    """One invocation's result folder, whole or nothing::

        with OutputFolder(args.out, overwrite=args.overwrite, culprit=setting("out")) as tmp:
            save_npz(tmp / "spikes.npz", ...)
            write_manifest(tmp, ...)        # last, with inventory(tmp)

    On enter: a target that is a file is refused, and so is a folder that holds anything
    unless ``overwrite`` (InputError naming the culprit and the path); an overwritten folder
    that a running train/study holds (:class:`FolderLock`) is refused too. ``inputs`` (what the
    command reads) and the current folder are never the target nor inside it
    (:func:`check_output_path`), and ``overwrite`` replaces only an astrocpg output folder
    (:func:`check_replaceable`): never a folder of the user's own files. The parent folders
    are created, stale temporaries in the parent removed, and the hidden temporary sibling
    ``.<name>.partial-<pid>-<random>`` created and returned.

    On normal exit the temporary is renamed into place in one step. With ``overwrite`` the old
    and the new folder are swapped atomically (``renameat2(RENAME_EXCHANGE)``; where that is
    missing: the old one is renamed aside to ``.<name>.replaced-<pid>-<random>``, the new one
    into place, and a killed process's aside folder is restored by the next start), then the
    old folder is deleted. The target never holds a mix of old and new files.

    On any exception, KeyboardInterrupt or SystemExit the temporary (and any parent folder this
    created) is deleted and the exception re-raised: an existing target is left untouched. An
    OSError (disk full, file too large, read-only file system, ...) becomes an EnvironmentFault
    naming the path (inside the target, not the temporary) and the OS's reason.
    """

    def __init__(self, target: str | os.PathLike, *, overwrite: bool = False,
                 culprit: str | Field | None = setting("out"),
                 inputs: Iterable[str | os.PathLike | None] = (),
                 command: str | None = None) -> None:
        self.shown = as_path(target, culprit or "out")
        #: the command writing (``train``): what :func:`check_replaceable` lets it replace
        self.command = command
        #: what the command reads: the target may not be one, hold one, or lie inside one but
        #: at a derived place (:func:`check_output_path`)
        self.inputs = [p for p in inputs if p is not None]
        path = os.path.abspath(os.fspath(target))
        if os.path.islink(path):  # write where the link points, and keep the link
            path = os.path.realpath(path)
        self.target = Path(path)
        self.overwrite = overwrite
        self.culprit = culprit
        self.tmp: Path | None = None
        self._replacing = False
        self._lock: FolderLock | None = None
        self._created: list[Path] = []

    @property
    def _who(self) -> str:
        return str(shown_with(self.culprit, self.shown)) if self.culprit else str(self.shown)

    def check(self) -> "OutputFolder":
        """Refuse a bad target now, before a long computation whose result it would receive
        (the same refusals as on enter; nothing is created)."""
        if not self.target.name:
            raise InputError("cannot be the root folder", culprit=self._who)
        try:
            self._check_target()
        finally:
            self._release()
            self._replacing = False
        return self

    # ------------------------------------------------------------ enter
    def __enter__(self) -> Path:
        t = self.target
        if not t.name:
            raise InputError("cannot be the root folder", culprit=self._who)
        try:
            self._check_target()
            self._make_parents()
            clean_stale_temporaries(t.parent)
            try:
                tmp = Path(tempfile.mkdtemp(prefix=temp_prefix(t.name, "partial"), dir=t.parent))
            except OSError as e:
                raise EnvironmentFault.from_os_error(e, self.shown, "cannot create the folder") \
                    from None
            self.tmp = tmp
            umask = os.umask(0)
            os.umask(umask)
            try:
                os.chmod(tmp, 0o777 & ~umask)  # mkdtemp makes 0700; results are ordinary folders
            except OSError:
                pass
        except BaseException:
            self._discard()
            raise
        return tmp

    def _check_target(self) -> None:
        t = self.target
        refuse_in_use(t, culprit=self._who)  # another process's folder: say so first
        check_output_path(t, self.inputs, culprit=self._who)
        if not os.path.lexists(t):
            return
        if not t.is_dir():
            raise InputError("exists and is not a folder", culprit=self._who)
        try:
            with os.scandir(t) as it:
                holds_files = next(it, None) is not None
        except OSError as e:
            raise EnvironmentFault.from_os_error(e, self.shown, "cannot read the folder") from None
        if not holds_files:
            return
        if not self.overwrite:
            raise InputError(f"is not empty; {setting('overwrite')} replaces it whole (its "
                             f"files are deleted, "
                             "never mixed with the new ones)", culprit=self._who)
        if os.path.lexists(t / LOCK_NAME):  # a running train/study: say so, whatever it holds
            self._lock = FolderLock(t, culprit=self.culprit).acquire()
        check_replaceable(t, culprit=self._who, command=self.command)
        self._replacing = True
        self._lock = self._lock or FolderLock(t, culprit=self.culprit).acquire()

    def _make_parents(self) -> None:
        missing: list[Path] = []
        p = self.target.parent
        while not os.path.lexists(p):
            missing.append(p)
            p = p.parent
        if not p.is_dir():
            raise EnvironmentFault(f"cannot create {self.shown} in it: "
                                   f"{os.strerror(errno.ENOTDIR)}", culprit=p)
        for d in reversed(missing):
            try:
                os.mkdir(d)
            except FileExistsError:
                continue
            except OSError as e:
                raise EnvironmentFault.from_os_error(e, d, "cannot create the folder") from None
            self._created.append(d)

    # ------------------------------------------------------------ exit
    def __exit__(self, exc_type: Any, exc: BaseException | None, tb: Any) -> bool:
        if exc_type is None:
            old: Path | None = None
            try:
                old = self._commit()
            except BaseException as e:
                fault = self._fault(e, "cannot move the results into place")
                self._discard()
                if fault is not None:
                    raise fault from e
                raise
            finally:
                self._release()
            if old is not None:  # the replaced folder; if this is interrupted, the next start
                try:             # removes it (its name carries this pid)
                    _remove(old)
                except OSError:
                    pass
            return False
        assert exc is not None
        fault = self._fault(exc, "cannot write")
        self._discard()
        if fault is not None:
            raise fault from exc
        return False

    def _commit(self) -> Path | None:
        """Put the temporary in place; returns the old folder to delete, if any."""
        tmp, t = self.tmp, self.target
        assert tmp is not None
        _fsync_dir(tmp)
        old: Path | None = None
        if self._replacing and os.path.lexists(t):
            if exchange(tmp, t):
                old = tmp
            else:
                aside = t.parent / (temp_prefix(t.name, "replaced") + secrets.token_hex(4))
                os.rename(t, aside)
                try:
                    os.rename(tmp, t)
                except BaseException:
                    try:
                        os.rename(aside, t)
                    except OSError:
                        pass  # the next start restores it (clean_stale_temporaries)
                    raise
                old = aside
        else:
            try:
                os.rename(tmp, t)  # t absent, or an empty folder, which rename replaces
            except OSError as e:
                if e.errno in (errno.ENOTEMPTY, errno.EEXIST):
                    raise InputError("is not empty: another process wrote into it meanwhile; "
                                     f"{setting('overwrite')} replaces it whole",
                                     culprit=self._who) from None
                if e.errno == errno.ENOTDIR:
                    raise InputError("exists and is not a folder", culprit=self._who) from None
                raise
        self.tmp = None
        _fsync_dir(t.parent)
        return old

    def _release(self) -> None:
        if self._lock is not None:
            self._lock.release()
            self._lock = None

    def _discard(self) -> None:
        """Delete the temporary and the parent folders this created (if still empty)."""
        try:
            mine = [self.tmp] if self.tmp is not None else []
            # an interrupt between mkdtemp's return and the assignment of self.tmp leaves a
            # temporary no attribute names: find this process's own by its pid-tagged prefix
            prefix = temp_prefix(self.target.name, "partial")
            try:
                mine += [p for p in self.target.parent.iterdir() if p.name.startswith(prefix)]
            except OSError:
                pass
            for tmp in dict.fromkeys(mine):
                try:
                    _remove(tmp)
                except OSError:
                    pass  # its name carries this pid: the next start removes it
            self.tmp = None
            for d in reversed(self._created):
                try:
                    os.rmdir(d)
                except OSError:
                    break
            self._created = []
        finally:
            self._release()

    def _fault(self, err: BaseException, doing: str) -> EnvironmentFault | None:
        """An OSError as one line naming the user's path (inside the target, not the
        temporary) and the OS's reason; None for any other exception (and a broken pipe)."""
        if not isinstance(err, OSError) or isinstance(err, BrokenPipeError):
            return None
        where: Any = self.shown
        name = err.filename
        if name is not None and not isinstance(name, int):
            where = p = Path(os.fsdecode(name))
            if self.tmp is not None:
                try:
                    where = self.shown / p.relative_to(self.tmp)
                except ValueError:
                    pass
        return EnvironmentFault.from_os_error(err, where, doing)


# ---------------------------------------------------------------- inventory
def _files(root: Path) -> Iterator[tuple[str, Path]]:
    """(relative POSIX path, path) of every file below ``root``, sorted, without the
    top-level :data:`UNLISTED` names and without hidden temporaries (:func:`parse_temp_name`:
    what a running or killed ``plot``, ``video`` or atomic writer has there is not the
    folder's, and a killed one's is removed by the next start beside it). Links to files count
    as files; links to folders are not followed."""
    def fail(err: OSError) -> None:
        raise err

    for dirpath, dirnames, filenames in os.walk(root, onerror=fail):
        dirnames[:] = sorted(d for d in dirnames if parse_temp_name(d) is None)
        for f in sorted(x for x in filenames if parse_temp_name(x) is None):
            path = Path(dirpath, f)
            rel = path.relative_to(root).as_posix()
            # a lock is never a result, at any depth (a study's worker locks its run folder)
            if rel not in UNLISTED and f not in (LOCK_NAME, OWNER_NAME):
                yield rel, path


#: sha256 of files this process wrote, hashed as their bytes went out (writing.save_npz), by
#: (device, inode, size, mtime_ns): the inventory takes the hash from here instead of reading
#: the file back, which after a write that bypassed the page cache would read it from disk.
#: A file changed since (size or mtime) is hashed again; a renamed one keeps its inode.
_WRITTEN: dict[tuple[int, int, int, int], str] = {}
_WRITTEN_MAX = 256


def remember_sha256(path: str | os.PathLike, sha256: str) -> None:
    """Record the sha256 of the file just written at ``path`` (its bytes as written)."""
    st = os.stat(path)
    if len(_WRITTEN) >= _WRITTEN_MAX:
        _WRITTEN.pop(next(iter(_WRITTEN)))
    _WRITTEN[(st.st_dev, st.st_ino, st.st_size, st.st_mtime_ns)] = sha256


def _written_sha256(st: os.stat_result) -> str | None:
    return _WRITTEN.get((st.st_dev, st.st_ino, st.st_size, st.st_mtime_ns))


def file_sha256(path: str | os.PathLike) -> str:
    """sha256 of a file, streamed."""
    h = hashlib.sha256()
    with open_regular(path) as f:  # a FIFO in a folder is refused, never waited on
        for chunk in iter(lambda: f.read(1 << 20), b""):
            h.update(chunk)
    return h.hexdigest()


#: files this process wrote in place (``remember_written``), by (device, inode, size,
#: mtime_ns): what an inventory of a folder written in place may list beside what it listed
_MINE: dict[tuple[int, int, int, int], None] = {}
_MINE_MAX = 1 << 16


def remember_written(path: str | os.PathLike) -> None:
    """Record that this process just wrote the file ``path`` (the atomic writers call it) into
    a folder it holds (:class:`FolderLock`: a training, a study, a study's run): an inventory
    of a folder written in place lists only such files and those it listed before. A file
    written elsewhere (an export beside a recorded session, by the same Python session) is
    not the folder's."""
    real = os.path.realpath(os.path.dirname(os.path.abspath(os.fspath(path))))
    if not any(real == h or real.startswith(h.rstrip(os.sep) + os.sep) for h in _HELD):
        return
    try:
        st = os.stat(path)
    except OSError:
        return
    if len(_MINE) >= _MINE_MAX:
        _MINE.pop(next(iter(_MINE)))
    _MINE[(st.st_dev, st.st_ino, st.st_size, st.st_mtime_ns)] = None


def _wrote(st: os.stat_result) -> bool:
    return (st.st_dev, st.st_ino, st.st_size, st.st_mtime_ns) in _MINE


def _nested_listing(root: Path, rel: str, cache: dict[str, dict[str, Any] | None]
                    ) -> tuple[str, dict[str, Any]] | None:
    """The nearest folder strictly inside ``root`` and above ``rel`` whose astrocpg manifest
    has an inventory (a recorded session, a study's run): (its relative path with ``/``, the
    inventory), or None."""
    parts = rel.split("/")[:-1]
    for n in range(len(parts), 0, -1):
        at = "/".join(parts[:n]) + "/"
        if at not in cache:
            cache[at] = _listing(_astrocpg_manifest(root / at))
        if cache[at] is not None:
            return at, cache[at]  # type: ignore[return-value]
    return None


def _adopted(root: Path, rel: str, path: Path, st: os.stat_result,
             nested: dict[str, dict[str, Any] | None]) -> bool:
    """Is ``rel`` (not written by this process) in a folder inside ``root`` whose astrocpg
    manifest lists it as it is (or that manifest itself)?"""
    listing = _nested_listing(root, rel, nested)
    if listing is None:
        return False
    at, listed = listing
    sub = rel[len(at):]
    return sub == MANIFEST or (sub in listed and _as_recorded(path, st, listed[sub]))


def written_in_place(folder: str | os.PathLike) -> bool:
    """Is ``folder`` written in place (a training, a study, a recorded session), not a
    command's own hidden temporary (``.<name>.partial-...``, where only the command writes)?"""
    return (parse_temp_name(Path(folder).name) or {}).get("kind") != "partial"


def inventory(folder: str | os.PathLike,
              previous: Mapping[str, Mapping[str, Any]] | None = None, *,
              in_place: bool = False) -> dict[str, dict[str, Any]]:
    """``{relative POSIX path: {"bytes": int, "sha256": str, "mtime_ns": int}}`` of the files
    astrocpg wrote in ``folder`` (sub-folders included) except ``manifest.json`` and the lock
    files. Hashing is streamed; a file whose size and mtime match its entry in ``previous``
    keeps that hash (a training rewrites its inventory at every checkpoint without rehashing
    its recordings).

    Every file is listed, unless ``in_place`` (``written_in_place``: a training, a study,
    a recorded session, where the user may add files while it runs or between its runs); then
    only what is astrocpg's: the files this process wrote (``remember_written``),
    those ``previous`` listed (as it listed them: a change since is for readers to find) and,
    inside a folder with an astrocpg manifest of its own (a study's run written by a worker),
    what that manifest's inventory lists as it is. A file the user put there is never
    adopted: a later ``overwrite`` refuses to delete it."""
    root = Path(folder)
    whole = not in_place
    out: dict[str, dict[str, Any]] = {}
    previous = previous or {}
    nested: dict[str, dict[str, Any] | None] = {}
    path = root
    try:
        for rel, path in _files(root):
            st = os.stat(path)
            old = previous.get(rel)
            if not whole and (os.path.islink(path) or not _wrote(st)):
                if os.path.islink(path) or not _adopted(root, rel, path, st, nested):
                    if old:  # listed before: as it was listed (a change is for readers)
                        out[rel] = dict(old)
                    continue  # not astrocpg's: never adopted
            if old and old.get("bytes") == st.st_size and old.get("mtime_ns") == st.st_mtime_ns:
                sha = old["sha256"]
            else:
                sha = _written_sha256(st) or file_sha256(path)
            out[rel] = {"bytes": st.st_size, "sha256": sha, "mtime_ns": st.st_mtime_ns}
    except OSError as e:
        raise EnvironmentFault.from_os_error(e, e.filename or path, "cannot read") from None
    return dict(sorted(out.items()))


def _safe_rel(name: Any) -> bool:
    if not isinstance(name, str) or not name or name.startswith("/") or "\\" in name:
        return False
    parts = name.split("/")
    return all(p not in ("", ".", "..") for p in parts) and name not in UNLISTED


def verify(folder: str | os.PathLike, *, culprit: str | None = None,
           strict: bool = True, only: Iterable[str] | None = None) -> dict[str, Any]:
    """Read ``folder/manifest.json`` and check its ``"inventory"`` against the files on disk;
    returns the manifest. InputError naming the folder and the first file that is missing, has
    another size or sha256, or (``strict``) is not listed; and for a folder without a readable
    manifest ("not an astrocpg output folder"). ``only``: check just these files (those of
    them the inventory lists), e.g. what a reader is about to read."""
    root = Path(folder)
    who = shown_with(culprit, folder) if culprit else str(folder)
    if not os.path.lexists(root):  # a missing input: the environment's (exit 1)
        raise EnvironmentFault("no such folder", culprit=who)
    if not root.is_dir():
        raise InputError("is not a folder", culprit=who)
    try:
        manifest = read_json(root / MANIFEST)
    except FileNotFoundError:
        raise InputError(f"not an astrocpg output folder (no {MANIFEST})", culprit=who) from None
    except OSError as e:
        raise InputError(f"not an astrocpg output folder (cannot read {MANIFEST}: "
                         f"{e.strerror or type(e).__name__})", culprit=who) from None
    except InputError:  # not a regular file, nested too deeply: named as such
        raise
    except ValueError:
        raise InputError(f"not an astrocpg output folder ({MANIFEST} is not valid JSON)",
                         culprit=who) from None
    if not isinstance(manifest, dict):
        raise InputError(f"not an astrocpg output folder ({MANIFEST} is not an object)",
                         culprit=who)
    listed = manifest.get("inventory")
    if not isinstance(listed, dict):
        raise InputError(f"{MANIFEST} lists no files (no \"inventory\"; written by an older "
                         "astrocpg?)", culprit=who)
    for name, entry in listed.items():
        if not (_safe_rel(name) and isinstance(entry, dict)
                and isinstance(entry.get("bytes"), int) and isinstance(entry.get("sha256"), str)):
            raise InputError(f"{MANIFEST}: bad inventory entry {name!r}", culprit=who)
    if only is not None:
        keep = set(only)
        listed = {k: v for k, v in listed.items() if k in keep}
    path = root
    try:
        on_disk = dict(_files(root))
        if only is not None:
            on_disk = {k: v for k, v in on_disk.items() if k in listed}
        # cheap checks first (missing, unlisted, size), then the hashes
        for name in sorted(set(listed) | set(on_disk)):
            if name not in on_disk:
                raise InputError(f"{name} is missing ({MANIFEST} lists it): the folder does not "
                                 "match its manifest", culprit=who)
            if name not in listed:
                # a training folder may gain anything later; any folder, derived outputs
                if not strict or any(fnmatch.fnmatchcase(name, p) for p in DERIVED):
                    continue
                raise InputError(f"{name} is not listed in {MANIFEST}: the folder does not "
                                 "match its manifest", culprit=who)
            path = on_disk[name]
            size = os.stat(path).st_size
            if size != listed[name]["bytes"]:
                raise InputError(f"{name} has {size} bytes, {MANIFEST} says "
                                 f"{listed[name]['bytes']}: changed or truncated", culprit=who)
        for name in sorted(listed):
            path = on_disk[name]
            if file_sha256(path) != listed[name]["sha256"]:
                raise InputError(f"{name} has changed since {MANIFEST} was written (sha256 "
                                 "differs)", culprit=who)
    except OSError as e:
        raise EnvironmentFault.from_os_error(e, e.filename or path, "cannot read") from None
    return manifest


def clear_folder(folder: str | os.PathLike, *, culprit: str | None = None) -> None:
    """Delete everything in ``folder`` but its lock files (its owner replaces it whole). The
    folder must hold nothing but what astrocpg wrote and recorded: else InputError naming
    ``culprit`` and the user's first entry, and nothing is deleted (checked again here, under
    the folder's lock, in case a file was added since :func:`check_replaceable`)."""
    root = Path(folder)
    _refuse_foreign_files(root, culprit or setting("out", root))
    try:
        for entry in list(root.iterdir()):
            if entry.name in (LOCK_NAME, OWNER_NAME):
                continue
            if entry.is_dir() and not entry.is_symlink():
                shutil.rmtree(entry)
            else:
                entry.unlink()
    except OSError as e:
        raise EnvironmentFault.from_os_error(e, e.filename or root, "cannot clear") from None


def remove_derived(folder: str | os.PathLike) -> list[str]:
    """Delete what later commands derived from ``folder`` (the :data:`DERIVED` entries at its
    top: ``figures/``, ``report/``, ``evaluation/`` and ``evaluation.parts/``, videos, power
    estimates); returns their names. A training that continues (a resumed one) calls it:
    those were made from weights the training is about to change, and a stale evaluation beside
    new weights would read as theirs (and ``evaluation.parts/`` would even be reused by the next
    ``evaluate``). Only what astrocpg wrote and recorded goes (``sort_out``): a file of the
    user's in ``figures/`` stays, and so does the folder that holds it."""
    root = Path(folder)
    try:
        names = [n for n in os.listdir(root)
                 if _derived(n, folder=(root / n).is_dir() and not (root / n).is_symlink())]
    except OSError as e:
        raise EnvironmentFault.from_os_error(e, root, "cannot read the folder") from None
    own, _ = sort_out(root, only=names)  # the derived places only: nothing else is hashed
    gone = [p for p in own if _derived(p.relative_to(root).as_posix(), folder=False)]
    _remove_files(root, gone)
    names = {p.relative_to(root).parts[0] + ("/" if len(p.relative_to(root).parts) > 1
                                              else "") for p in gone}
    return sorted(names)


def holds_results(folder: str | os.PathLike) -> bool:
    """Does ``folder`` hold anything but lock files?"""
    try:
        return any(e.name not in (LOCK_NAME, OWNER_NAME) for e in Path(folder).iterdir())
    except FileNotFoundError:
        return False


# ---------------------------------------------------------------- the lock
#: Folders this process holds a :class:`FolderLock` on (real paths -> how many locks): its own
#: writes into them (and below them) are never refused by :func:`refuse_in_use`.
_HELD: dict[str, int] = {}


def _locked_by_another(lock: Path) -> bool:
    """Does a process hold the ``flock`` of the lock file ``lock``? A shared non-blocking
    probe: it fails exactly while some process holds the exclusive lock (a killed holder's
    lock is gone with it). A lock file that cannot be opened tells nothing: False."""
    import fcntl

    try:
        fd = os.open(lock, os.O_RDONLY | getattr(os, "O_CLOEXEC", 0))
    except OSError:
        return False
    try:
        fcntl.flock(fd, fcntl.LOCK_SH | fcntl.LOCK_NB)
    except BlockingIOError:
        return True
    except OSError:
        return False
    else:
        fcntl.flock(fd, fcntl.LOCK_UN)
        return False
    finally:
        os.close(fd)


def holder_of(path: str | os.PathLike, *, stop: str | os.PathLike | None = None) -> Path | None:
    """The folder at or above ``path`` that another process holds with a :class:`FolderLock`
    (a running train or study, or a study's worker training one of its runs), or None.

    Walks up from ``path``; the first folder with a live lock decides: held by this process
    (its own writes) -> None, held by another -> that folder. ``stop``: a folder whose holder
    has allowed this (a study's worker locks a run folder inside the study's folder): the walk
    ends there."""
    p = Path(os.path.abspath(os.fspath(path)))
    end = None if stop is None else os.path.realpath(os.fspath(stop))
    for d in (p, *p.parents):
        real = os.path.realpath(d)
        if end is not None and real == end:
            return None
        if not os.path.lexists(d / LOCK_NAME):
            continue
        if _HELD.get(real):
            return None
        if _locked_by_another(d / LOCK_NAME):
            return d
    return None


def refuse_in_use(path: str | os.PathLike, *, culprit: str,
                  stop: str | os.PathLike | None = None) -> None:
    """InputError when ``path`` is, or lies inside, a folder another astrocpg process is using
    (:func:`holder_of`): nothing may write into a training or a study while it runs, nor into
    one of a study's runs while its worker trains it."""
    held = holder_of(path, stop=stop)
    if held is None:
        return
    lock = FolderLock(held)
    here = Path(os.path.abspath(os.fspath(path))) == held
    what = "is" if here else f"lies inside {held}, which is"
    raise InputError(f"{what} {lock._in_use().removeprefix('is ')}", culprit=culprit)


class FolderLock:
    """``with FolderLock(folder, culprit=setting("out")):`` -- this process owns ``folder`` while
    the block runs (train, study). A non-blocking exclusive lock (filelock; ``flock`` on Unix) on
    ``folder/.astrocpg.lock``; ``.astrocpg.lock.owner`` says who holds it. When another process
    holds it: InputError "is in use by another astrocpg process (pid N since <time>)". The lock of a
    killed process does not block (the kernel drops it). Released, and both files removed, on exit.
    The folder must exist."""

    def __init__(self, folder: str | os.PathLike, *, culprit: str | None = None,
                 inside: str | os.PathLike | None = None) -> None:
        self.folder = Path(folder)
        self.culprit = culprit
        # the folder above whose holder lets this one be locked (a study's, for its runs)
        self.inside = inside
        self._lock: Any = None  # a filelock.BaseFileLock while held
        self._mine: dict[Path, os.stat_result] = {}
        self._real: str | None = None

    @property
    def _who(self) -> str:
        return str(shown_with(self.culprit, self.folder)) if self.culprit else str(self.folder)

    @property
    def path(self) -> Path:
        return self.folder / LOCK_NAME

    @property
    def held(self) -> bool:
        return self._lock is not None

    def owner(self) -> dict[str, Any] | None:
        """What the owner file says (pid, since, host, argv), or None."""
        try:
            data = read_json(self.folder / OWNER_NAME)
        except (OSError, ValueError):
            return None
        return data if isinstance(data, dict) else None

    def held_elsewhere(self) -> bool:
        """Does a live process hold this folder's lock (as :meth:`acquire` found)? The lock is
        the kernel's: a process that died holds nothing."""
        import filelock

        if self._lock is not None or not self.path.exists():
            return False
        probe = filelock.FileLock(os.fspath(self.path), timeout=0)
        try:
            probe.acquire()
        except filelock.Timeout:
            return True
        except OSError:
            return False
        probe.release()
        return False

    def acquire(self) -> "FolderLock":
        if self._lock is not None:
            return self
        if not os.path.lexists(self.folder):  # a missing input: the environment's (exit 1)
            raise EnvironmentFault("no such folder", culprit=self._who)
        if not self.folder.is_dir():
            raise InputError("is not a folder", culprit=self._who)
        # a folder inside one another process holds (a study's run folder while the study
        # runs) is that process's: refused as the folder itself would be
        refuse_in_use(self.folder, culprit=self._who, stop=self.inside)
        import filelock  # here: its import takes ~0.1 s of every command's start-up

        lock = filelock.FileLock(os.fspath(self.path), timeout=0)
        try:
            lock.acquire()
        except filelock.Timeout:
            raise InputError(self._in_use(), culprit=self._who) from None
        except OSError as e:
            raise EnvironmentFault.from_os_error(e, self.path, "cannot lock the folder") from None
        self._lock = lock
        self._real = os.path.realpath(self.folder)
        _HELD[self._real] = _HELD.get(self._real, 0) + 1
        try:
            self._mine[self.path] = os.stat(self.path)
            self._write_owner()
        except BaseException as e:
            self.release()
            if isinstance(e, OSError):
                raise EnvironmentFault.from_os_error(e, self.folder / OWNER_NAME,
                                                     "cannot lock the folder") from None
            raise
        return self

    def _write_owner(self) -> None:
        info = {"pid": os.getpid(), "since": _now(), "host": socket.gethostname(),
                "argv": list(sys.argv)}
        fd, tmp = tempfile.mkstemp(dir=self.folder, prefix=temp_prefix(OWNER_NAME[1:]))
        try:
            with os.fdopen(fd, "w") as f:
                json.dump(info, f)
            os.replace(tmp, self.folder / OWNER_NAME)
        except BaseException:
            try:
                os.unlink(tmp)
            except OSError:
                pass
            raise
        self._mine[self.folder / OWNER_NAME] = os.stat(self.folder / OWNER_NAME)

    def _in_use(self) -> str:
        info = self.owner() or {}
        pid, since = info.get("pid"), info.get("since")
        if isinstance(pid, int):
            return (f"is in use by another astrocpg process (pid {pid}"
                    f"{f' since {since}' if since else ''}); wait for it to finish or stop it")
        return "is in use by another astrocpg process; wait for it to finish or stop it"

    def release(self) -> None:
        """Remove the owner and lock files (only if they are still this lock's), then unlock."""
        if self._lock is None:
            return
        try:
            for path in (self.folder / OWNER_NAME, self.path):
                st = self._mine.get(path)
                try:
                    if st is not None and os.path.samestat(os.lstat(path), st):
                        os.unlink(path)
                except OSError:
                    pass
        finally:
            self._mine.clear()
            lock, self._lock = self._lock, None
            if self._real is not None:
                left = _HELD.get(self._real, 1) - 1
                if left > 0:
                    _HELD[self._real] = left
                else:
                    _HELD.pop(self._real, None)
                self._real = None
            lock.release()

    def __enter__(self) -> "FolderLock":
        return self.acquire()

    def __exit__(self, *exc: Any) -> None:
        self.release()


__all__ = ["OutputFolder", "FolderLock", "as_path", "holder_of", "refuse_in_use",
           "check_output_path", "check_replaceable", "is_astrocpg_output", "inventory",
           "verify", "clean_stale_temporaries", "remove_derived", "remove_own", "sort_out",
           "written_in_place",
           "remember_written",
           "temp_prefix", "temp_suffix", "parse_temp_name", "pid_alive", "exchange",
           "MANIFEST", "LOCK_NAME", "OWNER_NAME", "UNLISTED", "DERIVED"]
