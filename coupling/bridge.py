"""The 1 ms coupling between the Brian2 CPG and MuJoCo: one ``network_operation`` per step.

Per step (docs/model.md, "Coupling to the robot"), after the CPG has spiked and its torque
traces have taken this step's spikes in:

1. thigh and calf motors get their torque traces, hips get the PI torque (from the hip angles
   read after the previous physics step);
2. MuJoCo advances every trial's robot one step;
3. the new state is read: torso speed sets the background drive, thigh angles set the
   limit-position inhibition, and the reward is computed.

The bridge holds no model constant: gains, margins and the reward come from ``models``; the
robot's figures from the MJCF model. Hot-loop rules: raw arrays cached once, in-place writes,
a Python loop over trials (MjData) only, never over neurons.

Hooks (like FlyGym's ``Simulation.step``: pre-step, physics, post-step). Code that acts every
step registers a named hook with :meth:`Bridge.add_hook` instead of wrapping the bridge; hooks
of a stage run in ``(order, name)`` order, whatever order they were added in:

``before_physics``  after this step's torques are in :attr:`Bridge.ctrl`, before they go to
                    MuJoCo (a hook may read or change ``ctrl``)
``after_physics``   after the physics step, the divergence check and the senses (reward, alive,
                    torso speed): the state of the step just done
``diverged``        called with the :class:`~astrocpg.errors.Diverged` just before the bridge
                    raises it (e.g. training closes the trial's session as diverged)

Orders used by astrocpg (lower first): :data:`ORDER_MEASURE` 10 (read the step before the session
loop may end a session and reset the trial: ``session_recorder``, power's ``limit_count``),
:data:`ORDER_TRAINING` 20 (``training``, the session loop; ``training_diverged``),
:data:`ORDER_RECORDING` 30 (``recording``, :meth:`Bridge.start_recording`),
:data:`ORDER_PROGRESS` 100 (``progress``, the ``on_step`` callback).

Divergence (errors.Diverged, exit 3), by the one rule of :mod:`astrocpg.network.divergence`
(NaN, inf or beyond 1e50 in SI units): after every physics step, each trial's MuJoCo
instability warnings (bad qpos, qvel, qacc, ctrl, which MuJoCo raises beyond its own stricter
bound of 1e10: MuJoCo resets such a robot itself, so the counters are read the step it happens)
and NaN/inf in the robot state and torques; every ``check_every`` steps, and once after a run,
every state variable of the CPG (:meth:`CPG.first_invalid`). Run the network with
:func:`astrocpg.network.run_network` to get the ``Diverged`` out of ``Network.run``.
"""

from __future__ import annotations

import math
import dataclasses
from dataclasses import dataclass
from typing import Any, Callable

import brian2
import mujoco
import numpy as np

from ..errors import Diverged
from ..models import ModelSet
from ..network import CPG, LEGS, POOLS, invalid
from .robot import RobotLayout, reset

_THIGH, _CALF = 1, 2  # joint order within a leg: hip, thigh, calf
_FLEXOR, _EXTENSOR = POOLS.index("thigh_flexor"), POOLS.index("thigh_extensor")

STAGES = ("before_physics", "after_physics", "diverged")
ORDER_MEASURE = 10  # reads the step's state before the session loop may reset a trial
ORDER_TRAINING = 20  # the session loop (training.Training)
ORDER_RECORDING = 30  # Bridge.start_recording
ORDER_PROGRESS = 100  # the on_step callback

# MuJoCo's instability warnings: the robot's numbers left the finite range (MuJoCo resets the
# data on bad qpos, qvel and qacc; a bad ctrl is set to zero)
INSTABILITY_WARNINGS = {
    int(mujoco.mjtWarning.mjWARN_BADQACC): ("mjWARN_BADQACC", "bad qacc (acceleration)", "dof"),
    int(mujoco.mjtWarning.mjWARN_BADQPOS): ("mjWARN_BADQPOS", "bad qpos (position)", "qpos"),
    int(mujoco.mjtWarning.mjWARN_BADQVEL): ("mjWARN_BADQVEL", "bad qvel (velocity)", "dof"),
    int(mujoco.mjtWarning.mjWARN_BADCTRL): ("mjWARN_BADCTRL", "bad ctrl (NaN/inf or huge "
                                            "torque)", "actuator"),
}
_QACC, _QPOS, _QVEL, _CTRL = INSTABILITY_WARNINGS


