"""What the CPG and the learning read from the robots after every physics step.

:class:`Senses` turns the batched robot state (:class:`~astrocpg.coupling.robots.Robots`) into
the senses of the network and the learning: the torso's speed (the pools' background drive),
the limit-position inhibition of the thigh pools (a thigh angle within ``limit_margin`` of its
joint's range), the reward (the ``reward`` model) and the alive indicator (the ``alive``
model). Every constant comes from the models and the robot model; the arrays it writes are the
network's own (numpy target: live arrays; with the limbs in stages, buffers copied into the
pool group by the tables' ``write``).

It also writes the robot senses a neuron model binds in its ``senses`` table (the list, with
units: :data:`astrocpg.models.senses.ROBOT_SENSES`; :data:`SENSE_READERS` computes each): after
every physics step and every reset, each bound sense is computed once and written into the
bound variable of every cell of its leg (or trial), or of the cells ``only`` names. With no
sense bound, nothing of this runs.
"""

from __future__ import annotations

import numpy as np

from typing import Callable

from ..errors import InputError
from ..models import ModelSet
from ..network import CPG, LEGS, POOLS, TrialTable
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


# ---- the robot senses a neuron model may bind (models/senses.ROBOT_SENSES), each written into
# ``out``: (trials, 4 legs) for a sense per leg, (trials,) per trial, SI units
def _joint_angle(j: int) -> Callable[[Robots, np.ndarray], None]:
    def read(robots: Robots, out: np.ndarray) -> None:
        np.take(robots.qpos, robots.qa[:, j], axis=1, out=out)
    return read


def _joint_velocity(j: int) -> Callable[[Robots, np.ndarray], None]:
    def read(robots: Robots, out: np.ndarray) -> None:
        np.take(robots.qvel, robots.layout.dof_adr[:, j], axis=1, out=out)
    return read


def _foot_force(robots: Robots, out: np.ndarray) -> None:
    # the feet's touch sensors, computed by mj_step (the robot model must have them)
    robots.touch_into(out)


def _foot_contact(robots: Robots, out: np.ndarray) -> None:
    _foot_force(robots, out)
    np.greater(out, 0.0, out=out)


def _torso_speed(robots: Robots, out: np.ndarray) -> None:
    v = robots.torso["velocity"]
    np.einsum("ij,ij->i", v, v, out=out)
    np.sqrt(out, out=out)


def _forward_velocity(robots: Robots, out: np.ndarray) -> None:
    out[:] = robots.torso["forward"]


def _height(robots: Robots, out: np.ndarray) -> None:
    out[:] = _torso_height(robots.qpos, robots.fq)


def _z_up(robots: Robots, out: np.ndarray) -> None:
    out[:] = _torso_z_up(robots.qpos, robots.fq)


#: How each robot sense of :data:`astrocpg.models.senses.ROBOT_SENSES` is computed
#: (``tests/test_senses.py`` checks that the two lists agree).
SENSE_READERS: dict[str, Callable[[Robots, np.ndarray], None]] = {
    "foot_force": _foot_force, "foot_contact": _foot_contact,
    "hip_angle": _joint_angle(0), "thigh_angle": _joint_angle(1), "calf_angle": _joint_angle(2),
    "hip_velocity": _joint_velocity(0), "thigh_velocity": _joint_velocity(1),
    "calf_velocity": _joint_velocity(2),
    "torso_speed": _torso_speed, "forward_velocity": _forward_velocity,
    "torso_height": _height, "torso_z_up": _z_up,
}

#: The senses read from the feet's touch sensors (a robot model may lack them).
NEEDS_TOUCH = frozenset({"foot_force", "foot_contact"})


class _BoundSense:
    """One model variable bound to a robot sense: writes the sense's buffer into the cells of
    the population's table that receive it."""

    def __init__(self, table: TrialTable, n_legs: int, cells: np.ndarray | None,
                 per_leg: bool, value: np.ndarray) -> None:
        B = value.shape[0]
        self.table, self.value = table, value
        self.view = table.values.reshape(B, n_legs, -1)
        self.cells = cells  # None: every cell of the leg
        # the sense broadcast over the cells: (B, 4, 1) per leg, (B, 1, 1) per trial
        self.source = value[:, :, None] if per_leg else value[:, None, None]

    def write(self) -> None:
        if self.cells is None:
            self.view[:] = self.source
        else:
            self.view[:, :, self.cells] = self.source
        self.table.write()


