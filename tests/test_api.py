"""The Python API (``import astrocpg as ac``): the same results as the commands, folders read back
into the same Result, spike and trace selections that agree with the index layout, bad
arguments as one-line InputErrors, and an ``import astrocpg`` that does not load Brian2."""

from __future__ import annotations

import json
import shutil
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

import astrocpg as ac
from astrocpg.errors import InputError
from astrocpg.studies.commands.simulate import POPULATIONS
from astrocpg.network.populations import BUILT_IN, trace_sources
from astrocpg.studies.cli import main

TRACE_SOURCES = trace_sources(BUILT_IN)

SHORT_SESSIONS = ["L_max=0.3*second", "L_non_alive=0.2*second"]


@pytest.fixture(scope="module")
def tmp_module(tmp_path_factory) -> Path:
    return tmp_path_factory.mktemp("api")


@pytest.fixture(scope="module")
def in_process():
    return ac.run(seconds=0.3, seed=3, progress=False)


@pytest.fixture(scope="module")
def run_folder(tmp_module) -> Path:
    out = tmp_module / "run"
    assert main(["run", "--seconds", "0.3", "--seed", "3", "--out", str(out),
                 "--no-progress"]) == 0
    return out


@pytest.fixture(scope="module")
def unit2(tmp_module):
    """Two units (trials) with a folder: trial filters, and loading a unit folder."""
    return ac.unit(seconds=0.4, seed=2, trials=2, progress=False, out=tmp_module / "unit")


@pytest.fixture(scope="module")
def training(tmp_module):
    return ac.train(out=tmp_module / "train", sessions=2, seed=5, overrides=SHORT_SESSIONS,
                    record_every=1, spikes=("motor", "astrocyte"),
                    traces=("astrocyte_Ca", "astrocyte_ADO"), progress=False)


# ---------------------------------------------------------------- same as the command
def test_api_and_command_give_identical_spikes(in_process, run_folder):
    loaded = ac.load(run_folder)
    assert set(in_process.spikes) == set(POPULATIONS) == set(loaded.spikes)
    for pop in POPULATIONS:
        t0, i0 = in_process.spikes[pop]
        t1, i1 = loaded.spikes[pop]
        np.testing.assert_array_equal(t0, t1)
        np.testing.assert_array_equal(i0, i1)
    assert len(in_process.spikes["motor"][0]) > 100


def test_load_gives_the_same_result(in_process, run_folder):
    loaded = ac.load(run_folder)
    assert (loaded.kind, loaded.seed, loaded.seconds) == ("run", 3, 0.3) == \
        (in_process.kind, in_process.seed, in_process.seconds)
    assert loaded.layout == in_process.layout
    assert loaded.folder == run_folder and in_process.folder is None
    for leg in ("FR", "RL"):
        for pool in ("thigh_flexor", "calf_extensor"):
            np.testing.assert_array_equal(loaded.spike_times("motor", leg=leg, pool=pool),
                                          in_process.spike_times("motor", leg=leg, pool=pool))
    for name in TRACE_SOURCES:
        a, b = in_process.trace(name), loaded.trace(name)
        np.testing.assert_array_equal(np.asarray(a.t), np.asarray(b.t))
        np.testing.assert_array_equal(np.asarray(a.values), np.asarray(b.values))
        assert a.columns == b.columns and a.unit == b.unit
    assert set(loaded.robot) == set(in_process.robot)
    for key, value in in_process.robot.items():
        np.testing.assert_array_equal(loaded.robot[key], value, err_msg=key)
    assert loaded.summary["distance_m"] == in_process.summary["distance_m"]
    assert loaded.manifest["astrocpg_command"] == "run"
    assert in_process.manifest["settings"]["seed"] == 3
    # live objects only in the process that made the result
    from brian2 import Network, SpikeMonitor

    from astrocpg.network.recording import TraceRecorder
    assert isinstance(in_process.network, Network)
    assert isinstance(in_process.monitors["motor"], SpikeMonitor)
    assert isinstance(in_process.monitors["traces"], TraceRecorder)
    assert len(in_process.monitors["motor"].t) == len(in_process.spikes["motor"][0])
    assert loaded.network is None and loaded.monitors is None
    assert loaded.models == in_process.models  # rebuilt from the manifest
    text = repr(loaded)
    assert "run" in text and "motor" in text and "astrocyte_Ca" in text and "robot" in text


