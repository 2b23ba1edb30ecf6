"""``--overwrite`` replaces only what astrocpg wrote, and never a part of another output."""

from __future__ import annotations

import json
import shutil
from pathlib import Path

import pytest

from astrocpg.studies.cli import main
from astrocpg.studies.outputs.folder import inventory

RUN = ["run", "--seconds", "0.3"]


@pytest.fixture(scope="module")
def made(tmp_path_factory) -> Path:
    out = tmp_path_factory.mktemp("made") / "r"
    assert main([*RUN, "--out", str(out)]) == 0
    return out


@pytest.mark.parametrize("added", [["analysis.md"], ["mydata/x.csv"],
                                   ["analysis.md", "mydata/x.csv"]])
def test_overwrite_keeps_files_astrocpg_did_not_write(made, tmp_path, capsys, added):
    out = tmp_path / "runu"
    shutil.copytree(made, out)
    for rel in added:
        (out / rel).parent.mkdir(parents=True, exist_ok=True)
        (out / rel).write_text("mine\n")
    assert main([*RUN, "--out", str(out), "--overwrite"]) == 2
    err = capsys.readouterr().err.strip().splitlines()[-1]
    assert sorted(added)[0] in err and "did not write" in err
    if len(added) > 1:
        assert "1 more" in err
    for rel in added:
        assert (out / rel).read_text() == "mine\n"


def test_overwrite_still_replaces_a_folder_of_its_own_files(made, tmp_path):
    out = tmp_path / "own"
    shutil.copytree(made, out)
    (out / "figures").mkdir()
    (out / "figures" / "x.png").write_bytes(b"png")  # a later command's: astrocpg's own
    assert main([*RUN, "--out", str(out), "--overwrite"]) == 0
    assert not (out / "figures").exists()


@pytest.mark.parametrize("command", ["study", "train"])
def test_overwrite_never_replaces_a_part_of_another_output(made, tmp_path, capsys, command):
    holder = tmp_path / "S"
    part = holder / "runs" / "a__seed1"
    shutil.copytree(made, part)
    (holder / "manifest.json").write_text(json.dumps(
        {"astrocpg_command": command, "inventory": inventory(holder)}))
    before = {p: p.read_bytes() for p in holder.rglob("*") if p.is_file()}
    assert main([*RUN, "--out", str(part), "--overwrite"]) == 2
    err = capsys.readouterr().err.strip().splitlines()[-1]
    assert f"part of the astrocpg {command} folder {holder}" in err
    assert {p: p.read_bytes() for p in holder.rglob("*") if p.is_file()} == before
