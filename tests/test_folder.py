"""Result folders: whole or nothing, listed in the manifest, owned while in use, and no stray
temporaries (studies/outputs/folder.py). Fast: no Brian2, a few short child processes."""

from __future__ import annotations

import errno
import hashlib
import json
import os
import select
import shutil
import signal
import subprocess
import sys
import tempfile
import textwrap
from pathlib import Path

import pytest

from astrocpg.errors import EnvironmentFault, InputError
from astrocpg.studies.outputs import folder as F
from astrocpg.studies.outputs.folder import (FolderLock, OutputFolder,
                                           clean_stale_temporaries, inventory, parse_temp_name,
                                           temp_prefix, verify)

CHILD_HEADER = textwrap.dedent("""\
    import os, signal, sys, time
    from pathlib import Path
    from astrocpg.errors import AstrocpgError
    from astrocpg.studies.outputs.folder import FolderLock, OutputFolder
    """)


def snapshot(root: Path) -> dict[str, bytes]:
    """Every file below ``root`` (hidden ones too) -> its bytes."""
    return {p.relative_to(root).as_posix(): p.read_bytes()
            for p in sorted(root.rglob("*")) if p.is_file()}


def hidden(parent: Path) -> list[str]:
    return sorted(n for n in os.listdir(parent) if n.startswith("."))


def astrocpg_output(folder: Path) -> Path:
    """Make ``folder`` an astrocpg output (its manifest, listing the files there): what
    --overwrite may replace."""
    folder.mkdir(parents=True, exist_ok=True)
    (folder / "manifest.json").write_text(json.dumps({"astrocpg_command": "run",
                                                      "inventory": F.inventory(folder)}))
    return folder


def one_line(err: BaseException) -> str:
    line = str(err)
    assert "\n" not in line and line
    return line


