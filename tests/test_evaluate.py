"""astrocpg evaluate: trained controllers in other worlds."""

from __future__ import annotations

import csv
import json
from pathlib import Path

import numpy as np
import pytest

from astrocpg.errors import InputError
from astrocpg.models import DEFAULT_MODELS
from astrocpg.studies.cli import main
from astrocpg.studies.commands.evaluate import COLUMNS, in_world, read_worlds


def test_builtin_robustness_worlds_parse():
    worlds = read_worlds("robustness", DEFAULT_MODELS).worlds
    assert worlds["flat"] == {"set": [], "scale": {}}
    assert worlds["uphill_0.17"]["set"] == ["slope=0.17"]
    assert any(item.startswith("terrain_height=") for w in worlds.values() for item in w["set"])


def test_a_grid_is_the_product_of_its_axes(tmp_path):
    path = tmp_path / "g.toml"
    path.write_text('[grid.drive]\nscale = ["I_background_0"]\nvalues = [0.8, 1.0, 1.2]\n'
                    '[grid.torque_gain]\nscale = ["I_thigh", "I_calf"]\nvalues = [0.5, 1.5]\n'
                    '[worlds.uphill]\nslope = "0.1"\n')
    ws = read_worlds(path, DEFAULT_MODELS)
    assert len(ws.worlds) == 3 * 2 + 1
    cell = ws.worlds["drive=1.2, torque_gain=0.5"]
    assert cell["scale"] == {"I_background_0": 1.2, "I_thigh": 0.5, "I_calf": 0.5}
    assert ws.cell["drive=1.2, torque_gain=0.5"] == (2, 0)
    models = in_world(DEFAULT_MODELS, cell)
    for name, f in (("I_background_0", 1.2), ("I_thigh", 0.5), ("I_calf", 0.5)):
        assert float(models.parameter(name).value) == pytest.approx(
            f * float(DEFAULT_MODELS.parameter(name).value))
    assert ws.labels["torque_gain"] == "torque_gain (x I_thigh, I_calf)"


def test_a_named_world_is_the_whole_world(tmp_path):
    """A controller trained on rough terrain is evaluated on flat ground in the world 'flat'."""
    import brian2

    rough = DEFAULT_MODELS.with_values({"terrain_height": 0.02 * brian2.meter, "slope": 0.1})
    flat = in_world(rough, {"set": [], "scale": {}})
    assert float(flat.parameter("terrain_height").value) == 0.0
    assert float(flat.parameter("slope").value) == 0.0
    up = in_world(rough, {"set": ["slope=0.05"], "scale": {}})
    assert float(up.parameter("slope").value) == pytest.approx(0.05)
    assert float(up.parameter("terrain_height").value) == 0.0


@pytest.mark.parametrize("text, words", [
    ('[worlds.a]\ntau_motor = "9*ms"\n', ["a.tau_motor", "not a world parameter"]),
    ('[worlds.a]\nslope = "3*second"\n', ["slope"]),
    ('[worlds.a]\nslope = "0.1"\n[other]\n', ["[worlds.NAME]"]),
    ("[worlds.a\n", ["TOML"]),
    ('[grid.g]\nscale = ["I_thight"]\nvalues = [1.0]\n', ["I_thight"]),
    ('[grid.g]\nscale = ["I_thigh"]\nvalues = [-1.0]\n', ["grid.g.values", "positive"]),
    ('[grid.slope]\nvalues = []\n', ["grid.slope.values"]),
])
def test_bad_worlds_files_are_named(tmp_path, text, words):
    path = tmp_path / "w.toml"
    path.write_text(text)
    with pytest.raises(InputError) as e:
        read_worlds(path, DEFAULT_MODELS)
    for w in words:
        assert w in str(e.value)


def test_evaluate_refuses_a_folder_that_is_not_a_training(tmp_path, capsys):
    (tmp_path / "x").mkdir()
    assert main(["evaluate", str(tmp_path / "x"), "--no-progress"]) == 2
    assert "neither a training" in capsys.readouterr().err


