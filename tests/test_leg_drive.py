"""A per-limb drive (models/variants/leg_drive_motor_neuron.toml): the network tells a
motor-neuron model that declares ``leg`` each neuron's limb, and the variant's drive scale of
one limb changes that limb's neurons only."""

from __future__ import annotations

import numpy as np
import pytest
from brian2 import SpikeMonitor, second

from astrocpg.models.compose import model_set
from astrocpg.network import build_cpg
from astrocpg.network.populations import LEGS
from astrocpg.support.shipped import resolve

VARIANT = resolve("leg_drive_motor_neuron", "model")


def _spikes(overrides: list[str], legs=LEGS, seconds: float = 0.4):
    models = model_set(overrides, models={"motor_neuron": VARIANT.read_text()})
    cpg = build_cpg(models, n_trials=1, seed=3, legs=legs)
    (motor,) = [part.obj for part in cpg.parts("motor")]
    mon = SpikeMonitor(motor)
    cpg.net.add(mon)
    cpg.net.run(seconds * second, namespace={})
    per_leg = len(motor) // len(legs)
    i, t = np.asarray(mon.i[:]), np.asarray(mon.t_[:])
    return [(i[(i // per_leg) == k], t[(i // per_leg) == k]) for k in range(len(legs))], \
        np.asarray(motor.leg[:])


def test_the_network_numbers_each_neurons_limb_in_LEGS_order():
    _, leg = _spikes([], seconds=0.001)
    per_leg = len(leg) // 4
    assert [int(x) for x in leg[::per_leg]] == [0, 1, 2, 3]
    _, leg = _spikes([], legs=("RR",), seconds=0.001)
    assert set(leg.tolist()) == {LEGS.index("RR")}


@pytest.fixture(scope="module")
def base():
    return _spikes([])[0]


@pytest.mark.slow
@pytest.mark.parametrize("leg", ["FL", "RR"])
def test_one_limbs_drive_changes_that_limb_only(leg, base):
    raised, _ = _spikes([f"drive_{leg}=1.3"])
    k = LEGS.index(leg)
    for j in range(4):
        same = (np.array_equal(base[j][0], raised[j][0])
                and np.array_equal(base[j][1], raised[j][1]))
        assert same == (j != k), (leg, LEGS[j])
    assert len(raised[k][0]) > 1.1 * len(base[k][0])  # a 30 % stronger drive: more spikes


@pytest.mark.slow
def test_all_scales_one_is_the_built_in_neurons_drive(base):
    cpg = build_cpg(model_set(), n_trials=1, seed=3)
    (motor,) = [part.obj for part in cpg.parts("motor")]
    mon = SpikeMonitor(motor)
    cpg.net.add(mon)
    cpg.net.run(0.4 * second, namespace={})
    i, t = np.asarray(mon.i[:]), np.asarray(mon.t_[:])
    per_leg = len(motor) // 4
    for k in range(4):
        mine = (i // per_leg) == k
        assert np.array_equal(base[k][0], i[mine]) and np.array_equal(base[k][1], t[mine]), k
