"""A population from a model file receives from and sends to the built-in populations
(``[[population.outputs]]``: tests/data/renshaw_recurrent.toml, a Renshaw-like cell per pool
inhibiting its pool's motor neurons), and its model joins the model set, so that ``--set``
(command line) and ``overrides=`` (API) reach its parameters, the manifest records them and
``describe`` shows them (docs/model-files.md, "A new population")."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

import astrocpg as ac
from astrocpg.errors import InputError
from astrocpg.network import build_cpg, populations
from astrocpg.network.layout import POOLS

DATA = Path(__file__).parent / "data"
RECURRENT = DATA / "renshaw_recurrent.toml"
INPUT_ONLY = DATA / "renshaw_population.toml"
BUILT_IN = tuple(p.name for p in populations.BUILT_IN)


def _file(path: Path) -> dict[str, str]:
    return {str(path): path.read_text()}


def test_the_file_declares_an_output():
    row = populations.population_from_toml(RECURRENT.read_text(), culprit=str(RECURRENT))
    assert [(o.target, o.synapse, o.match) for o in row.outputs] == \
        [("motor", "interneuron_to_pool", "label")]
    assert row.to_json(3)["outputs"] == [{"to": "motor", "synapse": "interneuron_to_pool",
                                          "match": "label"}]
    assert populations.from_json(row.to_json(3)).outputs == row.outputs


def test_outputs_wire_each_cell_to_its_pool():
    """Each motor neuron is inhibited by its own pool's Renshaw cell, in every trial and limb."""
    row = populations.population_from_toml(RECURRENT.read_text(), culprit=str(RECURRENT))
    cpg = build_cpg(n_trials=2, seed=3, populations=(row,))
    L = cpg.layout
    s = cpg.synapses["renshaw_to_motor"]
    assert "renshaw_to_motor" in cpg.synapse_kinds
    assert len(s) == L.motor_per_trial * 2  # one Renshaw cell per motor neuron
    i, j = np.asarray(s.i[:]), np.asarray(s.j[:])
    labels = row.labels(L.pool_size)
    n_per_trial = L.cells_per_trial("renshaw")
    for src, tgt in zip(i, j):
        b, leg, k = src // n_per_trial, (src % n_per_trial) // len(labels), src % len(labels)
        assert tgt in set(L.motor_neurons(b, leg, labels[k]))
    assert populations.names() == BUILT_IN  # the table passed as a value: nothing registered


def test_outputs_reach_the_target_pool():
    """The same seed with and without the output: the Renshaw cells fire and the motor
    neurons' spikes change."""
    kw = dict(seconds=1.0, seed=1, progress=False)
    with_output = ac.unit(populations=_file(RECURRENT), **kw)
    without = ac.unit(populations=_file(INPUT_ONLY), **kw)
    assert len(with_output.spike_times("renshaw", trial=0)) > 0
    a = with_output.spike_times("motor", trial=0)
    b = without.spike_times("motor", trial=0)
    assert len(a) < len(b)  # the pools' own Renshaw cells inhibit them
    # the input-only population leaves the built-in network as it is
    plain = ac.unit(**kw)
    assert np.array_equal(np.sort(plain.spike_times("motor", trial=0)), np.sort(b))


def test_overrides_reach_its_parameters(tmp_path):
    """overrides= (API) sets a parameter of the added population's model: its spikes change and
    the manifest records the value, in the settings and in the models."""
    kw = dict(seconds=1.0, seed=1, progress=False, populations=_file(RECURRENT))
    default = ac.unit(**kw)
    slower = ac.unit(overrides={"tau_renshaw": "40*ms"}, out=tmp_path / "slow", **kw)
    n0 = len(default.spike_times("renshaw", trial=0))
    n1 = len(slower.spike_times("renshaw", trial=0))
    assert n0 != n1
    manifest = json.loads((tmp_path / "slow" / "manifest.json").read_text())
    assert manifest["settings"]["overrides"] == ["tau_renshaw=40*ms"]
    recorded = manifest["models"]["renshaw"]["parameters"]["tau_renshaw"]
    assert recorded["si_value"] == pytest.approx(0.040)
    # the folder reads back whole in a process that never added the population
    loaded = ac.load(tmp_path / "slow")
    assert loaded.models is not None
    assert float(loaded.models.parameter("tau_renshaw").value) == pytest.approx(0.040)
    assert len(loaded.spike_times("renshaw", trial=0)) == n1


