"""The settings of a command as one typed value (astrocpg.studies.settings): built from the
command line and from the Python API they are equal, the manifest records them, and read back
from the manifest they are the same value; a value is checked when built (a bad one is refused
naming its setting) and cannot be changed afterwards. The training's (TrainSettings) too: both
doors record the same, and a resume reads back what the training recorded."""

from __future__ import annotations

import dataclasses
import json
from pathlib import Path

import pytest

import astrocpg as ac
from astrocpg.errors import InputError
from astrocpg.studies.cli import main
from astrocpg.studies.commands.train import TrainSettings
from astrocpg.studies.settings import RunSettings, UnitSettings


def _settings(folder: Path) -> dict:
    return json.loads((folder / "manifest.json").read_text())["settings"]


def test_unit_settings_from_both_doors_are_one_value(tmp_path, capsys):
    cli, api = tmp_path / "cli", tmp_path / "api"
    assert main(["unit", "--seconds", "0.05", "--trials", "2", "--seed", "3", "--set",
                 "tau_motor=9*ms", "--spikes", "motor", "--trace-dt", "2", "--workers", "1",
                 "--no-progress", "--out", str(cli)]) == 0
    ac.unit(seconds=0.05, trials=2, seed=3, overrides=["tau_motor=9*ms"], spikes="motor",
            trace_dt=2, workers=1, progress=False, out=api)
    from_cli, from_api = (UnitSettings.from_record(_settings(f)) for f in (cli, api))
    assert from_cli == from_api
    assert from_cli.record() == _settings(cli)          # read back, recorded again: the same
    assert (from_cli.seconds, from_cli.trials, from_cli.seed) == (0.05, 2, 3)
    assert from_cli.overrides == ("tau_motor=9*ms",)
    assert from_cli.spikes == ("motor",)   # --spikes motor and spikes="motor": one setting


def test_run_settings_from_both_doors_are_one_value(tmp_path, capsys):
    cli, api = tmp_path / "cli", tmp_path / "api"
    assert main(["run", "--seconds", "0.05", "--trials", "2", "--seed", "4", "--robot-stride",
                 "2", "--traces", "none", "--workers", "1", "--no-progress",
                 "--out", str(cli)]) == 0
    ac.run(seconds=0.05, trials=2, seed=4, robot_stride=2, traces="none", workers=1,
           progress=False, out=api)
    from_cli, from_api = (RunSettings.from_record(_settings(f)) for f in (cli, api))
    assert from_cli == from_api
    assert from_cli.record() == _settings(cli)
    assert from_cli.robot_stride == 2 and from_cli.traces == ()


@pytest.mark.parametrize("cls, changes, field", [
    (UnitSettings, {"seconds": -1.0}, "seconds"),
    (UnitSettings, {"seconds": 0.0005}, "seconds"),        # not a whole number of 1 ms steps
    (UnitSettings, {"trials": 0}, "trials"),
    (UnitSettings, {"seed": 2**32}, "seed"),
    (UnitSettings, {"trace_dt": 0.5}, "trace_dt"),
    (UnitSettings, {"trace_dtype": "float16"}, "trace_dtype"),
    (UnitSettings, {"spikes": "motr"}, "spikes"),
    (RunSettings, {"robot_stride": 0}, "robot_stride"),
    (RunSettings, {"trial": -1}, "trial"),
])
def test_a_value_is_checked_when_built(cls, changes, field):
    with pytest.raises(InputError) as e:
        cls(**{"seconds": 0.1, "seed": 1, "trials": 1, **changes})
    assert field in {f.name for f in e.value.fields}, e.value.line


def test_a_manifest_with_a_bad_or_unknown_setting_is_refused():
    good = RunSettings(seconds=0.1, seed=1, trials=1).record()
    with pytest.raises(InputError):
        RunSettings.from_record({**good, "seconds": -2})
    with pytest.raises(InputError, match="expected a mapping"):   # a hand-edited text
        RunSettings.from_record({**good, "equations": "dv/dt = -v/tau : volt"})
    with pytest.raises(InputError, match="does not know: speed"):
        RunSettings.from_record({**good, "speed": 3})


def test_a_value_cannot_change():
    value = UnitSettings(seconds=0.1, seed=1, trials=1)
    with pytest.raises(dataclasses.FrozenInstanceError):
        value.seconds = 2.0  # type: ignore[misc]


def test_train_settings_from_both_doors_and_the_resume(tmp_path, capsys):
    short = ["L_max=0.2*second", "L_non_alive=0.1*second"]
    cli, api = tmp_path / "cli", tmp_path / "api"
    assert main(["train", "--sessions", "1", "--trials", "1", "--seed", "2", "--workers", "1",
                 "--set", short[0], "--set", short[1], "--no-progress",
                 "--out", str(cli)]) == 0
    ac.train(sessions=1, trials=1, seed=2, workers=1, overrides=short, progress=False, out=api)
    assert TrainSettings.from_record(_settings(cli)) == TrainSettings.from_record(_settings(api))
    before = TrainSettings.from_record(_settings(cli))
    ac.resume(cli, sessions=2, progress=False)   # extends: the rest read back from the folder
    after = TrainSettings.from_record(_settings(cli))
    assert dataclasses.replace(after, n_sessions=1) == before
