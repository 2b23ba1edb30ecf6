"""The one rule of ``--out`` and ``--overwrite`` (``studies/outputs/folder.py``:
``check_output_path`` / ``check_replaceable``), as a property over every command with ``--out``.

For each command and each place a careless ``--out ... --overwrite`` can point at -- a folder of
the user's own files, the command's input (the folder it reads, or the astrocpg folder holding
the file it reads), the input's parent (itself made to look like an astrocpg output, so that
only the containment rule can stop it) and ``.`` -- the command exits 2 with one line naming
``--out``, and every file of the whole test tree is byte-identical (sha256) afterwards.

The folders read are made once per module (a 0.02 s run, a one-session training); a study
folder is faked (its index and manifest): every command refuses a bad ``--out`` before it reads
more than that. The last tests show the rule is not "refuse everything": ``--overwrite`` still
replaces an astrocpg output folder that is no input, and the default derived folders
(``plot``'s ``figures/``) are still replaced on each call.
"""

from __future__ import annotations

import hashlib
import json
import os
import shutil
from pathlib import Path
from typing import Callable

import pytest

from astrocpg.studies.cli import main
from astrocpg.studies.outputs.folder import inventory, verify
from tiny_study import tiny_study

SHORT = ["--set", "L_max=0.2*second", "--set", "L_non_alive=0.1*second"]
STUDY = tiny_study("rule", sessions=1)
USER_FILES = {"thesis.tex": "my thesis\n", "data/raw.csv": "1,2,3\n", ".hidden": "secret\n"}


def _ok(argv: list[str]) -> None:
    assert main(argv) == 0, argv


@pytest.fixture(scope="module")
def made(tmp_path_factory) -> dict[str, Path]:
    """A finished run and a one-session training (read-only: every test works on copies)."""
    base = tmp_path_factory.mktemp("made")
    out = {"run": base / "run", "train": base / "train"}
    _ok(["run", "--seconds", "0.02", "--no-progress", "--out", str(out["run"])])
    _ok(["train", "--sessions", "1", *SHORT, "--no-progress", "--out", str(out["train"])])
    from astrocpg.models import DEFAULT_MODELS
    from astrocpg.models.files import model_to_toml
    out["model"] = base / "astro.toml"
    out["model"].write_text(model_to_toml(dict(DEFAULT_MODELS.items())["astrocyte"]))
    return out


def _user_files(folder: Path, *, astrocpg: bool = False) -> Path:
    """``folder`` with the user's files; ``astrocpg``: also a manifest astrocpg would write,
    so that only the rule's other parts can protect it."""
    for rel, text in USER_FILES.items():
        p = folder / rel
        p.parent.mkdir(parents=True, exist_ok=True)
        p.write_text(text)
    if astrocpg:
        (folder / "manifest.json").write_text(json.dumps({"astrocpg_command": "run",
                                                          "inventory": {}}))
    return folder


class World:
    """One test's tree: ``user/`` (the user's files), ``here/`` (the cwd: user files and an
    astrocpg-looking manifest), ``in/`` (the input's parent, likewise) holding the inputs:
    ``in/r`` (a run, with a model file in it), ``in/t`` (a training), ``in/S`` (a study with
    its study file in it)."""

    def __init__(self, tmp: Path, made: dict[str, Path]) -> None:
        self.tmp = tmp
        self.user = _user_files(tmp / "user")
        self.here = _user_files(tmp / "here", astrocpg=True)
        self.parent = _user_files(tmp / "in", astrocpg=True)
        self.r = self.parent / "r"
        shutil.copytree(made["run"], self.r)
        self.model = self.r / "astro.toml"  # a file read, inside an astrocpg output folder
        shutil.copy(made["model"], self.model)
        self.t = self.parent / "t"
        shutil.copytree(made["train"], self.t)
        self.S = self.parent / "S"
        self.S.mkdir()
        self.study_file = self.S / "rule.toml"
        self.study_file.write_text(STUDY)
        (self.S / "study.json").write_text(json.dumps({"name": "rule", "runs": []}))
        (self.S / "manifest.json").write_text(json.dumps({"astrocpg_command": "study",
                                                          "inventory": {}}))


# command -> (argv before --out, the folder that is "the input" for --out)
COMMANDS: dict[str, Callable[[World], tuple[list[str], Path]]] = {
    "unit": lambda w: (["unit", "--seconds", "0.01", "--no-progress", "--model",
                        f"astrocyte={w.model}"], w.r),
    "run": lambda w: (["run", "--seconds", "0.01", "--no-progress", "--weights", str(w.t)],
                      w.t),
    "run-model": lambda w: (["run", "--seconds", "0.01", "--no-progress", "--model",
                             f"astrocyte={w.model}"], w.r),
    "train": lambda w: (["train", "--sessions", "1", *SHORT, "--no-progress", "--model",
                         f"astrocyte={w.model}"], w.r),
    "evaluate": lambda w: (["evaluate", str(w.t), "--seconds", "0.05", "--repeats", "1",
                            "--no-progress"], w.t),
    "plot": lambda w: (["plot", str(w.r)], w.r),
    "plot-training": lambda w: (["plot", str(w.t), "--seconds", "0.05"], w.t),
    "video": lambda w: (["video", str(w.r), "--no-progress", "--size", "64", "48"], w.r),
    "export": lambda w: (["export", str(w.r), "--format", "npz"], w.r),
    "study": lambda w: (["study", str(w.study_file), "--workers", "1", "--no-progress"], w.S),
    "report": lambda w: (["report", str(w.S)], w.S),
    "response": lambda w: (["response", "astrocyte", "--rates", "100", "--seconds", "0.01",
                            "--warmup", "0", "--replicates", "1", "--no-progress", "--model",
                            f"astrocyte={w.model}"], w.r),
}
TARGETS: dict[str, Callable[[World, Path], str]] = {
    "user-files": lambda w, inp: str(w.user),
    "the-input": lambda w, inp: str(inp),
    "its-parent": lambda w, inp: str(inp.parent),
    "dot": lambda w, inp: ".",
    "dot-dot": lambda w, inp: "..",  # holds the cwd, the input and the user's folder
}


