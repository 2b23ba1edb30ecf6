"""The world parameters (models.world, coupling.world): each acts as it says, and the defaults
leave the robot exactly as it was without them."""

from __future__ import annotations

import math

import brian2
import mujoco
import numpy as np
import pytest
from brian2.units.allunits import newton, radian

from astrocpg.coupling.assembly import build_closed_loop
from astrocpg.coupling.robot import A1Parameters, RobotLayout, build_model, reset
from astrocpg.coupling.world import World, heightfield, world_model
from astrocpg.errors import InputError
from astrocpg.models import DEFAULT_MODELS
from astrocpg.models.world import TERRAIN_FLAT_RADIUS, TERRAIN_X, TERRAIN_Y


def _world(**values) -> World:
    return World.from_models(DEFAULT_MODELS.with_values(values))


def _rollout(model: mujoco.MjModel, steps: int = 400, seed: int = 3) -> np.ndarray:
    """qpos after each of ``steps`` physics steps under the same random torques."""
    params = A1Parameters()
    layout = RobotLayout.from_model(model, params)
    data = mujoco.MjData(model)
    reset(model, data, layout)
    ctrl = np.random.default_rng(seed).uniform(-10, 10, size=(steps, model.nu))
    out = np.empty((steps, model.nq))
    for k in range(steps):
        data.ctrl[:] = ctrl[k]
        mujoco.mj_step(model, data)
        out[k] = data.qpos
    return out


def test_defaults_leave_the_robot_exactly_as_before():
    before = build_model(A1Parameters())
    now = world_model(DEFAULT_MODELS)
    assert np.array_equal(_rollout(before), _rollout(now))
    loop = build_closed_loop(DEFAULT_MODELS, n_trials=1, seed=1)
    assert "world" not in {h.name for h in loop.bridge.hooks()}  # no per-step cost


def test_default_closed_loop_trajectory_is_unchanged():
    # each built and run in turn: Brian2's random stream is seeded when a network is built
    old = build_closed_loop(DEFAULT_MODELS, n_trials=1, seed=2, robot=build_model(A1Parameters()))
    old.run(0.2)
    new = build_closed_loop(DEFAULT_MODELS, n_trials=1, seed=2)
    new.run(0.2)
    assert np.array_equal(old.bridge.qpos, new.bridge.qpos)


@pytest.mark.parametrize("slope", [0.09, -0.17])
def test_slope_tilts_the_projected_gravity(slope):
    model = world_model(DEFAULT_MODELS.with_values({"slope": slope * radian}))
    g = 9.806
    assert np.allclose(model.opt.gravity, [-g * math.sin(slope), 0.0, -g * math.cos(slope)])
    data = mujoco.MjData(model)
    reset(model, data, RobotLayout.from_model(model, A1Parameters()))
    mujoco.mj_forward(model, data)
    rot = data.xmat[1].reshape(3, 3)  # the trunk's orientation, level at reset
    projected = rot.T @ model.opt.gravity
    # uphill (slope > 0) pulls the robot back along its own -x axis
    assert projected[0] == pytest.approx(-g * math.sin(slope), abs=1e-6)
    assert projected[2] == pytest.approx(-g * math.cos(slope), abs=1e-6)
    assert np.linalg.norm(projected) == pytest.approx(g)


def test_heightfield_is_a_function_of_its_seed():
    a = heightfield(_world(terrain_height=0.03 * brian2.meter, terrain_seed=1))
    b = heightfield(_world(terrain_height=0.03 * brian2.meter, terrain_seed=1))
    c = heightfield(_world(terrain_height=0.03 * brian2.meter, terrain_seed=2))
    assert np.array_equal(a, b)
    assert not np.allclose(a, c)
    ny, nx = a.shape
    x = np.linspace(*TERRAIN_X, nx)
    y = np.linspace(*TERRAIN_Y, ny)
    far = np.hypot(x[None, :], y[:, None]) > 2 * TERRAIN_FLAT_RADIUS
    assert a[far].std() == pytest.approx(0.03, rel=0.1)  # the RMS asked for
    assert a[np.argmin(np.abs(y)), np.argmin(np.abs(x))] == 0.0  # level where the robot starts


