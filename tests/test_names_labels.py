"""Names that shadow and labels that lie.

Names: a model parameter named like a Brian2 special name, a unit, a function, a constant or
one of the model's own variables is refused when the model is made (one check,
:mod:`astrocpg.models.names`), model files' fields are strictly typed, and a parameter the
network does not read is not accepted as "applied".

Labels: every duration runs as whole steps (:func:`astrocpg.models.units.whole_steps`), an
export says how the run ended and how long it simulated, "upright" reads the torso's height
too, and an evaluation grid has one axis per parameter.
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
from brian2 import ms, mV, second
from hypothesis import given, settings, strategies as st

from astrocpg.errors import InputError
from astrocpg.models import DEFAULT_MODELS, NeuronModel, Parameter, ParameterTable
from astrocpg.models.files import model_from_toml, model_to_toml
from astrocpg.models.names import SPECIAL_NAMES, why_reserved
from astrocpg.models.units import whole_steps
from astrocpg.studies.cli import main


def _astrocyte_file(line: str, edit=None) -> str:
    """The built-in astrocyte as a model file with ``line`` added to its [parameters]."""
    text = model_to_toml(DEFAULT_MODELS.astrocyte)
    if edit is not None:
        text = edit(text)
    return text.replace("[parameters]\n", f"[parameters]\n{line}\n")


def _refused(text: str, *words: str, slot: str = "astrocyte") -> str:
    with pytest.raises(InputError) as e:
        model_from_toml(text, culprit=f"--model {slot}", default=dict(DEFAULT_MODELS.items())[slot])
    line = str(e.value)
    assert "\n" not in line
    for word in words:
        assert word in line, (word, line)
    return line


def _one_line(capsys) -> str:
    err = capsys.readouterr().err
    lines = [x for x in err.splitlines() if x.strip()]
    assert len(lines) == 1 and lines[0].startswith("astrocpg:"), err
    assert "Traceback" not in err
    return lines[0]


# ---------------------------------------------------------------- class 4: names that shadow

# the examples, and one of each kind of name Brian2 gives a meaning
SHADOWING = {
    "dt": "special", "t": "special", "i": "special", "N": "special", "xi": "special",
    "xi_2": "special", "lastspike": "special", "not_refractory": "special",
    "t_in_timesteps": "special", "N_incoming": "special", "delay": "special",
    "ms": "unit", "mV": "unit", "umolar": "unit", "second": "unit", "mS": "unit",
    "exp": "function", "rand": "function", "randn": "function", "clip": "function",
    "int": "function", "where": "function",
    "pi": "constant", "e": "constant", "inf": "constant",
    "True": "keyword", "False": "keyword", "lambda": "keyword",
}


@pytest.mark.parametrize("name", sorted(SHADOWING))
def test_a_model_file_parameter_with_a_reserved_name_is_refused(name):
    value = '"1*second"' if name != "e" else "2.0"
    line = _refused(_astrocyte_file(f'{name} = {{ value = {value} }}'), name,
                    "cannot name a parameter")
    kind = SHADOWING[name]
    assert {"special": "special names", "unit": "unit", "function": "function",
            "constant": "constant", "keyword": "keyword"}[kind] in line, line


@pytest.mark.parametrize("name", ["Ca", "IP3", "AG", "ADO"])
def test_a_parameter_named_like_the_models_own_variable_is_refused(name):
    _refused(_astrocyte_file(f'{name} = {{ value = "1*umolar" }}'), name,
             "state variable of the equations")


def test_a_parameter_named_like_a_subexpression_is_refused():
    text = _astrocyte_file('s_x = { value = "1*second" }', edit=lambda t: t.replace(
        "dAG/dt = ", "s_x = 2*AG : 1\ndAG/dt = "))
    _refused(text, "s_x", "subexpression")


def test_an_expression_parameter_named_like_an_input_is_refused():
    text = model_to_toml(DEFAULT_MODELS.reward).replace(
        "[parameters]\n", '[parameters]\nvel_x = { value = "1.0" }\n')
    _refused(text, "vel_x", "input of the expression", slot="reward")


@settings(max_examples=60, deadline=None)
@given(st.sampled_from(sorted(__import__("brian2.core.namespace", fromlist=["x"]).DEFAULT_UNITS))
       | st.sampled_from(sorted(__import__("brian2.core.functions", fromlist=["x"])
                                .DEFAULT_FUNCTIONS))
       | st.sampled_from(sorted(SPECIAL_NAMES)))
def test_every_brian2_unit_function_and_special_name_is_refused(name):
    assert why_reserved(name) is not None, name
    with pytest.raises(InputError, match="cannot name a parameter"):
        NeuronModel(name="m", equations="dv/dt = -v/tau_ok : volt",
                    parameters=ParameterTable("m", [
                        Parameter(name="tau_ok", value=5 * ms, symbol="", meaning=""),
                        Parameter(name=name, value=1.0, symbol="", meaning="")]))


def test_every_built_in_parameter_passes_the_name_check():
    for model_name, model in DEFAULT_MODELS.items():
        for name in model.parameters:
            assert why_reserved(name) is None, (model_name, name)


def test_a_python_built_model_is_checked_too():
    """The check is the model's own (Model.__post_init__), not the file reader's."""
    with pytest.raises(InputError, match=r"m\.v: .*state variable"):
        NeuronModel(name="m", equations="dv/dt = -v/(5*ms) : volt",
                    parameters=ParameterTable("m", [Parameter(name="v", value=1 * mV,
                                                              symbol="", meaning="")]))
    with pytest.raises(InputError, match=r"motor_neuron\.dt: .*special"):
        DEFAULT_MODELS.motor_neuron.replace(parameters=ParameterTable(
            "m", [*DEFAULT_MODELS.motor_neuron.parameters.values(),
                  Parameter(name="dt", value=0.1 * second, symbol="", meaning="")]))


# ---- typed fields

@pytest.mark.parametrize("entry,field", [
    ('{ value = "1*second", positive = "false" }', "positive"),
    ('{ value = "1*second", positive = 0 }', "positive"),
    ('{ value = "1*second", symbol = 3 }', "symbol"),
    ('{ value = "1*second", meaning = ["a"] }', "meaning"),
])
def test_parameter_fields_have_their_toml_type(entry, field):
    text = _astrocyte_file(f"tau_x = {entry}", edit=lambda t: t.replace(
        "dAG/dt = -AG/tau_AG", "dAG/dt = -AG/tau_AG + 0/tau_x"))
    _refused(text, "parameters.tau_x", f"'{field}'")


def test_positive_false_text_was_read_as_true_and_now_is_refused():
    """The issue's case: positive = "false" on a negative value."""
    text = _astrocyte_file('tau_x = { value = "-1*second", positive = "false" }',
                           edit=lambda t: t.replace("dAG/dt = -AG/tau_AG",
                                                    "dAG/dt = -AG/tau_AG + 0/tau_x"))
    _refused(text, "positive", "true or false")


