"""Recording chosen training sessions, so a long training keeps its spikes and traces for
analysis without filling the disk.

A :class:`RecordPlan` says which sessions of each trial are recorded (the first, then every
``every``-th, and the last), which populations' spikes and which traces, and the stride (in
steps) of trace and robot samples. While a trial is in a recorded session, every step (after the
physics, before the session loop may end the session) its spikes are read off the populations'
``lastspike`` and, every ``stride`` steps, the traces and the robot's joint angles, applied
torques and torso position and velocity are copied into buffers allocated at the session's
start. When the session ends, the buffers go to ``on_recorded`` (which writes them). The state
of sessions in progress is part of training checkpoints, so a resumed training records the same.

Why not a run's recorders (``studies/commands/simulate.add_monitors``: Brian2's spike
monitors and :class:`~astrocpg.network.recording.TraceRecorder`): they record every trial of
the network for the whole run, while the trials of a training are in different sessions at any
step and only chosen sessions of each trial are kept; their memory would grow with the whole
training. So a run records with those (the network) and
:mod:`astrocpg.coupling.robot_recording` (the robot), a training with this recorder.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, Callable, Sequence

import numpy as np

from ..network import CPG
from ..network.populations import BUILT_IN, spike_populations, trace_sources
from .bridge import ORDER_MEASURE, Bridge

#: what a built-in network can record (RecordPlan's default)
POPULATIONS: tuple[str, ...] = spike_populations(BUILT_IN)
TRACES: tuple[str, ...] = tuple(trace_sources(BUILT_IN))


@dataclass(frozen=True, kw_only=True)
class RecordPlan:
    """What a training records.

    every: sessions 1, 1+every, 1+2*every, ... and each trial's last session are recorded.
    spikes: populations whose spikes are kept (motor, interneuron, astrocyte = adenosine
        release).
    traces: traces kept (motor_Ca, astrocyte_Ca, astrocyte_IP3, astrocyte_AG, astrocyte_ADO).
    stride: physics steps between two samples of the traces and of the robot.
    dtype: what the traces are kept as, "float32" (7 significant digits; a value beyond about
        3.4e38 is kept as inf, and the session's manifest counts them) or "float64".
    """

    every: int
    spikes: tuple[str, ...] = POPULATIONS
    traces: tuple[str, ...] = TRACES
    stride: int = 1
    dtype: str = "float32"

    def __post_init__(self) -> None:
        if self.every < 1:
            raise ValueError(f"RecordPlan.every must be at least 1, got {self.every}")
        if self.stride < 1:
            raise ValueError(f"RecordPlan.stride must be at least 1, got {self.stride}")
        if self.dtype not in ("float32", "float64"):
            raise ValueError(f"RecordPlan.dtype must be float32 or float64, got {self.dtype!r}")

    def check_names(self, rows: Any) -> None:
        """Its populations and traces are among those of ``rows`` (a network's population
        rows: which it can record depends on the populations it was built with)."""
        for p in self.spikes:
            if p not in spike_populations(rows):
                raise ValueError(f"RecordPlan.spikes: unknown population '{p}'")
        sources = trace_sources(rows)
        for t in self.traces:
            if t not in sources:
                raise ValueError(f"RecordPlan.traces: unknown trace '{t}'")

    @classmethod
    def from_dict(cls, fields: dict[str, Any]) -> "RecordPlan":
        """From ``dataclasses.asdict`` output or a study file's table (lists become tuples)."""
        return cls(**{k: tuple(v) if isinstance(v, list) else v for k, v in fields.items()})

    def records(self, session: int, n_sessions: int) -> bool:
        """Is session ``session`` (1-based) recorded?"""
        return (session - 1) % self.every == 0 or session == n_sessions


class SessionRecorder:
    """Records the sessions of ``plan`` for every trial of a training."""

    def __init__(self, cpg: CPG, bridge: Bridge, plan: RecordPlan, *, n_sessions: int,
                 max_steps: int, step_in_session: np.ndarray,
                 on_recorded: Callable[[int, int, dict[str, Any]], None]) -> None:
        plan.check_names(cpg.layout.rows)
        self.cpg, self.bridge, self.plan = cpg, bridge, plan
        self.n_sessions, self.max_steps = int(n_sessions), int(max_steps)
        self.on_recorded = on_recorded
        self._step_in_session = step_in_session  # the session loop's live counters
        B = self.n_trials = cpg.n_trials
        self.dt = float(cpg.dt)
        # (trial, element) tables in the files' order (live arrays with one stage of limbs)
        self._lastspike = {p: cpg.table(p, "lastspike") for p in plan.spikes}
        self._traces = {}
        sources = trace_sources(cpg.layout.rows)  # the network's rows, added ones too
        for name in plan.traces:
            group, var, scale, _ = sources[name]
            self._traces[name] = (cpg.table(group, var), scale)
        self._clock = cpg.clock
        self.session = np.zeros(B, dtype=np.int64)  # the session being recorded, 0 = none
        self.buffers: list[dict[str, Any] | None] = [None] * B
        self.n_samples = self.max_steps // plan.stride + 1
        for b in range(B):
            self.start(b, 1)
        # before the session loop (order ORDER_TRAINING) may end the session and reset the trial
        bridge.add_hook("after_physics", "session_recorder", self.step, order=ORDER_MEASURE)

    # ---- session boundaries
    def start(self, b: int, session: int) -> None:
        """Begin trial ``b``'s session ``session`` (recorded or not)."""
        if session > self.n_sessions or not self.plan.records(session, self.n_sessions):
            self.session[b], self.buffers[b] = 0, None
            return
        n = self.n_samples
        angles, torques, _, _ = self.bridge.robot_sample(b)
        self.session[b] = session
        self.buffers[b] = {
            "spikes": {p: [] for p in self.plan.spikes},  # (step, indices) per step with spikes
            "traces": {name: np.zeros((n, table.values.shape[1]), dtype=self.plan.dtype)
                       for name, (table, _) in self._traces.items()},
            "joint_angles": np.zeros((n,) + angles.shape),
            "torques": np.zeros((n,) + torques.shape),
            "torso_position": np.zeros((n, 3)),
            "torso_velocity": np.zeros((n, 3)),
            "torso_quaternion": np.tile([1.0, 0.0, 0.0, 0.0], (n, 1)),
            "samples": 0,
        }

    def finish(self, b: int, session_done: int) -> None:
        """Trial ``b`` has just finished session ``session_done``: hand over its recording and
        prepare the next session."""
        buf = self.buffers[b]
        if buf is not None and self.session[b] == session_done:
            self.on_recorded(b, session_done, self._arrays(buf))
        self.start(b, session_done + 1)

    def _arrays(self, buf: dict[str, Any]) -> dict[str, Any]:
        n = buf["samples"]
        # sample j is the state at the end of session step j*stride, i.e. at time (j*stride+1)*dt
        # from the session's start (the time a Brian2 StateMonitor would give it)
        t = (np.arange(n) * self.plan.stride + 1) * self.dt
        out: dict[str, Any] = {"spikes": {}, "traces": {}, "robot": {"t": t}}
        for pop, chunks in buf["spikes"].items():
            steps = np.concatenate([np.full(len(i), s) for s, i in chunks]) if chunks \
                else np.zeros(0)
            idx = np.concatenate([i for _, i in chunks]) if chunks else np.zeros(0, np.int32)
            out["spikes"][pop] = (steps * self.dt, idx.astype(np.int32))
        for name, arr in buf["traces"].items():
            out["traces"][name] = (t, arr[:n].copy())
        for key in ("joint_angles", "torques", "torso_position", "torso_velocity",
                    "torso_quaternion"):
            if key in buf:  # a checkpoint written before quaternions were recorded has none
                out["robot"][key] = buf[key][:n].copy()
        return out

    # ---- per step
    def step(self) -> None:
        active = np.flatnonzero(self.session)
        if active.size == 0:
            return
        t = self._clock.t_
        br = self.bridge
        stride = self.plan.stride
        for table in self._lastspike.values():
            table.read()
        sampled = False
        for b in active:
            buf = self.buffers[b]
            step = int(self._step_in_session[b])  # 0-based step of the session (this step)
            for pop, table in self._lastspike.items():
                fired = np.flatnonzero(table.values[b] == t)
                if fired.size:
                    buf["spikes"][pop].append((step, fired.astype(np.int32)))
            if step % stride == 0 and buf["samples"] < self.n_samples:
                k = buf["samples"]
                if not sampled:
                    for table, _ in self._traces.values():
                        table.read()
                    sampled = True
                with np.errstate(over="ignore"):  # beyond float32: inf, counted when written
                    for name, (table, scale) in self._traces.items():
                        buf["traces"][name][k] = table.values[b] * scale
                (buf["joint_angles"][k], buf["torques"][k], buf["torso_position"][k],
                 buf["torso_velocity"][k]) = br.robot_sample(b)
                if "torso_quaternion" in buf:
                    buf["torso_quaternion"][k] = br.torso_quaternion[b]
                buf["samples"] = k + 1

    # ---- checkpoints
    def extend(self, old_sessions: int, trials: Sequence[int]) -> None:
        """After a restore of a training of ``old_sessions`` sessions per trial, record as one of
        :attr:`n_sessions` does: a session in progress recorded only as the old last one is not
        recorded, and ``trials`` (reopened: :meth:`Training.reopen`) begin their next one."""
        for b in range(self.n_trials):
            s = int(self.session[b])
            if s == old_sessions and not self.plan.records(s, self.n_sessions):
                self.session[b], self.buffers[b] = 0, None
        for b in trials:
            self.start(b, old_sessions + 1)

    def state(self) -> dict[str, Any]:
        return {"session": self.session.copy(), "buffers": self.buffers}

    def restore(self, state: dict[str, Any]) -> None:
        self.session[...] = state["session"]
        self.buffers = list(state["buffers"])