@pytest.fixture
def children():
    """Start child Pythons; whatever is still running at the end is killed."""
    procs: list[subprocess.Popen] = []

    def start(code: str, *args: str, prefix: list[str] | None = None) -> subprocess.Popen:
        p = subprocess.Popen([*(prefix or []), sys.executable, "-c", CHILD_HEADER + code, *args],
                             stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
        procs.append(p)
        return p

    yield start
    for p in procs:
        if p.poll() is None:
            p.kill()
        p.wait()
        p.stdout.close()
        p.stderr.close()


def read_line(proc: subprocess.Popen, timeout: float = 30.0) -> str:
    ready, _, _ = select.select([proc.stdout], [], [], timeout)
    assert ready, "child said nothing"
    line = proc.stdout.readline().strip()
    if not line:
        proc.wait(timeout)
        pytest.fail(f"child exited {proc.returncode}: {proc.stderr.read()}")
    return line


def kill9(proc: subprocess.Popen) -> None:
    proc.send_signal(signal.SIGKILL)
    proc.wait(10)  # reaped: its pid no longer exists


# ---------------------------------------------------------------- whole or nothing
def test_success_appears_whole_without_temporaries(tmp_path):
    target = tmp_path / "a" / "b" / "out"
    with OutputFolder(target) as d:
        assert d.parent == target.parent and d.name.startswith(".out.partial-")
        assert parse_temp_name(d.name)["pid"] == os.getpid()
        assert not target.exists()
        (d / "spikes.npz").write_bytes(b"123")
        (d / "sub").mkdir()
        (d / "sub" / "x.txt").write_text("x")
    assert snapshot(target) == {"spikes.npz": b"123", "sub/x.txt": b"x"}
    assert os.listdir(target.parent) == ["out"]
    umask = os.umask(0)
    os.umask(umask)
    assert target.stat().st_mode & 0o777 == 0o777 & ~umask  # an ordinary folder, not 0700


@pytest.mark.parametrize("exc", [RuntimeError("boom"), KeyboardInterrupt(), SystemExit(3)])
def test_failure_leaves_no_new_folder(tmp_path, exc):
    target = tmp_path / "a" / "b" / "out"
    with pytest.raises(type(exc)):
        with OutputFolder(target) as d:
            (d / "half.npz").write_bytes(b"half")
            raise exc
    assert os.listdir(tmp_path) == []  # nor the parents it created


@pytest.mark.parametrize("exc", [RuntimeError("boom"), KeyboardInterrupt()])
def test_failed_overwrite_leaves_the_old_folder_byte_identical(tmp_path, exc):
    target = tmp_path / "out"
    (target / "sub").mkdir(parents=True)
    (target / "spikes.npz").write_bytes(b"old spikes")
    (target / "sub" / "t.txt").write_text("old")
    astrocpg_output(target)
    before = snapshot(target)
    with pytest.raises(type(exc)):
        with OutputFolder(target, overwrite=True) as d:
            (d / "spikes.npz").write_bytes(b"new spikes")
            raise exc
    assert snapshot(target) == before
    assert os.listdir(tmp_path) == ["out"]


@pytest.mark.parametrize("swap", ["exchange", "rename aside"])
def test_overwrite_replaces_whole_never_merges(tmp_path, monkeypatch, swap):
    if swap == "rename aside":
        monkeypatch.setattr(F, "exchange", lambda a, b: False)
    target = tmp_path / "out"
    target.mkdir()
    (target / "only_old.txt").write_text("old")
    (target / "shared.txt").write_text("old")
    astrocpg_output(target)
    with OutputFolder(target, overwrite=True) as d:
        (d / "shared.txt").write_text("new")
    assert snapshot(target) == {"shared.txt": b"new"}
    assert os.listdir(tmp_path) == ["out"]


def test_non_empty_folder_refused_empty_accepted_file_refused(tmp_path):
    target = tmp_path / "out"
    target.mkdir()
    with OutputFolder(target) as d:  # an empty folder is fine
        (d / "a").write_text("a")
    assert snapshot(target) == {"a": b"a"}
    with pytest.raises(InputError) as e:
        with OutputFolder(target):
            pytest.fail("entered")
    line = one_line(e.value)
    assert line.startswith(f"out={target}:") and "overwrite=True" in line  # the API's words
    assert e.value.exit_code == 2
    assert snapshot(target) == {"a": b"a"} and os.listdir(tmp_path) == ["out"]
    (tmp_path / "file").write_text("f")
    with pytest.raises(InputError, match="not a folder"):
        with OutputFolder(tmp_path / "file", overwrite=True, culprit="--nwb"):
            pass


def test_symlinked_target_is_written_through(tmp_path):
    real = tmp_path / "real"
    real.mkdir()
    (real / "old").write_text("old")
    astrocpg_output(real)
    (tmp_path / "link").symlink_to(real)
    with OutputFolder(tmp_path / "link", overwrite=True) as d:
        (d / "new").write_text("new")
    assert (tmp_path / "link").is_symlink() and snapshot(real) == {"new": b"new"}


# ---------------------------------------------------------------- killed processes
WRITE_AND_WAIT = """
with OutputFolder(sys.argv[1]) as d:
    (d / "spikes.npz").write_bytes(b"x" * 1000)
    print(d, flush=True)
    time.sleep(120)
"""


def test_sigkill_leaves_no_folder_and_the_next_start_cleans_only_dead_temporaries(
        tmp_path, children):
    dead = children(WRITE_AND_WAIT, str(tmp_path / "killed"))
    dead_tmp = Path(read_line(dead))
    live = children(WRITE_AND_WAIT, str(tmp_path / "running"))
    live_tmp = Path(read_line(live))
    kill9(dead)
    assert not (tmp_path / "killed").exists() and dead_tmp.is_dir()
    # a killed export's atomic temporary (pid-tagged), a legacy mkstemp name (no pid: kept)
    stale_file = tmp_path / f".spikes.tmp-{dead.pid}-a1b2c3d4.npz"
    stale_file.write_bytes(b"half")
    legacy = tmp_path / ".spikes.k2j4h5g6.npz"
    legacy.write_bytes(b"?")
    with OutputFolder(tmp_path / "next") as d:
        (d / "ok").write_text("ok")
    assert not dead_tmp.exists() and not stale_file.exists()
    assert live_tmp.is_dir() and snapshot(live_tmp) == {"spikes.npz": b"x" * 1000}
    assert legacy.exists()
    assert sorted(os.listdir(tmp_path)) == sorted([live_tmp.name, legacy.name, "next"])


def test_killed_overwrite_between_renames_is_undone(tmp_path, children):
    """The fallback without an atomic swap renames the old folder aside first; if killed
    there, the next start puts it back."""
    proc = children("print(os.getpid(), flush=True)")
    pid = int(read_line(proc))
    proc.wait(10)
    aside = tmp_path / f".out.replaced-{pid}-abcdef12"
    aside.mkdir()
    (aside / "spikes.npz").write_bytes(b"old")
    assert clean_stale_temporaries(tmp_path) == []
    assert os.listdir(tmp_path) == ["out"] and snapshot(tmp_path / "out") == {"spikes.npz": b"old"}


def test_temp_names(tmp_path):
    fd, name = tempfile.mkstemp(dir=tmp_path, prefix=temp_prefix("spikes"), suffix=".npz")
    os.close(fd)
    parsed = parse_temp_name(Path(name).name)
    assert parsed == {"name": "spikes", "kind": "tmp", "pid": os.getpid(), "suffix": ".npz"}
    assert parse_temp_name(".run.v2.partial-12-abcdef12")["name"] == "run.v2"
    for other in ("spikes.npz", ".spikes.k2j4h5g6.npz", ".x.partial-12-ab", ".x.tmp-a-abcdefgh"):
        assert parse_temp_name(other) is None
    assert clean_stale_temporaries(tmp_path) == [] and Path(name).exists()  # our own: alive


# ---------------------------------------------------------------- inventory and verify
@pytest.fixture
def listed(tmp_path):
    d = tmp_path / "run"
    (d / "sub").mkdir(parents=True)
    (d / "spikes.npz").write_bytes(os.urandom(3 << 20))  # several hashing chunks
    (d / "sub" / "notes.txt").write_text("notes")
    (d / "traces.npz").write_bytes(b"traces")
    manifest = {"astrocpg_command": "run", "inventory": inventory(d)}
    (d / "manifest.json").write_text(json.dumps(manifest))
    return d


def test_inventory_lists_every_file_but_the_manifest(listed):
    inv = inventory(listed)
    assert list(inv) == ["spikes.npz", "sub/notes.txt", "traces.npz"]
    data = (listed / "spikes.npz").read_bytes()
    assert {k: inv["spikes.npz"][k] for k in ("bytes", "sha256")} == \
        {"bytes": len(data), "sha256": hashlib.sha256(data).hexdigest()}
    # unchanged files keep their hash without being read again
    (listed / "traces.npz").write_bytes(b"TRACES")
    again = inventory(listed, previous={k: dict(v, sha256="kept") for k, v in inv.items()})
    assert again["spikes.npz"]["sha256"] == "kept"
    assert again["traces.npz"]["sha256"] == hashlib.sha256(b"TRACES").hexdigest()
    (listed / "traces.npz").write_bytes(b"traces")
    assert verify(listed, culprit="--from")["astrocpg_command"] == "run"
    (listed / F.LOCK_NAME).write_text("")  # a killed holder's lock is not a result file
    assert verify(listed)


def _change_byte(d):
    p = d / "spikes.npz"
    data = bytearray(p.read_bytes())
    data[len(data) // 2] ^= 1
    p.write_bytes(bytes(data))


@pytest.mark.parametrize("change, name, words", [
    (_change_byte, "spikes.npz", "sha256"),
    (lambda d: (d / "sub" / "notes.txt").unlink(), "sub/notes.txt", "missing"),
    (lambda d: (d / "sub" / "extra.png").write_bytes(b"png"), "sub/extra.png", "not listed"),
    (lambda d: os.truncate(d / "traces.npz", 3), "traces.npz", "3 bytes"),
], ids=["changed byte", "removed", "added", "truncated"])
def test_verify_refuses_a_folder_that_does_not_match(listed, change, name, words):
    change(listed)
    with pytest.raises(InputError) as e:
        verify(listed, culprit="--from")
    line = one_line(e.value)
    assert line.startswith(f"--from {listed}: {name} ") and words in line


@pytest.mark.parametrize("manifest", [None, "{not json", "[]", json.dumps({"argv": []}),
                                      json.dumps({"inventory": {"../x": {"bytes": 1,
                                                                         "sha256": "0"}}})],
                         ids=["none", "bad json", "not an object", "no inventory", "outside"])
def test_verify_refuses_without_a_readable_manifest(tmp_path, manifest):
    d = tmp_path / "d"
    d.mkdir()
    (d / "x.npz").write_bytes(b"x")
    if manifest is not None:
        (d / "manifest.json").write_text(manifest)
    with pytest.raises(InputError) as e:
        verify(d)
    assert one_line(e.value).startswith(str(d))
    if manifest in (None, "{not json", "[]"):
        assert "not an astrocpg output folder" in str(e.value)


# ---------------------------------------------------------------- the lock
HOLD = """
with FolderLock(sys.argv[1]):
    print("locked", flush=True)
    time.sleep(120)
"""


def test_second_process_refused_then_lock_of_killed_holder_is_free(tmp_path, children):
    d = tmp_path / "train"
    d.mkdir()
    holder = children(HOLD, str(d))
    assert read_line(holder) == "locked"
    with pytest.raises(InputError) as e:
        with FolderLock(d, culprit="--out"):
            pytest.fail("two holders")
    line = one_line(e.value)
    assert line.startswith(f"--out {d}: is in use by another astrocpg process (pid {holder.pid} ")
    (d / "result.npz").write_text("r")
    with pytest.raises(InputError, match=f"pid {holder.pid}"):  # nor overwritten meanwhile
        with OutputFolder(d, overwrite=True):
            pass
    assert (d / "result.npz").exists()
    kill9(holder)
    with FolderLock(d) as lock:
        assert lock.held and lock.owner()["pid"] == os.getpid()
        with pytest.raises(InputError, match=f"pid {os.getpid()}"):
            FolderLock(d).acquire()
    assert sorted(os.listdir(d)) == ["result.npz"]  # lock files gone on release


def test_lock_needs_the_folder(tmp_path):
    from astrocpg.errors import EnvironmentFault
    with pytest.raises(EnvironmentFault, match="no such folder"):  # exit 1: the environment's
        FolderLock(tmp_path / "missing").acquire()


# ---------------------------------------------------------------- write failures
def test_file_too_large_is_one_line_and_leaves_nothing(tmp_path, children):
    code = """
import resource
signal.signal(signal.SIGXFSZ, signal.SIG_IGN)
resource.setrlimit(resource.RLIMIT_FSIZE, (100_000, resource.RLIM_INFINITY))
try:
    with OutputFolder(sys.argv[1]) as d:
        with open(d / "big.npz", "wb") as f:
            f.write(b"x" * 1_000_000)
except AstrocpgError as e:
    print(e.line, flush=True)
    sys.exit(e.exit_code)
"""
    target = tmp_path / "out"
    proc = children(code, str(target))
    line = read_line(proc)
    assert proc.wait(10) == 1
    assert line == f"{target}: cannot write: {os.strerror(errno.EFBIG)}"  # write() names no file
    assert os.listdir(tmp_path) == []


@pytest.mark.skipif(not os.path.exists("/dev/full"), reason="needs /dev/full")
def test_disk_full_is_one_line_and_leaves_nothing(tmp_path):
    target = tmp_path / "out"
    with pytest.raises(EnvironmentFault) as e:
        with OutputFolder(target) as d:
            os.symlink("/dev/full", d / "spikes.npz")  # every write: "No space left on device"
            with open(d / "spikes.npz", "wb") as f:
                f.write(b"x" * 10)
    assert one_line(e.value) == f"{target}: cannot write: {os.strerror(errno.ENOSPC)}"
    assert e.value.exit_code == 1 and os.listdir(tmp_path) == []


def test_error_naming_a_file_names_it_inside_the_target_not_the_temporary(tmp_path):
    target = tmp_path / "out"
    with pytest.raises(EnvironmentFault) as e:
        with OutputFolder(target) as d:
            open(d / "missing" / "x.npz", "wb")
    assert one_line(e.value) == (f"{target / 'missing' / 'x.npz'}: cannot write: "
                                 f"{os.strerror(errno.ENOENT)}")
    assert os.listdir(tmp_path) == []


def test_uncreatable_folder_is_one_line(tmp_path):
    target = "/sys/astrocpg_out"  # root may write anywhere else; /sys refuses new entries
    with pytest.raises(EnvironmentFault) as e:
        with OutputFolder(target):
            pytest.fail("entered")
    line = one_line(e.value)
    assert line.startswith(f"{target}: cannot create the folder: ") and not os.path.exists(target)


def test_read_only_file_system_is_one_line(tmp_path, children):
    ro = tmp_path / "ro"
    ro.mkdir()
    unshare = shutil.which("unshare")
    if unshare is None:
        pytest.skip("needs unshare")
    probe = subprocess.run([unshare, "-m", "--propagation", "private", "mount", "-t", "tmpfs",
                            "-o", "ro,size=64k", "tmpfs", str(ro)], capture_output=True)
    if probe.returncode != 0:
        pytest.skip("cannot mount a read-only tmpfs here (needs a mount namespace)")
    code = """
try:
    with OutputFolder(sys.argv[1]) as d:
        pass
except AstrocpgError as e:
    print(e.line, flush=True)
    sys.exit(e.exit_code)
"""
    target = ro / "out"  # read-only only in the child's mount namespace
    proc = children(code, str(target), prefix=[
        unshare, "-m", "--propagation", "private", "sh", "-c",
        f'mount -t tmpfs -o ro,size=64k tmpfs "{ro}" && exec "$@"', "sh"])
    line = read_line(proc)
    assert proc.wait(10) == 1
    assert line == f"{target}: cannot create the folder: {os.strerror(errno.EROFS)}"
    assert os.listdir(ro) == []


@pytest.mark.parametrize("below", ["out", "a/out"])
def test_parent_that_is_a_file_is_one_line(tmp_path, below):
    (tmp_path / "f").write_text("f")
    with pytest.raises(EnvironmentFault) as e:
        with OutputFolder(tmp_path / "f" / below):
            pytest.fail("entered")
    assert one_line(e.value).startswith(f"{tmp_path / 'f'}: cannot create ")
    assert os.strerror(errno.ENOTDIR) in str(e.value)


# ---------------------------------------------------------------- history
def test_manifest_history_keeps_the_original_command(tmp_path, monkeypatch):
    from astrocpg.studies.outputs import writing as outputs

    common = dict(command="train", seed=1, settings={}, models_json={}, files={})
    monkeypatch.setattr(sys, "argv", ["astrocpg", "train", "--out", "out/t"])
    outputs.write_manifest(tmp_path, **common, results={"status": "running"}, history=True)
    first = json.loads((tmp_path / "manifest.json").read_text())
    (tmp_path / "analysis.md").write_text("mine\n")  # the user's: never adopted
    monkeypatch.setattr(sys, "argv", ["astrocpg", "train", "--resume", "out/t"])
    monkeypatch.setattr(outputs, "_STARTED", "later")  # another process
    with FolderLock(tmp_path):  # as a training holds its folder while it writes
        outputs.atomic_write(tmp_path / "sessions.csv", lambda f: f.write(b"a\n"))
        outputs.write_manifest(tmp_path, **common, results={"status": "finished"},
                               history=True)
    m = json.loads((tmp_path / "manifest.json").read_text())
    assert m["argv"] == first["argv"] and m["created"] == first["created"]
    assert [h["argv"][2] for h in m["history"]] == ["--out", "--resume"]
    assert [h["status"] for h in m["history"]] == ["running", "finished"]
    assert set(m["inventory"]) == {"sessions.csv"}
    verify(tmp_path, strict=False)
