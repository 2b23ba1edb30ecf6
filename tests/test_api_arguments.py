"""The Python API's arguments (``import astrocpg as ac``): a wrong type is an InputError naming
the argument, never a TypeError or AttributeError from inside; a text where a list of names is
expected is one name (or names separated by commas), never read one character at a time."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

import astrocpg as ac

CHEAP = {"seconds": 0.02, "progress": False}


@pytest.fixture(scope="module")
def written(tmp_path_factory) -> "ac.Result":
    out = tmp_path_factory.mktemp("api") / "run"
    return ac.run(**CHEAP, seed=3, out=out)


@pytest.mark.parametrize("spikes", ["motor", " motor ", ["motor"], ("motor",)])
def test_spikes_as_one_name_or_a_list(spikes):
    r = ac.run(**CHEAP, spikes=spikes, traces="none")
    assert set(r.spikes) == {"motor"}, sorted(r.spikes)


def test_spikes_and_traces_as_text_of_names():
    r = ac.run(**CHEAP, spikes="motor,astrocyte", traces="astrocyte_Ca")
    assert set(r.spikes) == {"motor", "astrocyte"}
    assert set(r.traces) == {"astrocyte_Ca"}


@pytest.mark.parametrize("kw, culprit", [
    ({"spikes": 3}, "spikes"), ({"spikes": ["motor", 3]}, "spikes"),
    ({"spikes": b"motor"}, "spikes"), ({"traces": 1.5}, "traces"),
    ({"spikes": "m"}, "'m'"), ({"traces": "motor_K"}, "motor_K"),
    ({"weights": [[1.0, 2.0]]}, "weights"), ({"weights": object()}, "weights"),
    ({"weights": [["a"] * 8] * 8}, "weights"), ({"weights": np.full((8, 8), np.nan)}, "weights"),
    ({"equations": "dv/dt = 0 : volt"}, "equations"), ({"models": ["astrocyte"]}, "models"),
    ({"models": "astrocyte.toml"}, "models"),
], ids=lambda v: repr(v) if isinstance(v, dict) else None)
def test_a_wrong_argument_is_an_input_error_naming_it(kw, culprit):
    with pytest.raises(ac.InputError) as e:
        ac.run(**CHEAP, **kw)
    assert culprit in str(e.value), str(e.value)
    assert "--" not in str(e.value), str(e.value)  # the API's keywords, not the options


@pytest.mark.parametrize("weights", [np.zeros((8, 8)), np.zeros((8, 8)).tolist(),
                                     [np.zeros(8).tolist() for _ in range(8)],
                                     tuple(tuple(row) for row in np.zeros((8, 8)))])
def test_weights_of_plain_numbers_are_refused_asking_for_a_unit(weights):
    with pytest.raises(ac.InputError) as e:
        ac.run(**CHEAP, weights=weights)
    assert e.value.culprit == "weights" and "* mV" in str(e.value)


def test_weights_in_mV_equal_the_same_weights_in_volt():
    from brian2 import mV, volt

    table = np.zeros((8, 8))
    table[0, 2] = table[4, 6] = 0.04  # mV, across limbs (same-limb blocks stay zero)
    a = ac.run(**CHEAP, seed=2, weights=table * mV, traces="none")
    b = ac.run(**CHEAP, seed=2, weights=(table * 1e-3) * volt, traces="none")
    assert np.array_equal(a.spike_times("motor"), b.spike_times("motor"))


def test_unit_takes_names_as_text():
    r = ac.unit(seconds=0.02, progress=False, spikes="motor", traces="none")
    assert set(r.spikes) == {"motor"}


def test_export_takes_a_written_result(written, tmp_path):
    path = ac.export(written, "npz", out=tmp_path / "r.npz")
    assert Path(path).is_file()
    with np.load(path) as z:
        assert any(k.startswith("spikes_motor") for k in z.files)


def test_export_takes_one_experimenter_as_text(written, tmp_path):
    import json

    path = ac.export(written, "npz", out=tmp_path / "r.npz", experimenter="Doe, Jane")
    with np.load(path) as z:
        meta = json.loads(str(z["metadata_json"]))
    assert meta["experimenter"] == ["Doe, Jane"]


@pytest.mark.parametrize("call, culprit", [
    (lambda w, t: ac.export(ac.run(**CHEAP)), "folder"),  # a Result never written
    (lambda w, t: ac.export(3), "folder"),
    (lambda w, t: ac.export(w, 7), "format"),
    (lambda w, t: ac.export(w, "npz", out=5), "out"),
    (lambda w, t: ac.export(w, "npz", out=t / "x.npz", experimenter=[1]), "experimenter"),
    (lambda w, t: ac.export(w, "npz", out=t / "x.npz", institution=3), "institution"),
])
def test_export_refuses_wrong_arguments_naming_them(written, tmp_path, call, culprit):
    with pytest.raises(ac.InputError) as e:
        call(written, tmp_path)
    assert culprit in str(e.value), str(e.value)
    assert not (tmp_path / "x.npz").exists()


@pytest.mark.parametrize("kw, culprit", [({"equations": "text"}, "equations"),
                                         ({"models": ["astrocyte"]}, "models")])
def test_describe_refuses_wrong_arguments_naming_them(kw, culprit):
    with pytest.raises(ac.InputError) as e:
        ac.describe("astrocyte", **kw)
    assert culprit in str(e.value)


@pytest.mark.parametrize("call, culprit", [
    (lambda: ac.run(**CHEAP, out=3), "out"), (lambda: ac.unit(**CHEAP, out=["o"]), "out"),
    (lambda: ac.run(**CHEAP, robot=3), "robot"), (lambda: ac.load(3), "folder"),
    (lambda: ac.plot(None), "folder"), (lambda: ac.video(7), "folder"),
    (lambda: ac.resume(3), "folder"), (lambda: ac.train(out=3, sessions=1), "out"),
    (lambda: ac.run(**CHEAP, overrides=3), "overrides"),
    (lambda: ac.run(**CHEAP, overrides=[("tau_motor", "9*ms")]), "overrides"),
], ids=["run-out", "unit-out", "run-robot", "load", "plot", "video", "resume", "train-out",
        "overrides-number", "overrides-pairs"])
def test_a_path_or_override_of_the_wrong_type_is_an_input_error_naming_it(call, culprit):
    with pytest.raises(ac.InputError) as e:
        call()
    assert culprit in str(e.value), str(e.value)


def test_overrides_as_one_text_or_a_mapping():
    a = ac.run(**CHEAP, overrides="tau_motor=9*ms", traces="none")
    b = ac.run(**CHEAP, overrides={"tau_motor": "9*ms"}, traces="none")
    assert np.array_equal(a.spike_times("motor"), b.spike_times("motor"))


# ---- the API speaks its own words: no Brian2 banner above an astrocpg error, keywords named
_SCRIPT = """
import astrocpg as ac
ac.{call}
"""


@pytest.mark.parametrize("call, words", [
    ("run(seconds=-1, progress=False)", "seconds: must be greater than 0"),
    ("unit(seconds=0.02, overrides={'tau_motr': '8*ms'}, progress=False)",
     "overrides tau_motr: unknown model parameter"),
    ("run(seconds=0.02, trace_dtype='float16', progress=False)", "trace_dtype"),
], ids=["run-seconds", "unit-overrides", "run-trace-dtype"])
def test_an_error_in_a_plain_script_prints_no_brian_banner_and_names_the_keyword(
        call, words, tmp_path):
    import subprocess
    import sys

    script = tmp_path / "script.py"
    script.write_text(_SCRIPT.format(call=call))
    done = subprocess.run([sys.executable, str(script)], cwd=tmp_path, capture_output=True,
                          text=True, timeout=300)
    assert done.returncode == 1
    assert "Brian 2 encountered" not in done.stderr, done.stderr
    last = done.stderr.strip().splitlines()[-1]
    assert last.startswith("astrocpg.errors.InputError: ") and words in last, last
    assert "--" not in last, last


def test_the_command_line_keeps_its_options_names(capsys):
    from astrocpg.studies.cli import main

    assert main(["run", "--seconds", "-1"]) == 2
    assert "--seconds" in capsys.readouterr().err


def test_a_model_set_is_accepted_where_a_model_set_is_meant():
    """The manual's "edit the model set itself": a ModelSet given as ``models`` runs as the same
    change given as overrides, and its changed models are recorded as model files."""
    from brian2 import ms

    from astrocpg.models import DEFAULT_MODELS

    edited = DEFAULT_MODELS.with_values({"tau_motor": 8 * ms})
    by_set = ac.unit(seconds=0.05, seed=2, models=edited, progress=False)
    by_override = ac.unit(seconds=0.05, seed=2, overrides={"tau_motor": "8*ms"}, progress=False)
    plain = ac.unit(seconds=0.05, seed=2, progress=False)
    np.testing.assert_array_equal(by_set.spikes["motor"][0], by_override.spikes["motor"][0])
    assert not np.array_equal(by_set.spikes["motor"][0], plain.spikes["motor"][0]) \
        or len(by_set.spikes["motor"][0]) != len(plain.spikes["motor"][0])
    assert set(by_set.manifest["settings"]["models"]) == {"motor_neuron"}