@dataclass(frozen=True)
class Hook:
    """A named function the bridge calls at ``stage`` every step (``diverged``: on divergence,
    with the error)."""

    stage: str
    name: str
    fn: Callable[..., None]
    order: float = 0


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
    torso_quaternion: np.ndarray  # (trials, samples, 4) torso orientation (w, x, y, z), world

    def truncated(self, n_steps: int) -> "Recording":
        """The samples of the first ``n_steps`` steps only (a run that ended early)."""
        n = min(len(self.t), (n_steps + self.stride - 1) // self.stride)
        return dataclasses.replace(self, **{f.name: getattr(self, f.name)[..., :n]
                                            if f.name == "t" else getattr(self, f.name)[:, :n]
                                            for f in dataclasses.fields(self)
                                            if f.name != "stride"})

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
            torso_quaternion=np.tile([1.0, 0.0, 0.0, 0.0], (n_trials, n, 1)),
        )


class Bridge:
    """Couples ``cpg`` (n_trials copies) to ``n_trials`` MjData of one robot model.

    Use :meth:`operation` to get the Brian2 ``NetworkOperation`` to add to the network (or
    :func:`astrocpg.coupling.assembly.build_closed_loop`, which does it all).

    on_step: called with the number of steps done after every step (a hook named ``progress``,
        order :data:`ORDER_PROGRESS`).
    check_every: steps between two checks of the CPG's state (NaN, inf or beyond 1e50; 0: never;
        the robot is checked every step).
    """

    def __init__(
        self,
        cpg: CPG,
        model: mujoco.MjModel,
        layout: RobotLayout,
        models: ModelSet,
        *,
        on_step: Callable[[int], None] | None = None,
        check_every: int = 10,
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
        self.step_count = 0  # physics steps done (hooks of a step see it counted)
        # step_count at each trial's last reset: the start of its session
        self.session_start = np.zeros(B, dtype=np.int64)
        self.recording: Recording | None = None
        if int(check_every) < 0:
            raise ValueError(f"check_every must be 0 (off) or positive, got {check_every}")
        self.check_every = int(check_every)
        self._until_check = self.check_every
        self._hooks: dict[str, Hook] = {}
        self._run: dict[str, tuple[Callable[..., None], ...]] = {s: () for s in STAGES}

        # cached raw views into the Brian2 state (numpy target: live arrays; with the limbs in
        # stages, buffers in trial-major order that _sense copies into the pool group)
        self._speed_table = cpg.table("pool", "torso_speed")
        self._limit_table = cpg.table("pool", "limit_inhibition")
        self._torso_speed = self._speed_table.values.reshape(B, 4, len(POOLS))
        self._limit = self._limit_table.values.reshape(B, 4, len(POOLS))
        self._h = cpg.array("torque", "h").reshape(B, 4, 2)  # (trial, leg, thigh/calf)

        # model-side constants, as plain floats
        margin = models.value("limit_margin")
        ranges = layout.joint_range  # (4, 3, 2) from the robot model
        self._flexor_limit = ranges[:, _THIGH, 0] + margin  # inhibit flexor below this
        self._extensor_limit = ranges[:, _THIGH, 1] - margin  # inhibit extensor above this
        target = models.value("hip_target")
        # outward: +target for left legs (y > 0), -target for right legs
        self._hip_target = np.array([target if leg[1] == "L" else -target for leg in LEGS])
        self._hip_torque = models.hip_controller.compile()
        self._reward = models.reward.compile()
        self._alive = models.alive.compile()
        self._alive_inputs = tuple(models.alive.inputs)  # a model file may read fewer
        self.dt = float(cpg.dt)

        # batched robot state, refreshed after every physics step; qpos, qvel and ctrl are views
        # of one buffer, so one reduction checks them all for NaN/inf
        nq, nv, nu = model.nq, model.nv, model.nu
        self._robot_state = np.zeros((B, nq + nv + nu))
        self.qpos = self._robot_state[:, :nq]
        self.qvel = self._robot_state[:, nq:nq + nv]
        self.ctrl = self._robot_state[:, nq + nv:]
        self._robot_sum = self._robot_state.reshape(-1).sum
        self.hip_integral = np.zeros((B, 4))
        self.reward = np.zeros(B)
        self.alive = np.ones(B, dtype=bool)
        self._qa = layout.qpos_adr  # (4, 3)
        self._ctrl_lo = model.actuator_ctrlrange[layout.actuator, 0]
        self._ctrl_hi = model.actuator_ctrlrange[layout.actuator, 1]
        self._act = layout.actuator  # (4, 3)
        fq, fv = self._fq, self._fv = int(layout.free_qpos_adr), int(layout.free_dof_adr)
        # torso state: read-only views, live after every step
        self._torso = {
            "position": self.qpos[:, fq:fq + 3], "quaternion": self.qpos[:, fq + 3:fq + 7],
            "velocity": self.qvel[:, fv:fv + 3], "forward": self.qvel[:, fv],
            "angular": self.qvel[:, fv + 3:fv + 6],
        }
        for view in self._torso.values():
            view.flags.writeable = False
        # per trial, cached once: MjData, its ctrl, qpos, qvel views and warning counters
        self._mj = [(d, d.ctrl, d.qpos, d.qvel, memoryview(d.warning.number))
                    for d in self.data]
        self.reset_all()
        if on_step is not None:
            self.add_hook("after_physics", "progress", lambda: on_step(self.step_count),
                          order=ORDER_PROGRESS)

    # ---- hooks
    def add_hook(self, stage: str, name: str, fn: Callable[..., None],
                 order: float = 0) -> Hook:
        """Call ``fn()`` at ``stage`` ("before_physics", "after_physics") of every step, or
        ``fn(error)`` when the run diverges ("diverged"). Hooks of a stage run in ``(order,
        name)`` order. Names are unique across stages: a name in use is a ``ValueError``."""
        if stage not in STAGES:
            raise ValueError(f"unknown hook stage '{stage}' (stages: {', '.join(STAGES)})")
        if name in self._hooks:
            raise ValueError(f"the bridge already has a hook named '{name}' "
                             f"({self._hooks[name].stage}); remove it first")
        if not callable(fn):
            raise ValueError(f"hook '{name}': {fn!r} is not callable")
        hook = self._hooks[name] = Hook(stage=stage, name=name, fn=fn, order=order)
        self._rebuild_hooks()
        return hook

    def remove_hook(self, name: str) -> Hook:
        """Remove the hook ``name`` (a ``KeyError`` if there is none) and return it."""
        try:
            hook = self._hooks.pop(name)
        except KeyError:
            raise KeyError(f"the bridge has no hook named '{name}'") from None
        self._rebuild_hooks()
        return hook

    def hooks(self, stage: str | None = None) -> tuple[Hook, ...]:
        """The hooks of ``stage`` (all stages: None), in the order they run."""
        return tuple(sorted((h for h in self._hooks.values() if stage in (None, h.stage)),
                            key=lambda h: (STAGES.index(h.stage), h.order, h.name)))

    def _rebuild_hooks(self) -> None:
        # the step loops over these precomputed tuples only
        self._run = {s: tuple(h.fn for h in self.hooks(s)) for s in STAGES}

    @property
    def actuators(self) -> np.ndarray:
        """(4, 3) index into :attr:`ctrl` of each leg's hip, thigh and calf motor."""
        return self._act

    # ---- torso state (world frame unless noted), after the last physics step
    @property
    def torso_position(self) -> np.ndarray:
        """(trials, 3) m: the torso's (free joint's) position."""
        return self._torso["position"]

    @property
    def torso_velocity(self) -> np.ndarray:
        """(trials, 3) m/s: the torso's linear velocity."""
        return self._torso["velocity"]

    @property
    def torso_quaternion(self) -> np.ndarray:
        """(trials, 4): the torso's orientation, (w, x, y, z)."""
        return self._torso["quaternion"]

    @property
    def forward_velocity(self) -> np.ndarray:
        """(trials,) m/s: the torso's velocity along the world x axis (forward at reset)."""
        return self._torso["forward"]

    @property
    def torso_angular_velocity(self) -> np.ndarray:
        """(trials, 3) rad/s: the torso's angular velocity in the torso frame (= gyro)."""
        return self._torso["angular"]

    # ---- state
    def reset_trial(self, b: int) -> None:
        """Reset one trial's robot and the bridge's per-trial state (hip integrator)."""
        reset(self.model, self.data[b], self.layout)
        self.hip_integral[b] = 0.0
        self.session_start[b] = self.step_count
        self._read(b)
        self._sense()

    def reset_all(self) -> None:
        for b in range(self.n_trials):
            reset(self.model, self.data[b], self.layout)
            self._read(b)
        self.hip_integral[:] = 0.0
        self.session_start[:] = self.step_count
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
        """One 1 ms step: torques, ``before_physics`` hooks, physics of every trial, divergence
        checks, senses and reward, ``after_physics`` hooks."""
        qa, act = self._qa, self._act
        q = self.qpos[:, qa]  # (B, 4, 3) angles after the previous physics step
        # 1. torques: traces to thigh and calf, PI to hips
        hip_error = q[:, :, 0] - self._hip_target
        self.hip_integral += hip_error * self.dt
        ctrl = self.ctrl
        ctrl[:, act[:, 0]] = self._hip_torque(error=hip_error, error_integral=self.hip_integral)
        ctrl[:, act[:, _THIGH]] = self._h[:, :, 0]
        ctrl[:, act[:, _CALF]] = self._h[:, :, 1]
        for fn in self._run["before_physics"]:
            fn()
        # 2. physics; MuJoCo's instability warnings are read the step they happen
        model, qpos, qvel = self.model, self.qpos, self.qvel
        for b, (d, d_ctrl, d_qpos, d_qvel, _) in enumerate(self._mj):
            d_ctrl[:] = ctrl[b]
            mujoco.mj_step(model, d)
            qpos[b] = d_qpos
            qvel[b] = d_qvel
        self.step_count += 1
        if self._robot_unstable():
            self._robot_diverged()
        if self.check_every:
            self._until_check -= 1
            if not self._until_check:
                self._until_check = self.check_every
                self.check_cpg()
        # 3. senses for the next step, and the reward
        self._sense()
        for fn in self._run["after_physics"]:
            fn()

    # ---- divergence
    @property
    def t(self) -> float:
        """Simulated time (s) at the end of the last physics step: ``step_count * dt`` (the
        network's time after that step, the bridge being in the network from its start)."""
        return self.step_count * self.dt

    def check_cpg(self, t: float | None = None, full: bool = False) -> None:
        """Raise :class:`Diverged` (through :meth:`diverge`) if any CPG state is invalid (NaN,
        inf or beyond 1e50: :meth:`CPG.first_invalid`; ``full``: constants too, e.g. after a
        run). ``t``: the time to report (default: the end of the step in progress)."""
        found = self.cpg.first_invalid(full)
        if found is not None:
            self.diverge(found.error(self.t if t is None else t))

    def diverge(self, error: Diverged) -> None:
        """Run the ``diverged`` hooks with ``error``, then raise it."""
        for fn in self._run["diverged"]:
            fn(error)
        raise error

    def _robot_unstable(self) -> bool:
        """Every step: did MuJoCo warn of instability in any trial, or is there NaN/inf in qpos,
        qvel or ctrl (the sum of their one buffer is not finite)? A few us at 16 trials."""
        for _, _, _, _, warn in self._mj:
            if warn[_QACC] or warn[_QPOS] or warn[_QVEL] or warn[_CTRL]:
                return True
        return not math.isfinite(self._robot_sum())

    def _robot_diverged(self) -> None:
        """A MuJoCo instability warning or NaN/inf in qpos, qvel or ctrl this step: report the
        CPG's non-finite state if there is one (NaN torques come from there), else MuJoCo's
        warning, else the robot's non-finite value."""
        t = self.t
        self.check_cpg(t)
        for b, (d, _, _, _, warn) in enumerate(self._mj):
            for k, (name, what, index) in INSTABILITY_WARNINGS.items():
                if warn[k]:
                    info = int(d.warning.lastinfo[k])
                    self.diverge(Diverged(
                        f"MuJoCo reported {what} at {index} {info} in trial {b} at "
                        f"t = {t:.3f} s (MuJoCo resets such a robot; the run stops)",
                        culprit=f"MuJoCo {name}", t=t, trial=b))
        bad = np.argwhere(invalid(self._robot_state))
        if not len(bad):  # a sum of huge valid values overflowed: nothing to report
            return
        b, k = (int(x) for x in bad[0])
        nq, nv = self.model.nq, self.model.nv
        which, i = (("qpos", k) if k < nq else ("qvel", k - nq) if k < nq + nv
                    else ("ctrl", k - nq - nv))
        self.diverge(Diverged(f"{self._robot_state[b, k]} in {which}[{i}] of trial {b} at "
                              f"t = {t:.3f} s", culprit=f"robot {which}", t=t, trial=b))

    def _sense(self) -> None:
        fq = self._fq
        v = self._torso["velocity"]  # free joint: linear velocity in the world frame
        omega = self._torso["angular"]  # angular velocity in the torso frame (= gyro)
        speed = np.sqrt(np.einsum("ij,ij->i", v, v))
        self._torso_speed[:] = speed[:, None, None]
        thigh = self.qpos[:, self._qa[:, _THIGH]]  # (B, 4)
        self._limit[:, :, _FLEXOR] = thigh < self._flexor_limit
        self._limit[:, :, _EXTENSOR] = thigh > self._extensor_limit
        self._speed_table.write()
        self._limit_table.write()
        self.reward[:] = self._reward(vel_x=v[:, 0], omega_roll=omega[:, 0],
                                      omega_pitch=omega[:, 1], omega_yaw=omega[:, 2])
        # alive: z component of the torso's z axis in the world frame, from the quaternion,
        # and the height of the torso's centre above the ground (z = 0)
        qx, qy = self.qpos[:, fq + 4], self.qpos[:, fq + 5]
        senses = {"torso_z_up": 1.0 - 2.0 * (qx * qx + qy * qy),
                  "torso_height": self.qpos[:, fq + 2]}
        self.alive[:] = self._alive(**{k: senses[k] for k in self._alive_inputs})

    def robot_sample(self, trials: int | slice = slice(None)) -> tuple[np.ndarray, ...]:
        """Joint angles (leg, joint) rad, applied torques (leg, joint) N m, torso position and
        linear velocity (xyz, world) of ``trials`` after this step's physics."""
        return (self.qpos[trials, self._qa],
                # as applied: MuJoCo clamps ctrl to the motors' ctrlrange
                np.clip(self.ctrl[trials, self._act], self._ctrl_lo, self._ctrl_hi),
                self.torso_position[trials], self.torso_velocity[trials])

    def _record(self) -> None:
        rec = self.recording
        k, r = divmod(self.step_count - 1, rec.stride)  # sample of the step just done
        if r or k >= len(rec.t):
            return
        (rec.joint_angles[:, k], rec.torques[:, k], rec.torso_position[:, k],
         rec.torso_velocity[:, k]) = self.robot_sample()
        rec.torso_quaternion[:, k] = self.torso_quaternion
        rec.reward[:, k] = self.reward
        rec.alive[:, k] = self.alive
        if self.layout.touch_adr is not None:
            for b, d in enumerate(self.data):
                rec.foot_force[b, k] = d.sensordata[self.layout.touch_adr]

    def start_recording(self, n_steps: int, stride: int = 1) -> Recording:
        """Record the robot every ``stride`` steps for the next ``n_steps`` steps of the bridge
        (from its start: ``step_count`` 0); a hook named ``recording``."""
        self.recording = Recording.allocate(self.n_trials, n_steps, stride, self.dt)
        if "recording" not in self._hooks:
            self.add_hook("after_physics", "recording", self._record, order=ORDER_RECORDING)
        return self.recording