@pytest.mark.parametrize("key,value", [("description", "3"), ("method", "1"),
                                       ("threshold", "true")])
def test_model_fields_have_their_toml_type(key, value):
    fields = {"name": '"m"', "kind": '"neuron"', "equations": '"dv/dt = -v/tau : 1"',
              "threshold": '"v > 1"', "method": '"euler"', "description": '"d"', key: value}
    text = "".join(f"{k} = {v}\n" for k, v in fields.items())
    _refused(text + '[parameters]\ntau = { value = "5*ms" }\n', key, "must be text")


def test_an_initial_value_expression_must_be_text():
    import re
    text, n = re.subn(r"(?m)^Ca = \{ value = .*$", "Ca = { expression = 3 }",
                      model_to_toml(DEFAULT_MODELS.astrocyte))
    assert n == 1
    _refused(text, "initial_values.Ca", "'expression' must be text")


def test_ParameterTable_refuses_a_text_flag():
    with pytest.raises(InputError, match="'positive' must be true or false"):
        ParameterTable("m", [Parameter(name="tau", value=1 * ms, symbol="", meaning="",
                                       positive="false")])


# ---- applied means applied

def test_a_parameter_no_code_reads_is_refused(tmp_path, capsys):
    f = tmp_path / "a.toml"
    f.write_text(_astrocyte_file('tau_dead = { value = "1*second" }'))
    code = main(["run", "--seconds", "0.01", "--no-progress", "--model", f"astrocyte={f}",
                 "--out", str(tmp_path / "o")])
    line = _one_line(capsys)
    assert code == 2 and "tau_dead" in line and str(f) in line, line
    assert not (tmp_path / "o").exists()


