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

The bridge is a thin composition (like FlyGym's ``Simulation`` of a ``Fly`` in an
``Arena``): :class:`~astrocpg.coupling.robots.Robots` holds the batched MuJoCo state and steps
it, :class:`~astrocpg.coupling.senses.Senses` reads the senses and the reward from it,
:class:`~astrocpg.coupling.robot_recording.Recording` records it; the bridge itself holds the
hip PI, the hooks, the divergence checks and the step that calls them in order.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Callable

import brian2
import mujoco
import numpy as np

from ..errors import Diverged
from ..models import ModelSet
from ..network import CPG, LEGS
from .robot import RobotLayout
from .robot_recording import Recording
from .robots import Robots
from .senses import Senses

_THIGH, _CALF = 1, 2  # joint order within a leg: hip, thigh, calf

STAGES = ("before_physics", "after_physics", "diverged")
ORDER_MEASURE = 10  # reads the step's state before the session loop may reset a trial
ORDER_TRAINING = 20  # the session loop (training.Training)
ORDER_RECORDING = 30  # Bridge.start_recording
ORDER_PROGRESS = 100  # the on_step callback


@dataclass(frozen=True)
class Hook:
    """A named function the bridge calls at ``stage`` every step (``diverged``: on divergence,
    with the error)."""

    stage: str
    name: str
    fn: Callable[..., None]
    order: float = 0



