"""The project's A1 is the A1: compared with the authors' model (tests only, never copied)."""

from __future__ import annotations

import mujoco
import numpy as np
import pytest

from astrocpg.coupling.robot import (ACTUATOR_NAMES, JOINT_NAMES, A1Parameters, RobotLayout,
                                     build_model, export_xml, load_robot, reset)
from astrocpg.errors import InputError


@pytest.fixture(scope="module")
def ours(tmp_path_factory):
    path = tmp_path_factory.mktemp("a1") / "a1.xml"
    export_xml(path)  # the exported file is what users get: test that, not the in-memory model
    return mujoco.MjModel.from_xml_path(str(path))


@pytest.fixture(scope="module")
def ref(reference_a1_path):
    return mujoco.MjModel.from_xml_path(str(reference_a1_path))


def _body(model, name):
    k = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_BODY, name)
    assert k >= 0, name
    return k


def _bodies(ref):
    return [mujoco.mj_id2name(ref, mujoco.mjtObj.mjOBJ_BODY, b) for b in range(1, ref.nbody)]


def _inertia_tensor(model, b):
    """Body inertia in the body frame: R diag(I) R^T with R from body_iquat."""
    R = np.zeros(9)
    mujoco.mju_quat2Mat(R, model.body_iquat[b])
    R = R.reshape(3, 3)
    return R @ np.diag(model.body_inertia[b]) @ R.T


def test_masses_within_one_percent(ours, ref):
    assert ours.body_mass.sum() == pytest.approx(ref.body_mass.sum(), rel=0.01)
    for name in _bodies(ref):
        assert ours.body_mass[_body(ours, name)] == pytest.approx(
            ref.body_mass[_body(ref, name)], rel=0.01), name


def test_inertias_within_five_percent(ours, ref):
    for name in _bodies(ref):
        a = _inertia_tensor(ours, _body(ours, name))
        b = _inertia_tensor(ref, _body(ref, name))
        rel = np.linalg.norm(a - b) / np.linalg.norm(b)
        assert rel < 0.05, (name, rel)
        assert np.allclose(ours.body_ipos[_body(ours, name)], ref.body_ipos[_body(ref, name)],
                           atol=1e-4), name


def _feet(model, data):
    out = []
    for leg in ("FR", "FL", "RR", "RL"):
        calf = _body(model, f"{leg}_calf")
        out.append(data.xpos[calf] + data.xmat[calf].reshape(3, 3) @ np.array([0, 0, -0.2]))
    return np.array(out)


def _set_joints(model, data, q):
    for k, name in enumerate(JOINT_NAMES):
        j = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_JOINT, name)
        data.qpos[model.jnt_qposadr[j]] = q[k]


def test_foot_positions_at_random_configurations(ours, ref):
    rng = np.random.default_rng(0)
    d1, d2 = mujoco.MjData(ours), mujoco.MjData(ref)
    lo = np.array([ref.jnt_range[mujoco.mj_name2id(ref, mujoco.mjtObj.mjOBJ_JOINT, n)][0]
                   for n in JOINT_NAMES])
    hi = np.array([ref.jnt_range[mujoco.mj_name2id(ref, mujoco.mjtObj.mjOBJ_JOINT, n)][1]
                   for n in JOINT_NAMES])
    worst = 0.0
    for _ in range(20):
        q = rng.uniform(lo, hi)
        pose = np.concatenate([rng.normal(0, 0.3, 3), rng.normal(size=4)])
        pose[3:] /= np.linalg.norm(pose[3:])
        for m, d in ((ours, d1), (ref, d2)):
            d.qpos[:7] = pose
            _set_joints(m, d, q)
            mujoco.mj_kinematics(m, d)
        worst = max(worst, np.abs(_feet(ours, d1) - _feet(ref, d2)).max())
    assert worst < 0.002, f"worst foot deviation {worst * 1e3:.3f} mm"


def _actuator_order(model):
    return np.array([mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_ACTUATOR, n)
                     for n in ACTUATOR_NAMES])


