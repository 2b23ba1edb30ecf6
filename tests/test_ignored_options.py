"""An option that acts only together with another is refused without it (exit 2, naming the
option), never accepted and ignored: ``run --trial`` picks a table of a training folder
(``--weights DIR``), ``run --session`` replays a training's session, ``plot --seconds``
simulates a training's weights. The same through the Python API."""

from __future__ import annotations

import numpy as np
import pytest

import astrocpg as ac
from astrocpg.errors import InputError
from astrocpg.studies.cli import main


def _cli(argv, capsys):
    code = main([str(a) for a in argv])
    err = [x for x in capsys.readouterr().err.splitlines() if x.strip()]
    return code, err


@pytest.mark.parametrize("extra", [[], ["--weights", "w.csv"]], ids=["no-weights", "a-file"])
def test_run_trial_needs_a_training_folder(tmp_path, capsys, monkeypatch, extra):
    monkeypatch.chdir(tmp_path)
    np.savetxt(tmp_path / "w.csv", np.zeros((8, 8)), delimiter=",")
    code, err = _cli(["run", *extra, "--trial", "0", "--seconds", "0.01", "--no-progress",
                      "--out", tmp_path / "o"], capsys)
    assert code == 2 and len(err) == 1 and "--trial 0" in err[0], err
    assert not (tmp_path / "o").exists()


def test_run_session_needs_a_training_folder(tmp_path, capsys):
    code, err = _cli(["run", "--session", "1", "--seconds", "0.01", "--no-progress",
                      "--out", tmp_path / "o"], capsys)
    assert code == 2 and len(err) == 1 and "--session" in err[0], err


@pytest.mark.parametrize("weights", [None, np.zeros((8, 8))], ids=["none", "an-array"])
def test_api_run_trial_needs_a_training_folder(weights):
    with pytest.raises(InputError, match="trial"):
        ac.run(seconds=0.01, trial=0, weights=weights, progress=False)


def test_plot_seconds_is_for_a_training_only(tmp_path, capsys):
    run = tmp_path / "run"
    assert main(["run", "--seconds", "0.02", "--no-progress", "--out", str(run)]) == 0
    code, err = _cli(["plot", run, "--seconds", "2", "--out", tmp_path / "f"], capsys)
    assert code == 2 and len(err) == 1 and "--seconds" in err[0], err
    assert not (tmp_path / "f").exists()
    with pytest.raises(InputError, match="seconds"):
        ac.plot(run, seconds=2, out=tmp_path / "g")
    assert ac.plot(run, out=tmp_path / "h")  # without it: drawn from the recording
