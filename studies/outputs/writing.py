"""Result folders: every one holds ``manifest.json`` (parameters with units, seed, package
versions, git commit, command) next to its ``.npz`` arrays. Files are written atomically (to a
temporary name, then renamed), so an interrupted run never leaves a half-written file.
"""

from __future__ import annotations

import errno
import functools
import hashlib
import io
import json
import mmap
import os
import platform
import sys
import tempfile
import time
from importlib import metadata
from pathlib import Path
from typing import Any, Callable, Mapping

import numpy as np

from ...errors import InputError, setting
from ...support.reading import read_json
from .folder import (MANIFEST, clean_stale_temporaries, file_sha256, inventory, remember_sha256,
                     remember_written, temp_prefix, temp_suffix, written_in_place)

_STARTED = time.strftime("%Y-%m-%dT%H:%M:%S%z")  # when this process started (history entries)
PACKAGES = ("astrocpg", "brian2", "numpy", "mujoco", "sympy", "matplotlib", "dask", "distributed",
            "pandas", "pynwb")


def brian2_target() -> str | None:
    """Brian2's code-generation target in this process (numpy or cython: the same model and
    noise, rounded by numpy or by C), or None where Brian2 was never loaded (nothing was
    simulated)."""
    if "brian2" not in sys.modules:
        return None
    from ...network.codegen import framework_target  # the framework's, not the user's pref

    return framework_target()


#: ``physics`` and ``trace_sampling`` as the worker processes of a command that split its
#: trials over them reported them (:func:`note_worker_environment`): they simulated, not this one
_WORKER_ENVIRONMENT: dict[str, str] = {}


def note_worker_environment(states: dict[str, str]) -> None:
    """What :func:`environment_record` says of ``physics`` and ``trace_sampling`` from now on
    in this process: the workers' (each reports :func:`simulation_environment`)."""
    _WORKER_ENVIRONMENT.clear()
    _WORKER_ENVIRONMENT.update(states)


def simulation_environment() -> dict[str, str]:
    """``physics`` and ``trace_sampling`` of this process as :func:`environment_record` gives
    them (only those used)."""
    return {k: v for k, v in environment_record().items()
            if k in ("physics", "trace_sampling") and v is not None}


def environment_record() -> dict[str, str | None]:
    """The environment variables that can change a result (:data:`astrocpg.support.environment.RECORDED`)
    as set, ``physics``: how the robots' physics stepped in this process (compiled or from
    Python; absent where no robot was simulated), and ``trace_sampling``: how traces were
    sampled (compiled or numpy; absent where none was recorded)."""
    from ...support.environment import recorded

    out: dict[str, str | None] = dict(recorded())
    compiled = sys.modules.get("astrocpg.coupling.compiled")  # loaded only where robots ran
    if compiled is not None:
        out["physics"] = compiled.state()
    traces = sys.modules.get("astrocpg.network.recording")
    if traces is not None and traces.kernel_state() != "not used yet":
        out["trace_sampling"] = traces.kernel_state()
    out.update(_WORKER_ENVIRONMENT)
    return out


def package_versions() -> dict[str, str]:
    """The versions of Python and the packages a result depends on; astrocpg's is this copy's
    (a development build names its commit: ``0.2.1.dev3+g1a2b3c4d5``), not the one an editable
    install recorded when it was installed."""
    from ... import __version__

    out = {"python": platform.python_version()}
    for name in PACKAGES:
        try:
            out[name] = __version__ if name == "astrocpg" else metadata.version(name)
        except metadata.PackageNotFoundError:
            out[name] = "not installed"
    return out


@functools.lru_cache(maxsize=1)
def git_commit() -> dict[str, Any]:
    """The commit of the astrocpg code, and whether it had uncommitted changes: from git in a
    checkout, from what the build recorded in an installed wheel (``source``: "git" or
    "build"); None where neither knows.

    Read once per process: a long run records the code it started with, even if the tree
    changes while it runs."""
    from ... import build_info

    info = build_info()
    return {"commit": info["commit"], "dirty": info["dirty"], "source": info["source"]}


