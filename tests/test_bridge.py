"""The bridge on its own: ordered named hooks, one step at a time (torques to ctrl, physics),
torso accessors against MjData, and which trial a divergence is charged to."""

from __future__ import annotations

import mujoco
import numpy as np
import pytest

from astrocpg.coupling.assembly import build_closed_loop
from astrocpg.coupling.bridge import STAGES
from astrocpg.errors import Diverged
from astrocpg.models import DEFAULT_MODELS


@pytest.fixture()
def loop():
    # no check_runs: bridge.step() alone needs no Brian2 code
    return build_closed_loop(DEFAULT_MODELS, n_trials=2, seed=5, check=False)


def test_hooks_run_in_order_whatever_the_registration_order(loop):
    br = loop.bridge
    calls: list[str] = []
    for stage, name, order in (("after_physics", "c", 20), ("after_physics", "a", 20),
                               ("before_physics", "z", 50), ("after_physics", "b", 5),
                               ("before_physics", "y", -1), ("after_physics", "d", 100)):
        br.add_hook(stage, name, lambda n=name: calls.append(n), order=order)
    assert [h.name for h in br.hooks("after_physics")] == ["b", "a", "c", "d"]
    assert [h.name for h in br.hooks()] == ["y", "z", "b", "a", "c", "d"]
    br.step()
    assert calls == ["y", "z", "b", "a", "c", "d"]

    with pytest.raises(ValueError, match="already has a hook named 'a'"):
        br.add_hook("before_physics", "a", lambda: None)
    with pytest.raises(ValueError, match="unknown hook stage"):
        br.add_hook("during_physics", "e", lambda: None)
    assert set(STAGES) == {"before_physics", "after_physics", "diverged"}

    removed = br.remove_hook("a")
    assert removed.name == "a" and removed.order == 20
    with pytest.raises(KeyError):
        br.remove_hook("a")
    calls.clear()
    br.step()
    assert calls == ["y", "z", "b", "c", "d"]
    br.add_hook("after_physics", "a", lambda: calls.append("a2"), order=0)  # name free again
    calls.clear()
    br.step()
    assert calls == ["y", "z", "a2", "b", "c", "d"]


def test_training_and_recorder_hooks_have_documented_orders(loop):
    from astrocpg.coupling.bridge import ORDER_MEASURE, ORDER_PROGRESS, ORDER_RECORDING, \
        ORDER_TRAINING
    from astrocpg.coupling.recorder import RecordPlan, SessionRecorder
    from astrocpg.coupling.training import Training

    br = loop.bridge
    tr = Training(loop.cpg, br, DEFAULT_MODELS, n_sessions=2)
    SessionRecorder(loop.cpg, br, RecordPlan(every=1), n_sessions=2, max_steps=tr.max_steps,
                    step_in_session=tr.step_in_session, on_recorded=lambda *a: None)
    br.start_recording(10)
    assert [(h.name, h.order) for h in br.hooks("after_physics")] == [
        ("session_recorder", ORDER_MEASURE), ("training", ORDER_TRAINING),
        ("recording", ORDER_RECORDING)]
    assert ORDER_MEASURE < ORDER_TRAINING < ORDER_RECORDING < ORDER_PROGRESS
    with pytest.raises(ValueError, match="already has a hook named 'training'"):
        Training(loop.cpg, br, DEFAULT_MODELS, n_sessions=2)  # a second session loop


