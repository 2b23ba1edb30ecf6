"""A population added by a model file (tests/data/renshaw_population.toml) in a training, its
resume, a study and the replays of a trained folder (docs/model-files.md, "A new
population"): it is built into every session's network, recorded where the training records,
its file is one of the training's settings (manifest, checkpoint fingerprint), ``--resume``
rebuilds it from the folder and refuses another file, a study file names it for every run, and
whatever re-simulates the folder (``run --weights``, a session's replay, ``gait``,
``evaluate``, ``power``) builds it too."""

from __future__ import annotations

import hashlib
import json
from pathlib import Path

import numpy as np
import pytest

import astrocpg as ac
from astrocpg.errors import InputError
from astrocpg.network import populations
from astrocpg.network.layout import POOLS

POPULATION_FILE = Path(__file__).parent / "data" / "renshaw_population.toml"
SHORT = ["L_max=0.3*second", "L_non_alive=0.1*second"]
BUILT_IN = tuple(p.name for p in populations.BUILT_IN)


def _other_file(tmp: Path) -> Path:
    """The Renshaw population with another membrane time constant: another file."""
    path = tmp / "renshaw_other.toml"
    path.write_text(POPULATION_FILE.read_text().replace('value = "9. ms"', 'value = "8. ms"'))
    assert path.read_text() != POPULATION_FILE.read_text()
    return path


def _manifest(folder: Path) -> dict:
    return json.loads((folder / "manifest.json").read_text())


def _spike_files(folder: Path) -> list[str]:
    with np.load(folder / "spikes.npz") as z:
        return list(z.files)


@pytest.fixture(scope="module")
def trained(tmp_path_factory) -> Path:
    """One trial, one 0.3 s session, recorded, with the Renshaw population added (ac.train)."""
    out = tmp_path_factory.mktemp("poptrain") / "train"
    result = ac.train(out=out, sessions=1, seed=2, overrides=SHORT, record_every=1,
                      populations={str(POPULATION_FILE): POPULATION_FILE.read_text()},
                      progress=False)
    assert "renshaw" in result.trainer.cpg.groups
    assert populations.names() == BUILT_IN  # added for the call only
    return out


def test_train_builds_records_and_keeps_the_file(trained):
    from astrocpg.studies.commands.train import TrainSettings
    from astrocpg.studies.outputs.checkpoint import read_checkpoint

    manifest = _manifest(trained)
    text = POPULATION_FILE.read_text()
    record = manifest["settings"]["populations"]["renshaw"]
    assert record == {"sha256": hashlib.sha256(text.encode()).hexdigest(), "content": text}
    rows = {r["name"]: r for r in manifest["results"]["layout"]["populations"]}
    assert rows["renshaw"]["cells_per_leg"] == list(POOLS)
    # recorded where the training records: the session's folder, read by a plain process
    session = trained / "recordings" / "trial00_session0001"
    assert {"renshaw_times", "renshaw_indices"} <= set(_spike_files(session))
    with np.load(session / "traces.npz") as z:
        assert "renshaw_v" in z.files
    assert len(ac.load(session).spike_times("renshaw", trial=0)) > 0
    # the checkpoint's fingerprint covers the file; a training without one keeps its own
    meta, _ = read_checkpoint(trained / "checkpoint.npz")
    settings = TrainSettings(**meta["settings"])
    assert settings.populations["renshaw"]["content"] == text
    assert meta["fingerprint"] == settings.fingerprint()
    plain = TrainSettings(**{k: v for k, v in meta["settings"].items() if k != "populations"})
    assert plain.fingerprint() != settings.fingerprint()
    assert plain.fingerprint() == hashlib.sha256(repr(
        (1, 2, 1, True, sorted(SHORT), [])).encode()).hexdigest()
    assert "populations" not in plain.record()


