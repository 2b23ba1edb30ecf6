"""The model contract: tables complete, validation names the culprit, integration as the paper,
one contract for every kind of model, manifests that rebuild the models."""

import json

import numpy as np
import pytest
from brian2 import Equations, NeuronGroup, Network, ms, mV, second, umolar

from astrocpg.errors import InputError
from astrocpg.models import DEFAULT_MODELS, Model, ModelSet
from astrocpg.models.base import ExpressionModel, NeuronModel, SynapseModel, WorldModel
from astrocpg.models.integration import InputThenDecay, input_then_decay, register_method
from astrocpg.network import build_cpg, check_runs


def test_every_parameter_has_symbol_meaning_and_unique_name():
    seen = set()
    for model_name, model in DEFAULT_MODELS.items():
        for name, p in model.parameters.items():
            assert p.symbol and p.meaning, f"{model_name}.{name} lacks symbol or meaning"
            assert name not in seen
            seen.add(name)
    # the paper's Table I/II values that drive the rhythm
    assert DEFAULT_MODELS.parameter("tau_motor").value == 9 * ms
    assert DEFAULT_MODELS.parameter("I_background_0").value == 1380 * mV / second
    assert DEFAULT_MODELS.parameter("C_K_chan").value == 8000 * mV / second


def test_syntax_error_in_equations_names_the_model():
    with pytest.raises(InputError, match="motor_neuron.equations: equation string is invalid"):
        DEFAULT_MODELS.motor_neuron.replace(equations="dv/dt = (-v/tau_motor : volt")


def test_inconsistent_units_name_the_model():
    bad = DEFAULT_MODELS.motor_neuron.replace(
        equations=DEFAULT_MODELS.motor_neuron.equations.replace(
            "- C_K_chan*K_open : volt", "- C_K_chan*K_open + Ca : volt"))
    cpg = build_cpg(DEFAULT_MODELS.replace(motor_neuron=bad), legs=("FR",))
    with pytest.raises(InputError) as err:
        check_runs(cpg)
    msg = str(err.value)
    assert msg.startswith("motor_neuron:") and "unit" in msg and "\n" not in msg


def test_unknown_parameter_and_wrong_unit_and_non_positive_time_constant():
    with pytest.raises(InputError, match="tau_motr: unknown model parameter"):
        DEFAULT_MODELS.with_values({"tau_motr": 9 * ms})
    with pytest.raises(InputError, match="tau_motor.*units"):
        DEFAULT_MODELS.parse_assignment("tau_motor=9")
    with pytest.raises(InputError, match="motor_neuron.tau_motor: must be positive"):
        DEFAULT_MODELS.with_values({"tau_motor": -9 * ms})
    with pytest.raises(InputError, match="overrides tau_ADO: must be positive"):
        DEFAULT_MODELS.parse_assignment("tau_ADO=0*second")
    with pytest.raises(InputError, match="astrocyte.tau_ADO: must be positive"):
        DEFAULT_MODELS.with_values({"tau_ADO": 0 * ms})


def test_overrides_reach_the_namespace():
    m = DEFAULT_MODELS.with_values(dict([DEFAULT_MODELS.parse_assignment("A_random=0.25")]))
    assert m.motor_neuron.parameters.namespace()["A_random"] == 0.25
    assert DEFAULT_MODELS.motor_neuron.parameters.namespace()["A_random"] == 0.5  # immutable


def test_input_then_decay_is_the_authors_update():
    # x <- (x + dt*I) * exp(-dt/tau): one step from x0 with constant input
    g = NeuronGroup(1, "dx/dt = -x/tau + I : volt\nI : volt/second\ntau : second",
                    method=input_then_decay, dt=1 * ms)
    g.x, g.I, g.tau = 2 * mV, 1000 * mV / second, 9 * ms
    net = Network(g)
    net.run(1 * ms)
    expected = (2 + 1.0) * np.exp(-1 / 9)
    assert g.x[0] / mV == pytest.approx(expected, rel=1e-12)


def test_reward_expression_penalises_rotation():
    r = DEFAULT_MODELS.reward.compile()
    assert r(vel_x=1.0, omega_roll=0.0, omega_pitch=0.0, omega_yaw=0.0) == pytest.approx(1.0)
    assert r(vel_x=1.0, omega_roll=-2.0, omega_pitch=1.0, omega_yaw=0.0) == pytest.approx(0.7)


# ---- one contract for every kind of model

KINDS = {"motor_neuron": ("neuron", "equations"), "intra_pool_synapse": ("synapse", "model"),
         "reward": ("expression", "expression")}


