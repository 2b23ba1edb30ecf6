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


# ---- evaluate, study, power and the views: one value from both doors, recorded, read back
from astrocpg.studies.settings import (EvaluateSettings, PlotSettings, PowerSettings,  # noqa: E402
                                       StudySettings, VideoSettings)

SHORT = ["L_max=0.2*second", "L_non_alive=0.1*second"]


@pytest.fixture(scope="module")
def trained(tmp_path_factory):
    """A training of one session of 0.2 s, 2 trials: what evaluate and power read."""
    folder = tmp_path_factory.mktemp("settings") / "train"
    ac.train(sessions=1, trials=2, seed=3, workers=1, overrides=SHORT, progress=False,
             out=folder)
    return folder


def test_evaluate_settings_from_both_doors_and_again(trained, tmp_path, capsys):
    worlds = tmp_path / "worlds.toml"
    worlds.write_text('[worlds.flat]\n[worlds.slippery]\nfriction = "0.5"\n')
    cli, api = tmp_path / "cli", tmp_path / "api"
    assert main(["evaluate", str(trained), "--worlds", str(worlds), "--seconds", "0.05",
                 "--repeats", "2", "--seed", "4", "--baseline", "flat", "--set",
                 "tau_motor=9*ms", "--workers", "1", "--no-progress", "--out", str(cli)]) == 0
    ac.evaluate(trained, worlds=worlds, seconds=0.05, repeats=2, seed=4, baseline="flat",
                overrides=["tau_motor=9*ms"], workers=1, progress=False, out=api)
    from_cli, from_api = (EvaluateSettings.from_record(_settings(f)) for f in (cli, api))
    assert from_cli == from_api
    recorded = _settings(cli)
    assert {k: recorded[k] for k in from_cli.record()} == from_cli.record()
    assert from_cli.worlds == str(worlds) and recorded["worlds_source"] == str(worlds)
    assert from_cli.variant == {"overrides": ["tau_motor=9*ms"]}
    assert (from_cli.seconds, from_cli.repeats, from_cli.seed) == (0.05, 2, 4)
    # the value read back runs the same evaluation: the same rows
    again = tmp_path / "again"
    v = from_cli
    ac.evaluate(v.folder, worlds=v.worlds, seconds=v.seconds, repeats=v.repeats, seed=v.seed,
                baseline=v.baseline, overrides=v.variant["overrides"], workers=1,
                progress=False, out=again)
    assert EvaluateSettings.from_record(_settings(again)) == from_cli
    assert (again / "evaluation.csv").read_text() == (cli / "evaluation.csv").read_text()


def test_study_settings_from_both_doors_and_the_continued_study(tmp_path, capsys):
    from tiny_study import tiny_study

    file = tmp_path / "tiny.toml"
    file.write_text(tiny_study(sessions=1))
    cli, api = tmp_path / "cli", tmp_path / "api"
    assert main(["study", str(file), "--seeds", "2,3", "--sessions", "1", "--set",
                 "L_max=0.15*second", "--workers", "1", "--no-progress",
                 "--out", str(cli)]) == 0
    ac.study(file, seeds=[2, 3], sessions=1, overrides={"L_max": "0.15*second"}, workers=1,
             progress=False, out=api)
    from_cli, from_api = (StudySettings.from_record(_settings(f)) for f in (cli, api))
    assert from_cli == from_api          # "2,3" and [2, 3]: one setting, recorded alike
    assert from_cli.seeds == "2,3" and from_cli.overrides == ("L_max=0.15*second",)
    assert from_cli.record() == {k: _settings(cli)[k] for k in ("study", "overrides")}
    # continued with the settings read back: the same value, nothing run again
    v = from_cli
    ac.study(v.file, seeds=v.seeds, sessions=v.sessions, overrides=list(v.overrides),
             workers=1, progress=False, out=cli)
    assert StudySettings.from_record(_settings(cli)) == from_cli


def test_power_settings_from_both_doors(trained, tmp_path, capsys):
    assert main(["power", str(trained), "--trial", "1", "--sessions", "1", "--set",
                 "limit_margin=0", "--no-progress"]) == 0
    path = trained / "power_trial1_limit_margin=0.json"
    from_cli = PowerSettings.from_record(json.loads(path.read_text())["settings"])
    path.unlink()
    ac.power(trained, trial=1, sessions=1, overrides={"limit_margin": "0"}, progress=False)
    from_api = PowerSettings.from_record(json.loads(path.read_text())["settings"])
    assert from_cli == from_api == PowerSettings(folder=str(trained), trial=1, sessions=1,
                                                 overrides=["limit_margin=0"])


