"""No number or label silently wrong: a table's unit, which tables are final, the seed a trained
table runs on, values beyond float32, and statistics over blank cells.

Each test holds a case that an earlier astrocpg got wrong without a word: a plain array read in
another unit than the one it came out in, a stopped or running training's tables called final,
trial k's table run on trial 0's network, traces overflowing float32 in a training's recordings
with no way to keep them, a blank cell dropped or a NaN turned into a tiny p-value.
"""

from __future__ import annotations

import fcntl
import json
import math
import os
import subprocess
import sys
import warnings
from pathlib import Path

import numpy as np
import pytest

import astrocpg as ac
from astrocpg.errors import InputError
from astrocpg.studies.analysis.compare import bootstrap_interval, mann_whitney, permutation_test
from astrocpg.studies.cli import main
from astrocpg.studies.outputs.kept_tables import keep_tables, kept_controllers, kept_state
from astrocpg.studies.outputs.weights import tables_state

ROOT = Path(__file__).resolve().parents[1]
SHORT = ["L_max=0.2*second", "L_non_alive=0.1*second"]


@pytest.fixture(scope="module")
def training(tmp_path_factory) -> Path:
    """A finished two-trial training (seed 5), two short sessions per trial."""
    out = tmp_path_factory.mktemp("trained") / "t"
    ac.train(out=out, sessions=2, trials=2, seed=5, overrides=SHORT, progress=False)
    return out


def _stopped_copy(training: Path, dst: Path) -> Path:
    """A copy of ``training`` whose manifest plans more sessions than it did: a training
    stopped before its end, as a killed one is."""
    import shutil

    shutil.copytree(training, dst)
    manifest = json.loads((dst / "manifest.json").read_text())
    manifest["settings"]["n_sessions"] = 30
    (dst / "manifest.json").write_text(json.dumps(manifest))
    return dst


# ---------------------------------------------------------------- a table's unit
def test_a_plain_array_is_refused_naming_the_unit():
    table = np.zeros((8, 8))
    with pytest.raises(InputError) as e:
        ac.run(seconds=0.01, weights=table, progress=False)
    assert e.value.culprit == "weights" and "mV" in str(e.value)


def test_a_trained_table_passed_back_with_its_unit_runs_unclipped(training):
    from brian2 import mV

    trained = ac.load(training).weights[:, -1]  # (trial, 8, 8) in mV, as the docs say
    r = ac.run(seconds=0.01, trials=2, weights=trained * mV, progress=False)
    assert np.allclose(r.robot["interlimb_weights_mV"] if "interlimb_weights_mV" in (r.robot or {})
                       else trained, trained)


def test_a_table_in_volt_read_as_mV_would_be_out_of_range_and_is_refused():
    from brian2 import mV

    table = np.zeros((8, 8))
    table[0, 2] = 20.0  # 20 mV: far above w_max (0.05 mV); was clipped without a word
    with pytest.raises(InputError) as e:
        ac.run(seconds=0.01, weights=table * mV, progress=False)
    assert "w_max" in str(e.value)


def test_a_quantity_of_another_dimension_is_refused():
    from brian2 import second

    with pytest.raises(InputError) as e:
        ac.run(seconds=0.01, weights=np.zeros((8, 8)) * second, progress=False)
    assert e.value.culprit == "weights"


# ---------------------------------------------------------------- the seed a table trained on
def test_a_trials_table_runs_on_the_network_it_trained_with(training):
    r = ac.run(seconds=0.01, weights=training, trial=1, progress=False)
    assert r.seed == 5 + 1  # the training's seed plus the trial, not 1
    r = ac.run(seconds=0.01, weights=training, trials=2, progress=False)
    assert r.seed == 5


def test_another_seed_given_for_a_trained_table_runs_with_a_warning(training):
    with pytest.warns(UserWarning, match="trained with seed 6"):
        r = ac.run(seconds=0.01, seed=1, weights=training, trial=1, progress=False)
    assert r.seed == 1


def test_the_command_line_runs_a_trials_table_on_its_seed(training, tmp_path, capsys):
    assert main(["run", "--seconds", "0.01", "--weights", str(training), "--trial", "1",
                 "--out", str(tmp_path / "r"), "--no-progress"]) == 0
    assert "trial 0 (seed 6+0)" in capsys.readouterr().out
    assert json.loads((tmp_path / "r" / "manifest.json").read_text())["seed"] == 6