@pytest.mark.parametrize("name", sorted(KINDS))
def test_replace_with_values_and_with_code_on_each_kind(name):
    model = getattr(DEFAULT_MODELS, name)
    kind, code_field = KINDS[name]
    assert isinstance(model, Model) and model.kind == kind and model.code_field == code_field
    assert model.code == getattr(model, code_field)

    described = model.replace(description="edited")
    assert described.description == "edited" and described.code == model.code
    assert model.description != "edited"  # immutable

    pname = next(n for n, p in model.parameters.items() if float(np.asarray(p.value)) != 0)
    value = model.parameters[pname].value * 2
    changed = model.with_values(**{pname: value})
    assert changed.parameters[pname].value == value and type(changed) is type(model)
    assert model.parameters[pname].value != value

    text = model.code + ("\n" if kind != "expression" else "")
    edited = model.with_code(text)
    assert getattr(edited, code_field) == text and edited.statements()[code_field] == text

    with pytest.raises(InputError) as err:
        model.replace(no_such_field=1)
    assert err.value.culprit == f"{model.name}.no_such_field"
    with pytest.raises(InputError) as err:
        model.with_values(**{pname: "9"})
    assert err.value.culprit == f"{model.name}.{pname}"


def test_statements_by_role():
    motor = DEFAULT_MODELS.motor_neuron.statements()
    assert list(motor) == ["equations", "threshold", "reset", "refractory"]
    assert motor["reset"] == "v = v_motor_rest; Ca += r_Ca"
    assert list(DEFAULT_MODELS.torque.statements()) == ["equations"]
    assert list(DEFAULT_MODELS.intra_pool_synapse.statements()) == ["model", "on_pre", "weight"]
    assert list(DEFAULT_MODELS.interlimb_synapse.statements()) == ["model", "on_step"]
    assert list(DEFAULT_MODELS.pool_to_interneuron.statements()) == ["on_pre"]  # model is ""
    assert DEFAULT_MODELS.reward.statements() == {"expression": DEFAULT_MODELS.reward.expression}


def test_models_set_their_method_by_registered_name():
    assert DEFAULT_MODELS.motor_neuron.method == "input_then_decay"
    assert DEFAULT_MODELS.interlimb_synapse.method == "input_then_decay"
    assert DEFAULT_MODELS.astrocyte.method == "euler"
    # a registered scheme object is stored as its name
    assert DEFAULT_MODELS.torque.replace(method=input_then_decay).method == "input_then_decay"
    assert DEFAULT_MODELS.torque.replace(method="Exponential_Euler").method == "exponential_euler"


def test_unknown_method_names_the_model():
    with pytest.raises(InputError) as err:
        DEFAULT_MODELS.motor_neuron.replace(method="input_then_decy")
    assert err.value.culprit == "motor_neuron.method" and "input_then_decay" in err.value.message
    with pytest.raises(InputError) as err:
        DEFAULT_MODELS.interlimb_synapse.replace(method=InputThenDecay)  # a class, not a scheme
    assert err.value.culprit == "interlimb_synapse.method"
    entry = DEFAULT_MODELS.motor_neuron.to_json() | {"method": "rk5"}
    with pytest.raises(InputError) as err:
        Model.from_json(entry)
    assert err.value.culprit == "motor_neuron.method"


def test_registering_the_scheme_twice_is_harmless():
    from brian2.stateupdaters.base import StateUpdateMethod
    from brian2.stateupdaters.explicit import ExplicitStateUpdater

    assert register_method("input_then_decay", input_then_decay) == "input_then_decay"
    try:  # a re-import makes a new object of the same scheme
        assert register_method("input_then_decay", InputThenDecay()) == "input_then_decay"
        g = NeuronGroup(1, "dx/dt = -x/(9*ms) + 1*volt/second : volt", method="input_then_decay",
                        dt=1 * ms)
        Network(g).run(1 * ms)
        assert g.x[0] / mV == pytest.approx(1.0 * np.exp(-1 / 9), rel=1e-12)
    finally:
        StateUpdateMethod.stateupdaters["input_then_decay"] = input_then_decay
    with pytest.raises(InputError) as err:  # another scheme may not take the name
        register_method("input_then_decay", ExplicitStateUpdater("x_new = x + dt*f(x, t)"))
    assert "input_then_decay" in err.value.culprit
    assert StateUpdateMethod.stateupdaters["input_then_decay"] is input_then_decay


@pytest.mark.slow
def test_registration_on_import_survives_a_reimport_in_a_fresh_process():
    import subprocess
    import sys
    code = ("import importlib, astrocpg.models as m, astrocpg.models.integration as i; "
            "importlib.reload(i); importlib.reload(m); "
            "print(m.DEFAULT_MODELS.motor_neuron.method)")
    proc = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True)
    assert proc.returncode == 0, proc.stderr
    assert proc.stdout.strip() == "input_then_decay"


def test_to_json_records_method_initial_values_and_inputs():
    j = json.loads(json.dumps(DEFAULT_MODELS.to_json()))  # plain JSON
    motor = j["motor_neuron"]
    assert motor["kind"] == "neuron" and motor["method"] == "input_then_decay"
    assert motor["parameters"]["tau_motor"]["value"] == "9. ms"
    assert motor["parameters"]["tau_motor"]["dimensions"] == {"s": 1}
    assert motor["reset"] == DEFAULT_MODELS.motor_neuron.reset
    ca = j["astrocyte"]["initial_values"]["Ca"]
    assert ca["value"] == str(0.071006 * umolar) and ca["dimensions"] == {"m": -3, "mol": 1}
    assert j["astrocyte"]["method"] == "euler"
    assert j["interlimb_synapse"]["method"] == "input_then_decay"
    assert j["reward"]["inputs"] == ["vel_x", "omega_roll", "omega_pitch", "omega_yaw"]
    assert "method" not in j["reward"]
    assert j["pool"]["parameters"]["pool_size"]["si_value"] == 20  # an int stays an int


