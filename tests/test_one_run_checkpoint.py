"""A folder holds one run (a checkpoint from another training is refused on resume), and a
checkpoint is read within its own size (no unreferenced, compressed or oversized entry)."""

from __future__ import annotations

import json
import os
import shutil
import zipfile
from pathlib import Path

import numpy as np
import pytest

from astrocpg.errors import InputError
from astrocpg.studies.cli import main
from astrocpg.studies.outputs import checkpoint as ck

SHORT = ["--sessions", "2", "--set", "L_max=0.2*second", "--set", "L_non_alive=0.1*second",
         "--no-progress"]


def _stop_after_one(out: Path, seed: int) -> None:
    """A training of two sessions stopped after its first: it can be resumed."""
    assert main(["train", *SHORT, "--seed", str(seed), "--out", str(out)]) == 0
    m = json.loads((out / "manifest.json").read_text())
    assert m["seed"] == seed


@pytest.fixture(scope="module")
def two(tmp_path_factory):
    base = tmp_path_factory.mktemp("two")
    _stop_after_one(base / "s2", 2)
    _stop_after_one(base / "s3", 3)
    return base


@pytest.mark.parametrize("how", ["copy", "symlink"])
def test_resume_refuses_a_checkpoint_of_another_seed(two, tmp_path, capsys, how):
    folder = tmp_path / "s2"
    shutil.copytree(two / "s2", folder)
    (folder / ck.CHECKPOINT).unlink()
    if how == "copy":
        shutil.copy(two / "s3" / ck.CHECKPOINT, folder / ck.CHECKPOINT)
    else:
        os.symlink(two / "s3" / ck.CHECKPOINT, folder / ck.CHECKPOINT)
    manifest = (folder / "manifest.json").read_bytes()
    code = main(["train", "--resume", str(folder), "--no-progress"])
    err = capsys.readouterr().err.strip().splitlines()[-1]
    assert code == 2, err
    assert str(folder / ck.CHECKPOINT) in err and "seed 3 (folder: 2)" in err, err
    assert (folder / "manifest.json").read_bytes() == manifest


def _small(path: Path) -> None:
    ck.write_checkpoint(path, {"settings": {}}, {"x": np.arange(100.0)})


def test_checkpoint_with_an_unreferenced_compressed_entry_is_refused_unread(tmp_path):
    path = tmp_path / ck.CHECKPOINT
    _small(path)
    with zipfile.ZipFile(path, "a", compression=zipfile.ZIP_DEFLATED) as z:
        with z.open("a9.npy", "w", force_zip64=True) as f:  # 256 MiB of zeros, ~0.3 MB stored
            block = bytes(1 << 20)
            for _ in range(256):
                f.write(block)
    assert path.stat().st_size < 2_000_000
    with pytest.raises(InputError, match="a9.npy is compressed"):
        ck.read_checkpoint(path)


def test_checkpoint_with_an_unreferenced_stored_entry_is_refused(tmp_path):
    path = tmp_path / ck.CHECKPOINT
    _small(path)
    with zipfile.ZipFile(path, "a") as z:
        z.writestr("a7.npy", np.lib.format.header_data_from_array_1_0(np.zeros(3)) and b"x" * 64)
    # refused by its header (no array) before the state is read, or as no part of the state
    with pytest.raises(InputError, match="entry a7"):
        ck.read_checkpoint(path)
    buf = __import__("io").BytesIO()
    np.save(buf, np.zeros(3))
    _small(path)
    with zipfile.ZipFile(path, "a") as z:  # a well-formed array the state does not name
        z.writestr("a8.npy", buf.getvalue())
    with pytest.raises(InputError, match="entry a8 is not part of its state"):
        ck.read_checkpoint(path)


def test_checkpoint_entry_declaring_more_than_the_file_is_refused(tmp_path):
    path = tmp_path / ck.CHECKPOINT
    _small(path)
    data = bytearray(path.read_bytes())
    # the central directory's uncompressed size of the first entry: 1 GiB declared
    cd = data.rfind(b"PK\x01\x02", 0, len(data))
    first = data.find(b"PK\x01\x02")
    data[first + 24:first + 28] = (1 << 30).to_bytes(4, "little")
    path.write_bytes(bytes(data))
    assert cd > 0
    with pytest.raises(InputError, match=str(path)):
        ck.read_checkpoint(path)


def test_a_checkpoint_astrocpg_wrote_is_still_read(tmp_path):
    path = tmp_path / ck.CHECKPOINT
    _small(path)
    meta, state = ck.read_checkpoint(path)
    assert np.array_equal(state["x"], np.arange(100.0))
