"""Extending a training (``train --resume DIR --sessions N``, more than it had): the same files
as a training asked for N sessions from the start."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

import astrocpg
from astrocpg.studies.cli import main

SHORT = ["--set", "L_max=0.3*second", "--set", "L_non_alive=0.2*second", "--no-progress"]


def _same_outputs(a: Path, b: Path) -> None:
    assert (a / "sessions.csv").read_text() == (b / "sessions.csv").read_text()
    with np.load(a / "weights.npz") as x, np.load(b / "weights.npz") as y:
        assert x.files == y.files
        for k in x.files:
            assert np.array_equal(x[k], y[k], equal_nan=x[k].dtype.kind == "f"), k
    with np.load(a / "session_starts.npz") as x, np.load(b / "session_starts.npz") as y:
        assert sorted(x.files) == sorted(y.files)
        for k in x.files:
            assert np.array_equal(x[k], y[k], equal_nan=x[k].dtype.kind == "f"), k


@pytest.mark.slow
def test_extended_training_equals_the_longer_one(tmp_path, capsys):
    # recorded every 3 sessions (1, 4 and the last): session 3 only as the 3-session training's last
    rec = ["--record-every", "3", "--record-stride", "50", "--spikes", "motor",
           "--traces", "motor_Ca"]
    whole, grown = tmp_path / "whole", tmp_path / "grown"
    assert main(["train", "--out", str(whole), "--sessions", "5", "--seed", "2", *rec,
                 *SHORT]) == 0
    assert main(["train", "--out", str(grown), "--sessions", "3", "--seed", "2", *rec,
                 *SHORT]) == 0
    assert (grown / "recordings" / "trial00_session0003").is_dir()
    # fewer than done: refused naming both numbers, nothing changed
    before = (grown / "sessions.csv").read_bytes()
    capsys.readouterr()
    assert main(["train", "--resume", str(grown), "--sessions", "2", "--no-progress"]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and "--sessions" in err and "2 " in err and " 3 " in err, err
    assert (grown / "sessions.csv").read_bytes() == before
    # the same number: already finished
    assert main(["train", "--resume", str(grown), "--sessions", "3", "--no-progress"]) == 2
    assert "already finished" in capsys.readouterr().err

    assert main(["train", "--resume", str(grown), "--sessions", "5", "--no-progress"]) == 0
    _same_outputs(whole, grown)
    recorded = sorted(p.relative_to(whole).as_posix() for p in (whole / "recordings").rglob("*"))
    assert recorded == sorted(p.relative_to(grown).as_posix()
                              for p in (grown / "recordings").rglob("*"))
    assert not (grown / "recordings" / "trial00_session0003").exists()
    for rel in recorded:
        if rel.endswith(".npz"):
            with np.load(whole / rel) as a, np.load(grown / rel) as b:
                for k in a.files:
                    assert np.array_equal(a[k], b[k]), (rel, k)
    manifest = json.loads((grown / "manifest.json").read_text())
    assert manifest["settings"]["n_sessions"] == 5
    assert [h["sessions"] for h in manifest["history"]] == [3, 5]
    assert manifest["results"]["status"] == "finished"
    # its checkpoint says 5 too: a plain resume is "finished", nothing asked again
    assert main(["train", "--resume", str(grown), "--no-progress"]) == 2
    assert "already finished (5 sessions" in capsys.readouterr().err


@pytest.mark.slow
def test_extension_through_the_api_and_after_a_stop_before_its_checkpoint(tmp_path):
    whole, grown = tmp_path / "whole", tmp_path / "grown"
    kw = dict(seed=3, overrides=["L_max=0.3*second", "L_non_alive=0.2*second"], progress=False)
    astrocpg.train(out=whole, sessions=4, **kw)
    astrocpg.train(out=grown, sessions=2, **kw)
    # the manifest of an extension that stopped before writing its first checkpoint: the
    # checkpoint still says 2, the folder plans 4; a plain resume extends it
    manifest = json.loads((grown / "manifest.json").read_text())
    manifest["settings"]["n_sessions"] = 4
    manifest["results"] = {"status": "running"}
    (grown / "manifest.json").write_text(json.dumps(manifest))
    with pytest.raises(astrocpg.InputError, match="fewer than the 4"):
        astrocpg.resume(grown, sessions=3, progress=False)
    r = astrocpg.resume(grown, progress=False)
    assert len(r.sessions) == 4
    _same_outputs(whole, grown)


def test_a_trial_that_ran_idle_is_not_extended(tmp_path):
    """Two trials: the one that finished first ran on idle, learning off; an extension would
    not be what the longer training does, so it is refused with the reason."""
    from astrocpg.studies.commands.resume import _check_extension

    state = {"done": np.array([True, True]), "step_in_session": np.array([120, 0])}
    with pytest.raises(astrocpg.InputError) as e:
        _check_extension(tmp_path, 400, 500, state)
    assert e.value.culprit == "sessions" and "trial 0 (120 steps)" in e.value.line
    assert "idle" in e.value.line and "trial 1" not in e.value.line
    _check_extension(tmp_path, 400, 500, {"done": np.array([True, True]),
                                          "step_in_session": np.array([0, 0])})


@pytest.mark.slow
def test_two_trials_that_finish_together_extend_exactly(tmp_path):
    """Sessions of full length end in the same step for both trials: no trial ran idle, so
    the extension is exact for both (the network holds both trials)."""
    whole, grown = tmp_path / "whole", tmp_path / "grown"
    kw = dict(seed=5, trials=2, overrides=["L_max=0.2*second", "L_non_alive=0.2*second"],
              progress=False)
    astrocpg.train(out=whole, sessions=3, **kw)
    r = astrocpg.train(out=grown, sessions=2, **kw)
    assert set(r.sessions["length_s"].round(6)) == {0.2}  # every session full: ends together
    astrocpg.resume(grown, sessions=3, progress=False)
    _same_outputs(whole, grown)


def test_a_study_run_is_not_extended(tmp_path):
    """A study's run trains the study's sessions: extending it alone is refused."""
    from astrocpg.studies.commands.resume import _check_extension

    (tmp_path / "manifest.json").write_text(json.dumps({"astrocpg_command": "study-run"}))
    with pytest.raises(astrocpg.InputError) as e:
        _check_extension(tmp_path, 3, 5, None)
    assert e.value.culprit == "sessions" and "a run of a study" in e.value.line
