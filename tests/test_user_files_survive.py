"""Nothing a user made is deleted: a file, a link, a folder (empty or not) placed anywhere in or
beside a command's output -- before the command, between a run and its resume, inside
``recordings/`` or ``figures/`` -- survives every later command, with and without
``--overwrite``: the command either refuses (exit 2) or works around it, and the user's things
are byte-identical after. astrocpg never adopts such a thing into a folder's inventory."""

from __future__ import annotations

import json
import os
import shutil
from pathlib import Path

import pytest

from astrocpg.studies.cli import main
from tiny_study import tiny_study

RUN = ["run", "--seconds", "0.3", "--no-progress"]
UNIT = ["unit", "--seconds", "0.3", "--no-progress"]
TRAIN = ["train", "--sessions", "2", "--set", "L_max=0.3*second", "--record-every", "1",
         "--no-progress"]


def place(folder: Path, outside: Path) -> list[Path]:
    """A user's things in ``folder``: a file, a folder with a file, an empty folder, a link to
    a folder and a link to a file (both outside). Returns their paths."""
    folder.mkdir(parents=True, exist_ok=True)
    outside.mkdir(parents=True, exist_ok=True)
    (outside / "target.txt").write_text("linked\n")
    made = [folder / "mine.txt", folder / "mydir", folder / "mydir" / "data.csv",
            folder / "emptyd", folder / "dirlink", folder / "filelink"]
    made[0].write_text("mine\n")
    made[1].mkdir()
    made[2].write_text("1,2\n")
    made[3].mkdir()
    made[4].symlink_to(outside, target_is_directory=True)
    made[5].symlink_to(outside / "target.txt")
    return made


def snapshot(paths: list[Path]) -> dict[Path, tuple]:
    """What each path is: a link (where it points), a folder, a file (its bytes)."""
    out: dict[Path, tuple] = {}
    for p in paths:
        if p.is_symlink():
            out[p] = ("link", os.readlink(p))
        elif p.is_dir():
            out[p] = ("dir",)
        elif p.is_file():
            out[p] = ("file", p.read_bytes())
        else:
            out[p] = ("gone",)
    return out


def listed(folder: Path) -> set[str]:
    return set(json.loads((folder / "manifest.json").read_text())["inventory"])


def check(argv: list[str], things: dict[Path, tuple], capsys) -> int:
    """Run ``argv``: it exits 0 or 2 (never deletes, never fails otherwise), and every user's
    thing is as it was."""
    code = main(argv)
    err = capsys.readouterr().err
    assert code in (0, 2), (argv, code, err)
    if code == 2:
        assert "astrocpg:" in err and len(err.strip().splitlines()) == 1, err
    assert snapshot(list(things)) == things, argv
    return code


@pytest.fixture(scope="module")
def bases(tmp_path_factory) -> dict[str, Path]:
    """A run, a unit and a training (two sessions, both recorded), made once."""
    root = tmp_path_factory.mktemp("bases")
    made = {"run": root / "r", "unit": root / "u", "train": root / "t"}
    assert main([*RUN, "--out", str(made["run"])]) == 0
    assert main([*UNIT, "--out", str(made["unit"])]) == 0
    assert main([*TRAIN, "--out", str(made["train"])]) == 0
    return made


def copy(bases: dict[str, Path], kind: str, to: Path) -> Path:
    out = to / kind
    shutil.copytree(bases[kind], out, symlinks=True)
    return out


