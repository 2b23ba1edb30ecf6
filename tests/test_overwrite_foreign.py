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
    (out / "figures" / "manifest.json").write_text(json.dumps(
        {"astrocpg_command": "plot", "inventory": inventory(out / "figures")}))
    assert main([*RUN, "--out", str(out), "--overwrite"]) == 0
    assert not (out / "figures").exists()


@pytest.mark.parametrize("added", ["figures/notes.md", "figures/", "lnk", "empty/",
                                   "changed"])
def test_overwrite_keeps_links_empty_folders_changed_files_and_figures(made, tmp_path, capsys,
                                                                       added):
    """Nothing astrocpg did not write and record goes: a file of the user's in figures/ (which
    has a manifest of its own), a figures/ without one, a link, an empty folder, a listed file
    the user changed since."""
    out = tmp_path / "runx"
    shutil.copytree(made, out)
    (out / "figures").mkdir()
    (out / "figures" / "x.png").write_bytes(b"png")
    if added != "figures/":
        (out / "figures" / "manifest.json").write_text(json.dumps(
            {"astrocpg_command": "plot", "inventory": inventory(out / "figures")}))
    if added == "figures/notes.md":
        (out / added).write_text("mine\n")
    elif added == "lnk":
        (out / "lnk").symlink_to(tmp_path)
    elif added == "empty/":
        (out / "empty").mkdir()
    elif added == "changed":
        (out / "spikes.npz").write_bytes(b"mine")
    before = sorted((p.relative_to(out), p.is_symlink()) for p in out.rglob("*"))
    assert main([*RUN, "--out", str(out), "--overwrite"]) == 2
    err = capsys.readouterr().err.strip().splitlines()[-1]
    named = {"figures/": "figures/x.png", "changed": "spikes.npz"}.get(added, added)
    assert f"holds {named}" in err and "did not write" in err, err
    assert sorted((p.relative_to(out), p.is_symlink()) for p in out.rglob("*")) == before


def test_a_manifest_without_inventory_claims_nothing(made, tmp_path, capsys):
    """A folder whose astrocpg manifest lists no files (an older astrocpg's, or a copy of a
    study folder with the user's scripts in it) is not replaced: nothing proves its files are
    astrocpg's."""
    out = tmp_path / "abl"
    shutil.copytree(made, out)
    manifest = json.loads((out / "manifest.json").read_text())
    del manifest["inventory"]
    (out / "manifest.json").write_text(json.dumps(manifest))
    (out / "compare_rows.py").write_text("print(1)\n")
    assert main([*RUN, "--out", str(out), "--overwrite"]) == 2
    err = capsys.readouterr().err.strip().splitlines()[-1]
    assert f"--out {out}" in err and "lists no files" in err and "compare_rows.py" in err, err
    assert (out / "compare_rows.py").read_text() == "print(1)\n"
    assert (out / "spikes.npz").is_file()


def test_a_plot_never_replaces_a_training(tmp_path, capsys):
    """--overwrite replaces a training only with another training."""
    out = tmp_path / "t"
    assert main(["train", "--sessions", "1", "--set", "L_max=0.3*second", "--no-progress",
                 "--out", str(out)]) == 0
    capsys.readouterr()
    before = {p: p.read_bytes() for p in out.rglob("*") if p.is_file()}
    src = tmp_path / "r"
    assert main([*RUN, "--out", str(src)]) == 0
    assert main(["plot", str(src), "--out", str(out), "--overwrite"]) == 2
    err = capsys.readouterr().err.strip().splitlines()[-1]
    assert "train output" in err and f"--out {out}" in err, err
    assert {p: p.read_bytes() for p in out.rglob("*") if p.is_file()} == before


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