def test_terrain_is_built_into_the_model():
    values = {"terrain_height": 0.02 * brian2.meter, "terrain_seed": 5}
    one = world_model(DEFAULT_MODELS.with_values(values))
    two = world_model(DEFAULT_MODELS.with_values(values))
    other = world_model(DEFAULT_MODELS.with_values({**values, "terrain_seed": 6}))
    assert one.nhfield == 1 and one.geom_type[0] == mujoco.mjtGeom.mjGEOM_HFIELD
    assert np.array_equal(one.hfield_data, two.hfield_data)
    assert not np.array_equal(one.hfield_data, other.hfield_data)
    # the robot stands on it for a while without diverging
    loop = build_closed_loop(DEFAULT_MODELS.with_values(values), n_trials=1, seed=1)
    loop.run(0.3)
    assert np.all(np.isfinite(loop.bridge.qpos))


def test_push_changes_the_velocity_by_force_times_duration_over_mass():
    force, duration = 400.0, 0.05
    models = DEFAULT_MODELS.with_values({"push_force": force * newton,
                                         "push_time": 0.05 * brian2.second,
                                         "push_duration": duration * brian2.second})
    # no gravity, no contact, no dry friction on the free joint: only the push acts on the body
    robot = world_model(models, A1Parameters(frictionloss_free_joint=0.0))
    robot.opt.gravity[:] = 0.0
    # the legs move with the CPG: their contacts with the ground would add forces of their own
    robot.opt.disableflags |= mujoco.mjtDisableBit.mjDSBL_CONTACT
    loop = build_closed_loop(models, n_trials=1, seed=1, robot=robot,
                             robot_params=A1Parameters(frictionloss_free_joint=0.0))
    trunk = loop.robot_layout.trunk_body
    data = loop.bridge.data[0]
    mass = mujoco.mj_getTotalmass(robot)
    loop.run(0.04)
    mujoco.mj_forward(robot, data)
    mujoco.mj_subtreeVel(robot, data)
    com_before, torso_before = data.subtree_linvel[trunk, 1], loop.bridge.torso_velocity[0, 1]
    loop.run(0.08)
    mujoco.mj_forward(robot, data)
    mujoco.mj_subtreeVel(robot, data)
    expected = force * duration / mass
    assert data.subtree_linvel[trunk, 1] - com_before == pytest.approx(expected, rel=0.05)
    assert loop.bridge.torso_velocity[0, 1] - torso_before == pytest.approx(expected, rel=0.05)
    assert data.xfrc_applied[trunk, 1] == 0.0  # over


def test_payload_changes_the_total_mass():
    base = mujoco.mj_getTotalmass(world_model(DEFAULT_MODELS))
    loaded = world_model(DEFAULT_MODELS.with_values({"payload": 3 * brian2.kilogram}))
    assert mujoco.mj_getTotalmass(loaded) == pytest.approx(base + 3.0)


def test_friction_is_the_grounds_coefficient_of_every_contact():
    model = world_model(DEFAULT_MODELS.with_values({"friction": 0.25}))
    data = mujoco.MjData(model)
    reset(model, data, RobotLayout.from_model(model, A1Parameters()))
    for _ in range(300):  # the robot drops onto the ground
        mujoco.mj_step(model, data)
    assert data.ncon > 0
    assert np.allclose(data.contact.friction[:data.ncon, 0], 0.25)


def test_torque_noise_is_seeded_and_acts():
    models = DEFAULT_MODELS.with_values({"torque_noise": 0.2})
    runs = []
    for seed in (1, 1):
        loop = build_closed_loop(models, n_trials=1, seed=seed)
        loop.run(0.15)
        runs.append(loop.bridge.qpos.copy())
    assert np.array_equal(runs[0], runs[1])
    quiet = build_closed_loop(DEFAULT_MODELS, n_trials=1, seed=1)
    quiet.run(0.15)
    assert not np.array_equal(quiet.bridge.qpos, runs[0])


@pytest.mark.parametrize("assignment, culprit", [
    ("terrain_seed=1.5", "world.terrain_seed"),
    ("payload=-1*kilogram", "world.payload"),
    ("slope=2", "world.slope"),
])
def test_bad_world_values_name_the_parameter(assignment, culprit):
    name, value = DEFAULT_MODELS.parse_assignment(assignment)
    with pytest.raises(InputError, match=culprit):
        World.from_models(DEFAULT_MODELS.with_values({name: value}))


def test_world_parameters_are_settable_and_recorded():
    name, value = DEFAULT_MODELS.parse_assignment("slope=0.09")
    models = DEFAULT_MODELS.with_values({name: value})
    assert models.owner_of("slope") == "world"
    assert models.to_json()["world"]["parameters"]["slope"]["si_value"] == pytest.approx(0.09)