def test_the_error_names_the_file_the_parameter_and_why(tmp_path, capsys):
    f = tmp_path / "shadow.toml"
    f.write_text(_astrocyte_file('dt = { value = "0.1*second" }'))
    code = main(["run", "--seconds", "0.01", "--no-progress", "--model", f"astrocyte={f}",
                 "--set", "dt=0.1*second", "--out", str(tmp_path / "o")])
    line = _one_line(capsys)
    assert code == 2 and "shadow.toml" in line and "dt" in line and "special" in line, line
    assert not (tmp_path / "o").exists()


def test_set_dt_is_not_a_parameter(tmp_path, capsys):
    code = main(["run", "--seconds", "0.01", "--no-progress", "--set", "dt=0.1*second",
                 "--out", str(tmp_path / "o")])
    line = _one_line(capsys)
    assert code == 2 and "dt" in line and "unknown model parameter" in line, line


def test_a_synapse_parameter_shadowed_by_its_target_group_is_refused_at_build(tmp_path, capsys):
    """What only the built network knows: ``u`` is a variable of the pools the inter-limb
    synapses read (Brian2 resolves it before the namespace)."""
    text = model_to_toml(DEFAULT_MODELS.interlimb_synapse).replace(
        "[parameters]\n", '[parameters]\nu = { value = "1" }\n').replace(
        "model = '''\n", "model = '''\nu_seen = u : 1\n", 1)  # code that reads u
    f = tmp_path / "il.toml"
    f.write_text(text)
    code = main(["run", "--seconds", "0.01", "--no-progress", "--model",
                 f"interlimb_synapse={f}", "--out", str(tmp_path / "o")])
    line = _one_line(capsys)
    assert code == 2 and "interlimb_synapse.u" in line and "not the value" in line, line
    assert not (tmp_path / "o").exists()


def test_the_recorded_values_are_the_values_the_built_network_reads():
    """Every parameter of every Brian2 object is, in the object's namespace, the model set's
    value (what a manifest records), and Brian2 resolves the name to the namespace."""
    from astrocpg.network import build_cpg
    from astrocpg.network.divergence import model_of
    from astrocpg.models.compose import model_set

    models = model_set(["tau_motor=9*ms", "tau_IP3=6*second", "w_max=0.04*mV"])
    cpg = build_cpg(models, seed=1)
    seen = set()
    for obj in cpg.net.objects:
        slot = model_of(obj.name) if hasattr(obj, "namespace") else None
        if not slot or not getattr(obj, "namespace", None):
            continue
        model = getattr(models, slot)
        for name, p in model.parameters.items():
            resolved = obj._resolve(name, run_namespace={}, user_identifier=False)
            assert np.all(np.asarray(resolved.get_value()) == np.asarray(p.value)), \
                (obj.name, name)
            seen.add(name)
    assert {"tau_motor", "tau_IP3", "w_max"} <= seen
    recorded = models.to_json()
    assert recorded["motor_neuron"]["parameters"]["tau_motor"]["si_value"] == pytest.approx(9e-3)


# ---------------------------------------------------------------- class 5: labels that lie