def prepare_output_dir(path: str | os.PathLike) -> Path:
    """Create the output folder (parents too). Refuses a path that is a file."""
    p = Path(path)
    if p.exists() and not p.is_dir():
        raise InputError("exists and is not a folder", culprit=setting("out", p))
    try:
        p.mkdir(parents=True, exist_ok=True)
    except OSError as e:
        raise InputError(f"cannot create the folder ({e.strerror})",
                         culprit=setting("out", p)) from None
    return p


def atomic_path(path: Path, write_to: Callable[[Path], None]) -> None:
    """``write_to(tmp)`` writes a temporary file beside ``path`` (same suffix, for libraries that
    check it, e.g. pynwb), which then replaces ``path``: never a half-written result. What a
    killed writer left beside ``path`` (its pid gone) is removed first, so that e.g. a killed
    ``video``'s temporary goes with the next video, not only with the next ``plot``."""
    clean_stale_temporaries(path.parent)
    # pid-tagged, so that the next start removes what a killed process left
    suffix = temp_suffix(path.suffix)  # the name fits NAME_MAX, however long the path's
    prefix = temp_prefix(path.stem, suffix=suffix)
    tmp: str | None = None
    try:
        try:
            fd, tmp = tempfile.mkstemp(dir=path.parent, prefix=prefix, suffix=suffix)
        except OSError as e:
            raise _naming(e, path) from None
        os.close(fd)  # inside the try: an interrupt here still removes the temporary
        write_to(Path(tmp))
        umask = os.umask(0)
        os.umask(umask)
        os.chmod(tmp, 0o666 & ~umask)  # mkstemp makes 0600; results are ordinary files
        os.replace(tmp, path)
        remember_written(path)  # this process's: its folder's inventory may list it
    except BaseException as e:
        # an interrupt inside mkstemp, after it made the file: find it by this pid's prefix
        mine = [tmp] if tmp is not None else [
            os.path.join(path.parent, n) for n in _listdir(path.parent)
            if n.startswith(prefix) and n.endswith(suffix)]
        for name in mine:
            if os.path.exists(name):
                os.unlink(name)
        if isinstance(e, OSError) and not isinstance(e, BrokenPipeError):
            raise _naming(e, path) from None
        raise


def _listdir(folder: Path) -> list[str]:
    try:
        return os.listdir(folder)
    except OSError:
        return []


def _naming(err: OSError, path: Path) -> OSError:
    """The same error, naming ``path`` (what the user asked for), not the hidden temporary."""
    return type(err)(err.errno, err.strerror or str(err), os.fspath(path)) if err.errno \
        else err


def atomic_write(path: Path, write: Callable[[Any], Any]) -> None:
    """``write(f)`` into a binary file object, synced to disk, then renamed to ``path``."""
    def to(tmp: Path) -> None:
        with open(tmp, "wb") as f:
            write(f)
            f.flush()
            os.fsync(f.fileno())
    atomic_path(path, to)


#: An uncompressed ``.npz`` of at least this many bytes of arrays is written past the page cache
#: (:class:`DirectFile`): a run's traces are hundreds of MiB that nobody reads in this process,
#: and copying them into the page cache costs the kernel as much as it takes to allocate as
#: many fresh pages (on a virtual machine that returns freed memory to its host, about 3 ms of
#: system CPU per MiB: more than recording the traces in the run did).
DIRECT_BYTES = 8 << 20
_BLOCK = 4096  # O_DIRECT's alignment: of the buffer, the file offset and each write's length
_STAGE = 8 << 20  # bytes staged per write (a whole number of blocks)