@pytest.mark.parametrize("kind", ["run", "unit"])
def test_a_run_or_unit_folder_keeps_the_users_things(bases, tmp_path, capsys, kind,
                                                     monkeypatch):
    monkeypatch.chdir(tmp_path)
    out = copy(bases, kind, tmp_path)
    things = snapshot(place(out, tmp_path / "elsewhere") + place(tmp_path / "beside",
                                                                 tmp_path / "elsewhere2"))
    again = RUN if kind == "run" else UNIT
    assert check([*again, "--out", str(out)], things, capsys) == 2
    assert check([*again, "--out", str(out), "--overwrite"], things, capsys) == 2
    other = UNIT if kind == "run" else RUN
    assert check([*other, "--out", str(out), "--overwrite"], things, capsys) == 2
    # the derived places: figures/ inside, an export beside (written, the user's things kept)
    check(["plot", str(out), "--no-progress"], things, capsys)
    figures = snapshot(place(out / "figures", tmp_path / "elsewhere3"))
    things |= figures
    assert check(["plot", str(out), "--no-progress"], things, capsys) == 2
    assert check(["plot", str(out), "--no-progress", "--out", str(out / "figures"),
                  "--overwrite"], things, capsys) == 2
    # export reads the folder strictly: it may refuse the user's files there; never deletes
    check(["export", str(out)], things, capsys)
    check(["export", str(out), "--overwrite"], things, capsys)
    assert check(["export", str(out), "--out", str(out / "mine.txt"), "--overwrite"],
                 things, capsys) == 2
    assert not listed(out) & {"mine.txt", "mydir/data.csv", "filelink"}


def test_before_the_command_a_folder_of_the_users_is_never_replaced(bases, tmp_path, capsys,
                                                                    monkeypatch):
    monkeypatch.chdir(tmp_path)
    target = tmp_path / "target"
    things = snapshot(place(target, tmp_path / "elsewhere"))
    for argv in (RUN, UNIT, TRAIN):
        assert check([*argv, "--out", str(target)], things, capsys) == 2
        assert check([*argv, "--out", str(target), "--overwrite"], things, capsys) == 2
    assert check(["plot", str(bases["run"]), "--no-progress", "--out", str(target),
                  "--overwrite"], things, capsys) == 2
    # a folder holding nothing but the user's empty folder, or a link, is not empty either
    for name in ("emptyonly", "linkonly"):
        t = tmp_path / name
        t.mkdir()
        if name == "emptyonly":
            (t / "sub").mkdir()
        else:
            (t / "lnk").symlink_to(tmp_path / "elsewhere")
        kept = snapshot([t / "sub" if name == "emptyonly" else t / "lnk"])
        assert check([*RUN, "--out", str(t), "--overwrite"], kept, capsys) == 2


def test_a_training_keeps_the_users_things_across_resume_and_overwrite(bases, tmp_path, capsys,
                                                                       monkeypatch):
    monkeypatch.chdir(tmp_path)
    out = copy(bases, "train", tmp_path)
    rec = out / "recordings" / "trial00_session0001"
    # an export of a recorded session beside it, inside the training's recordings/
    assert main(["export", str(rec)]) == 0
    capsys.readouterr()
    nwb = rec.with_suffix(".nwb")
    assert nwb.is_file()
    things = snapshot([nwb, *place(out, tmp_path / "e1"), *place(out / "recordings", tmp_path / "e2"),
                       *place(rec, tmp_path / "e3"), *place(tmp_path / "beside", tmp_path / "e4")])
    # a resume works around the user's things, and never adopts them
    assert check(["train", "--resume", str(out), "--sessions", "3", "--no-progress"],
                 things, capsys) == 0
    inventory = listed(out)
    assert not {r for r in inventory if "mine" in r or "mydir" in r or "link" in r
                or r.endswith(".nwb")}, inventory
    # ... a later --overwrite then refuses, naming the first of them
    code = main([*TRAIN, "--out", str(out), "--overwrite"])
    err = capsys.readouterr().err
    assert code == 2 and "did not write" in err and "dirlink" in err, err
    assert snapshot(list(things)) == things
    assert check(["plot", str(out), "--no-progress"], things, capsys) == 0
    figures = snapshot(place(out / "figures", tmp_path / "e5"))
    things |= figures
    assert check(["power", str(out), "--no-progress"], things, capsys) == 0
    assert check(["plot", str(out), "--no-progress"], things, capsys) == 2
    # another resume removes what was derived from the old weights, not the user's things
    assert check(["train", "--resume", str(out), "--sessions", "4", "--no-progress"],
                 things, capsys) == 0
    assert not list(out.glob("power_trial*.json"))
    assert not (out / "figures" / "manifest.json").exists()
    # a run, a plot, a unit may not replace a training at all
    assert check([*RUN, "--out", str(out), "--overwrite"], things, capsys) == 2
    assert check(["plot", str(bases["run"]), "--no-progress", "--out", str(out),
                  "--overwrite"], things, capsys) == 2
    assert check(["train", "--resume", str(out), "--overwrite", "--no-progress"], things,
                 capsys) == 2


