"""The robot's side of a run, recorded: :class:`Recording` holds every trial's joints, torques,
torso, reward, alive and foot forces, sampled every ``stride`` steps, and :meth:`Recording.take`
fills one sample from the robots and the senses (the bridge's ``recording`` hook, started by
:meth:`~astrocpg.coupling.bridge.Bridge.start_recording`). The network's spikes and traces are
recorded by Brian2's spike monitors and :class:`~astrocpg.network.recording.TraceRecorder`, a
training's sessions by ``coupling/recorder.py``: this one reads MuJoCo. Its arrays are
allocated and written through once at the start, so the run's memory is taken then and not
page by page inside the step.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any, Callable

import numpy as np

if TYPE_CHECKING:
    from .robots import Robots
    from .senses import Senses


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

        def full(shape: tuple[int, ...], value: Any, dtype: type = float) -> np.ndarray:
            # held sample-major, seen trial-major: a step's sample of every trial is one
            # contiguous block (a few cache lines, one page), not a row in each trial's stretch
            # of memory; written through now: the run's memory is taken at its start, not page
            # by page inside the step
            a = np.empty((shape[1], shape[0]) + shape[2:], dtype=dtype)
            a[...] = value
            return a.swapaxes(0, 1)

        return cls(
            stride=stride,
            t=(np.arange(n) * stride + 1) * dt,
            joint_angles=full((n_trials, n, 4, 3), 0.0),
            torques=full((n_trials, n, 4, 3), 0.0),
            torso_position=full((n_trials, n, 3), 0.0),
            torso_velocity=full((n_trials, n, 3), 0.0),
            reward=full((n_trials, n), 0.0),
            alive=full((n_trials, n), False, bool),
            foot_force=full((n_trials, n, 4), np.nan),
            torso_quaternion=full((n_trials, n, 4), np.array([1.0, 0.0, 0.0, 0.0])),
        )

    def taker(self, robots: "Robots", senses: "Senses") -> Callable[[int], None]:
        """``take(step_count)``: :meth:`take` of these robots and senses, made once; every
        trial's sample written by one call of compiled code where it can be
        (:func:`~astrocpg.coupling.compiled.take_robots`: the same values), else :meth:`take`."""
        fast = robots.take_into(senses.reward, senses.alive, {
            "angles": self.joint_angles, "torques": self.torques,
            "position": self.torso_position, "velocity": self.torso_velocity,
            "quaternion": self.torso_quaternion, "reward": self.reward, "alive": self.alive,
            "touch": self.foot_force})
        if fast is None:
            return lambda step_count: self.take(step_count, robots, senses)
        stride, n = self.stride, len(self.t)

        def take(step_count: int) -> None:
            k, r = divmod(step_count - 1, stride)  # sample of the step just done
            if not r and k < n:
                fast(k)
        return take

    def take(self, step_count: int, robots: "Robots", senses: "Senses") -> None:
        """The sample of the step just done (``step_count`` steps counted), if it is one."""
        k, r = divmod(step_count - 1, self.stride)  # sample of the step just done
        if r or k >= len(self.t):
            return
        robots.joints_into(self.joint_angles[:, k], self.torques[:, k])
        torso = robots.torso
        self.torso_position[:, k] = torso["position"]
        self.torso_velocity[:, k] = torso["velocity"]
        self.torso_quaternion[:, k] = torso["quaternion"]
        self.reward[:, k] = senses.reward
        self.alive[:, k] = senses.alive
        robots.touch_into(self.foot_force[:, k])  # left NaN when the robot has no sensors