def test_plot_and_video_settings_from_both_doors(tmp_path, capsys):
    run = tmp_path / "run"
    ac.run(seconds=0.06, trials=1, seed=2, workers=1, progress=False, out=run)
    cli, api = tmp_path / "cli", tmp_path / "api"
    assert main(["plot", str(run), "--window", "0.01", "0.05", "--format", "svg",
                 "--no-progress", "--out", str(cli)]) == 0
    ac.plot(run, window=(0.01, 0.05), fmt="svg", progress=False, out=api)
    from_cli, from_api = (PlotSettings.from_record(_settings(f)) for f in (cli, api))
    assert from_cli == from_api
    assert from_cli.window == (0.01, 0.05) and from_cli.format == "svg"

    a, b = tmp_path / "a.mp4", tmp_path / "b.mp4"
    assert main(["video", str(run), "--size", "64", "48", "--fps", "50", "--no-progress",
                 "--out", str(a)]) == 0
    made = ac.video(run, size=(64, 48), fps=50, progress=False, out=b)
    from_cli, from_api = (VideoSettings.from_record(_video_comment(p)) for p in (a, b))
    assert from_cli == from_api == VideoSettings.from_record(made["settings"])
    assert from_cli.size == (64, 48) and from_cli.fps == 50.0


def _video_comment(path: Path) -> dict:
    """The settings a video records in its MP4 comment, read back with ffmpeg."""
    import subprocess

    import imageio_ffmpeg

    probe = subprocess.run([imageio_ffmpeg.get_ffmpeg_exe(), "-hide_banner", "-i", str(path)],
                           capture_output=True, text=True)
    line = next(x for x in probe.stderr.splitlines() if x.strip().startswith("comment"))
    return json.loads(line.split(":", 1)[1].strip())


@pytest.mark.parametrize("cls, given, field", [
    (EvaluateSettings, {"folder": "f", "seconds": -1}, "seconds"),
    (EvaluateSettings, {"folder": "f", "repeats": 0}, "repeats"),
    (EvaluateSettings, {"folder": "f", "session": 0}, "session"),
    (EvaluateSettings, {"folder": "f", "conditions": [1]}, "conditions"),
    (EvaluateSettings, {"folder": "f", "seed": -3}, "seed"),
    (StudySettings, {"file": "s.toml", "seeds": "3-1"}, "seeds"),
    (StudySettings, {"file": "s.toml", "sessions": 0}, "sessions"),
    (StudySettings, {"file": "s.toml", "overrides": ["L_max"]}, "overrides"),
    (PowerSettings, {"folder": "f", "trial": -1}, "trial"),
    (PowerSettings, {"folder": "f", "sessions": 0}, "sessions"),
    (PlotSettings, {"folder": "f", "format": "gif"}, "format"),
    (PlotSettings, {"folder": "f", "window": (2, 1)}, "window"),
    (PlotSettings, {"folder": "f", "seconds": 0.0004}, "seconds"),
    (VideoSettings, {"folder": "f", "fps": 0}, "fps"),
    (VideoSettings, {"folder": "f", "size": (15, 16)}, "size"),
    (VideoSettings, {"folder": "f", "start": float("nan")}, "start"),
])
def test_each_value_is_checked_when_built(cls, given, field):
    with pytest.raises(InputError) as e:
        cls(**given)
    assert field in {f.name for f in e.value.fields}, e.value.line


@pytest.mark.parametrize("value", [
    EvaluateSettings(folder="f", worlds="w.toml", conditions="astro", session=2,
                     variant={"overrides": ["a=1"], "models": None}),
    StudySettings(file="s.toml", seeds=[4, 2], sessions=3, overrides={"L_max": "1*second"}),
    PowerSettings(folder="f", trial=1, overrides={"limit_margin": 0}),
    PlotSettings(folder="f", window=[0, 1.5], format="pdf", seconds=2),
    VideoSettings(folder="f", size=[32, 32], panel=1, start=0.5),
])
def test_each_value_reads_back_from_its_record(value):
    record = json.loads(json.dumps(value.record()))   # as a file holds it
    assert type(value).from_record(record) == value
    with pytest.raises(InputError, match="does not know: speed_up"):
        type(value).from_record({**record, "speed_up": 2})