def test_torso_trajectory_under_the_same_torques(ours, ref):
    """One second from the reset pose under the same smooth random torques on all 12 motors.
    The collision geometry, solver and contact settings are the same, so the trajectories should
    agree closely; contacts make them chaotic over long times, so the tolerance is 5 mm."""
    rng = np.random.default_rng(1)
    knots = rng.uniform(-10, 10, (11, 12))
    torque = np.array([np.interp(np.arange(1000) / 1000, np.linspace(0, 1, 11), knots[:, k])
                       for k in range(12)]).T
    params = A1Parameters()
    traj = []
    for m in (ours, ref):
        d = mujoco.MjData(m)
        layout = RobotLayout.from_model(m, params)
        reset(m, d, layout)
        order = _actuator_order(m)
        path = []
        for k in range(1000):
            d.ctrl[order] = torque[k]
            mujoco.mj_step(m, d)
            path.append(d.qpos[:3].copy())
        traj.append(np.array(path))
    dev = np.abs(traj[0] - traj[1]).max()
    moved = np.abs(traj[1][-1] - traj[1][0]).max()
    assert moved > 0.01  # the torques did something
    assert dev < 0.005, f"torso deviation {dev * 1e3:.2f} mm"


def test_settings_match(ours, ref):
    for name in JOINT_NAMES:
        a = mujoco.mj_name2id(ours, mujoco.mjtObj.mjOBJ_JOINT, name)
        b = mujoco.mj_name2id(ref, mujoco.mjtObj.mjOBJ_JOINT, name)
        assert np.allclose(ours.jnt_range[a], ref.jnt_range[b]), name
        da, db = ours.jnt_dofadr[a], ref.jnt_dofadr[b]
        assert ours.dof_frictionloss[da] == ref.dof_frictionloss[db], name
        assert ours.dof_damping[da] == ref.dof_damping[db]
        assert ours.dof_armature[da] == ref.dof_armature[db]
    # the free joint's dry friction (SPEC: kept as in the published runs)
    assert np.allclose(ours.dof_frictionloss[:6], ref.dof_frictionloss[:6])
    for name in ACTUATOR_NAMES:
        a = mujoco.mj_name2id(ours, mujoco.mjtObj.mjOBJ_ACTUATOR, name)
        assert np.allclose(ours.actuator_ctrlrange[a], [-33.5, 33.5])
    assert ours.opt.timestep == ref.opt.timestep == 0.001
    assert ours.opt.solver == ref.opt.solver and ours.opt.iterations == ref.opt.iterations
    assert np.allclose(ours.opt.gravity, ref.opt.gravity)


def test_layout_and_reset_pose():
    m = build_model()
    layout = RobotLayout.from_model(m)
    for leg, name in enumerate(("FR", "FL", "RR", "RL")):
        for j, joint in enumerate(("hip", "thigh", "calf")):
            jid = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_JOINT, f"{name}_{joint}_joint")
            assert layout.qpos_adr[leg, j] == m.jnt_qposadr[jid]
            assert mujoco.mj_id2name(m, mujoco.mjtObj.mjOBJ_ACTUATOR,
                                     layout.actuator[leg, j]) == f"{name}_{joint}"
    d = mujoco.MjData(m)
    reset(m, d, layout)
    assert d.qpos[2] == pytest.approx(0.35)
    assert d.qpos[layout.qpos_adr[0, 1]] == pytest.approx(0.7 * 0.6 + 0.3 * 1.4)
    assert d.qpos[layout.qpos_adr[2, 1]] == pytest.approx(0.7 * 0.7 + 0.3 * 1.5)
    assert d.qpos[layout.qpos_adr[1, 2]] == pytest.approx(0.7 * -1.6 + 0.3 * -1.0)


def test_reference_model_loads_as_a_user_robot(reference_a1_path):
    m = load_robot(reference_a1_path)
    assert m.nu == 12


@pytest.mark.parametrize("text,expected", [
    (None, "no such file"),
    ("<mujoco><worldbody>", "not a valid MJCF"),
    ("<mujoco><worldbody><body name='trunk'><freejoint/><geom size='0.1'/></body></worldbody>"
     "</mujoco>", "lacks the A1 joint"),
])
def test_load_robot_errors(tmp_path, text, expected):
    path = tmp_path / "robot.xml"
    if text is not None:
        path.write_text(text)
    from astrocpg.errors import AstrocpgError, EnvironmentFault
    with pytest.raises(AstrocpgError) as err:
        load_robot(path)
    # a missing file is the environment's (exit 1), a wrong one bad input (exit 2)
    assert isinstance(err.value, EnvironmentFault if text is None else InputError)
    assert expected in str(err.value) and "robot.xml" in str(err.value)
    assert "\n" not in str(err.value)


def test_parameters_are_validated():
    with pytest.raises(InputError, match="A1Parameters.timestep"):
        A1Parameters(timestep=-1)
    with pytest.raises(InputError, match="calf_range"):
        A1Parameters(calf_range=(-1.0, -1.6))