# ---------------------------------------------------------------- selections
def test_spike_time_filters_agree_with_raw_indices(unit2):
    L = unit2.layout
    assert L.n_trials == 2 and L.legs == ("FR",)
    t, i = unit2.spikes["motor"]
    for b in (0, 1):
        for pool in ("thigh_flexor", "calf_extensor"):
            cells = L.motor_neurons(b, 0, pool)
            want = np.sort(t[np.isin(i, cells)])
            got = unit2.spike_times("motor", trial=b, leg="FR", pool=pool)
            np.testing.assert_array_equal(got, want)
            k = 7
            np.testing.assert_array_equal(
                unit2.spike_times("motor", trial=b, leg="FR", pool=pool, neuron=k),
                np.sort(t[i == cells[k]]))
        # the neuron's index within the trial, without leg/pool
        np.testing.assert_array_equal(unit2.spike_times("motor", trial=b, neuron=45),
                                      np.sort(t[i == b * L.motor_per_trial + 45]))
        trial_spikes = unit2.spike_times("motor", trial=b)
        assert np.all(np.diff(trial_spikes) >= 0)
        assert len(trial_spikes) == np.sum(i // L.motor_per_trial == b)
    np.testing.assert_array_equal(unit2.spike_times("motor", trial=None), np.sort(t))
    ti, ii = unit2.spikes["interneuron"]
    for name in ("thigh_flexor_to_extensor", "thigh_flexor_to_calf_extensor"):
        idx = L.interneuron(1, 0, name)
        np.testing.assert_array_equal(unit2.spike_times("interneuron", trial=1, pool=name),
                                      np.sort(ti[ii == idx]))
    ta, ia = unit2.spikes["astrocyte"]
    np.testing.assert_array_equal(
        unit2.spike_times("astrocyte", trial=1, leg="FR", pool="thigh_extensor"),
        np.sort(ta[ia == L.thigh_pool(1, 0, "thigh_extensor")]))
    assert unit2.rate("motor", trial=0, pool="thigh_flexor") > 0


def test_trace_units_and_columns(unit2):
    from brian2 import second, umolar
    from brian2.units.fundamentalunits import get_dimensions

    L = unit2.layout
    for name, (group, _, _, unit) in TRACE_SOURCES.items():
        tr = unit2.trace(name)
        t_raw, raw = unit2.traces[name]
        np.testing.assert_allclose(np.asarray(tr.t / second), t_raw)
        assert tr.unit == unit
        if unit == "uM":
            assert get_dimensions(tr.values) == get_dimensions(umolar)
            np.testing.assert_allclose(np.asarray(tr.values / umolar), raw, rtol=1e-6)
        else:
            assert get_dimensions(tr.values).is_dimensionless
            np.testing.assert_allclose(np.asarray(tr.values), raw)
        assert len(tr.columns) == raw.shape[1]
    ca = unit2.trace("astrocyte_Ca")
    assert ca.columns[L.thigh_pool(1, 0, "thigh_extensor")] == \
        {"trial": 1, "leg": "FR", "pool": "thigh_extensor", "index": 3}
    np.testing.assert_allclose(
        np.asarray(ca.column(trial=1, leg="FR", pool="thigh_extensor") / umolar),
        unit2.traces["astrocyte_Ca"][1][:, L.thigh_pool(1, 0, "thigh_extensor")], rtol=1e-6)
    mca = unit2.trace("motor_Ca")
    cells = L.motor_neurons(1, 0, "calf_flexor")
    np.testing.assert_allclose(np.asarray(mca.column(trial=1, pool="calf_flexor", neuron=4)),
                               unit2.traces["motor_Ca"][1][:, cells[4]])
    assert mca.column(trial=1, pool="calf_flexor").shape == (len(mca.t), L.pool_size)
    assert mca.columns[cells[4]] == {"trial": 1, "leg": "FR", "pool": "calf_flexor",
                                     "index": int(cells[4]), "neuron": 4}


# ---------------------------------------------------------------- loading folders
def test_load_unit_folder(unit2, tmp_module):
    loaded = ac.load(tmp_module / "unit")
    assert loaded.kind == "unit" and loaded.robot is None and loaded.layout == unit2.layout
    for pop in POPULATIONS:
        for b in (0, 1):
            np.testing.assert_array_equal(loaded.spike_times(pop, trial=b),
                                          unit2.spike_times(pop, trial=b))
    assert loaded.summary["rhythm"] == unit2.summary["rhythm"]


def test_load_training_and_recorded_session(training, tmp_module):
    folder = tmp_module / "train"
    assert training.kind == "train" and training.trainer is not None
    assert training.network is not None
    assert list(training.sessions["session"]) == [1, 2]
    assert training.weights.shape == (1, 2, 8, 8)
    loaded = ac.load(folder)
    assert loaded.kind == "train" and loaded.network is None
    assert loaded.sessions.equals(training.sessions)
    np.testing.assert_array_equal(loaded.weights, training.weights)
    assert loaded.summary["status"] == "finished"
    assert set(loaded.recordings) == {(0, 1), (0, 2)}
    rec = loaded.recording(trial=0, session=1)
    assert rec.kind == "train-session" and rec.layout.n_trials == 1
    assert rec.seconds == pytest.approx(loaded.sessions["length_s"].iloc[0])
    t, i = rec.spikes["motor"]
    assert len(t) > 0
    np.testing.assert_array_equal(rec.spike_times("motor", pool="thigh_flexor", leg="RR"),
                                  np.sort(t[np.isin(i, rec.layout.motor_neurons(0, 2,
                                                                                "thigh_flexor"))]))
    assert set(rec.traces) == {"astrocyte_Ca", "astrocyte_ADO"}
    assert set(rec.spikes) == {"motor", "astrocyte"}
    assert rec.trace("astrocyte_ADO").values.shape[1] == 8
    assert rec.robot["joint_angles"].shape[0] == 1
    same = ac.load(folder / "recordings" / "trial00_session0002")
    assert same.manifest["settings"]["session"] == 2
    with pytest.raises(InputError, match="recorded"):
        loaded.recording(trial=0, session=7)


# ---------------------------------------------------------------- bad input
def _one_line(err: pytest.ExceptionInfo, *words: str) -> None:
    text = str(err.value)
    assert "\n" not in text
    for w in words:
        assert w in text, (w, text)


@pytest.mark.parametrize("kwargs, words", [
    ({"population": "motr"}, ["population='motr'", "interneuron"]),
    ({"population": "motor", "leg": "XX"}, ["leg='XX'", "FR"]),
    ({"population": "motor", "pool": "hip"}, ["pool='hip'", "thigh_flexor"]),
    ({"population": "interneuron", "pool": "thigh_flexor"},
     ["pool='thigh_flexor'", "thigh_flexor_to_extensor"]),
    ({"population": "motor", "trial": 5}, ["trial=5", "0..1"]),
    ({"population": "motor", "leg": "FR", "pool": "calf_flexor", "neuron": 20},
     ["neuron=20", "0..19"]),
    ({"population": "motor", "pool": "calf_flexor", "neuron": 2}, ["neuron=2", "leg="]),
])
def test_bad_spike_selection(unit2, kwargs, words):
    with pytest.raises(InputError) as err:
        unit2.spike_times(**kwargs)
    _one_line(err, *words)


def test_bad_trace_requests(unit2, training):
    with pytest.raises(InputError) as err:
        unit2.trace("astrocyte_Cal")
    _one_line(err, "astrocyte_Cal", "astrocyte_Ca")
    with pytest.raises(InputError) as err:
        unit2.trace("astrocyte_Ca").column(trial=1, leg="FR", pool="calf_flexor")
    _one_line(err, "pool='calf_flexor'", "thigh_extensor")
    session = training.recording(trial=0, session=2)
    with pytest.raises(InputError) as err:
        session.trace("motor_Ca")
    _one_line(err, "not recorded", "astrocyte_Ca")
    with pytest.raises(InputError) as err:
        session.spike_times("interneuron")
    _one_line(err, "not recorded", "motor")
    with pytest.raises(InputError) as err:
        ac.run(seconds=-1)
    _one_line(err, "seconds")


def test_load_refuses_what_is_not_an_output_folder(tmp_path, run_folder):
    from astrocpg.errors import EnvironmentFault
    with pytest.raises(EnvironmentFault) as err:  # a missing input: the environment's, exit 1
        ac.load(tmp_path / "absent")
    _one_line(err, "absent", "no such folder")
    (tmp_path / "empty").mkdir()
    with pytest.raises(InputError) as err:
        ac.load(tmp_path / "empty")
    _one_line(err, "empty", "not an astrocpg output folder")
    study = tmp_path / "study"
    study.mkdir()
    (study / "manifest.json").write_text(json.dumps({"astrocpg_command": "study", "files": {}}))
    with pytest.raises(InputError) as err:
        ac.load(study)
    _one_line(err, "study")
    corrupt = tmp_path / "corrupt"
    shutil.copytree(run_folder, corrupt)
    data = (corrupt / "spikes.npz").read_bytes()
    (corrupt / "spikes.npz").write_bytes(data[: len(data) // 2])
    with pytest.raises(InputError) as err:
        ac.load(corrupt)
    _one_line(err, str(corrupt), "spikes.npz")
    missing = tmp_path / "missing"
    shutil.copytree(run_folder, missing)
    (missing / "robot.npz").unlink()
    with pytest.raises(InputError) as err:
        ac.load(missing)
    _one_line(err, str(missing), "robot.npz")


# ---------------------------------------------------------------- the package
def test_import_astrocpg_does_not_load_brian2():
    code = ("import sys, astrocpg, astrocpg.studies.cli; "
            "assert 'brian2' not in sys.modules, 'brian2 loaded'; "
            "print(sorted(astrocpg.__all__))")
    proc = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                          timeout=120)
    assert proc.returncode == 0, proc.stderr
    for name in ("unit", "run", "train", "resume", "load", "describe", "Result"):
        assert f"'{name}'" in proc.stdout
    from astrocpg.studies.commands import api
    # the functions as handed out name the API's keywords in their errors (the same function
    # inside); the classes are the classes
    assert ac.load.__wrapped__ is api.load and ac.run.__wrapped__ is api.run
    assert ac.Result is api.Result
    with pytest.raises(AttributeError):
        ac.no_such_function  # noqa: B018


def test_public_functions_have_docstrings():
    for name in ("unit", "run", "train", "resume", "load", "describe", "export"):
        assert len((getattr(ac, name).__doc__ or "").strip()) > 40, name
    for name in ("spike_times", "trace", "recording", "neurons", "rate", "from_simulation"):
        assert (getattr(ac.Result, name).__doc__ or "").strip(), name
    assert ac.Trace.column.__doc__


def test_describe_returns_plain_text_or_markdown():
    text = ac.describe("astrocyte", overrides={"tau_ADO": "2*second"})
    assert text.startswith("astrocyte\n") and "tau_ADO" in text and "2. s" in text
    md = ac.describe("astrocyte", "markdown", overrides={"tau_ADO": "2*second"})
    assert md.startswith("## astrocyte") and "| `tau_ADO` |" in md