def test_a_resume_that_drops_a_recording_keeps_the_users_files_in_it(tmp_path, capsys):
    """--record-every 3 with 2 sessions records session 2 as the last; extended to 3 sessions,
    session 2 is no longer recorded: its files go, the user's file in it stays."""
    out = tmp_path / "t"
    assert main(["train", "--sessions", "2", "--set", "L_max=0.3*second", "--record-every",
                 "3", "--no-progress", "--out", str(out)]) == 0
    dropped = out / "recordings" / "trial00_session0002"
    assert (dropped / "spikes.npz").is_file()
    things = snapshot([*place(dropped, tmp_path / "e")])
    assert check(["train", "--resume", str(out), "--sessions", "3", "--no-progress"],
                 things, capsys) == 0
    assert not (dropped / "spikes.npz").exists() and not (dropped / "manifest.json").exists()
    assert (out / "recordings" / "trial00_session0003" / "manifest.json").is_file()


def test_the_python_api_keeps_the_users_things(bases, tmp_path):
    import astrocpg as ac

    out = copy(bases, "run", tmp_path)
    things = snapshot(place(out, tmp_path / "e"))
    with pytest.raises(ac.InputError, match="did not write"):
        ac.run(seconds=0.3, out=out, overwrite=True, progress=False)
    with pytest.raises(ac.InputError):
        ac.unit(seconds=0.3, out=out, overwrite=True, progress=False)
    assert snapshot(list(things)) == things


@pytest.mark.slow
def test_a_study_keeps_the_users_things(tmp_path, capsys, monkeypatch):
    monkeypatch.chdir(tmp_path)
    toml = tmp_path / "tiny.toml"
    toml.write_text(tiny_study())
    out = tmp_path / "S"
    assert main(["study", str(toml), "--out", str(out), "--no-progress"]) == 0
    run = next((out / "runs").iterdir())
    things = snapshot([*place(out, tmp_path / "e1"), *place(run, tmp_path / "e2")])
    assert check(["study", str(toml), "--out", str(out), "--no-progress"], things, capsys) == 0
    assert not {r for r in listed(out) if "mine" in r or "mydir" in r or "link" in r}
    assert check(["study", str(toml), "--out", str(out), "--overwrite", "--no-progress"],
                 things, capsys) == 2
    assert check([*RUN, "--out", str(out), "--overwrite"], things, capsys) == 2
    assert check([*RUN, "--out", str(run), "--overwrite"], things, capsys) == 2
    assert check(["report", str(out)], things, capsys) == 0
    assert check(["evaluate", str(out), "--seconds", "0.2", "--repeats", "1",
                  "--no-progress"], things, capsys) in (0, 2)


def test_a_file_output_replaces_only_a_file_of_its_own_kind(bases, tmp_path, capsys):
    """export --out FILE --overwrite replaces an earlier export, never a file of the user's
    (a text, a file renamed .nwb); a video replaces an .mp4 only."""
    notes = tmp_path / "notes.txt"
    notes.write_text("mine\n")
    fake = tmp_path / "fake.nwb"
    fake.write_text("not an NWB\n")
    things = snapshot([notes, fake])
    for target in (notes, fake):
        code = check(["export", str(bases["run"]), "--out", str(target), "--overwrite"],
                     things, capsys)
        assert code == 2
    mine = tmp_path / "r.nwb"
    assert check(["export", str(bases["run"]), "--out", str(mine)], things, capsys) == 0
    assert check(["export", str(bases["run"]), "--out", str(mine), "--overwrite"], things,
                 capsys) == 0
    clip = tmp_path / "clip.mp4"
    clip.write_text("mine\n")
    things |= snapshot([clip])
    assert check(["video", str(bases["run"]), "--out", str(clip), "--overwrite",
                  "--no-progress"], things, capsys) == 2