@pytest.mark.slow
def test_evaluate_a_training_in_two_worlds(tmp_path):
    train = tmp_path / "train"
    assert main(["train", "--out", str(train), "--sessions", "1", "--trials", "2", "--seed", "3",
                 "--set", "L_max=0.3*second", "--no-progress"]) == 0
    worlds = tmp_path / "w.toml"
    worlds.write_text('[worlds.flat]\n[worlds.uphill]\nslope = "0.17"\n')
    out = tmp_path / "ev"
    assert main(["evaluate", str(train), "--worlds", str(worlds), "--seconds", "0.6",
                 "--repeats", "2", "--out", str(out), "--no-progress"]) == 0
    rows = list(csv.DictReader(open(out / "evaluation.csv")))
    assert tuple(rows[0]) == COLUMNS
    # 2 trained trials x 2 worlds x 2 repeats, seeds of the training's trials
    assert len(rows) == 8
    assert {r["seed"] for r in rows} == {"3", "4"}
    assert {r["world"] for r in rows} == {"flat", "uphill"}
    flat = sum(float(r["distance_m"]) for r in rows if r["world"] == "flat")
    up = sum(float(r["distance_m"]) for r in rows if r["world"] == "uphill")
    assert up < flat  # gravity pulls the robot back uphill
    assert (out / "worlds.png").stat().st_size > 0  # two named worlds: speed and falls
    summary = list(csv.DictReader(open(out / "summary.csv")))
    assert {s["world"] for s in summary} == {"flat", "uphill"}
    manifest = json.loads((out / "manifest.json").read_text())
    assert manifest["settings"]["worlds"]["uphill"]["set"] == ["slope=0.17"]
    assert manifest["astrocpg_command"] == "evaluate"
    # a two-axis grid draws a gait map, and its values are columns
    grid = tmp_path / "g.toml"
    grid.write_text('[grid.drive]\nscale = ["I_background_0"]\nvalues = [0.9, 1.1]\n'
                    '[grid.torque_gain]\nscale = ["I_thigh", "I_calf"]\nvalues = [0.8, 1.2]\n')
    assert main(["evaluate", str(train), "--worlds", str(grid), "--seconds", "0.4",
                 "--repeats", "1", "--no-progress"]) == 0  # default: DIR/evaluation
    done = train / "evaluation"
    assert (done / "gait_map.png").stat().st_size > 0
    rows = list(csv.DictReader(open(done / "evaluation.csv")))
    assert {(r["grid_drive"], r["grid_torque_gain"]) for r in rows} == {
        ("0.9", "0.8"), ("0.9", "1.2"), ("1.1", "0.8"), ("1.1", "1.2")}


# ---- resumable, and on Dask (everything runs on Dask and resumes)
WORLDS3 = '[worlds.flat]\n[worlds.uphill]\nslope = "0.1"\n[worlds.slippery]\nfriction = "0.4"\n'


@pytest.fixture(scope="module")
def trained(tmp_path_factory):
    root = tmp_path_factory.mktemp("ev")
    train = root / "train"
    assert main(["train", "--out", str(train), "--sessions", "1", "--trials", "2", "--seed", "5",
                 "--set", "L_max=0.3*second", "--no-progress"]) == 0
    worlds = root / "w3.toml"
    worlds.write_text(WORLDS3)
    return train, worlds


def _evaluate(train, worlds, out, seconds="0.3", *extra) -> int:
    """``astrocpg evaluate`` in this process, its cells here (``--workers 1``: the cells the
    tests count run in this process, not on a cluster)."""
    return main(["evaluate", str(train), "--worlds", str(worlds), "--seconds", seconds,
                 "--repeats", "1", "--out", str(out), "--no-progress", "--workers", "1",
                 *extra])


def _counting(monkeypatch, fail_at: int | None = None) -> list[str]:
    """Count the cells run here; raise KeyboardInterrupt (Ctrl-C) when cell ``fail_at`` starts."""
    import astrocpg.studies.commands.evaluate as ev

    real, calls = ev.evaluate_cell, []

    def cell(controller, tables, world, *args, **kwargs):
        calls.append(world)
        if fail_at is not None and len(calls) == fail_at:
            raise KeyboardInterrupt
        return real(controller, tables, world, *args, **kwargs)

    monkeypatch.setattr(ev, "evaluate_cell", cell)
    return calls