@pytest.mark.parametrize("value,step,ok", [(0.3, 1e-3, 300), (10.0, 1e-3, 10000),
                                           (1.0, 1.0, 1), (0.007, 1e-3, 7)])
def test_whole_steps_accepts_whole_numbers_of_steps(value, step, ok):
    assert whole_steps(value, step, culprit="x") == ok


@pytest.mark.parametrize("value,step,unit,nearest", [
    (0.0015, 1e-3, "s", "0.001 or 0.002 s"), (0.0005, 1e-3, "s", "0.001 s"),
    (0.5, 1.0, "ms", "1 ms"), (2.5, 1.0, "ms", "2 or 3 ms"), (0.2005, 1e-3, "s", "0.2 or 0.201")])
def test_whole_steps_refuses_the_rest_and_names_the_nearest(value, step, unit, nearest):
    with pytest.raises(InputError) as e:
        whole_steps(value, step, culprit="--opt", unit=unit)
    assert str(e.value).startswith("--opt: ") and nearest in str(e.value), str(e.value)


@pytest.mark.parametrize("argv,culprit", [
    (["run", "--seconds", "0.0015"], "--seconds"),
    (["unit", "--seconds", "0.0015"], "--seconds"),
    (["run", "--seconds", "0.01", "--trace-dt", "0.5"], "--trace-dt"),
    (["unit", "--seconds", "0.01", "--trace-dt", "1.5"], "--trace-dt"),
    (["train", "--sessions", "1", "--set", "L_max=0.2005*second"], "L_max"),
    (["train", "--sessions", "1", "--set", "L_max=0.2*second",
      "--set", "L_non_alive=0.1005*second"], "L_non_alive"),
    (["train", "--sessions", "1", "--set", "L_max=0.2*second",
      "--set", "reward_window=0.0105*second"], "reward_window"),
    (["train", "--sessions", "1", "--set", "L_max=0.2*second",
      "--set", "session_memory=2.5"], "session_memory"),
])
def test_durations_that_are_not_whole_steps_are_refused(argv, culprit, tmp_path, capsys):
    code = main([*argv, "--no-progress", "--out", str(tmp_path / "o")])
    line = _one_line(capsys)
    assert code == 2 and culprit in line, line
    assert not (tmp_path / "o").exists()


def test_a_study_with_a_session_length_off_the_steps_is_refused_before_it_runs(tmp_path, capsys):
    f = tmp_path / "s.toml"
    f.write_text('[study]\nname = "t"\nsessions = 1\nseeds = [1]\n'
                 '[base]\nL_max = "0.2005*second"\n')
    code = main(["study", str(f), "--out", str(tmp_path / "o"), "--workers", "1",
                 "--no-progress"])
    line = _one_line(capsys)
    assert code == 2 and "L_max" in line and "0.2 or 0.201" in line, line
    assert not (tmp_path / "o").exists()


def test_a_study_evaluate_seconds_off_the_steps_is_refused(tmp_path, capsys):
    f = tmp_path / "s.toml"
    f.write_text('[study]\nname = "t"\nsessions = 1\nseeds = [1]\n'
                 '[base]\nL_max = "0.2*second"\n[evaluate]\nseconds = 0.0015\n')
    code = main(["study", str(f), "--out", str(tmp_path / "o"), "--workers", "1",
                 "--no-progress"])
    line = _one_line(capsys)
    assert code == 2 and "[evaluate] seconds" in line, line
    assert not (tmp_path / "o").exists()


def test_the_help_says_durations_are_whole_steps(capsys):
    for command in (["run"], ["unit"], ["gait"], ["evaluate"], ["plot"]):
        with pytest.raises(SystemExit):
            main([*command, "--help"])
        text = " ".join(capsys.readouterr().out.split())
        assert "whole number of 1 ms steps" in text, command


# ---- exports say how the run ended

def _diverged_manifest() -> dict:
    return {"astrocpg_command": "run", "seed": 1, "settings": {"seconds": 10.0},
            "results": {"status": "diverged", "seconds": 0.37,
                        "error": {"line": "NaN in motor.v", "t_s": 0.37, "trial": 0}}}


