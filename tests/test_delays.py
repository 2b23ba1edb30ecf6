"""Inter-limb delays: the per-pair table of the inter-limb synapse model, the stages it orders
the limbs in, the authors' preset (0 ms from a lower-index to a higher-index limb), and that the
network gives exactly those delays."""

from __future__ import annotations

import itertools
import json
from pathlib import Path

import numpy as np
import pytest
from brian2 import ms

from astrocpg.errors import InputError
from astrocpg.models import DEFAULT_MODELS
from astrocpg.models.interlimb_synapse import LIMBS
from astrocpg.coupling.session import reset_trial
from astrocpg.network.build import build_cpg
from astrocpg.network.delays import limb_stages
from astrocpg.network.layout import LEGS, THIGH_POOLS
from astrocpg.studies.cli import main
from astrocpg.models.compose import model_set

VARIANTS = Path(__file__).resolve().parents[1] / "models" / "variants"
AUTHORS = VARIANTS / "interlimb_authors_delays.toml"


def _with_zero(*pairs: tuple[str, str]):
    return DEFAULT_MODELS.with_values({f"delay_{a}_{b}": 0 * ms for a, b in pairs})


def _authors():
    return model_set(models={"interlimb_synapse": AUTHORS.read_text()})


def test_the_model_and_the_layout_name_the_limbs_alike():
    assert LIMBS == LEGS


def test_stages_of_the_default_the_authors_and_a_front_before_hind_table():
    assert limb_stages(DEFAULT_MODELS, LEGS, 1 * ms) == ((0, 1, 2, 3),)
    assert limb_stages(_authors(), LEGS, 1 * ms) == ((0,), (1,), (2,), (3,))
    front_first = _with_zero(*[(a, b) for a in ("FR", "FL") for b in ("RR", "RL")])
    assert limb_stages(front_first, LEGS, 1 * ms) == ((0, 1), (2, 3))
    # the unit alone (one limb) has nothing to order
    assert limb_stages(_authors(), ("FR",), 1 * ms) == ((0,),)


def test_the_authors_file_is_the_built_in_model_with_six_delays_at_zero():
    authors = _authors().interlimb_synapse
    built_in = DEFAULT_MODELS.interlimb_synapse
    zero = {f"delay_{a}_{b}" for a, b in itertools.combinations(LIMBS, 2)}
    assert len(zero) == 6
    for name, p in built_in.parameters.items():
        expected = 0 * ms if name in zero else p.value
        assert authors.parameters[name].value == expected, name
    assert authors.model == built_in.model and authors.on_step == built_in.on_step


@pytest.mark.parametrize("values, words", [
    ({"delay_FR_FL": 2 * ms}, ["interlimb_synapse.delay_FR_FL", "0 ms or one step"]),
    ({"delay_FR_FL": -1 * ms}, ["interlimb_synapse.delay_FR_FL"]),
    ({"delay_FR_FL": 0 * ms, "delay_FL_FR": 0 * ms}, ["delay_FR_FL", "delay_FL_FR", "both 0 ms"]),
    ({"delay_FR_FL": 0 * ms}, ["delay_FR_FL is 0 ms", "neither is"]),
])
def test_a_table_no_order_of_the_limbs_can_give_is_refused(values, words):
    with pytest.raises(InputError) as e:
        build_cpg(DEFAULT_MODELS.with_values(values), n_trials=1)
    for word in words:
        assert word in str(e.value), (word, str(e.value))


def test_a_bad_delay_on_the_command_line_is_one_line_and_exit_2(capsys, tmp_path):
    out = tmp_path / "run"
    code = main(["run", "--seconds", "0.01", "--set", "delay_RR_RL=3*ms", "--no-progress",
                 "--out", str(out)])
    err = capsys.readouterr().err.strip()
    assert code == 2 and len(err.splitlines()) == 1 and "delay_RR_RL" in err, err
    assert not out.exists()


def _stepped(models, weights: np.ndarray, steps: int = 300, n_trials: int = 2):
    """Run ``steps`` 1 ms steps; per step, every pool's count (files' order) and the inter-limb
    input of every thigh pool, read at the end of the step."""
    from brian2 import NetworkOperation

    cpg = build_cpg(models, n_trials=n_trials, seed=5, interlimb_weights=weights)
    n_table, input_table = cpg.table("pool", "n"), cpg.table("pool", "I_interlimb")
    counts, inputs = [], []

    def read() -> None:
        counts.append(n_table.read().copy())
        inputs.append(input_table.read().copy())

    cpg.net.add(NetworkOperation(read, dt=1 * ms, when="end", order=100))
    cpg.net.run(steps * ms, namespace={})
    return cpg, np.array(counts), np.array(inputs)


def _thigh_columns(cpg) -> np.ndarray:
    """Pool index (within a trial, files' order) of each row/column of the inter-limb table."""
    L = cpg.layout
    return np.array([leg * 4 + THIGH_POOLS.index(p) for leg in range(L.n_legs)
                     for p in THIGH_POOLS])