@pytest.mark.slow
def test_an_interrupted_evaluation_runs_only_the_cells_it_had_not_finished(
        trained, tmp_path, monkeypatch):
    from astrocpg.studies.outputs.folder import verify

    train, worlds = trained
    whole = tmp_path / "whole"
    with monkeypatch.context() as m:
        calls = _counting(m)
        assert _evaluate(train, worlds, whole) == 0
        assert calls == ["flat", "uphill", "slippery"]
    out = tmp_path / "ev"
    parts = tmp_path / "ev.parts"
    with monkeypatch.context() as m:
        _counting(m, fail_at=3)
        assert _evaluate(train, worlds, out) == 130  # Ctrl-C during the third cell
    assert not out.exists(), "an interrupted evaluation wrote its folder"
    assert sorted(p.name for p in parts.iterdir()) == ["0000-0000.json", "0000-0001.json",
                                                        "fingerprint.txt"]
    with monkeypatch.context() as m:
        calls = _counting(m)
        assert _evaluate(train, worlds, out) == 0
        assert calls == ["slippery"], "the finished cells ran again"
    assert not parts.exists(), "the parts outlived the written folder"
    # the same table as an evaluation never interrupted
    assert (out / "evaluation.csv").read_text() == (whole / "evaluation.csv").read_text()
    assert json.loads((out / "manifest.json").read_text())["settings"]["cells_reused"] == 2


@pytest.mark.slow
def test_other_settings_do_not_reuse_the_cells(trained, tmp_path, monkeypatch):
    train, worlds = trained
    out = tmp_path / "ev"
    with monkeypatch.context() as m:
        _counting(m, fail_at=2)
        assert _evaluate(train, worlds, out) == 130
    assert (tmp_path / "ev.parts" / "0000-0000.json").exists()
    with monkeypatch.context() as m:
        calls = _counting(m)
        assert _evaluate(train, worlds, out, "0.2") == 0  # other --seconds: other cells
        assert calls == ["flat", "uphill", "slippery"]
    assert not (tmp_path / "ev.parts").exists()


@pytest.mark.slow
def test_evaluate_on_dask_gives_the_rows_of_the_serial_run(trained, tmp_path):
    from astrocpg.studies.outputs.folder import verify

    train, worlds = trained
    here, dask = tmp_path / "here", train / "evaluation"
    assert _evaluate(train, worlds, here) == 0
    assert main(["evaluate", str(train), "--worlds", str(worlds), "--seconds", "0.3",
                 "--repeats", "1", "--no-progress", "--workers", "2"]) == 0
    assert (dask / "evaluation.csv").read_text() == (here / "evaluation.csv").read_text()
    assert json.loads((dask / "manifest.json").read_text())["settings"]["workers"] == 2
    verify(train)  # evaluation/ beside a training's files: still its whole, listed folder


def test_the_tables_after_a_session_are_those_the_training_kept(tmp_path):
    """--session S evaluates each trial's table after session S (weights.npz keeps one per
    session), refused where a trial has not done it or the source is a table file."""
    from astrocpg.studies.outputs.weights import load_weights

    folder = tmp_path / "train"
    folder.mkdir()
    per_session = np.arange(2 * 3 * 64, dtype=float).reshape(2, 3, 8, 8) * 1e-4  # mV
    np.savez(folder / "weights.npz", weights_mV=per_session, final_weights_mV=per_session[:, -1],
             sessions_done=np.array([3, 2]), labels=np.array(["x"] * 8))
    np.testing.assert_array_equal(load_weights(folder, session=1), per_session[:, 0] * 1e-3)
    np.testing.assert_array_equal(load_weights(folder, session=2, trial=1),
                                  per_session[1, 1] * 1e-3)
    np.testing.assert_array_equal(load_weights(folder), per_session[:, -1] * 1e-3)
    with pytest.raises(InputError, match="not every trial has done 3 sessions") as e:
        load_weights(folder, session=3)
    assert e.value.culprit == "session=3"  # the setting, in the Python API's words
    with pytest.raises(InputError, match="at least 1"):
        load_weights(folder, session=0)
    np.save(tmp_path / "t.npy", per_session[0, 0])
    with pytest.raises(InputError, match="has no sessions"):
        load_weights(tmp_path / "t.npy", session=1)


@pytest.mark.slow
def test_evaluate_names_a_session_no_trial_has_reached(trained, tmp_path, capsys):
    train, worlds = trained
    assert _evaluate(train, worlds, tmp_path / "ev", "0.3", "--session", "5") == 2
    err = capsys.readouterr().err
    assert "--session 5" in err and "not every trial has done 5 sessions" in err
    assert not (tmp_path / "ev").exists()
