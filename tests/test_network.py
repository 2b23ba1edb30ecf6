"""The wiring: sizes, independence of trials, the inter-limb table."""

import numpy as np
import pytest
from brian2 import mV, ms, second

from astrocpg.errors import InputError
from astrocpg.network import build_cpg, check_runs, same_limb_mask


@pytest.fixture(scope="module")
def cpg3():
    return build_cpg(n_trials=3, seed=5)


def test_sizes_per_trial(cpg3):
    L = cpg3.layout
    assert (L.motor_per_trial, L.interneurons_per_trial, L.thigh_pools_per_trial) == (320, 24, 8)
    assert len(cpg3.motor) == 3 * 320 and len(cpg3.astrocyte) == 3 * 8
    assert len(cpg3.synapses["intra_pool"]) == 3 * 16 * 20 * 19
    assert len(cpg3.synapses["pool_to_interneuron"]) == 3 * 24 * 20
    assert len(cpg3.synapses["interneuron_to_pool"]) == 3 * 24 * 20
    assert len(cpg3.synapses["interlimb"]) == 3 * (64 - 16)


def test_no_synapse_crosses_trials(cpg3):
    L = cpg3.layout
    for name, (n_pre, n_post) in {
        "intra_pool": (320, 320), "pool_to_interneuron": (320, 24),
        "interneuron_to_pool": (24, 320), "interlimb": (16, 16), "pool_activity": (320, 16),
    }.items():
        s = cpg3.synapses[name]
        assert np.array_equal(s.i[:] // n_pre, s.j[:] // n_post), name


def test_trials_have_their_own_connectivity_from_their_own_seed(cpg3):
    w = cpg3.synapses["intra_pool"].w[:] / mV
    w = w.reshape(3, -1)
    assert not np.allclose(w[0], w[1])
    # trial 2 of a batch seeded 5 is the network of seed 7
    single = build_cpg(n_trials=1, seed=7)
    assert np.allclose(single.synapses["intra_pool"].w[:] / mV, w[2])
    # distance-dependent weight within (4 mV*exp(-0.3*sqrt(3)), 4 mV]
    assert w.max() <= 4 and w.min() >= 4 * np.exp(-0.3 * np.sqrt(3))


def test_interlimb_table_roundtrip_and_same_limb_blocks(cpg3):
    rng = np.random.default_rng(0)
    table = rng.uniform(-0.05, 0.05, (3, 8, 8)) * 1e-3
    table[:, same_limb_mask(cpg3.layout)] = 0
    cpg3.set_interlimb_weights(table)
    assert np.allclose(cpg3.interlimb_weights(), table)
    bad = table[0].copy()
    bad[0, 1] = 1e-5
    with pytest.raises(InputError, match="same-limb"):
        cpg3.set_interlimb_weights(bad)


def test_interlimb_input_is_weight_times_source_spikes():
    """The summed inter-limb input of pool y is sum_x w[x, y] * n_x / dt."""
    cpg = build_cpg(n_trials=1, seed=3)
    table = np.zeros((8, 8))
    table[0, 2] = 0.05e-3  # FR flexor -> FL flexor
    table[3, 0] = -0.04e-3  # FL extensor -> FR flexor
    cpg.set_interlimb_weights(table)
    check_runs(cpg)
    n = cpg.array("pool", "n")
    I = cpg.array("pool", "I_interlimb")
    seen = []

    from brian2 import NetworkOperation

    def probe():
        # runs before the groups of the next step: I must equal sum w n of this step
        seen.append((n.copy(), I.copy()))

    cpg.net.add(NetworkOperation(probe, dt=1 * ms, when="end"))
    cpg.net.run(400 * ms, namespace={})
    counts = np.array([s[0] for s in seen])
    inputs = np.array([s[1] for s in seen])
    L = cpg.layout
    fr_flex, fr_ext = L.pool(0, 0, "thigh_flexor"), L.pool(0, 0, "thigh_extensor")
    fl_flex, fl_ext = L.pool(0, 1, "thigh_flexor"), L.pool(0, 1, "thigh_extensor")
    assert counts[:, fr_flex].sum() > 0 and counts[:, fl_ext].sum() > 0
    # the summed variable is evaluated at the start of the next step from this step's counts
    expected_fl_flex = 0.05e-3 * counts[:-1, fr_flex] / 1e-3
    expected_fr_flex = -0.04e-3 * counts[:-1, fl_ext] / 1e-3
    assert np.allclose(inputs[1:, fl_flex], expected_fl_flex)
    assert np.allclose(inputs[1:, fr_flex], expected_fr_flex)
    assert np.all(inputs[:, L.pool(0, 0, "calf_flexor")] == 0)


def test_bad_sizes_are_rejected():
    with pytest.raises(InputError, match="n_trials"):
        build_cpg(n_trials=0)
    with pytest.raises(InputError, match="unknown leg"):
        build_cpg(legs=("FX",))


def test_only_a_network_of_other_models_than_the_built_in_ones_is_checked_first():
    """``check_runs`` generates every object's code once more before the run; the built-in
    models need no check (the suite runs them), any replaced Brian2 model does."""
    from brian2 import ms, mV

    from astrocpg.models import DEFAULT_MODELS
    from astrocpg.network import built_in_models

    assert built_in_models(DEFAULT_MODELS)
    world = DEFAULT_MODELS.with_values(dict([DEFAULT_MODELS.parse_assignment("slope=0.1")]))
    assert built_in_models(world)  # the world is no Brian2 model
    assert not built_in_models(DEFAULT_MODELS.with_values({"tau_motor": 8 * ms}))
    assert not built_in_models(DEFAULT_MODELS.with_values({"eta_ADO": 0 * mV}))
    # check_runs itself decides: no code generated for the built-in models, all of it otherwise
    built_in = build_cpg(legs=("FR",))
    check_runs(built_in)
    assert built_in.motor.state_updater.codeobj is None
    changed = build_cpg(DEFAULT_MODELS.with_values({"tau_motor": 8 * ms}), legs=("FR",))
    check_runs(changed)
    assert changed.motor.state_updater.codeobj is not None