# ---------------------------------------------------------------- which tables are final
def test_a_finished_trainings_tables_are_final(training):
    state = tables_state(training)
    assert state["final"] and state["label"] == "final" and not state["warning"]


def test_a_stopped_trainings_tables_are_not_called_final(training, tmp_path):
    stopped = _stopped_copy(training, tmp_path / "stopped")
    state = tables_state(stopped)
    assert not state["final"] and state["label"] == "after session 2"
    with pytest.warns(UserWarning, match="stopped before its end") as said:
        r = ac.run(seconds=0.01, trials=2, weights=stopped, progress=False,
                   out=tmp_path / "r")
    # a warning reaches Python users only (the command line shows none): Python's advice
    assert any(f"continue it with ac.resume({stopped})" in str(w.message) for w in said), \
        [str(w.message) for w in said]
    settings = json.loads((tmp_path / "r" / "manifest.json").read_text())["settings"]
    assert settings["tables"] == "after session 2"
    assert r.n_trials == 2


def test_a_running_trainings_tables_are_said_to_be_in_progress(training, tmp_path):
    """Another process holds the training's lock (as a running ``astrocpg train`` does)."""
    import shutil

    running = tmp_path / "running"
    shutil.copytree(training, running)
    holder = subprocess.Popen(
        [sys.executable, "-c",
         "import fcntl, os, sys, time\n"
         f"fd = os.open({str(running / '.astrocpg.lock')!r}, os.O_RDWR | os.O_CREAT)\n"
         "fcntl.flock(fd, fcntl.LOCK_EX)\nprint('held', flush=True)\ntime.sleep(60)\n"],
        stdout=subprocess.PIPE, text=True)
    try:
        assert holder.stdout.readline().strip() == "held"
        state = tables_state(running)
        assert state["running"] and not state["final"]
        with pytest.warns(UserWarning, match="still training"):
            ac.run(seconds=0.01, trials=2, weights=running, progress=False)
    finally:
        holder.kill()
        holder.wait()


@pytest.mark.slow
def test_evaluate_labels_a_stopped_trainings_tables(training, tmp_path):
    stopped = _stopped_copy(training, tmp_path / "stopped")
    worlds = tmp_path / "flat.toml"
    worlds.write_text('[worlds.flat]\n')
    with pytest.warns(UserWarning, match="stopped before its end"):
        res = ac.evaluate(stopped, worlds=worlds, seconds=0.05, repeats=1, out=tmp_path / "ev",
                          progress=False, workers=1)
    manifest = json.loads((tmp_path / "ev" / "manifest.json").read_text())
    assert manifest["settings"]["tables"] == "latest: after session 2"
    assert res is not None


def _kept_study(tmp_path: Path, done: int, planned: int) -> Path:
    """A study folder with one run whose seeds did ``done`` of ``planned`` sessions."""
    run = tmp_path / "study" / "runs" / "astrocytes__seeds1-2"
    run.mkdir(parents=True)
    w = np.zeros((2, done, 8, 8))
    np.savez(run / "weights.npz", weights_mV=w, final_weights_mV=w[:, -1],
             sessions_done=np.full(2, done), labels=np.array([str(i) for i in range(8)]))
    (run / "manifest.json").write_text(json.dumps(
        {"seed": 1, "settings": {"seed": 1, "n_sessions": planned, "condition": "astrocytes",
                                 "point": {}}}))
    return tmp_path / "study"


def test_kept_tables_of_a_stopped_run_are_not_final(tmp_path):
    study = _kept_study(tmp_path, done=12, planned=30)
    keep_tables(study, tmp_path / "kept")
    meta = json.loads(next((tmp_path / "kept").glob("*.json")).read_text())
    assert meta["tables"]["final"] is False and meta["tables"]["sessions_done"] == [12, 12]
    state = kept_state(kept_controllers(tmp_path / "kept")[0])
    assert state["label"] == "after session 12" and "stopped before its end" in state["warning"]


def test_kept_tables_of_a_finished_run_are_final(tmp_path):
    study = _kept_study(tmp_path, done=30, planned=30)
    keep_tables(study, tmp_path / "kept")
    assert kept_state(kept_controllers(tmp_path / "kept")[0])["final"]


@pytest.mark.parametrize("session", [0, -1])
def test_no_tables_are_kept_after_session_zero(tmp_path, session):
    study = _kept_study(tmp_path, done=3, planned=3)
    with pytest.raises(InputError) as e:
        keep_tables(study, tmp_path / "kept", [session])
    assert e.value.culprit == "sessions"  # the setting, in the Python API's words
    assert not (tmp_path / "kept").exists()