def test_step_writes_torque_traces_to_ctrl_and_advances_physics(loop):
    br, cpg = loop.bridge, loop.cpg
    act = loop.robot_layout.actuator  # (leg, joint)
    h = cpg.array("torque", "h").reshape(2, 4, 2)
    rng = np.random.default_rng(0)
    q0 = br.qpos.copy()
    counts = []
    br.add_hook("after_physics", "count", lambda: counts.append(br.step_count))
    for k in range(5):
        h[:] = rng.uniform(-5, 5, size=h.shape)
        br.step()
        for b, d in enumerate(br.data):
            np.testing.assert_array_equal(d.ctrl[act[:, 1]], h[b, :, 0])  # thigh traces
            np.testing.assert_array_equal(d.ctrl[act[:, 2]], h[b, :, 1])  # calf traces
            np.testing.assert_array_equal(br.ctrl[b], d.ctrl)
            assert d.time == pytest.approx((k + 1) * br.dt)
            np.testing.assert_array_equal(br.qpos[b], d.qpos)
            np.testing.assert_array_equal(br.qvel[b], d.qvel)
    assert counts == [1, 2, 3, 4, 5] and br.step_count == 5
    assert np.abs(br.qpos - q0).max() > 1e-4  # the robots moved (they fall and kick)
    # the applied torques of robot_sample are the ctrl clipped to the motors' range
    _, torques, _, _ = br.robot_sample()
    np.testing.assert_array_equal(torques[:, :, 1], np.clip(h[:, :, 0], -33.5, 33.5))


def test_torso_accessors_agree_with_mjdata(loop):
    br, lay, model = loop.bridge, loop.robot_layout, loop.robot
    for _ in range(20):
        loop.cpg.array("torque", "h")[:] = 3.0
        br.step()
    fq, fv = lay.free_qpos_adr, lay.free_dof_adr
    vel_sensor = model.sensor_adr[mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_SENSOR,
                                                    "torso_velocity")]
    for b, d in enumerate(br.data):
        np.testing.assert_array_equal(br.torso_position[b], d.qpos[fq:fq + 3])
        np.testing.assert_array_equal(br.torso_quaternion[b], d.qpos[fq + 3:fq + 7])
        np.testing.assert_array_equal(br.torso_velocity[b], d.qvel[fv:fv + 3])
        assert br.forward_velocity[b] == d.qvel[fv]
        np.testing.assert_array_equal(br.torso_angular_velocity[b], d.qvel[fv + 3:fv + 6])
        # against MuJoCo's kinematics of the same state (mj_step leaves them one step behind)
        e = mujoco.MjData(model)
        e.qpos[:], e.qvel[:] = d.qpos, d.qvel
        mujoco.mj_forward(model, e)
        np.testing.assert_allclose(br.torso_position[b], e.xpos[lay.trunk_body], atol=1e-12)
        np.testing.assert_allclose(br.torso_quaternion[b], e.xquat[lay.trunk_body], atol=1e-12)
        np.testing.assert_allclose(br.torso_velocity[b], e.sensordata[vel_sensor:vel_sensor + 3],
                                   atol=1e-9)
    assert br.torso_position.shape == (2, 3) and br.forward_velocity.shape == (2,)
    assert abs(br.forward_velocity).max() > 0  # something moved
    with pytest.raises(ValueError):  # read-only views of the live state
        br.torso_position[0, 0] = 1.0


def test_divergence_is_charged_to_its_trial(loop, tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)  # MuJoCo writes its warnings to MUJOCO_LOG.TXT here
    br = loop.bridge
    seen: list[Diverged] = []
    br.add_hook("diverged", "seen", seen.append)
    br.step()
    # MuJoCo: trial 1's velocity beyond MuJoCo's limit -> bad qvel, reset by MuJoCo itself
    br.data[1].qvel[0] = 1e12
    with pytest.raises(Diverged) as info:
        br.step()
    e = info.value
    assert e.culprit == "MuJoCo mjWARN_BADQVEL" and e.trial == 1
    assert e.t == pytest.approx(2 * br.dt) and seen == [e]
    assert e.exit_code == 3 and "trial 1" in e.line

    fresh = build_closed_loop(DEFAULT_MODELS, n_trials=2, seed=5, check=False, check_every=3)
    br2, cpg2 = fresh.bridge, fresh.cpg
    astro = cpg2.array("astrocyte", "IP3")
    astro[cpg2.layout.thigh_pools_per_trial + 2] = np.inf  # an astrocyte of trial 1
    br2.step()
    br2.step()  # no CPG check before the 3rd step
    with pytest.raises(Diverged) as info:
        br2.step()
    e = info.value
    assert e.culprit == "astrocyte.IP3" and e.trial == 1 and e.t == pytest.approx(3 * br2.dt)
    assert "trial 1" in e.line
