"""A neuron model reads a named robot sense (models/senses.py: the list; coupling/senses.py:
how each is computed): a test-only model file binds three senses and the run records them as
the robot has them; a bad binding is refused in one line naming it; the load afferent of
docs/beyond binds the foot's force to the extensor and flexor motor neurons."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from astrocpg.coupling.senses import SENSE_READERS
from astrocpg.errors import InputError
from astrocpg.models.files import model_from_toml, model_to_toml
from astrocpg.models.senses import ROBOT_SENSES
from astrocpg.network import populations
from astrocpg.network.layout import POOLS

ROOT = Path(__file__).resolve().parents[1]
SENSOR_FILE = ROOT / "tests" / "data" / "foot_sensor.toml"
LOAD_AFFERENT = ROOT / "docs" / "beyond" / "load_afferent.toml"
LEGS = ("FR", "FL", "RR", "RL")

SENSOR = SENSOR_FILE.read_text()


def _one_line(e: pytest.ExceptionInfo) -> str:
    text = str(e.value)
    assert "\n" not in text
    return text


def test_every_listed_sense_is_computed():
    assert set(SENSE_READERS) == set(ROBOT_SENSES)
    for name, sense in ROBOT_SENSES.items():
        assert sense.per in ("leg", "trial"), name


def test_a_binding_round_trips_through_a_model_file_and_json():
    from astrocpg.models.base import Model

    model = model_from_toml(SENSOR, culprit="foot_sensor.toml")
    assert {v: b.sense for v, b in model.senses.items()} == {
        "load": "foot_force", "contact": "foot_contact", "thigh": "thigh_angle"}
    assert model_from_toml(model_to_toml(model), culprit="again") == model
    assert Model.from_json(model.to_json()) == model
    afferent = model_from_toml(LOAD_AFFERENT.read_text(), culprit="load_afferent.toml")
    assert afferent.senses["load_extensor"].only == ("thigh_extensor", "calf_extensor")
    assert model_from_toml(model_to_toml(afferent), culprit="again") == afferent


@pytest.mark.parametrize("binding, words", [
    ('load = "foot_forse"', ["foot_sensor.toml", "senses.load", "unknown robot sense "
                                                                 "'foot_forse'",
                             "did you mean foot_force"]),
    ('load = "thigh_angle"', ["senses.load", "declared in newton", "'thigh_angle' is in radian"]),
    ('weight = "foot_force"', ["senses.weight", "not a variable of the equations",
                               "'weight : newton'"]),
    ('load = { sense = "foot_force", also = 1 }', ["senses.load", "unknown keys ['also']"]),
    ('load = 3', ["senses.load", "expected a sense name"]),
])
def test_a_bad_binding_is_refused_in_one_line(binding, words):
    text = SENSOR.replace('load = "foot_force"', binding)
    with pytest.raises(InputError) as e:
        model_from_toml(text, culprit="foot_sensor.toml")
    line = _one_line(e)
    for w in words:
        assert w in line, (w, line)


def test_a_bound_variable_must_be_plain():
    text = SENSOR.replace("load : newton", "dload/dt = -load/second : newton")
    with pytest.raises(InputError) as e:
        model_from_toml(text, culprit="f")
    assert "must be a plain variable" in _one_line(e)


def test_an_unknown_sense_on_the_command_line(tmp_path):
    """`astrocpg run --model` with a misspelt sense: exit 2, one line naming it, nothing run."""
    bad = tmp_path / "bad.toml"
    bad.write_text(LOAD_AFFERENT.read_text().replace('"foot_force", only = ["thigh_extensor"',
                                                     '"foot_load", only = ["thigh_extensor"'))
    p = subprocess.run([sys.executable, "-m", "astrocpg.studies.cli", "run", "--seconds", "0.1",
                        "--model", f"motor_neuron={bad}", "--out", str(tmp_path / "out")],
                       capture_output=True, text=True, timeout=300)
    assert p.returncode == 2, p.stderr
    lines = p.stderr.strip().splitlines()
    assert len(lines) == 1 and "unknown robot sense 'foot_load'" in lines[0], p.stderr
    assert "motor_neuron" in lines[0] and "load_extensor" in lines[0]
    assert not (tmp_path / "out").exists()


def _sensor_row() -> populations.Population:
    model = model_from_toml(SENSOR, culprit=str(SENSOR_FILE))
    return populations.Population(
        name="foot_sensor", model=model, cells_per_leg=lambda pool_size: ("foot",),
        traces={"foot_sensor_load": populations.TraceSource("load", 1.0, "N", "foot load"),
                "foot_sensor_contact": populations.TraceSource("contact", 1.0, "1", "contact"),
                "foot_sensor_thigh": populations.TraceSource("thigh", 1.0, "rad", "thigh")},
        cell_noun="foot_sensor", label_meaning="the leg's foot",
        wire=lambda w: None)  # read by nothing: it only shows what the coupling writes


def test_the_run_records_the_senses_a_model_binds(tmp_path):
    """Every step the coupling writes the robot's state after the physics step into the bound
    variables; the trace sampled at the start of step k holds the robot's state after step k-1,
    which the robot recording samples at its sample k-1."""
    from astrocpg.models import DEFAULT_MODELS
    from astrocpg.studies.commands.simulate import simulate_closed_loop

    # a row made in Python (its Python wiring step) is given to the simulation as a value
    result = simulate_closed_loop(
        DEFAULT_MODELS, seconds=0.3, seed=2, n_trials=2, progress=False, spikes=(),
        traces=("foot_sensor_load", "foot_sensor_contact", "foot_sensor_thigh"),
        populations=[_sensor_row()])

    def trace(name):  # (t, trial-major cells) -> (trial, t, leg)
        t, values = result.traces[name]
        return np.asarray(values).reshape(len(t), 2, 4).transpose(1, 0, 2)

    load, contact, thigh = (trace(f"foot_sensor_{k}") for k in ("load", "contact", "thigh"))
    force = np.asarray(result.robot.foot_force)  # (trial, t, leg)
    angles = np.asarray(result.robot.joint_angles)  # (trial, t, leg, joint)
    assert load.shape == force.shape == (2, 300, 4)
    assert force.max() > 10  # the feet carry the robot
    stored = load.dtype  # traces are stored in their own dtype (float32)
    np.testing.assert_array_equal(load[:, 1:], force[:, :-1].astype(stored))
    np.testing.assert_array_equal(contact[:, 1:], (force[:, :-1] > 0).astype(stored))
    np.testing.assert_array_equal(thigh[:, 1:], angles[:, :-1, :, 1].astype(stored))
    assert 0 < contact.mean() < 1
    # at the start, the pose after the reset (standing on the ground or dropping onto it)
    assert np.all(thigh[:, 0] != 0)


def test_only_names_cells_of_the_population():
    from astrocpg.coupling.assembly import build_closed_loop
    from astrocpg.models.compose import model_set

    text = LOAD_AFFERENT.read_text().replace('only = ["thigh_extensor", "calf_extensor"]',
                                             'only = ["thigh_extensors"]')
    models = model_set(models={"motor_neuron": text})
    with pytest.raises(InputError) as e:
        build_closed_loop(models, n_trials=1, seed=1)
    line = _one_line(e)
    assert "motor_neuron.senses.load_extensor" in line and "'thigh_extensors'" in line
    assert "thigh_extensor" in line  # the cells it may name


def test_the_load_afferent_reaches_extensors_and_flexors():
    """The motor neurons of docs/beyond/load_afferent.toml read their foot's force: extensor
    cells in load_extensor, flexor cells in load_flexor, the others 0; with C_load = 0 the
    network runs exactly as the built-in model (same draws, same spikes, same robot)."""
    from brian2 import mV, second

    from astrocpg.coupling.assembly import build_closed_loop
    from astrocpg.models.compose import model_set

    def closed_loop(c_load):
        models = model_set(models={"motor_neuron": LOAD_AFFERENT.read_text()}) \
            .with_values({"C_load": c_load})
        return build_closed_loop(models, n_trials=2, seed=4)

    loop = closed_loop(0 * mV / second)
    loop.run(0.2)
    touch = loop.bridge.robots.layout.touch_adr
    force = np.array([d.sensordata[touch] for d in loop.bridge.robots.data])  # (trial, leg)
    ext = loop.cpg.table("motor", "load_extensor").read().reshape(2, 4, len(POOLS), -1)
    flex = loop.cpg.table("motor", "load_flexor").read().reshape(2, 4, len(POOLS), -1)
    for p, pool in enumerate(POOLS):
        if pool.endswith("extensor"):
            np.testing.assert_array_equal(ext[:, :, p], force[:, :, None] * np.ones(ext.shape[-1]))
            assert np.all(flex[:, :, p] == 0)
        else:
            np.testing.assert_array_equal(flex[:, :, p], force[:, :, None] * np.ones(ext.shape[-1]))
            assert np.all(ext[:, :, p] == 0)
    qpos_off = loop.bridge.qpos.copy()

    from astrocpg.models import DEFAULT_MODELS
    plain = build_closed_loop(DEFAULT_MODELS, n_trials=2, seed=4)
    plain.run(0.2)
    np.testing.assert_array_equal(plain.bridge.qpos, qpos_off)

    on = closed_loop(300 * mV / second)
    on.run(0.2)
    assert not np.array_equal(on.bridge.qpos, qpos_off)  # the afferent acts