def sha_tree(root: Path) -> dict[str, str]:
    """relative path -> sha256 of every file below ``root``, hidden ones included."""
    return {p.relative_to(root).as_posix(): hashlib.sha256(p.read_bytes()).hexdigest()
            for p in sorted(root.rglob("*")) if p.is_file() and not p.is_symlink()}


@pytest.mark.parametrize("target", list(TARGETS))
@pytest.mark.parametrize("command", list(COMMANDS))
def test_overwrite_never_replaces_user_files_inputs_or_the_cwd(command, target, made, tmp_path,
                                                               monkeypatch, capsys) -> None:
    w = World(tmp_path, made)
    monkeypatch.chdir(w.here)
    argv, inp = COMMANDS[command](w)
    out = TARGETS[target](w, inp)
    before = sha_tree(tmp_path)
    code = main([*argv, "--out", out, "--overwrite"])
    err = capsys.readouterr().err
    lines = [x for x in err.splitlines() if x.strip()]
    assert sha_tree(tmp_path) == before, f"{command} --out {out} --overwrite changed files"
    assert code == 2, (code, err)
    assert len(lines) == 1 and lines[0].startswith("astrocpg:"), err
    assert f"--out {out}" in lines[0], lines[0]


@pytest.mark.parametrize("command, out, why", [
    ("export", "r/spikes.npz", "is inside"),     # a file of the folder it reads
    ("export", "r/notes.npz", "is inside"),      # a new file there: the run would not verify
    ("export", "t/weights.npz", "listed in its manifest"),  # a file another output lists
    ("export", "t/manifest.json", "listed in its manifest"),
    ("video", "r/clip.mp4", "is inside"),
    ("video", "r", "must end in .mp4"),
])
def test_file_outputs_never_replace_part_of_a_folder(command, out, why, made, tmp_path,
                                                     monkeypatch, capsys) -> None:
    w = World(tmp_path, made)
    monkeypatch.chdir(w.parent)
    argv = {"export": ["export", "r", "--format", "npz"],
            "video": ["video", "r", "--no-progress", "--size", "64", "48", "--fps", "5"]}[command]
    before = sha_tree(w.parent)
    code = main([*argv, "--out", out, "--overwrite"])
    err = capsys.readouterr().err
    assert code == 2 and why in err and f"--out {out}" in err, err
    assert len(err.strip().splitlines()) == 1, err
    assert sha_tree(w.parent) == before


def test_overwrite_still_replaces_an_astrocpg_output_that_is_no_input(made, tmp_path,
                                                                      monkeypatch) -> None:
    w = World(tmp_path, made)
    monkeypatch.chdir(w.here)
    other = tmp_path / "other_run"
    shutil.copytree(made["run"], other)
    (other / "figures").mkdir()
    (other / "figures" / "old.png").write_bytes(b"old")
    (other / "figures" / "manifest.json").write_text(json.dumps(  # plot's: astrocpg's own
        {"astrocpg_command": "plot", "inventory": inventory(other / "figures")}))
    assert main(["run", "--seconds", "0.01", "--no-progress", "--out", str(other),
                 "--overwrite"]) == 0
    verify(other)  # whole: none of the old files mixed in
    assert not (other / "figures").exists()
    # a folder astrocpg's lock files alone (a process killed before its manifest) is its own
    killed = tmp_path / "killed"
    killed.mkdir()
    (killed / ".astrocpg.lock").write_text("")
    assert main(["plot", str(w.r), "--out", str(killed), "--overwrite"]) == 0
    verify(killed)


def test_default_derived_folders_are_still_replaced_on_each_call(made, tmp_path,
                                                                 monkeypatch) -> None:
    w = World(tmp_path, made)
    monkeypatch.chdir(w.here)
    for _ in range(2):  # figures/ inside the input: the one place plot writes there
        assert main(["plot", str(w.r)]) == 0
    verify(w.r / "figures")
    user_figures = tmp_path / "mine"
    shutil.copytree(w.user, user_figures)
    assert main(["plot", str(w.r), "--out", str(w.r / "figures"), "--overwrite"]) == 0
    # a figures/ folder of the user's own files (no manifest) is not replaced, not even there
    shutil.rmtree(w.r / "figures")
    shutil.copytree(w.user, w.r / "figures")
    assert main(["plot", str(w.r)]) == 2
    assert sha_tree(w.r / "figures") == sha_tree(w.user)