def bind_senses(cpg: CPG, robots: Robots, models: ModelSet
                ) -> tuple[list[tuple[Callable[[Robots, np.ndarray], None], np.ndarray]],
                           list[_BoundSense]]:
    """The senses the network's neuron models bind (each computed once per step into its
    buffer) and their writers. A sense the robot model cannot give, or an ``only`` label that
    is no cell of the population, is an InputError naming the binding."""
    from ..models.senses import ROBOT_SENSES

    B, n_legs = robots.n_trials, cpg.layout.n_legs
    buffers: dict[str, np.ndarray] = {}
    writers: list[_BoundSense] = []
    for pop in cpg.layout.rows:  # the rows the network was built from
        model = pop.model_in(models)
        for var, binding in (getattr(model, "senses", None) or {}).items():
            culprit = f"{model.name}.senses.{var}"
            sense = ROBOT_SENSES[binding.sense]
            if binding.sense in NEEDS_TOUCH and robots.layout.touch_adr is None:
                raise InputError(f"the robot model has no foot touch sensors "
                                 f"({', '.join(f'{leg}_foot_touch' for leg in LEGS)}), which "
                                 f"the sense '{binding.sense}' reads", culprit=culprit)
            labels = pop.labels(cpg.layout.pool_size)
            cells = None
            if binding.only:
                unknown = [x for x in binding.only if x not in labels]
                if unknown:
                    raise InputError(f"'only' names {unknown[0]!r}, not a cell of the "
                                     f"{pop.name} population (cells of a leg: "
                                     f"{', '.join(dict.fromkeys(labels))})", culprit=culprit)
                cells = np.flatnonzero(np.isin(labels, binding.only))
            per_leg = sense.per == "leg"
            if binding.sense not in buffers:
                buffers[binding.sense] = np.zeros((B, n_legs) if per_leg else (B,))
            writers.append(_BoundSense(cpg.table(pop.name, var), n_legs, cells, per_leg,
                                       buffers[binding.sense]))
    readers = [(SENSE_READERS[name], out) for name, out in buffers.items()]
    return readers, writers


class Senses:
    """The senses of ``cpg`` (torso speed, limit inhibition) and the ``reward`` and ``alive``
    (trials,) arrays, computed from ``robots`` by :meth:`sense`."""

    def __init__(self, cpg: CPG, robots: Robots, models: ModelSet) -> None:
        B = robots.n_trials
        self._qpos, self._qa, self._fq = robots.qpos, robots.qa, robots.fq
        # the thighs' angles as flat indices into the robots' one state buffer (qpos being its
        # first columns): one cheap fancy index per step
        self._state_flat = robots.state.reshape(-1)
        self._thigh_qpos = np.arange(B)[:, None] * robots.state.shape[1] + robots.qa[:, _THIGH]
        self._velocity, self._angular = robots.torso["velocity"], robots.torso["angular"]
        # cached raw views into the Brian2 state (numpy target: live arrays; with the limbs in
        # stages, buffers in trial-major order that sense copies into the pool group)
        self._speed_table = cpg.table("pool", "torso_speed")
        self._limit_table = cpg.table("pool", "limit_inhibition")
        self._torso_speed = self._speed_table.values.reshape(B, 4, len(POOLS))
        self._limit = self._limit_table.values.reshape(B, 4, len(POOLS))
        self._limit_flexor = self._limit[:, :, _FLEXOR]  # views the step writes into
        self._limit_extensor = self._limit[:, :, _EXTENSOR]
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
        self._robots = robots
        self._speed = np.zeros(B)
        self._speed_cells = self._speed[:, None, None]  # broadcast over legs and pools
        # the reward's inputs: live views of the robots' state, made once. The free joint's
        # linear velocity is in the world frame, its angular velocity in the torso frame
        v, omega = self._velocity, self._angular
        self._reward_inputs = {"vel_x": v[:, 0], "omega_roll": omega[:, 0],
                               "omega_pitch": omega[:, 1], "omega_yaw": omega[:, 2]}
        # robot senses bound by the neuron models (none by default)
        self._bound_readers, self._bound_writers = bind_senses(cpg, robots, models)

    def sense(self) -> None:
        """Read the robots' state after a physics step (or a reset) into the senses."""
        fq = self._fq
        _torso_speed(self._robots, self._speed)  # the one definition, also a bindable sense
        self._torso_speed[:] = self._speed_cells
        qpos = self._qpos
        thigh = self._state_flat[self._thigh_qpos]  # (B, 4)
        np.less(thigh, self._flexor_limit, out=self._limit_flexor)  # 1.0 where inhibited
        np.greater(thigh, self._extensor_limit, out=self._limit_extensor)
        self._speed_table.write()
        self._limit_table.write()
        self.reward[:] = self._reward(**self._reward_inputs)
        # alive: only the senses its model reads are computed
        self.alive[:] = self._alive(**{k: f(qpos, fq) for k, f in self._alive_senses})
        for read, out in self._bound_readers:
            read(self._robots, out)
        for writer in self._bound_writers:
            writer.write()