def test_final_tables_script_refuses_session_zero(tmp_path):
    study = _kept_study(tmp_path, done=3, planned=3)
    proc = subprocess.run([sys.executable, str(ROOT / "docs" / "ablation" / "final_tables.py"),
                           str(study), "--sessions", "0", "--out", str(tmp_path / "kept")],
                          capture_output=True, text=True)
    assert proc.returncode != 0 and "counted from 1" in proc.stderr


# ---------------------------------------------------------------- float32 in recordings
@pytest.mark.slow
def test_a_trainings_recordings_say_when_traces_overflow_float32(tmp_path):
    common = dict(sessions=1, trials=1, overrides=[*SHORT, "r_Ca=1e45"], record_every=1,
                  spikes=(), traces=("motor_Ca",), progress=False)
    with pytest.warns(UserWarning, match="beyond float32"):
        ac.train(out=tmp_path / "t32", **common)
    rec = tmp_path / "t32" / "recordings" / "trial00_session0001"
    over = json.loads((rec / "manifest.json").read_text())["results"]["trace_overflow"]
    assert over["motor_Ca"]["values"] > 0
    training = json.loads((tmp_path / "t32" / "manifest.json").read_text())["results"]
    assert "trial00_session0001" in training["trace_overflow"]
    with warnings.catch_warnings(record=True) as said:
        warnings.simplefilter("always")
        ac.train(out=tmp_path / "t64", trace_dtype="float64", **common)
    assert not [w for w in said if "float32" in str(w.message)]
    with np.load(tmp_path / "t64" / "recordings" / "trial00_session0001" / "traces.npz") as z:
        key = next(k for k in z.files if "motor_Ca" in k and not k.endswith("_t"))
        assert z[key].dtype == np.float64 and np.all(np.isfinite(z[key]))


def test_trace_dtype_needs_record_every(tmp_path, capsys):
    code = main(["train", "--sessions", "1", "--trace-dtype", "float64", "--out",
                 str(tmp_path / "t"), "--no-progress"])
    assert code == 2 and "--trace-dtype" in capsys.readouterr().err
    assert not (tmp_path / "t").exists()


def test_a_replay_takes_trace_dtype(training, tmp_path):
    r = ac.run(weights=training, session=1, trial=1, trace_dtype="float64",
               out=tmp_path / "replay", progress=False)
    manifest = json.loads((tmp_path / "replay" / "manifest.json").read_text())
    assert manifest["settings"]["record"]["dtype"] == "float64"
    assert r is not None


# ---------------------------------------------------------------- statistics over blanks
def test_a_nan_gives_no_p_value_rather_than_a_tiny_one():
    a = [1.0, 2.0, 3.0, float("nan")]
    b = [1.0, 2.0, 3.0, float("nan")]
    assert math.isnan(permutation_test(a, b)["p"])
    assert all(math.isnan(v) for v in bootstrap_interval(a, b))
    assert math.isnan(mann_whitney(np.array(a), np.array(b))[1])
    many = list(np.arange(20.0)) + [float("nan")]
    assert math.isnan(permutation_test(many, many)["p"])  # Monte Carlo branch too


def test_retest_refuses_a_blank_cell_naming_its_line(tmp_path):
    import pandas as pd

    rows = pd.read_csv(ROOT / "docs" / "ablation" / "streams" / "results.csv.gz")
    rows = rows[rows["seed"] <= 3].reset_index(drop=True)
    rows.loc[7, "final_x_m"] = np.nan
    path = tmp_path / "rows.csv"
    rows.to_csv(path, index=False)
    proc = subprocess.run([sys.executable, str(ROOT / "docs" / "ablation" / "retest.py"),
                           str(path)], capture_output=True, text=True)
    assert proc.returncode == 2
    assert "line 9" in proc.stderr and "final_x_m" in proc.stderr


# ---------------------------------------------------------------- a user's model file
def test_robot_export_overwrite_replaces_only_an_unchanged_export(tmp_path, capsys):
    target = tmp_path / "a1.xml"
    assert main(["robot", "export", str(target)]) == 0
    assert main(["robot", "export", str(target), "--overwrite"]) == 0  # its own, unchanged
    edited = target.read_text().replace("<mujoco", "<!-- my friction --><mujoco", 1)
    target.write_text(edited)
    assert main(["robot", "export", str(target), "--overwrite"]) == 2
    assert "not the A1 model astrocpg writes" in capsys.readouterr().err
    assert target.read_text() == edited