def test_to_json_from_json_round_trip():
    data = json.loads(json.dumps(DEFAULT_MODELS.to_json()))
    rebuilt = ModelSet.from_json(data)
    assert rebuilt == DEFAULT_MODELS
    for name, model in DEFAULT_MODELS.items():
        other = getattr(rebuilt, name)
        assert type(other) is type(model) and other.name == model.name
        assert other.statements() == model.statements()
        assert getattr(other, "method", None) == getattr(model, "method", None)
        assert getattr(other, "inputs", None) == getattr(model, "inputs", None)
        for var, value in getattr(model, "initial_values", {}).items():
            assert other.initial_values[var] == value
            assert str(other.initial_values[var]) == str(value)
        assert list(other.parameters) == list(model.parameters)
        for pname, p in model.parameters.items():
            q = other.parameters[pname]
            assert q == p and str(q.value) == str(p.value) and q.dimensions == p.dimensions
    # equality is not vacuous
    assert ModelSet.from_json(data).with_values({"tau_motor": 9.5 * ms}) != DEFAULT_MODELS
    assert rebuilt.to_json() == data
    # the rebuilt set builds the same network
    cpg = build_cpg(rebuilt, legs=("FR",))
    check_runs(cpg)


def test_from_json_names_the_culprit():
    data = DEFAULT_MODELS.to_json()
    with pytest.raises(InputError) as err:
        ModelSet.from_json({"no_such_model": data["reward"]})
    assert err.value.culprit == "no_such_model"
    with pytest.raises(InputError) as err:
        Model.from_json(data["astrocyte"] | {"kind": "glia"})
    assert err.value.culprit == "astrocyte.kind"
    entry = json.loads(json.dumps(data["astrocyte"]))
    del entry["parameters"]["tau_IP3"]["si_value"]
    with pytest.raises(InputError) as err:
        Model.from_json(entry)
    assert err.value.culprit == "astrocyte.tau_IP3"
    with pytest.raises(InputError) as err:
        NeuronModel.from_json(data["reward"])  # an expression is not a neuron model
    assert err.value.culprit == "reward.kind"


def test_contract_validation_names_model_and_attribute():
    astro = DEFAULT_MODELS.astrocyte
    with pytest.raises(InputError) as err:
        astro.with_values(tau_IP3=-1 * second)
    assert err.value.culprit == "astrocyte.tau_IP3" and "positive" in err.value.message
    with pytest.raises(InputError) as err:
        astro.replace(initial_values={"Cb": 0.1 * umolar})
    assert err.value.culprit == "astrocyte.initial_values.Cb"
    with pytest.raises(InputError) as err:
        astro.replace(initial_values={"Ca": 0.1 * mV})
    assert err.value.culprit == "astrocyte.initial_values.Ca" and "units" in err.value.message
    with pytest.raises(InputError) as err:
        astro.replace(threshold=3)
    assert err.value.culprit == "astrocyte.threshold"
    with pytest.raises(InputError) as err:
        DEFAULT_MODELS.reward.replace(inputs=("vel x",))
    assert err.value.culprit == "reward.inputs"
    with pytest.raises(InputError) as err:
        DEFAULT_MODELS.replace(astrocyte=DEFAULT_MODELS.reward)
    assert err.value.culprit == "astrocyte" and "neuron model" in err.value.message
    with pytest.raises(InputError) as err:
        DEFAULT_MODELS.replace(glia=DEFAULT_MODELS.astrocyte)
    assert err.value.culprit == "glia"


def test_every_equation_string_comments_each_variable():
    for name, model in DEFAULT_MODELS.items():
        if not isinstance(model, (NeuronModel, SynapseModel)):
            continue
        eqs = Equations(model.code)  # Brian2 accepts the comments
        lines = [line for line in model.code.splitlines() if line.strip()]
        assert len(lines) == len(eqs.names), name
        for line in lines:
            code, sep, comment = line.partition("#")
            assert sep and comment.strip(), (name, line)
    assert all(isinstance(m, (ExpressionModel, NeuronModel, SynapseModel, WorldModel))
               for _, m in DEFAULT_MODELS.items())


def test_input_then_decay_by_name_in_a_group():
    g = NeuronGroup(1, "dx/dt = -x/tau + I : volt\nI : volt/second\ntau : second",
                    method="input_then_decay", dt=1 * ms)
    g.x, g.I, g.tau = 2 * mV, 1000 * mV / second, 9 * ms
    Network(g).run(1 * ms)
    assert g.x[0] / mV == pytest.approx((2 + 1.0) * np.exp(-1 / 9), rel=1e-12)