@pytest.mark.parametrize("preset", ["default", "authors"])
def test_each_pair_gets_exactly_its_delay(preset):
    """The input of every thigh pool after step t is the weighted sum of its source pools' spike
    counts of step t (0 ms pairs) or t - 1 (1 ms pairs): checked exactly for every pool, trial
    and step, with a random table."""
    models = DEFAULT_MODELS if preset == "default" else _authors()
    rng = np.random.default_rng(0)
    w = rng.uniform(-0.05, 0.05, size=(8, 8)) * 1e-3  # volt, within w_min..w_max
    limb = np.arange(8) // 2
    w[limb[:, None] == limb[None, :]] = 0.0
    cpg, counts, inputs = _stepped(models, w)
    assert counts.sum() > 1000  # the pools fire
    cols = _thigh_columns(cpg)
    zero = np.array([[a != b and preset == "authors" and a < b for b in range(4)]
                     for a in range(4)])[limb][:, limb]  # (source, target) at 0 ms
    dt = 1e-3
    n = counts[:, :, cols]  # (step, trial, thigh pool)
    previous = np.concatenate([np.zeros_like(n[:1]), n[:-1]])
    expected = (np.einsum("stx,xy->sty", n, w * zero)
                + np.einsum("stx,xy->sty", previous, w * ~zero)) / dt
    np.testing.assert_allclose(inputs[:, :, cols], expected, rtol=1e-12, atol=1e-15)
    assert (zero.sum() == 24) == (preset == "authors")


def test_the_authors_limbs_integrate_in_stages_and_the_files_keep_their_numbering():
    cpg = build_cpg(_authors(), n_trials=3, seed=2)
    assert [g.name for g in cpg.motor_groups] == ["motor_FR", "motor_FL", "motor_RR", "motor_RL"]
    assert sorted(s.name for s in cpg.synapse_kinds["interlimb"]) == sorted(
        f"interlimb_{leg}" for leg in LEGS)
    # every motor neuron once, in the files' numbering
    numbers = np.concatenate([p.numbers() for p in cpg.parts("motor")])
    assert np.array_equal(np.sort(numbers), np.arange(3 * cpg.layout.motor_per_trial))
    # positions as in the one-stage network (drawn per trial from the trial's seed)
    single = build_cpg(DEFAULT_MODELS, n_trials=3, seed=2)
    np.testing.assert_array_equal(cpg.table("motor", "x_position").read(),
                                  single.table("motor", "x_position").read())
    # the weights go in and out as the same (trial, 8, 8) tables
    w = np.random.default_rng(1).uniform(-4e-5, 4e-5, size=(3, 8, 8))
    w[:, np.arange(8)[:, None] // 2 == np.arange(8)[None, :] // 2] = 0.0
    cpg.set_interlimb_weights(w)
    np.testing.assert_array_equal(cpg.interlimb_weights(), w)
    with pytest.raises(AttributeError, match="parts"):
        cpg.motor  # noqa: B018


def test_a_session_reset_of_one_trial_leaves_the_others(tmp_path):
    cpg = build_cpg(_authors(), n_trials=3, seed=2)
    cpg.net.run(30 * ms, namespace={})
    v = cpg.table("motor", "v")
    before = v.read().copy()
    assert np.all(np.abs(before).sum(axis=1) > 0)
    reset_trial(cpg, 1)
    after = v.read()
    assert np.all(after[1] == 0.0)
    np.testing.assert_array_equal(after[[0, 2]], before[[0, 2]])


def test_run_with_the_authors_preset_records_every_limb_in_the_files_numbering(capsys,
                                                                              tmp_path):
    out = tmp_path / "run"
    assert main(["run", "--seconds", "0.3", "--model", f"interlimb_synapse={AUTHORS}",
                 "--no-progress", "--out", str(out)]) == 0
    manifest = json.loads((out / "manifest.json").read_text())
    assert manifest["settings"]["models"]["interlimb_synapse"]["content"] == AUTHORS.read_text()
    import astrocpg as ac
    r = ac.load(out)
    t, i = r.spikes["motor"]
    assert np.all(np.diff(t) >= 0)
    per_limb = np.bincount(np.asarray(i) // 80, minlength=4)
    assert per_limb.shape == (4,) and np.all(per_limb > 100)
    ca = r.trace("motor_Ca")
    assert ca.values.shape[1] == 320 and np.all(np.asarray(ca.values)[-1].reshape(4, -1).max(1) > 0)


def test_the_stages_count_the_same_synaptic_events_per_spike():
    from astrocpg.studies.commands.power import synaptic_events_per_spike

    assert synaptic_events_per_spike(build_cpg(_authors(), n_trials=2, seed=3)) == \
        synaptic_events_per_spike(build_cpg(DEFAULT_MODELS, n_trials=2, seed=3))


def test_a_non_finite_value_in_a_stage_names_its_group_and_trial():
    cpg = build_cpg(_authors(), n_trials=3, seed=2)
    assert cpg.first_invalid() is None
    fl = cpg.array("motor_FL", "v")
    fl[2 * 80 + 7] = np.nan  # trial 2 of the FL stage's group (80 neurons per trial)
    found = cpg.first_invalid()
    assert (found.population, found.variable, found.trial) == ("motor_FL", "v", 2)
    assert "model motor_neuron" in str(found.error(0.1))