def test_set_on_the_command_line(tmp_path, capsys):
    """astrocpg unit --population FILE --set NAME=VALUE reaches the population's parameter."""
    from astrocpg.studies.cli import main

    out = tmp_path / "cli"
    rc = main(["unit", "--seconds", "0.5", "--no-progress", "--population", str(RECURRENT),
               "--set", "v_renshaw_th=1*volt", "--out", str(out)])
    assert rc == 0
    manifest = json.loads((out / "manifest.json").read_text())
    assert manifest["models"]["renshaw"]["parameters"]["v_renshaw_th"]["si_value"] == 1.0
    assert len(ac.load(out).spike_times("renshaw", trial=0)) == 0  # a threshold never reached
    # describe shows the added population's model, with the value set
    rc = main(["describe", "v_renshaw_th", "--population", str(RECURRENT),
               "--set", "v_renshaw_th=7*mV"])
    assert rc == 0
    text = capsys.readouterr().out
    assert "a parameter of renshaw" in text and "7. mV" in text


def test_a_parameter_name_the_set_holds_is_refused():
    """A population's parameter named like a built-in one: refused, naming both."""
    text = RECURRENT.read_text().replace("tau_renshaw", "tau_motor")
    with pytest.raises(InputError) as err:
        ac.unit(seconds=0.1, progress=False, populations={"clash.toml": text})
    words = f"{err.value.culprit} {err.value}"
    assert "tau_motor" in words and "motor_neuron" in words and "clash.toml" in words


@pytest.mark.parametrize("change, words", [
    ('to = "motor"', 'to = "nowhere"'),
    ('synapse = "interneuron_to_pool"', 'synapse = "no_synapse"'),
    ('match = "label"\n', 'match = "neighbour"\n'),
])
def test_bad_output(change, words):
    text = RECURRENT.read_text()
    head, _, tail = text.rpartition("[[population.outputs]]")
    text = head + "[[population.outputs]]" + tail.replace(change, words)
    with pytest.raises(InputError) as err:
        populations.population_from_toml(text, culprit="bad.toml")
    assert "bad.toml" in err.value.culprit and "outputs[0]" in err.value.culprit


STUDY = """
[study]
name = "renshaw_sweep"
sessions = 1
seeds = {{ first = 1, count = 1 }}
batch = 1
populations = ["{file}"]
[base]
L_max = "0.3*second"
L_non_alive = "0.1*second"
[sweep.axes]
tau_renshaw = ["9*ms", "30*ms"]
"""


def test_a_study_sweeps_its_parameter(tmp_path):
    """A study file's sweep reaches the added population's parameter: each run's settings
    carry the value and its training records it in the manifest's models."""
    import shutil

    from astrocpg.studies.parameter_studies.execute import execute_run
    from astrocpg.studies.parameter_studies.study import load_study

    shutil.copy(RECURRENT, tmp_path / "renshaw.toml")
    path = tmp_path / "sweep.toml"
    path.write_text(STUDY.format(file="renshaw.toml"))
    study = load_study(path)
    assert sorted(r.overrides[-1] for r in study.runs) == ["tau_renshaw=30*ms",
                                                          "tau_renshaw=9*ms"]
    run = next(r for r in study.runs if "tau_renshaw=30*ms" in r.overrides)
    folder = tmp_path / "out" / "runs" / run.run_id
    status = execute_run(run, str(folder))  # what a worker runs
    assert status["state"] == "finished", status.get("error")
    manifest = json.loads((folder / "manifest.json").read_text())
    assert manifest["models"]["renshaw"]["parameters"]["tau_renshaw"]["si_value"] == \
        pytest.approx(0.030)
    # a value the parameter's unit refuses names the sweep
    path.write_text(STUDY.format(file="renshaw.toml").replace('"30*ms"', '"30*volt"'))
    with pytest.raises(InputError, match="tau_renshaw"):
        load_study(path)
    assert populations.names() == BUILT_IN


def test_the_model_set_holds_added_models():
    """ModelSet.added: set by name like a slot, recorded and read back (a manifest's models),
    a parameter name another model declares refused, naming both."""
    from astrocpg.models import DEFAULT_MODELS, ModelSet

    row = populations.population_from_toml(RECURRENT.read_text(), culprit=str(RECURRENT))
    from brian2 import ms

    models = DEFAULT_MODELS.with_added(row.model).with_values({"tau_renshaw": 30 * ms})
    assert dict(models.items())["renshaw"].parameters["tau_renshaw"].value == 30 * ms
    assert DEFAULT_MODELS.added == () and "renshaw" not in dict(DEFAULT_MODELS.items())
    data = json.loads(json.dumps(models.to_json()))
    assert data["renshaw"]["added"] is True and "added" not in data["motor_neuron"]
    assert ModelSet.from_json(data) == models
    assert models.with_added(row.model) is models  # held already: kept, with its values
    from astrocpg.models.files import model_from_toml

    text = RECURRENT.read_text().replace("tau_renshaw =", "tau_motor =").replace(
        "/tau_renshaw", "/tau_motor").split("[population]")[0]
    clash = model_from_toml(text, culprit="clash.toml")
    with pytest.raises(InputError) as err:
        DEFAULT_MODELS.with_added(clash)
    assert err.value.culprit == "renshaw.tau_motor" and "motor_neuron" in str(err.value)
