"""What the CPG and the learning read from the robots after every physics step.

:class:`Senses` turns the batched robot state (:class:`~astrocpg.coupling.robots.Robots`) into
the senses of the network and the learning: the torso's speed (the pools' background drive),
the limit-position inhibition of the thigh pools (a thigh angle within ``limit_margin`` of its
joint's range), the reward (the ``reward`` model) and the alive indicator (the ``alive``
model). Every constant comes from the models and the robot model; the arrays it writes are the
network's own (numpy target: live arrays; with the limbs in stages, buffers copied into the
pool group by the tables' ``write``).
"""

from __future__ import annotations

import numpy as np

from ..models import ModelSet
from ..network import CPG, POOLS
from .robots import Robots

_THIGH = 1  # joint order within a leg: hip, thigh, calf
_FLEXOR, _EXTENSOR = POOLS.index("thigh_flexor"), POOLS.index("thigh_extensor")


def _torso_z_up(qpos: np.ndarray, fq: int) -> np.ndarray:
    """The z component of the torso's z axis in the world frame, from its quaternion."""
    qx, qy = qpos[:, fq + 4], qpos[:, fq + 5]
    return 1.0 - 2.0 * (qx * qx + qy * qy)


def _torso_height(qpos: np.ndarray, fq: int) -> np.ndarray:
    """The height of the torso's centre above the ground plane (z = 0), m."""
    return qpos[:, fq + 2]


#: What the robot offers an alive model, by the input names of models/alive.SENSES.
ALIVE_SENSES = {"torso_z_up": _torso_z_up, "torso_height": _torso_height}


class Senses:
    """The senses of ``cpg`` (torso speed, limit inhibition) and the ``reward`` and ``alive``
    (trials,) arrays, computed from ``robots`` by :meth:`sense`."""

    def __init__(self, cpg: CPG, robots: Robots, models: ModelSet) -> None:
        B = robots.n_trials
        self._qpos, self._qa, self._fq = robots.qpos, robots.qa, robots.fq
        self._velocity, self._angular = robots.torso["velocity"], robots.torso["angular"]
        # cached raw views into the Brian2 state (numpy target: live arrays; with the limbs in
        # stages, buffers in trial-major order that sense copies into the pool group)
        self._speed_table = cpg.table("pool", "torso_speed")
        self._limit_table = cpg.table("pool", "limit_inhibition")
        self._torso_speed = self._speed_table.values.reshape(B, 4, len(POOLS))
        self._limit = self._limit_table.values.reshape(B, 4, len(POOLS))
        # model-side constants, as plain floats
        margin = models.value("limit_margin")
        ranges = robots.layout.joint_range  # (4, 3, 2) from the robot model
        self._flexor_limit = ranges[:, _THIGH, 0] + margin  # inhibit flexor below this
        self._extensor_limit = ranges[:, _THIGH, 1] - margin  # inhibit extensor above this
        self._reward = models.reward.compile()
        self._alive = models.alive.compile()
        # the senses the alive model reads (its interface, models/alive.SENSES, lists those
        # it may: a model file naming another is refused when it is loaded)
        self._alive_senses = tuple((k, ALIVE_SENSES[k]) for k in models.alive.inputs)
        self.reward = np.zeros(B)
        self.alive = np.ones(B, dtype=bool)

    def sense(self) -> None:
        """Read the robots' state after a physics step (or a reset) into the senses."""
        fq = self._fq
        v = self._velocity  # free joint: linear velocity in the world frame
        omega = self._angular  # angular velocity in the torso frame (= gyro)
        speed = np.sqrt(np.einsum("ij,ij->i", v, v))
        self._torso_speed[:] = speed[:, None, None]
        qpos = self._qpos
        thigh = qpos[:, self._qa[:, _THIGH]]  # (B, 4)
        self._limit[:, :, _FLEXOR] = thigh < self._flexor_limit
        self._limit[:, :, _EXTENSOR] = thigh > self._extensor_limit
        self._speed_table.write()
        self._limit_table.write()
        self.reward[:] = self._reward(vel_x=v[:, 0], omega_roll=omega[:, 0],
                                      omega_pitch=omega[:, 1], omega_yaw=omega[:, 2])
        # alive: only the senses its model reads are computed
        self.alive[:] = self._alive(**{k: f(qpos, fq) for k, f in self._alive_senses})
