"""The batched robots: ``n_trials`` MjData of one robot model, their state in one buffer.

:class:`Robots` owns what MuJoCo holds (FlyGym's ``Fly``/``Arena`` side of its
``Simulation``): the MjData of every trial, their joint state batched as ``qpos``, ``qvel`` and
``ctrl`` views of one array (so that one reduction checks them all for NaN/inf), the torso's
read-only views, the physics step of every trial and MuJoCo's instability warnings. It knows
nothing of the CPG, the senses or the hooks: :class:`~astrocpg.coupling.bridge.Bridge` composes
it with :class:`~astrocpg.coupling.senses.Senses` and the hooks.

Hot-loop rules (the 1 ms step): raw arrays cached once, in-place writes, a Python loop over
trials (MjData) only.
"""

from __future__ import annotations

import math
from typing import Callable

import mujoco
import numpy as np

from ..errors import Diverged
from ..network import invalid
from .compiled import gather_sensors, step_all, take_robots
from .robot import RobotLayout, reset

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


class Robots:
    """``n_trials`` copies of the robot ``model`` (described by ``layout``), stepped together.

    data: the MjData of every trial; qpos, qvel, ctrl: (trials, nq / nv / nu) batched state,
    refreshed after every physics step (``ctrl`` is what :meth:`physics` sends to MuJoCo);
    qa: (4, 3) index into qpos of each leg's hip, thigh and calf; act: (4, 3) index into ctrl
    of their motors.
    """

    def __init__(self, model: mujoco.MjModel, layout: RobotLayout, n_trials: int) -> None:
        self.model, self.layout = model, layout
        B = self.n_trials = n_trials
        self.data = [mujoco.MjData(model) for _ in range(B)]
        # batched robot state, refreshed after every physics step; qpos, qvel and ctrl are views
        # of one buffer, so one reduction checks them all for NaN/inf
        nq, nv, nu = model.nq, model.nv, model.nu
        self.state = np.zeros((B, nq + nv + nu))
        self.qpos = self.state[:, :nq]
        self.qvel = self.state[:, nq:nq + nv]
        self.ctrl = self.state[:, nq + nv:]
        self._state_sum = self.state.reshape(-1).sum
        self.qa = layout.qpos_adr  # (4, 3)
        self.act = layout.actuator  # (4, 3)
        self._ctrl_lo = model.actuator_ctrlrange[layout.actuator, 0]
        self._ctrl_hi = model.actuator_ctrlrange[layout.actuator, 1]
        fq, fv = self.fq, self.fv = int(layout.free_qpos_adr), int(layout.free_dof_adr)
        # torso state: read-only views, live after every step
        self.torso = {
            "position": self.qpos[:, fq:fq + 3], "quaternion": self.qpos[:, fq + 3:fq + 7],
            "velocity": self.qvel[:, fv:fv + 3], "forward": self.qvel[:, fv],
            "angular": self.qvel[:, fv + 3:fv + 6],
        }
        for view in self.torso.values():
            view.flags.writeable = False
        # per trial, cached once: MjData, its ctrl, qpos, qvel views and warning counters
        self._mj = [(d, d.ctrl, d.qpos, d.qvel, memoryview(d.warning.number))
                    for d in self.data]
        self._touch: list[np.ndarray] | None = None  # touch_views(), made at first use
        self._touch_batch: tuple | None = None  # touch_into()'s buffer and gather
        # every trial's step in one call of compiled code where it can be built (compiled.py);
        # the same MuJoCo calls and copies as the loop in physics(), so the same results
        self._compiled = step_all(model, self.data, self.state)
        self._warned = 0  # the compiled step's report of instability warnings
        # touch_into(): a buffer of every trial's touch sensors, gathered by compiled code in
        # one call where the step is compiled and the sensors are contiguous (the built-in A1)
        touch = layout.touch_adr
        if touch is not None:
            a, k = int(touch[0]), len(touch)
            buf = np.zeros((B, k))
            gather = (gather_sensors(self.data, a, k, buf) if self._compiled is not None
                      and np.array_equal(touch, np.arange(a, a + k)) else None)
            self._touch_batch = (buf, gather)

    def touch_views(self) -> list[np.ndarray] | None:
        """Per trial, its feet's touch sensors (4,) in MjData's sensordata: live views where
        the four are contiguous (the built-in A1), else None when the robot has none."""
        touch = self.layout.touch_adr
        if touch is None:
            return None
        if self._touch is None:
            a = int(touch[0])
            if np.array_equal(touch, np.arange(a, a + len(touch))):
                self._touch = [d.sensordata[a:a + len(touch)] for d in self.data]
            else:  # scattered addresses: a copy each call (user robots)
                return [d.sensordata[touch] for d in self.data]
        return self._touch

    def touch_into(self, out: np.ndarray) -> bool:
        """Every trial's feet touch sensors, (trials, 4), written into ``out`` (a view allowed);
        False (nothing written) when the robot has none. Where the four are contiguous (the
        built-in A1) the batch is gathered by compiled code in one call (the same values as
        :meth:`touch_views`), else trial by trial."""
        if self._touch_batch is None:
            return False
        buf, gather = self._touch_batch
        if gather is None:
            for b, sensed in enumerate(self.touch_views()):
                out[b] = sensed
            return True
        gather()
        np.copyto(out, buf)
        return True

    def reset(self, b: int) -> None:
        """Reset trial ``b``'s robot to its start pose and read its state."""
        d = self.data[b]
        reset(self.model, d, self.layout)
        self.qpos[b] = d.qpos
        self.qvel[b] = d.qvel

    def physics(self) -> None:
        """One physics step of every trial with its row of :attr:`ctrl`; the new state read."""
        if self._compiled is not None:
            self._warned = self._compiled()
            return
        model, ctrl, qpos, qvel = self.model, self.ctrl, self.qpos, self.qvel
        for b, (d, d_ctrl, d_qpos, d_qvel, _) in enumerate(self._mj):
            d_ctrl[:] = ctrl[b]
            mujoco.mj_step(model, d)
            qpos[b] = d_qpos
            qvel[b] = d_qvel

    def unstable(self) -> bool:
        """Every step: did MuJoCo warn of instability in any trial, or is there NaN/inf in qpos,
        qvel or ctrl (the sum of their one buffer is not finite)? A few us at 16 trials."""
        if self._compiled is not None:
            if self._warned:
                return True
        else:
            for _, _, _, _, warn in self._mj:
                if warn[_QACC] or warn[_QPOS] or warn[_QVEL] or warn[_CTRL]:
                    return True
        return not math.isfinite(self._state_sum())

    def instability(self, t: float) -> Diverged | None:
        """What :meth:`unstable` found, as the error to raise at time ``t``: MuJoCo's warning
        (the first trial that has one), else the robot's first non-finite value; None when a
        sum of huge valid values overflowed (nothing to report)."""
        for b, (d, _, _, _, warn) in enumerate(self._mj):
            for k, (name, what, index) in INSTABILITY_WARNINGS.items():
                if warn[k]:
                    info = int(d.warning.lastinfo[k])
                    return Diverged(
                        f"MuJoCo reported {what} at {index} {info} in trial {b} at "
                        f"t = {t:.3f} s (MuJoCo resets such a robot; the run stops)",
                        culprit=f"MuJoCo {name}", t=t, trial=b)
        bad = np.argwhere(invalid(self.state))
        if not len(bad):
            return None
        b, k = (int(x) for x in bad[0])
        nq, nv = self.model.nq, self.model.nv
        which, i = (("qpos", k) if k < nq else ("qvel", k - nq) if k < nq + nv
                    else ("ctrl", k - nq - nv))
        return Diverged(f"{self.state[b, k]} in {which}[{i}] of trial {b} at "
                        f"t = {t:.3f} s", culprit=f"robot {which}", t=t, trial=b)

    def take_into(self, reward: np.ndarray, alive: np.ndarray,
                  out: dict[str, np.ndarray]) -> Callable[[int], None] | None:
        """``take(k)``: every trial's sample k (joint angles, applied torques, torso position,
        velocity and quaternion, ``reward``, ``alive``, touch sensors) into ``out``'s
        trial-major arrays ((trials, samples, ...), held sample-major:
        :meth:`Recording.allocate <astrocpg.coupling.robot_recording.Recording.allocate>`) in
        one call of compiled code; None where that cannot be (no compiled step, sensors not
        contiguous, arrays laid out otherwise): the caller copies with numpy."""
        if self._compiled is None:
            return None
        touch = None
        if self._touch_batch is not None:
            if self._touch_batch[1] is None:  # scattered sensors: gathered trial by trial
                return None
            touch = (int(self.layout.touch_adr[0]), len(self.layout.touch_adr))
        samples = {k: a.swapaxes(0, 1) for k, a in out.items()}
        return take_robots(self.data, self.state, self.model.nq, self.model.nv, self.qa,
                           self.act, self._ctrl_lo, self._ctrl_hi, self.fq, self.fv, reward,
                           alive, touch, samples)

    def joints_into(self, angles: np.ndarray, torques: np.ndarray) -> None:
        """Every trial's joint angles and applied torques, (trials, 4 legs, 3 joints), written
        into ``angles`` and ``torques`` (views allowed): :meth:`sample` without temporaries,
        for a recorder that runs every step."""
        np.take(self.qpos, self.qa, axis=1, out=angles)
        np.take(self.ctrl, self.act, axis=1, out=torques)
        np.clip(torques, self._ctrl_lo, self._ctrl_hi, out=torques)  # as applied

    def sample(self, trials: int | slice = slice(None)) -> tuple[np.ndarray, ...]:
        """Joint angles (leg, joint) rad, applied torques (leg, joint) N m, torso position and
        linear velocity (xyz, world) of ``trials`` after this step's physics."""
        return (self.qpos[trials, self.qa],
                # as applied: MuJoCo clamps ctrl to the motors' ctrlrange
                np.clip(self.ctrl[trials, self.act], self._ctrl_lo, self._ctrl_hi),
                self.torso["position"][trials], self.torso["velocity"][trials])