def test_export_metadata_carries_the_status_and_the_simulated_time():
    from astrocpg.studies.outputs.export import _duration_text, _metadata
    m = _diverged_manifest()
    meta = _metadata(m)
    assert meta["status"] == "diverged" and meta["simulated_seconds"] == 0.37
    assert meta["error"]["line"] == "NaN in motor.v"
    text = _duration_text(m)
    assert "DIVERGED" in text and "0.37 s simulated" in text and "10 s asked" in text
    m["results"] = {"status": "finished", "seconds": 10.0}
    assert _duration_text(m) == "10 s" and _metadata(m)["status"] == "finished"


@pytest.mark.slow
def test_a_diverged_run_exported_to_nwb_says_so(tmp_path, capsys):
    from pynwb import NWBHDF5IO
    from astrocpg.coupling.robot import export_xml
    robot = tmp_path / "a1.xml"
    export_xml(robot)
    robot.write_text(robot.read_text().replace('ctrllimited="true"/>',
                                               'ctrllimited="true" gear="1e12"/>'))
    assert main(["run", "--seconds", "0.05", "--robot", str(robot), "--no-progress",
                 "--out", str(tmp_path / "r")]) == 3
    assert main(["export", str(tmp_path / "r"), "--out", str(tmp_path / "r.nwb")]) == 0
    capsys.readouterr()
    with NWBHDF5IO(str(tmp_path / "r.nwb"), "r") as io:
        nwb = io.read()
        notes = json.loads(nwb.notes)
        assert notes["status"] == "diverged" and notes["error"]
        assert "DIVERGED" in nwb.session_description
        assert "0.05 s asked" in nwb.session_description
        assert "diverged" in list(nwb.keywords[:])


# ---- upright means upright

ALIVE_HEIGHT = Path(__file__).resolve().parents[1] / "models" / "variants" / "alive_height.toml"


def test_the_built_in_alive_indicator_is_the_papers_and_the_height_variant_adds_a_bound():
    level = np.array([1.0, 1.0, 0.3])
    height = np.array([0.05, 0.30, 0.30])  # lying, standing, standing but tilted
    assert DEFAULT_MODELS.alive.compile()(torso_z_up=level).astype(bool).tolist() == \
        [True, True, False]
    variant = model_from_toml(ALIVE_HEIGHT.read_text(), culprit="alive",
                              default=DEFAULT_MODELS.alive).compile()
    assert variant(torso_z_up=level, torso_height=height).astype(bool).tolist() == \
        [False, True, False]


def test_a_crushing_payload_is_named_in_the_summary_and_the_height_variant_is_not_upright(
        tmp_path, capsys):
    argv = ["run", "--seconds", "1", "--set", "payload=1e6*kilogram", "--spikes", "none",
            "--traces", "none", "--no-progress"]
    assert main([*argv, "--out", str(tmp_path / "r")]) == 0
    out = capsys.readouterr().out
    results = json.loads((tmp_path / "r" / "manifest.json").read_text())["results"]
    assert results["lowest_torso_height_m"][0] < 0.15, results["lowest_torso_height_m"]
    assert "upright 100%" not in out and "above the ground" in out, out
    assert main([*argv, "--model", f"alive={ALIVE_HEIGHT}", "--out", str(tmp_path / "h")]) == 0
    results = json.loads((tmp_path / "h" / "manifest.json").read_text())["results"]
    assert results["upright_share"][0] < 0.5, results["upright_share"]


