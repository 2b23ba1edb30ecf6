"""The model contract: tables complete, validation names the culprit, integration as the paper."""

import numpy as np
import pytest
from brian2 import NeuronGroup, Network, ms, mV, second

from astrocpg.errors import InputError
from astrocpg.models import DEFAULT_MODELS, ModelSet
from astrocpg.models.integration import input_then_decay
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
    with pytest.raises(InputError, match="motor_neuron: equation string is invalid"):
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
    with pytest.raises(InputError, match="unknown model parameter 'tau_motr'"):
        DEFAULT_MODELS.with_values({"tau_motr": 9 * ms})
    with pytest.raises(InputError, match="tau_motor.*units"):
        DEFAULT_MODELS.parse_assignment("tau_motor=9")
    with pytest.raises(InputError, match="motor_neuron: parameter 'tau_motor'.*must be positive"):
        DEFAULT_MODELS.with_values({"tau_motor": -9 * ms})
    with pytest.raises(InputError, match="--set tau_ADO: must be positive"):
        DEFAULT_MODELS.parse_assignment("tau_ADO=0*second")
    with pytest.raises(InputError, match="astrocyte: parameter 'tau_ADO'.*must be positive"):
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
