"""Large .npz files are written past the page cache (studies.outputs.writing.DirectFile): the
file is the same .npz to every reader, its sha256 taken on the way is the file's, and where
O_DIRECT is refused the same bytes are written as an ordinary file."""

from __future__ import annotations

import os
import zipfile
from pathlib import Path

import numpy as np
import pytest

from astrocpg.studies.outputs import folder, writing
from astrocpg.studies.outputs.folder import file_sha256, inventory
from astrocpg.studies.outputs.writing import DIRECT_BYTES, DirectFile, save_npz


def _arrays() -> dict[str, np.ndarray]:
    rng = np.random.default_rng(1)
    return {"motor_Ca": rng.standard_normal((2100, 1234)).astype(np.float32),  # > DIRECT_BYTES
            "motor_Ca_t": np.arange(2100) * 1e-3, "empty": np.zeros((0, 3)),
            "scalar": np.float64(3.5), "fortran": np.asfortranarray(rng.standard_normal((50, 7))),
            "indices": np.arange(101, dtype=np.int32)}


def _check(path: Path, arrays: dict[str, np.ndarray]) -> None:
    with np.load(path) as f:
        assert sorted(f.files) == sorted(arrays)
        for k, v in arrays.items():
            assert f[k].dtype == np.asarray(v).dtype and np.array_equal(f[k], v), k
    with zipfile.ZipFile(path) as z:
        assert z.testzip() is None  # every member's CRC


def test_a_large_npz_reads_back_whole_and_its_hash_is_the_files(tmp_path, monkeypatch) -> None:
    arrays = _arrays()
    assert sum(a.nbytes for a in arrays.values()) >= DIRECT_BYTES
    save_npz(tmp_path / "traces.npz", arrays)
    _check(tmp_path / "traces.npz", arrays)
    assert os.listdir(tmp_path) == ["traces.npz"]  # no temporary left
    assert (os.stat(tmp_path / "traces.npz").st_mode & 0o777) == 0o666 & ~_umask()
    sha = file_sha256(tmp_path / "traces.npz")

    # the inventory takes the hash taken while writing: it does not read the file again
    def no_reading(path):
        raise AssertionError(f"read back {path}")
    monkeypatch.setattr(folder, "file_sha256", no_reading)
    assert inventory(tmp_path)["traces.npz"]["sha256"] == sha
    # a file changed since is hashed again
    with open(tmp_path / "traces.npz", "ab") as f:
        f.write(b"x")
    with pytest.raises(AssertionError, match="read back"):
        inventory(tmp_path)


def _umask() -> int:
    mask = os.umask(0)
    os.umask(mask)
    return mask


@pytest.mark.parametrize("sizes", [[1], [4095, 1, 4096], [3 << 20, 7 << 20, 5], [9 << 20]])
def test_any_sequence_of_writes_gives_the_same_bytes(tmp_path, sizes) -> None:
    """Whatever the pieces (smaller than a block, across the stage's end, longer than it), the
    file holds exactly the bytes written, padding cut off, and the returned sha256 is theirs."""
    rng = np.random.default_rng(sum(sizes))
    pieces = [rng.integers(0, 256, n, dtype=np.uint8).tobytes() for n in sizes]
    out = DirectFile(tmp_path / "f")
    for p in pieces:
        assert out.write(p) == len(p)
    assert out.tell() == sum(sizes)
    sha = out.close()
    data = (tmp_path / "f").read_bytes()
    assert data == b"".join(pieces) and sha == file_sha256(tmp_path / "f")


@pytest.mark.parametrize("sizes", [[8192, 100, 8192], [4096 * 300 + 17, 4096, 4096 * 3]])
def test_page_aligned_writes_go_out_as_they_are_and_give_the_same_bytes(tmp_path, monkeypatch,
                                                                        sizes) -> None:
    """Page-aligned data (a spilled trace's block) is written from where it lies, not copied
    into the stage, when nothing is staged: the same bytes and sha256 as any other writes,
    whatever is staged between."""
    import mmap

    rng = np.random.default_rng(len(sizes))
    pieces = []
    for n in sizes:
        a = np.frombuffer(mmap.mmap(-1, n), dtype=np.uint8)  # page-aligned
        a[:] = rng.integers(0, 256, n, dtype=np.uint8)
        pieces.append(a)
    written = []
    real_write = os.write

    def watching(fd, data):
        written.append(np.frombuffer(data, dtype=np.uint8).ctypes.data)
        return real_write(fd, data)
    monkeypatch.setattr(writing.os, "write", watching)
    out = DirectFile(tmp_path / "f", stage=1 << 20)
    for p in pieces:
        assert out.write(p) == len(p)
    direct = out.direct  # False where the file system refused O_DIRECT (tmpfs)
    sha = out.close()
    data = (tmp_path / "f").read_bytes()
    assert data == b"".join(p.tobytes() for p in pieces) and sha == file_sha256(tmp_path / "f")
    assert (pieces[0].ctypes.data in written) == direct  # the first went out from where it lay


def test_without_o_direct_the_same_file_is_written(tmp_path, monkeypatch) -> None:
    """A system without O_DIRECT, and a file system that refuses it at the first write (as
    tmpfs does at open), get the same file through the page cache."""
    arrays = _arrays()
    save_npz(tmp_path / "direct.npz", arrays)
    monkeypatch.delattr(os, "O_DIRECT", raising=False)
    save_npz(tmp_path / "plain.npz", arrays)
    _check(tmp_path / "plain.npz", arrays)
    monkeypatch.undo()

    real_write = os.write
    refused = []

    def refusing(fd, data):  # EINVAL on every O_DIRECT write
        import fcntl
        if fcntl.fcntl(fd, fcntl.F_GETFL) & getattr(os, "O_DIRECT", 0):
            refused.append(len(data))
            raise OSError(22, "Invalid argument")
        return real_write(fd, data)
    monkeypatch.setattr(writing.os, "write", refusing)
    save_npz(tmp_path / "refused.npz", arrays)
    monkeypatch.undo()
    _check(tmp_path / "refused.npz", arrays)
    assert refused or not hasattr(os, "O_DIRECT")


def test_an_interrupted_write_leaves_nothing(tmp_path, monkeypatch) -> None:
    def failing(*args, **kwargs):
        raise KeyboardInterrupt
    monkeypatch.setattr(writing.np.lib.format, "write_array", failing)
    with pytest.raises(KeyboardInterrupt):
        save_npz(tmp_path / "traces.npz", _arrays())
    assert os.listdir(tmp_path) == []


def test_small_and_compressed_files_are_written_as_before(tmp_path) -> None:
    small = {"w": np.ones((8, 8))}
    save_npz(tmp_path / "small.npz", small)
    save_npz(tmp_path / "sent.npz", _arrays(), compressed=True)
    _check(tmp_path / "small.npz", small)
    _check(tmp_path / "sent.npz", _arrays())
    with zipfile.ZipFile(tmp_path / "sent.npz") as z:
        assert all(i.compress_type == zipfile.ZIP_DEFLATED for i in z.infolist())


def test_a_full_disk_is_an_error_naming_the_file_and_leaves_nothing(tmp_path, monkeypatch) -> None:
    import errno

    def full(fd, data):
        raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))
    monkeypatch.setattr(writing.os, "write", full)
    with pytest.raises(OSError) as e:
        save_npz(tmp_path / "traces.npz", _arrays())
    assert e.value.errno == errno.ENOSPC and e.value.filename == os.fspath(tmp_path / "traces.npz")
    assert os.listdir(tmp_path) == []