def test_resume_rebuilds_it_and_refuses_another_file(trained, tmp_path):
    import shutil

    folder = tmp_path / "train"
    shutil.copytree(trained, folder)
    other = _other_file(tmp_path)
    with pytest.raises(InputError, match="another file") as refused:
        ac.resume(folder, sessions=2, progress=False,
                  populations={str(other): other.read_text()})
    assert "population" in str(refused.value.culprit)
    # the same population spelled otherwise (a comment) is the same file
    same = tmp_path / "renshaw_commented.toml"
    same.write_text(POPULATION_FILE.read_text() + "\n# the same cells\n")
    result = ac.resume(folder, sessions=2, progress=False, populations=[same.read_text()])
    assert "renshaw" in result.trainer.cpg.groups
    assert populations.names() == BUILT_IN
    assert sorted(result.sessions["session"]) == [1, 2]
    assert "renshaw_times" in _spike_files(folder / "recordings" / "trial00_session0002")
    assert "renshaw" in _manifest(folder)["settings"]["populations"]


def test_command_line_train_and_resume(tmp_path, capsys):
    from astrocpg.studies.cli import main

    out = tmp_path / "train"
    short = [x for s in SHORT for x in ("--set", s)]
    assert main(["train", "--sessions", "1", "--seed", "3", *short, "--record-every", "1",
                 "--population", str(POPULATION_FILE), "--out", str(out),
                 "--no-progress"]) == 0
    assert "renshaw" in _manifest(out)["settings"]["populations"]
    assert "renshaw_times" in _spike_files(out / "recordings" / "trial00_session0001")
    capsys.readouterr()
    other = _other_file(tmp_path)
    assert main(["train", "--resume", str(out), "--sessions", "2", "--population", str(other),
                 "--no-progress"]) == 2
    err = capsys.readouterr().err
    assert err.startswith("astrocpg: error: --population:") and "another file" in err
    assert len(_manifest(out)["history"]) == 1  # refused: nothing was changed
    # without the file: the folder's own population, rebuilt
    assert main(["train", "--resume", str(out), "--sessions", "2", "--no-progress"]) == 0
    assert "renshaw_times" in _spike_files(out / "recordings" / "trial00_session0002")


def test_resume_refuses_a_population_the_training_did_not_add(tmp_path):
    out = tmp_path / "plain"
    ac.train(out=out, sessions=1, seed=2, overrides=SHORT, progress=False)
    assert "populations" not in _manifest(out)["settings"]
    with pytest.raises(InputError, match="did not add the population renshaw"):
        ac.resume(out, sessions=2, populations=[POPULATION_FILE.read_text()], progress=False)


def test_replays_build_it(trained, tmp_path):
    """run --weights DIR, a session's replay, gait's runs of the trained tables."""
    from astrocpg.studies.commands.run import replay

    run = ac.run(seconds=0.3, weights=trained, out=tmp_path / "run", progress=False)
    assert "renshaw" in run.spikes and "renshaw_v" in run.traces
    assert "renshaw" in _manifest(tmp_path / "run")["settings"]["populations"]
    other = _other_file(tmp_path)
    with pytest.raises(InputError, match="another file"):
        ac.run(seconds=0.3, weights=trained, populations=[other.read_text()], progress=False)

    again = ac.run(weights=trained, session=1, out=tmp_path / "replay", progress=False)
    assert again.summary["replay"]["same"] is True
    assert "renshaw_times" in _spike_files(tmp_path / "replay" / "recordings"
                                           / "trial00_session0001")

    result, _ = replay(trained, seconds=0.3, progress=False)  # what gait and plot run
    assert "renshaw" in result.cpg.groups and "renshaw" in result.cpg.layout.to_json()[
        "cells_per_leg"]
    assert populations.names() == BUILT_IN