def test_an_alive_model_file_may_read_any_sense_the_robot_offers_and_no_other(tmp_path, capsys):
    """The bridge gives an alive model the inputs it declares, of those the robot offers."""
    code = main(["run", "--seconds", "0.05", "--model", f"alive={ALIVE_HEIGHT}", "--spikes",
                 "none", "--traces", "none", "--no-progress", "--out", str(tmp_path / "r")])
    out, err = capsys.readouterr()
    assert code == 0, err
    # the summary names the alive model the run used, not the built-in one's words
    assert ("alive (the alive model: (torso_z_up >= Thres_z_alive) * (torso_height >= "
            "Thres_height_alive))") in out, out
    assert "torso level" not in out
    f = tmp_path / "alive.toml"
    f.write_text(ALIVE_HEIGHT.read_text().replace("torso_height", "torso_heigth"))
    assert main(["run", "--seconds", "0.05", "--model", f"alive={f}", "--spikes", "none",
                 "--traces", "none", "--no-progress", "--out", str(tmp_path / "x")]) == 2
    assert "torso_heigth" in capsys.readouterr().err


# ---- one grid axis per parameter

@pytest.mark.parametrize("grid,both", [
    ('[grid.a]\nvalues = [2.0]\nscale = ["I_thigh"]\n'
     '[grid.b]\nvalues = [3.0]\nscale = ["I_thigh", "I_calf"]\n', "grid.a and grid.b"),
    ('[grid.a]\nvalues = [2.0]\nscale = ["I_thigh", "I_thigh"]\n', "grid.a.scale"),
    ('[grid.payload]\nvalues = ["1*kilogram"]\n'
     '[grid.heavier]\nvalues = [2.0]\nscale = ["payload"]\n', "grid.payload and grid.heavier"),
])
def test_two_grid_axes_on_one_parameter_are_refused(grid, both, tmp_path):
    from astrocpg.studies.commands.evaluate import read_worlds
    f = tmp_path / "w.toml"
    f.write_text(grid)
    with pytest.raises(InputError) as e:
        read_worlds(str(f), DEFAULT_MODELS)
    assert both in str(e.value), str(e.value)


def test_distinct_axes_are_accepted(tmp_path):
    from astrocpg.studies.commands.evaluate import read_worlds
    f = tmp_path / "w.toml"
    f.write_text('[grid.a]\nvalues = [2.0, 3.0]\nscale = ["I_thigh"]\n'
                 '[grid.b]\nvalues = [0.5]\nscale = ["I_calf"]\n')
    assert len(read_worlds(str(f), DEFAULT_MODELS).cell) == 2


@pytest.mark.parametrize("axis,condition", [
    ('tau_STDP = ["1*second", "2*second"]', 'set = { tau_STDP = "3*second" }'),
    ("astrocyte_regulation = [0.5, 1.0]", "astrocytes = false"),
])
def test_a_study_condition_on_a_swept_parameter_is_refused(axis, condition, tmp_path, capsys):
    """The same class in studies: a condition's value won over the sweep axis of the same
    parameter while the run's id named the axis value."""
    f = tmp_path / "s.toml"
    f.write_text('[study]\nname = "t"\nsessions = 1\nseeds = [1]\n[base]\nL_max = "0.2*second"\n'
                 f"[sweep.axes]\n{axis}\n[conditions.a]\n{condition}\n")
    code = main(["study", str(f), "--out", str(tmp_path / "o"), "--workers", "1",
                 "--no-progress"])
    line = _one_line(capsys)
    name = axis.split()[0]
    assert code == 2 and f"[conditions.a] and [sweep.axes] {name}" in line, line
    assert not (tmp_path / "o").exists()


def test_a_manifest_model_entry_with_a_text_flag_is_refused():
    from astrocpg.models import Model
    entry = DEFAULT_MODELS.astrocyte.to_json()
    assert Model.from_json(entry) == DEFAULT_MODELS.astrocyte
    entry["parameters"]["tau_IP3"]["positive"] = "false"
    with pytest.raises(InputError, match="'positive' must be true or false"):
        Model.from_json(entry)


def test_the_robot_offers_every_sense_an_alive_model_may_read():
    from astrocpg.coupling.senses import ALIVE_SENSES
    from astrocpg.models import alive

    assert set(ALIVE_SENSES) == set(alive.SENSES)
