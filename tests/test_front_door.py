"""One front door: the command line turns its arguments into the Python API's settings and
calls the API function, so a run folder records the same settings whichever door wrote it,
and the rules of a command (a resume's options given again, a replay's fixed settings, a
study's --sessions as text) hold for ``ac.*`` as for ``astrocpg``."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

import astrocpg as ac
from astrocpg.errors import InputError
from astrocpg.studies.cli import main

SHORT_SESSIONS = ["L_max=0.3*second", "L_non_alive=0.2*second"]


def _settings(folder: Path) -> dict:
    return json.loads((folder / "manifest.json").read_text())["settings"]


def test_run_records_the_same_settings_from_either_door(tmp_path, capsys):
    equations = tmp_path / "motor.txt"
    equations.write_text(dict(ac.list_models().items())["motor_neuron"].code)
    cli, api = tmp_path / "cli", tmp_path / "api"
    assert main(["run", "--seconds", "0.2", "--trials", "1", "--seed", "4", "--set",
                 "tau_motor=9*ms", "--equations", f"motor_neuron={equations}", "--spikes",
                 "motor", "--traces", "astrocyte_Ca", "--trace-dt", "2", "--no-progress",
                 "--out", str(cli)]) == 0
    capsys.readouterr()
    ac.run(seconds=0.2, trials=1, seed=4, overrides=["tau_motor=9*ms"],
           equations={"motor_neuron": equations.read_text()}, spikes=("motor",),
           traces=("astrocyte_Ca",), trace_dt=2, progress=False, out=api)
    by_cli, by_api = _settings(cli), _settings(api)
    assert by_cli == by_api
    # the checked values, not the command line's namespace
    assert by_cli["equations"] == {"motor_neuron": equations.read_text()}
    assert not {"out", "command", "no_progress", "codegen", "model_files"} & set(by_cli)


def test_unit_records_the_same_settings_from_either_door(tmp_path, capsys):
    cli, api = tmp_path / "cli", tmp_path / "api"
    assert main(["unit", "--seconds", "0.1", "--trials", "2", "--set", "tau_motor=9*ms",
                 "--no-progress", "--out", str(cli)]) == 0
    capsys.readouterr()
    ac.unit(seconds=0.1, trials=2, overrides={"tau_motor": "9*ms"}, progress=False, out=api)
    assert _settings(cli) == _settings(api)


def test_train_records_the_same_settings_from_either_door(tmp_path, capsys):
    cli, api = tmp_path / "cli", tmp_path / "api"
    sets = [x for item in SHORT_SESSIONS for x in ("--set", item)]
    assert main(["train", "--sessions", "1", "--seed", "2", *sets, "--no-progress",
                 "--out", str(cli)]) == 0
    capsys.readouterr()
    ac.train(out=api, sessions=1, seed=2, overrides=SHORT_SESSIONS, progress=False)
    assert _settings(cli) == _settings(api)
    # a resume's rules are the API's: an option given again must agree, --overwrite refused
    with pytest.raises(InputError) as e:
        ac.resume(api, seed=9)
    assert e.value.culprit == "seed" and "9" in e.value.message
    with pytest.raises(InputError) as e:
        ac.resume(api, overwrite=True)
    assert e.value.culprit == "overwrite=True"
    with pytest.raises(InputError) as e:
        ac.resume(api, out=tmp_path / "elsewhere")
    assert e.value.culprit == "out"


def test_train_without_a_folder_is_refused_by_either_door(capsys):
    assert main(["train", "--sessions", "1"]) == 2
    assert capsys.readouterr().err == "astrocpg: error: --out: is required (or --resume DIR)\n"
    with pytest.raises(InputError) as e:
        ac.train(out=None, sessions=1)
    assert e.value.culprit == "out"


def test_a_replay_takes_the_trainings_settings_by_either_door(tmp_path, capsys):
    assert main(["run", "--session", "1", "--out", str(tmp_path / "r")]) == 2
    assert "--session: replays a session of a training" in capsys.readouterr().err
    with pytest.raises(InputError) as e:
        ac.run(session=1, out=tmp_path / "r")
    assert e.value.culprit == "session" and "weights=DIR" in e.value.message
    with pytest.raises(InputError) as e:
        ac.run(session=1, weights=str(tmp_path), seconds=3, out=tmp_path / "r")
    assert e.value.culprit == "seconds"
    assert main(["run", "--session", "1", "--weights", str(tmp_path), "--seconds", "3",
                 "--out", str(tmp_path / "r")]) == 2
    assert capsys.readouterr().err.startswith("astrocpg: error: --seconds: a replay takes")


def test_a_study_reads_its_sessions_as_text_by_either_door(tmp_path, capsys):
    assert main(["study", "quick", "--sessions", "1.5", "--out", str(tmp_path / "s")]) == 2
    assert "--sessions: expected a whole number, got '1.5'" in capsys.readouterr().err
    with pytest.raises(InputError) as e:
        ac.study("quick", sessions="1.5", out=tmp_path / "s")
    assert e.value.culprit == "sessions"
    assert not (tmp_path / "s").exists()
