"""The 1 ms coupling between the Brian2 CPG and MuJoCo: one ``network_operation`` per step.

Per step (SPEC section 1, "Coupling to the robot"), after the CPG has spiked and its torque
traces have taken this step's spikes in:

1. thigh and calf motors get their torque traces, hips get the PI torque (from the hip angles
   read after the previous physics step);
2. MuJoCo advances every trial's robot one step;
3. the new state is read: torso speed sets the background drive, thigh angles set the
   limit-position inhibition, and the reward is computed.

The bridge holds no model constant: gains, margins and the reward come from ``models``; the
robot's figures from the MJCF model. Hot-loop rules: raw arrays cached once, in-place writes,
a Python loop over trials (MjData) only, never over neurons.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Callable

import brian2
import mujoco
import numpy as np

from ..models import ModelSet
from ..network import CPG, LEGS, POOLS
from .robot import RobotLayout, reset

_THIGH, _CALF = 1, 2  # joint order within a leg: hip, thigh, calf
_FLEXOR, _EXTENSOR = POOLS.index("thigh_flexor"), POOLS.index("thigh_extensor")


@dataclass
class Recording:
    """Robot-side traces of every trial, sampled every ``stride`` steps (time axis ``t``)."""

    stride: int
    t: np.ndarray
    joint_angles: np.ndarray  # (trials, samples, 4 legs, 3 joints) rad
    torques: np.ndarray  # (trials, samples, 4, 3) N m, as applied
    torso_position: np.ndarray  # (trials, samples, 3) m, world
    torso_velocity: np.ndarray  # (trials, samples, 3) m/s, world
    reward: np.ndarray  # (trials, samples)
    alive: np.ndarray  # (trials, samples) bool
    foot_force: np.ndarray  # (trials, samples, 4) N, foot touch sensors (NaN if the model has none)

    @classmethod
    def allocate(cls, n_trials: int, n_steps: int, stride: int, dt: float) -> "Recording":
        n = (n_steps + stride - 1) // stride
        return cls(
            stride=stride,
            t=(np.arange(n) * stride + 1) * dt,
            joint_angles=np.zeros((n_trials, n, 4, 3)),
            torques=np.zeros((n_trials, n, 4, 3)),
            torso_position=np.zeros((n_trials, n, 3)),
            torso_velocity=np.zeros((n_trials, n, 3)),
            reward=np.zeros((n_trials, n)),
            alive=np.zeros((n_trials, n), dtype=bool),
            foot_force=np.full((n_trials, n, 4), np.nan),
        )


class Bridge:
    """Couples ``cpg`` (n_trials copies) to ``n_trials`` MjData of one robot model.

    Use :meth:`operation` to get the Brian2 ``NetworkOperation`` to add to the network.
    """

    def __init__(
        self,
        cpg: CPG,
        model: mujoco.MjModel,
        layout: RobotLayout,
        models: ModelSet,
        *,
        on_step: Callable[[int], None] | None = None,
        after_physics: Callable[[], None] | None = None,
    ) -> None:
        if abs(model.opt.timestep - float(cpg.dt)) > 1e-12:
            raise ValueError(
                f"robot timestep {model.opt.timestep} s differs from the network's dt {cpg.dt}"
            )
        if cpg.layout.legs != LEGS:
            raise ValueError("the closed loop needs all four legs in the CPG")
        self.cpg, self.model, self.layout, self.models = cpg, model, layout, models
        B = self.n_trials = cpg.n_trials
        self.data = [mujoco.MjData(model) for _ in range(B)]
        self.step_count = 0
        self.on_step = on_step
        self.after_physics = after_physics  # e.g. the session loop of training
        self.recording: Recording | None = None

        # cached raw views into the Brian2 state (numpy target: live arrays)
        self._torso_speed = cpg.array("pool", "torso_speed").reshape(B, 4, len(POOLS))
        self._limit = cpg.array("pool", "limit_inhibition").reshape(B, 4, len(POOLS))
        self._h = cpg.array("torque", "h").reshape(B, 4, 2)  # (trial, leg, thigh/calf)

        # model-side constants, as plain floats
        margin = float(np.asarray(models.pool.parameters["limit_margin"].value))
        ranges = layout.joint_range  # (4, 3, 2) from the robot model
        self._flexor_limit = ranges[:, _THIGH, 0] + margin  # inhibit flexor below this
        self._extensor_limit = ranges[:, _THIGH, 1] - margin  # inhibit extensor above this
        hip = models.hip_controller.parameters
        target = float(np.asarray(hip["hip_target"].value))
        # outward: +target for left legs (y > 0), -target for right legs
        self._hip_target = np.array([target if leg[1] == "L" else -target for leg in LEGS])
        self._hip_torque = models.hip_controller.compile()
        self._reward = models.reward.compile()
        self._alive = models.alive.compile()
        self.dt = float(cpg.dt)

        # batched robot state, refreshed after every physics step
        self.qpos = np.zeros((B, model.nq))
        self.qvel = np.zeros((B, model.nv))
        self.hip_integral = np.zeros((B, 4))
        self.ctrl = np.zeros((B, model.nu))
        self.reward = np.zeros(B)
        self.alive = np.ones(B, dtype=bool)
        self._qa = layout.qpos_adr  # (4, 3)
        self._ctrl_lo = model.actuator_ctrlrange[layout.actuator, 0]
        self._ctrl_hi = model.actuator_ctrlrange[layout.actuator, 1]
        self._act = layout.actuator  # (4, 3)
        self._fq = int(layout.free_qpos_adr)
        self._fv = int(layout.free_dof_adr)
        self.reset_all()

    # ---- state
    def reset_trial(self, b: int) -> None:
        """Reset one trial's robot and the bridge's per-trial state (hip integrator)."""
        reset(self.model, self.data[b], self.layout)
        self.hip_integral[b] = 0.0
        self._read(b)
        self._sense()

    def reset_all(self) -> None:
        for b in range(self.n_trials):
            reset(self.model, self.data[b], self.layout)
            self._read(b)
        self.hip_integral[:] = 0.0
        self._sense()

    def _read(self, b: int) -> None:
        d = self.data[b]
        self.qpos[b] = d.qpos
        self.qvel[b] = d.qvel

    # ---- the step
    def operation(self, when: str = "end") -> brian2.NetworkOperation:
        return brian2.NetworkOperation(self.step, dt=self.cpg.dt, when=when, order=0,
                                       name="bridge")

    def step(self) -> None:
        qa, act = self._qa, self._act
        q = self.qpos[:, qa]  # (B, 4, 3) angles after the previous physics step
        # 1. torques: traces to thigh and calf, PI to hips
        hip_error = q[:, :, 0] - self._hip_target
        self.hip_integral += hip_error * self.dt
        ctrl = self.ctrl
        ctrl[:, act[:, 0]] = self._hip_torque(error=hip_error, error_integral=self.hip_integral)
        ctrl[:, act[:, _THIGH]] = self._h[:, :, 0]
        ctrl[:, act[:, _CALF]] = self._h[:, :, 1]
        # 2. physics
        for b, d in enumerate(self.data):
            d.ctrl[:] = ctrl[b]
            mujoco.mj_step(self.model, d)
            self.qpos[b] = d.qpos
            self.qvel[b] = d.qvel
        # 3. senses for the next step, and the reward
        self._sense()
        if self.after_physics is not None:
            self.after_physics()
        if self.recording is not None:
            self._record()
        self.step_count += 1
        if self.on_step is not None:
            self.on_step(self.step_count)

    def _sense(self) -> None:
        fv, fq = self._fv, self._fq
        v = self.qvel[:, fv:fv + 3]  # free joint: linear velocity in the world frame
        omega = self.qvel[:, fv + 3:fv + 6]  # angular velocity in the torso frame (= gyro)
        speed = np.sqrt(np.einsum("ij,ij->i", v, v))
        self._torso_speed[:] = speed[:, None, None]
        thigh = self.qpos[:, self._qa[:, _THIGH]]  # (B, 4)
        self._limit[:, :, _FLEXOR] = thigh < self._flexor_limit
        self._limit[:, :, _EXTENSOR] = thigh > self._extensor_limit
        self.reward[:] = self._reward(vel_x=v[:, 0], omega_roll=omega[:, 0],
                                      omega_pitch=omega[:, 1], omega_yaw=omega[:, 2])
        # alive: z component of the torso's z axis in the world frame, from the quaternion
        qx, qy = self.qpos[:, fq + 4], self.qpos[:, fq + 5]
        self.alive[:] = self._alive(torso_z_up=1.0 - 2.0 * (qx * qx + qy * qy))

    def robot_sample(self, trials: int | slice = slice(None)) -> tuple[np.ndarray, ...]:
        """Joint angles (leg, joint) rad, applied torques (leg, joint) N m, torso position and
        linear velocity (xyz, world) of ``trials`` after this step's physics."""
        fq, fv = self._fq, self._fv
        return (self.qpos[trials, self._qa],
                # as applied: MuJoCo clamps ctrl to the motors' ctrlrange
                np.clip(self.ctrl[trials, self._act], self._ctrl_lo, self._ctrl_hi),
                self.qpos[trials, fq:fq + 3], self.qvel[trials, fv:fv + 3])

    def _record(self) -> None:
        rec = self.recording
        k, r = divmod(self.step_count, rec.stride)
        if r or k >= len(rec.t):
            return
        (rec.joint_angles[:, k], rec.torques[:, k], rec.torso_position[:, k],
         rec.torso_velocity[:, k]) = self.robot_sample()
        rec.reward[:, k] = self.reward
        rec.alive[:, k] = self.alive
        if self.layout.touch_adr is not None:
            for b, d in enumerate(self.data):
                rec.foot_force[b, k] = d.sensordata[self.layout.touch_adr]

    def start_recording(self, n_steps: int, stride: int = 1) -> Recording:
        self.recording = Recording.allocate(self.n_trials, n_steps, stride, self.dt)
        return self.recording