def test_evaluate_and_power_build_it(trained, tmp_path, monkeypatch):
    """The cells of an evaluation and the power measurement build the trained network: the
    table they build from holds the training's population (the rows given to the build)."""
    from astrocpg.studies.commands import evaluate, power

    seen = []

    class Built(Exception):
        pass

    def spy(*args, **kwargs):
        seen.append(populations.names(kwargs.get("populations")))
        raise Built

    monkeypatch.setattr(evaluate, "simulate_closed_loop", spy)
    monkeypatch.setattr(power, "build_closed_loop", spy)
    worlds = tmp_path / "worlds.toml"
    worlds.write_text("[worlds.flat]\n")
    with pytest.raises(Built):
        ac.evaluate(trained, worlds=worlds, seconds=0.3, repeats=1, progress=False)
    with pytest.raises(Built):
        ac.power(trained, sessions=1, progress=False)
    assert seen == [BUILT_IN + ("renshaw",)] * 2
    assert populations.names() == BUILT_IN  # nothing left behind in the process


STUDY = """
[study]
name = "pop"
sessions = 1
seeds = {{ first = 1, count = 2 }}
batch = 1
populations = ["{file}"]
record = {{ every = 1 }}
[base]
L_max = "0.3*second"
L_non_alive = "0.1*second"
"""


def _study_file(tmp_path: Path) -> Path:
    """A two-run study naming the population beside it (a path relative to the study file)."""
    import shutil

    shutil.copy(POPULATION_FILE, tmp_path / "renshaw.toml")
    path = tmp_path / "pop.toml"
    path.write_text(STUDY.format(file="renshaw.toml"))
    return path


def test_study_file_names_populations(tmp_path):
    from astrocpg.studies.parameter_studies.execute import execute_run
    from astrocpg.studies.parameter_studies.study import load_study

    study = load_study(_study_file(tmp_path))
    assert len(study.runs) == 2
    for run in study.runs:
        assert run.populations["renshaw"]["content"] == POPULATION_FILE.read_text()
        assert "renshaw" in run.record["spikes"] and "renshaw_v" in run.record["traces"]
        assert run.train_settings().populations == run.populations
    assert populations.names() == BUILT_IN
    run = study.runs[0]
    folder = tmp_path / "out" / "runs" / run.run_id
    status = execute_run(run, str(folder))  # what a worker runs
    assert status["state"] == "finished", status.get("error")
    manifest = _manifest(folder)
    assert "renshaw" in manifest["settings"]["populations"]
    assert manifest["results"]["layout"]["populations"][-1]["name"] == "renshaw"
    assert "renshaw_times" in _spike_files(folder / "recordings" / "trial00_session0001")
    assert populations.names() == BUILT_IN
    # a replay of the study's run builds it too
    result = ac.run(seconds=0.3, weights=folder, progress=False)
    assert "renshaw" in result.spikes


@pytest.mark.parametrize("line, words", [
    ('populations = ["missing.toml"]', "cannot be read"),
    ('populations = "renshaw.toml"', "must be a list"),
])
def test_study_file_population_errors_name_the_key(tmp_path, line, words):
    from astrocpg.studies.parameter_studies.study import load_study

    path = _study_file(tmp_path)
    path.write_text(path.read_text().replace('populations = ["renshaw.toml"]', line))
    with pytest.raises(InputError, match=words) as refused:
        load_study(path)
    assert "[study] populations" in str(refused.value.culprit)


@pytest.mark.slow
def test_study_command_line(tmp_path):
    """astrocpg study with two runs on a local Dask worker: each run folder records the
    population, its recordings hold its spikes."""
    from astrocpg.studies.cli import main

    out = tmp_path / "out"
    assert main(["study", str(_study_file(tmp_path)), "--out", str(out), "--workers", "1",
                 "--no-progress"]) == 0
    runs = sorted((out / "runs").iterdir())
    assert len(runs) == 2
    for run in runs:
        assert "renshaw" in _manifest(run)["settings"]["populations"]
        assert "renshaw_times" in _spike_files(run / "recordings" / "trial00_session0001")