class Bridge:
    """Couples ``cpg`` (n_trials copies) to ``n_trials`` MjData of one robot model.

    Use :meth:`operation` to get the Brian2 ``NetworkOperation`` to add to the network (or
    :func:`astrocpg.coupling.assembly.build_closed_loop`, which does it all).

    on_step: called with the number of steps done after every step (a hook named ``progress``,
        order :data:`ORDER_PROGRESS`).
    check_every: steps between two checks of the CPG's state (NaN, inf or beyond 1e50; 0: never;
        the robot is checked every step).

    robots: the batched MuJoCo state (:class:`~astrocpg.coupling.robots.Robots`); ``data``,
    ``qpos``, ``qvel`` and ``ctrl`` are its arrays. senses: what is read from it each step
    (:class:`~astrocpg.coupling.senses.Senses`); ``reward`` and ``alive`` are its arrays.
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
        robots = self.robots = Robots(model, layout, B)
        # the robots' arrays under the names callers read (the same objects, not copies)
        self.data, self.qpos, self.qvel, self.ctrl = (robots.data, robots.qpos, robots.qvel,
                                                      robots.ctrl)
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

        self._h = cpg.array("torque", "h").reshape(B, 4, 2)  # (trial, leg, thigh/calf)
        senses = self.senses = Senses(cpg, robots, models)
        self.reward, self.alive = senses.reward, senses.alive  # its arrays, not copies
        self._sense = senses.sense  # bound once: the step calls it
        # the hips' PI controller (model-side constants, as plain floats)
        target = models.value("hip_target")
        # outward: +target for left legs (y > 0), -target for right legs
        self._hip_target = np.array([target if leg[1] == "L" else -target for leg in LEGS])
        self._hip_torque = models.hip_controller.compile()
        self.hip_integral = np.zeros((B, 4))
        self.dt = float(cpg.dt)
        # the step's index arrays and buffers, made once (the step allocates little): the hips'
        # qpos columns, their motors, the thighs' and calves' motors in the order of ``_h``
        act = robots.act
        self._hip_act = np.ascontiguousarray(act[:, 0])
        self._leg_act = np.ascontiguousarray(act[:, [_THIGH, _CALF]].reshape(-1))
        self._h_flat = self._h.reshape(-1)  # a view: trial, leg, (thigh, calf)
        self._hip_step = np.zeros((B, 4))
        # the same motors as flat indices into the robots' one state buffer (a 1-D fancy
        # assignment is several times cheaper than ``ctrl[:, columns] = ...``)
        state = robots.state
        first = np.arange(B)[:, None] * state.shape[1] + (model.nq + model.nv)
        self._state_flat = state.reshape(-1)  # a view (the buffer is C-contiguous)
        self._hip_qpos = np.arange(B)[:, None] * state.shape[1] + robots.qa[:, 0]  # (B, 4)
        self._hip_ctrl = (first + self._hip_act).reshape(-1)
        self._leg_ctrl = (first + self._leg_act).reshape(-1)
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
        return self.robots.act

    # ---- torso state (world frame unless noted), after the last physics step
    @property
    def torso_position(self) -> np.ndarray:
        """(trials, 3) m: the torso's (free joint's) position."""
        return self.robots.torso["position"]

    @property
    def torso_velocity(self) -> np.ndarray:
        """(trials, 3) m/s: the torso's linear velocity."""
        return self.robots.torso["velocity"]

    @property
    def torso_quaternion(self) -> np.ndarray:
        """(trials, 4): the torso's orientation, (w, x, y, z)."""
        return self.robots.torso["quaternion"]

    @property
    def forward_velocity(self) -> np.ndarray:
        """(trials,) m/s: the torso's velocity along the world x axis (forward at reset)."""
        return self.robots.torso["forward"]

    @property
    def torso_angular_velocity(self) -> np.ndarray:
        """(trials, 3) rad/s: the torso's angular velocity in the torso frame (= gyro)."""
        return self.robots.torso["angular"]

    # ---- state
    def reset_trial(self, b: int) -> None:
        """Reset one trial's robot and the bridge's per-trial state (hip integrator)."""
        self.robots.reset(b)
        self.hip_integral[b] = 0.0
        self.session_start[b] = self.step_count
        self._sense()

    def reset_all(self) -> None:
        for b in range(self.n_trials):
            self.robots.reset(b)
        self.hip_integral[:] = 0.0
        self.session_start[:] = self.step_count
        self._sense()

    # ---- the step
    def operation(self, when: str = "end") -> brian2.NetworkOperation:
        # on the network's own clock: one clock keeps Brian2 in its single-clock loop
        return brian2.NetworkOperation(self.step, clock=self.cpg.clock, when=when, order=0,
                                       name="bridge")

    def step(self) -> None:
        """One 1 ms step: torques, ``before_physics`` hooks, physics of every trial, divergence
        checks, senses and reward, ``after_physics`` hooks."""
        robots = self.robots
        # 1. torques: traces to thigh and calf, PI to hips (hip angles after the previous
        # physics step); into buffers made once, the same arithmetic as
        # ``hip_integral += (q_hip - target) * dt``
        hip_error = self._state_flat[self._hip_qpos]  # (B, 4), qpos being the first columns
        np.subtract(hip_error, self._hip_target, out=hip_error)
        np.multiply(hip_error, self.dt, out=self._hip_step)
        np.add(self.hip_integral, self._hip_step, out=self.hip_integral)
        tau = self._hip_torque(error=hip_error, error_integral=self.hip_integral)
        flat = self._state_flat
        if type(tau) is np.ndarray and tau.shape == hip_error.shape:
            flat[self._hip_ctrl] = tau.reshape(-1)
        else:  # a controller that gives a scalar or a row: broadcast as numpy does
            self.ctrl[:, self._hip_act] = tau
        flat[self._leg_ctrl] = self._h_flat
        for fn in self._run["before_physics"]:
            fn()
        # 2. physics; MuJoCo's instability warnings are read the step they happen
        robots.physics()
        self.step_count += 1
        if robots.unstable():
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
            self.diverge(found.error(self.t if t is None else t, self.cpg.layout.rows))

    def diverge(self, error: Diverged) -> None:
        """Run the ``diverged`` hooks with ``error``, then raise it."""
        for fn in self._run["diverged"]:
            fn(error)
        raise error

    def _robot_unstable(self) -> bool:
        """Every step: did MuJoCo warn of instability in any trial, or is there NaN/inf in the
        robot's state (``Robots.unstable``)?"""
        return self.robots.unstable()

    def _robot_diverged(self) -> None:
        """A MuJoCo instability warning or NaN/inf in qpos, qvel or ctrl this step: report the
        CPG's non-finite state if there is one (NaN torques come from there), else MuJoCo's
        warning, else the robot's non-finite value."""
        t = self.t
        self.check_cpg(t)
        error = self.robots.instability(t)
        if error is not None:  # None: a sum of huge valid values overflowed, nothing to report
            self.diverge(error)

    def robot_sample(self, trials: int | slice = slice(None)) -> tuple[np.ndarray, ...]:
        """Joint angles (leg, joint) rad, applied torques (leg, joint) N m, torso position and
        linear velocity (xyz, world) of ``trials`` after this step's physics."""
        return self.robots.sample(trials)

    def _record(self) -> None:
        self._take(self.step_count)

    def start_recording(self, n_steps: int, stride: int = 1) -> Recording:
        """Record the robot every ``stride`` steps for the next ``n_steps`` steps of the bridge
        (from its start: ``step_count`` 0); a hook named ``recording``."""
        self.recording = Recording.allocate(self.n_trials, n_steps, stride, self.dt)
        self._take = self.recording.taker(self.robots, self.senses)
        if "recording" not in self._hooks:
            self.add_hook("after_physics", "recording", self._record, order=ORDER_RECORDING)
        return self.recording