class DirectFile:
    """A write-only, non-seekable binary file whose bytes go to disk past the page cache.

    Written bytes are staged in a page-aligned buffer (one, reused) and written in whole blocks
    with ``O_DIRECT``; the last block is padded and the file cut back to its length. The sha256
    of every byte is kept (:meth:`close` returns it), so nobody has to read the file back to
    list it. Where ``O_DIRECT`` is refused (a file system without it, such as tmpfs; a system
    without it) the same bytes are written as an ordinary file. Not seekable: ``zipfile`` then
    writes each member's CRC and sizes after its data (data descriptors), which every zip
    reader, ``np.load`` included, reads from the central directory."""

    def __init__(self, path: str | os.PathLike, *, stage: int = _STAGE,
                 sha256: bool = True, about: str = "") -> None:
        if stage <= 0 or stage % _BLOCK:
            raise ValueError(f"stage must be a positive multiple of {_BLOCK} bytes, got {stage}")
        flags = os.O_WRONLY | os.O_CREAT | os.O_TRUNC
        direct = getattr(os, "O_DIRECT", 0)
        # named by a failed write (a full disk), with what the file is for
        self.path, self.about = os.fspath(path), about
        self.fd = -1
        if direct:
            try:
                self.fd = os.open(path, flags | direct, 0o600)
            except OSError:  # EINVAL: this file system has no O_DIRECT
                self.fd = -1
        self.direct = self.fd >= 0
        if not self.direct:
            self.fd = os.open(path, flags, 0o600)
        self._size = stage
        self._stage = mmap.mmap(-1, stage)  # anonymous: page-aligned, as O_DIRECT needs
        self._view = memoryview(self._stage)
        self._filled = 0
        self._written = 0
        self._sha = hashlib.sha256() if sha256 else None

    def write(self, data: Any) -> int:
        view = memoryview(data).cast("B")
        n = len(view)
        if self._sha is not None:
            self._sha.update(view)
        k, size = 0, self._size
        if not self._filled and self.direct and n >= _BLOCK \
                and np.frombuffer(view, dtype=np.uint8).ctypes.data % _BLOCK == 0:
            # page-aligned data (a spilled trace's block) goes to disk as it is, its whole
            # blocks not copied into the stage first
            k = n - n % _BLOCK
            self._drain(k, view)
        while k < n:
            take = min(n - k, size - self._filled)
            self._view[self._filled:self._filled + take] = view[k:k + take]
            self._filled += take
            k += take
            if self._filled == size:
                self._drain(size)
                self._filled = 0
        self._written += n
        return n

    def _drain(self, length: int, source: memoryview | None = None) -> None:
        """Write the first ``length`` bytes of the stage (or of ``source``, page-aligned)."""
        view = self._view if source is None else source
        done = 0
        while done < length:
            try:
                done += os.write(self.fd, view[done:length])
            except OSError as e:
                # refused at the first write, or a short write left the offset unaligned:
                # the rest goes through the page cache
                if e.errno != errno.EINVAL or not self.direct:
                    raise self._named(e) from None
                import fcntl

                fcntl.fcntl(self.fd, fcntl.F_SETFL,
                            fcntl.fcntl(self.fd, fcntl.F_GETFL) & ~os.O_DIRECT)
                self.direct = False

    def _named(self, e: OSError) -> OSError:
        """``e`` naming this file (``os.write`` names none: "No space left on device" alone)."""
        if e.filename is not None:
            return e
        reason = e.strerror or str(e)
        named = type(e)(e.errno, f"{reason} ({self.about})" if self.about else reason, self.path)
        return named.with_traceback(e.__traceback__)

    def tell(self) -> int:
        return self._written

    def read(self, *args: Any) -> bytes:  # np.savez takes an object with read() for a file
        raise io.UnsupportedOperation("read")

    def seekable(self) -> bool:
        return False

    def seek(self, *args: Any) -> int:
        raise io.UnsupportedOperation("seek")

    def flush(self) -> None:
        pass

    def close(self) -> str | None:
        """Write what is staged, sync to disk, close; the sha256 of the file's bytes (None when
        made with ``sha256=False``)."""
        try:
            tail = self._filled
            if tail and self.direct:
                padded = -(-tail // _BLOCK) * _BLOCK
                self._view[tail:padded] = bytes(padded - tail)
                self._drain(padded)
                try:
                    os.ftruncate(self.fd, self._written)  # the padding cut off
                except OSError as e:
                    raise self._named(e) from None
            elif tail:
                self._drain(tail)
            self._filled = 0
            if self._sha is not None:  # a result file; a spill is read once and removed
                try:
                    os.fsync(self.fd)
                except OSError as e:
                    raise self._named(e) from None
        finally:
            self.abandon()
        return None if self._sha is None else self._sha.hexdigest()

    def abandon(self) -> None:
        """Close without writing what is staged (the file is being thrown away)."""
        if self.fd < 0:
            return
        fd, self.fd = self.fd, -1
        os.close(fd)
        try:
            self._view.release()
            self._stage.close()
        except BufferError:
            # a failed write's traceback still holds a slice of the stage: the buffer is
            # freed with it, and the error being raised is the one that counts
            pass


#: the timestamp of every ``.npz`` member astrocpg writes (the earliest a zip can say): the
#: same arrays give the same bytes whenever they are written (two identical trainings' files
#: are identical), not bytes that differ by the second they were written in
ZIP_TIME = (1980, 1, 1, 0, 0, 0)


def _member(zf: Any, key: str) -> Any:
    """The ``.npy`` member ``key`` of an ``.npz`` opened for writing, as ``np.savez`` opens it
    (zip64, mode 0600) but dated :data:`ZIP_TIME`."""
    import zipfile

    info = zipfile.ZipInfo(key + ".npy", date_time=ZIP_TIME)
    info.compress_type = zf.compression
    info.external_attr = 0o600 << 16
    return zf.open(info, "w", force_zip64=True)


def savez(file: Any, arrays: Mapping[str, Any], *, compressed: bool = False) -> None:
    """``np.savez(file, **arrays)`` (``np.savez_compressed`` with ``compressed``), member for
    member, with fixed member timestamps (:data:`ZIP_TIME`) and no pickled objects: the same
    arrays in the same order always give the same bytes."""
    import zipfile

    mode = zipfile.ZIP_DEFLATED if compressed else zipfile.ZIP_STORED
    with zipfile.ZipFile(file, mode="w", compression=mode, allowZip64=True) as zf:
        for key, value in arrays.items():
            with _member(zf, key) as m:
                np.lib.format.write_array(m, np.asanyarray(value), allow_pickle=False)


def save_npz(path: Path, arrays: Mapping[str, np.ndarray], *, compressed: bool = False) -> None:
    """``arrays`` as one ``.npz`` (``np.load`` reads it), written atomically.

    Uncompressed by default: a run's traces are noise-like float32 that deflate shrinks by a
    quarter at about 30 times the CPU of writing them as they are (for 20 trials of 6 s, 5 s
    against 0.2 s: as much as the simulation itself), and a reader gets them back without
    inflating them. ``compressed`` for a file made to be sent (``astrocpg export`` as npz).
    Folders written compressed by earlier versions read the same. From :data:`DIRECT_BYTES` of
    arrays on, the file is written past the page cache (:class:`DirectFile`), its sha256 taken
    on the way for the folder's inventory."""
    spilled = any(_is_spilled(a) for a in arrays.values())
    if spilled and compressed:
        raise ValueError("a spilled trace is written uncompressed")
    if not spilled and (compressed or sum(np.asarray(a).nbytes for a in arrays.values())
                        < DIRECT_BYTES):
        atomic_write(path, lambda f: savez(f, arrays, compressed=compressed))
        return

    def to(tmp: Path) -> None:
        out = DirectFile(tmp)
        try:
            if spilled:
                _savez_streaming(out, arrays)
            else:
                savez(out, arrays)
        except BaseException:
            out.abandon()
            raise
        remember_sha256(tmp, out.close())  # the inode and mtime survive the rename
    atomic_path(path, to)


def _is_spilled(value: Any) -> bool:
    """Is ``value`` a :class:`~astrocpg.network.recording.SpilledTrace` (told by its class's
    mark: this module does not import the network, which imports Brian2)?"""
    return getattr(type(value), "is_spilled_trace", False) is True


def _savez_streaming(out: DirectFile, arrays: Mapping[str, Any]) -> None:
    """What :func:`savez` writes, byte for byte, where some values are
    :class:`~astrocpg.network.recording.SpilledTrace`: each of those is copied from its file
    into its ``.npy`` member (the offset of its data in the ``.npz`` kept as ``npz_offset``)."""
    import zipfile

    fmt = np.lib.format
    with zipfile.ZipFile(out, mode="w", compression=zipfile.ZIP_STORED, allowZip64=True) as zf:
        for key, value in arrays.items():
            with _member(zf, key) as member:
                if not _is_spilled(value):
                    fmt.write_array(member, np.asanyarray(value), allow_pickle=False)
                    continue
                header = {"descr": fmt.dtype_to_descr(value.dtype), "fortran_order": False,
                          "shape": value.shape}
                fmt.write_array_header_1_0(member, header)  # as write_array writes it
                value.npz_offset = out.tell()
                copied = copy_spilled(value.path, member, value.nbytes)
                if copied != value.nbytes:
                    raise OSError(errno.EIO, f"the spilled trace {value.name} holds {copied} "
                                  f"bytes, not {value.nbytes}", os.fspath(value.path))


def copy_spilled(path: str | os.PathLike, to: Any, nbytes: int) -> int:
    """Copy the first ``nbytes`` of the file at ``path`` into ``to`` (a writable file object),
    read past the page cache where the file system allows it (the file was written so, and is
    read once): the bytes copied."""
    direct = getattr(os, "O_DIRECT", 0)
    fd = -1
    if direct:
        try:
            fd = os.open(path, os.O_RDONLY | direct)
        except OSError:
            fd = -1
    if fd < 0:
        fd = os.open(path, os.O_RDONLY)
    buf = mmap.mmap(-1, _STAGE)  # page-aligned, reused
    view = memoryview(buf)
    done = 0
    try:
        while done < nbytes:
            try:
                n = os.preadv(fd, [view], done)
            except OSError as e:  # O_DIRECT refused at read: the rest through the page cache
                if e.errno != errno.EINVAL or not direct:
                    raise
                import fcntl

                fcntl.fcntl(fd, fcntl.F_SETFL, fcntl.fcntl(fd, fcntl.F_GETFL) & ~os.O_DIRECT)
                direct = 0
                continue
            if n <= 0:
                break
            n = min(n, nbytes - done)
            to.write(view[:n])
            done += n
    finally:
        os.close(fd)
        view.release()
        buf.close()
    return done


#: bytes a spill stages before it writes (whole blocks); one per spilled trace
SPILL_STAGE = 1 << 20


def spill_files(folder: str | os.PathLike) -> tuple[Callable[[str], tuple[Path, DirectFile]],
                                                      list[Path]]:
    """Where a run's large traces go as it runs (the ``spill`` of
    :class:`~astrocpg.network.recording.TraceRecorder`): hidden temporaries in ``folder`` (pid-tagged: what a killed run left is removed
    by the next write there), written past the page cache. Returns the factory and the list of
    the files it made, which the caller removes once they are copied (:func:`remove_files`)."""
    made: list[Path] = []
    folder = Path(folder)

    def spill(name: str) -> tuple[Path, DirectFile]:
        suffix = ".spill"
        fd, tmp = tempfile.mkstemp(dir=folder, prefix=temp_prefix(name, suffix=suffix),
                                   suffix=suffix)
        os.close(fd)
        made.append(Path(tmp))
        return Path(tmp), DirectFile(tmp, stage=SPILL_STAGE, sha256=False,
                                     about=f"the {name} trace of the run, written beside its "
                                           f"folder as it runs")
    return spill, made


def remove_files(paths: list[Path]) -> None:
    for p in paths:
        try:
            os.unlink(p)
        except FileNotFoundError:
            pass


def save_spikes_and_traces(out: Path, spikes: Mapping[str, tuple[np.ndarray, np.ndarray]],
                           traces: Mapping[str, tuple[np.ndarray, np.ndarray]]) -> dict[str, str]:
    """``spikes.npz`` (``<pop>_times``, ``<pop>_indices``) and, if any, ``traces.npz``
    (``<name>``, ``<name>_t``); returns what each file holds, for the manifest."""
    arrays: dict[str, np.ndarray] = {}
    for pop, (t, i) in spikes.items():
        arrays[f"{pop}_times"], arrays[f"{pop}_indices"] = t, i
    save_npz(out / "spikes.npz", arrays)
    files = {"spikes.npz": "per population (motor, interneuron, astrocyte = adenosine release): "
                           "<pop>_times (s) and <pop>_indices (see manifest results.layout)"}
    if traces:
        tr: dict[str, np.ndarray] = {}
        for name, (t, v) in traces.items():
            tr[name], tr[f"{name}_t"] = v, t
        save_npz(out / "traces.npz", tr)
        files["traces.npz"] = ("<name> (sample, neuron) and its time axis <name>_t (s): motor_Ca; "
                               "astrocyte_Ca, astrocyte_IP3 (uM); astrocyte_AG, astrocyte_ADO")
    return files


def save_json(path: Path, obj: Any) -> None:
    text = json.dumps(obj, indent=2, default=_json_default).encode()
    atomic_write(path, lambda f: f.write(text))


def _json_default(o: Any) -> Any:
    if isinstance(o, np.ndarray):
        return o.tolist()
    if isinstance(o, (np.integer, np.floating, np.bool_)):
        return o.item()
    return str(o)


def read_manifest(folder: Path) -> dict[str, Any] | None:
    """The folder's manifest, or None when it has none or it is unreadable (an InputError
    naming it when it is not a regular file or is nested too deeply)."""
    try:
        return read_json(Path(folder) / MANIFEST)
    except InputError:  # not a regular file, nested too deeply: refused, naming it
        raise
    except (OSError, ValueError):
        return None


def write_manifest(out: Path, *, command: str, seed: int, settings: Mapping[str, Any],
                   models_json: Mapping[str, Any], files: Mapping[str, str],
                   results: Mapping[str, Any] | None = None, history: bool = False,
                   invocation: Mapping[str, Any] | None = None) -> None:
    """``manifest.json``: what was run, with what, and what each file holds.

    With ``history`` (a folder that several invocations continue, e.g. a resumed training), the
    first invocation's ``argv`` and ``created`` are kept and each invocation has an entry in
    ``history`` (argv, start, commit, status, and ``invocation``'s entries, e.g. the sessions
    per trial it trained to), the latest updated in place."""
    now = time.strftime("%Y-%m-%dT%H:%M:%S%z")
    entry = {"argv": sys.argv, "started": _STARTED, "updated": now, "git": git_commit(),
             "status": dict(results or {}).get("status")} | dict(invocation or {})
    manifest: dict[str, Any] = {"astrocpg_command": command, "argv": sys.argv, "created": now}
    old = read_manifest(out) if history else None
    if old is not None:
        manifest["argv"], manifest["created"] = old.get("argv", sys.argv), old.get("created", now)
        # the same invocation (one process, one command line, the same extra entries) is
        # updated in place; two in one process (the API called twice) are two entries
        past = [h for h in old.get("history", []) if h.get("started") != _STARTED
                or h.get("argv") != sys.argv
                or any(h.get(k) != v for k, v in dict(invocation or {}).items())]
        manifest["history"] = past + [entry]
    elif history:
        manifest["history"] = [entry]
    manifest.update({
        "seed": seed,
        "settings": dict(settings),
        "models": dict(models_json),
        "files": dict(files),
        "results": dict(results or {}),
        "package_versions": package_versions(),
        "codegen": brian2_target(),
        # the environment variables that choose how a result is computed, as set, and how the
        # robots' physics stepped (compiled or Python: bit-identical, recorded all the same)
        "environment": environment_record(),
        "git": git_commit(),
        "machine": {"platform": platform.platform(), "processor": platform.processor(),
                    "cpu_count": os.cpu_count()},
        # every file the folder owns, with size and sha256: readers refuse a folder that does
        # not match (the manifest is written last)
        "inventory": inventory(out, (old or read_manifest(out) or {}).get("inventory"),
                               in_place=written_in_place(out)),
    })
    save_json(out / MANIFEST, manifest)
