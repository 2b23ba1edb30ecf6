"""The one-process training: :class:`Trainer` builds the network, robot, bridge and session
loop, runs them, writes the training's files and its checkpoint at session ends (spaced by
their cost: :data:`CHECKPOINT_SPACING`), and restores or extends a checkpoint's training;
:class:`TrainingStopped` is a run that ended before every session was done."""

from __future__ import annotations

import dataclasses
import math
import time
import warnings
from pathlib import Path
from typing import Any, Callable

import mujoco
import numpy as np
from brian2 import Network, NetworkOperation, second

from ...coupling.assembly import build_closed_loop
from ..settings.populations import population_table
from ...coupling.recorder import RecordPlan, SessionRecorder
from ...coupling.training import Training
from ...errors import Diverged, InputError
from ...models import ModelSet
from ...network import run_network
from ...network.recording import overflow_words, overflowed
from ..outputs.checkpoint import CHECKPOINT
from ..outputs.folder import remove_own
from ..outputs.writing import save_npz, save_spikes_and_traces, write_manifest
from ..runtime.progress import Bar as tqdm  # warnings wait until the bar closes
from ..settings import TrainSettings
from .train_files import write_training_files
from .train_state import (CLOCK, local_random_state, memory_from_state, memory_state,
                          portable_random_state, rename_clocks, same_codegen, write_payload)

# Writing the outputs and the checkpoint costs time that grows with the sessions done (20 trials
# x 400 sessions: about 0.2 s a write, and with 20 trials a session ends about twice per
# simulated second). So after a write the next one waits CHECKPOINT_SPACING times as long as it
# took: at most 1 / (1 + CHECKPOINT_SPACING) of the wall time goes to writing, a small training
# still writes at about every session end, the first session end and the last are always written.
CHECKPOINT_SPACING = 49.0


class TrainingStopped(RuntimeError):
    """The simulation ended before every session was done (e.g. Ctrl-C)."""

    def __init__(self, done: int, total: int) -> None:
        super().__init__(f"stopped after {done} of {total} sessions (interrupted)")
        self.done, self.total = done, total


class Trainer:
    """Builds the network, robot, bridge and session loop; runs; checkpoints; resumes."""

    def __init__(self, models: ModelSet, settings: TrainSettings, out: Path,
                 progress: bool = True, record: RecordPlan | None = None,
                 trial_offset: int = 0, folder: Path | None = None) -> None:
        self.settings, self.out = settings, out
        # a batch of a training split over processes (train_batched.py): its trials are
        # trials trial_offset... of the training in ``folder``, where its recordings go
        self.trial_offset, self.folder = int(trial_offset), folder if folder is not None else out
        self.record = record
        if not settings.astrocytes:
            models = models.with_values({"astrocyte_regulation": 0.0})
        self.models = models
        # the network it trains: the built-in populations and those the training added
        loop = build_closed_loop(models, n_trials=settings.n_trials, seed=settings.seed,
                                 populations=population_table(settings.populations))
        self.robot, self.layout, self.cpg, self.bridge = (loop.robot, loop.robot_layout,
                                                          loop.cpg, loop.bridge)
        self.training = Training(self.cpg, self.bridge, models, n_sessions=settings.n_sessions,
                                 on_session=self._on_session)
        self.recorder = None
        # recorded session folder -> the traces that overflowed float32 there
        self.trace_overflow: dict[str, dict[str, Any]] = {}
        if record is not None:
            self.recorder = SessionRecorder(
                self.cpg, self.bridge, record, n_sessions=settings.n_sessions,
                max_steps=self.training.max_steps,
                step_in_session=self.training.step_in_session, on_recorded=self._write_recording)
        # after the weight update of the step (interlimb_learning, order 10)
        self.cpg.net.add(NetworkOperation(self._maybe_checkpoint, clock=self.cpg.clock, when="end",
                                          order=20, name="checkpoint"))
        self._pending = False
        self._next_checkpoint = -math.inf  # time.monotonic() from when the next write may come
        self.on_checkpoint: Callable[[], None] | None = None
        self.progress = progress
        self.bar: Any = None  # shown from the start of the run (not while a refusal may come)

    # ---- during the run
    def _on_session(self, training: Training, trial: int) -> None:
        self._pending = True
        if self.recorder is not None:
            self.recorder.finish(trial, int(training.sessions_done[trial]))
        row = training.memory.rows[-1]
        self.bar.update(1)
        recent = training.memory.rows[-10 * self.settings.n_trials:]
        self.bar.set_postfix(speed=f"{np.mean([r['mean_forward_speed_m_per_s'] for r in recent]):.2f}",
                             length=f"{np.mean([r['length_s'] for r in recent]):.1f}s",
                             last=f"t{trial}:{row['length_s']:.1f}s")

    def _maybe_checkpoint(self) -> None:
        """At the end of a step after a session ended: the outputs and the checkpoint, unless the
        last write was too recent (:data:`CHECKPOINT_SPACING`). Always when every trial is done
        or a stop (Ctrl-C, SIGTERM) was asked for in this step: the network stops after it."""
        if not self._pending:
            return
        now = time.monotonic()
        # the session loop stops the network in the step its last trial finished (net._stopped)
        if (now < self._next_checkpoint
                and not (self.cpg.net._stopped or Network._globally_stopped)):
            return
        self._pending = False
        self.write_outputs()
        self.write_checkpoint()
        if self.on_checkpoint is not None:  # e.g. the manifest's inventory
            self.on_checkpoint()
        done = time.monotonic()
        self._next_checkpoint = done + CHECKPOINT_SPACING * (done - now)

    # ---- files
    def _write_recording(self, trial: int, session: int, arrays: dict[str, Any]) -> None:
        """One recorded session as a folder that ``astrocpg export`` reads like a run."""
        from ...network import Layout

        folder = (self.folder / "recordings"
                  / f"trial{trial + self.trial_offset:02d}_session{session:04d}")
        folder.mkdir(parents=True, exist_ok=True)
        files = save_spikes_and_traces(folder, arrays["spikes"], arrays["traces"])
        # never silent: the traces that lost values to float32 (stored as inf), how many
        over = overflowed(arrays["traces"])
        if over:
            if not self.trace_overflow:  # said once; every such session is in the manifest
                warnings.warn(f"{folder}: " + overflow_words(over) + " (every session that "
                              "does is listed in the training's manifest.json)", UserWarning,
                              stacklevel=2)
            self.trace_overflow[folder.name] = over
        robot = {k: (v if k == "t" else v[None]) for k, v in arrays["robot"].items()}
        save_npz(folder / "robot.npz", robot | {"legs": np.array(list(self.cpg.layout.legs)),
                                                "joints": np.array(["hip", "thigh", "calf"])})
        layout = Layout(n_trials=1, pool_size=self.cpg.layout.pool_size,
                        legs=self.cpg.layout.legs, populations=self.cpg.layout.rows)
        write_manifest(folder, command="train-session", seed=self.settings.seed + trial,
                       settings={"training": str(self.folder),
                                 "trial": trial + self.trial_offset, "session": session,
                                 "record": dataclasses.asdict(self.record),
                                 "overrides": list(self.settings.overrides),
                                 "astrocytes": self.settings.astrocytes,
                                 "seconds": self.training.memory.rows[-1]["length_s"]},
                       models_json=self.models.to_json(),
                       files=files | {"robot.npz": "t (s); joint_angles, torques (1, t, leg, "
                                                   "joint); torso_position, torso_velocity "
                                                   "(1, t, xyz); torso_quaternion (1, t, "
                                                   "wxyz)"},
                       results={"layout": layout.to_json(), "dt_s": float(self.cpg.dt),
                                **({"trace_overflow": over} if over else {})})

    def write_outputs(self) -> None:
        write_training_files(self.out, self.training.memory, self.training.sessions_done,
                             self.cpg.interlimb_weights() * 1e3, self.settings.n_trials)

    def write_checkpoint(self) -> None:
        net = self.cpg.net
        net.store("checkpoint")
        brian_state = portable_random_state(net._stored_state.pop("checkpoint"))
        # the same training writes the same checkpoint, byte for byte: in sorted order
        # (Brian2 stores its objects in an order that varies between processes), each clock
        # under its stem (the suffix a clock's name gets when the name
        # was taken earlier in the process is no part of the training; rename_clocks)
        brian_state = {CLOCK.sub(r"\1", k): dict(sorted(v.items())) if isinstance(v, dict)
                       else v for k, v in sorted(brian_state.items(),
                                                 key=lambda kv: CLOCK.sub(r"\1", kv[0]))}
        # the step in progress is complete: the resumed run starts at the next one
        brian_state["0_t"] = brian_state["0_t"] + float(self.cpg.dt)
        mj = []
        spec = mujoco.mjtState.mjSTATE_INTEGRATION
        size = mujoco.mj_stateSize(self.robot, spec)
        for d in self.bridge.data:
            s = np.empty(size)
            mujoco.mj_getState(self.robot, d, s, spec)
            mj.append(s)
        tr, br = self.training, self.bridge
        payload = {
            "fingerprint": self.settings.fingerprint(),
            "settings": self.settings.record(),
            "codegen": self.cpg.codegen,
            "brian": brian_state,
            "mujoco": mj,
            "bridge": {k: getattr(br, k).copy() for k in
                       ("qpos", "qvel", "hip_integral", "ctrl", "reward", "alive")}
            | {"step_count": br.step_count},
            "training": {k: getattr(tr, k).copy() for k in
                         ("step_in_session", "non_alive", "ring", "ring_sum", "reward_sum",
                          "speed_sum", "pool_counts", "count_base_in", "count_base_ado",
                          "sessions_done", "done", "progress", "t_learning_start")},
            "memory": memory_state(tr.memory, self.cpg.interlimb_weights().shape[1:]),
        }
        if self.recorder is not None:
            payload["record_plan"] = dataclasses.asdict(self.record)
            payload["recorder"] = self.recorder.state()
        write_payload(self.out / CHECKPOINT, payload)

    def restore(self, payload: dict[str, Any]) -> None:
        """Continue from a checkpoint's payload (:func:`read_checkpoint`). A payload that does
        not fit this network (a tampered or foreign checkpoint whose archive is whole) is an
        InputError naming the checkpoint, whatever part of it is off."""
        # an exact resume needs the target the training started with (same_codegen)
        same_codegen(payload.get("codegen", "numpy"), self.cpg.codegen)
        try:
            self._restore(payload)
        except InputError:
            raise
        except (KeyError, ValueError, TypeError, IndexError, AttributeError) as e:
            raise InputError(f"does not fit this training ({type(e).__name__}: "
                             f"{str(e)[:120]})", culprit=self.out / CHECKPOINT) from None

    def _restore(self, payload: dict[str, Any]) -> None:
        net = self.cpg.net
        net._stored_state["checkpoint"] = local_random_state(rename_clocks(payload["brian"], net))
        net.restore("checkpoint", restore_random_state=True)
        del net._stored_state["checkpoint"]
        spec = mujoco.mjtState.mjSTATE_INTEGRATION
        if len(payload["mujoco"]) != len(self.bridge.data):
            raise ValueError("another number of trials")
        size = mujoco.mj_stateSize(self.robot, spec)
        for d, s in zip(self.bridge.data, payload["mujoco"]):
            s = np.asarray(s, dtype=np.float64)
            if s.shape != (size,):  # MuJoCo would read past the array's end
                raise ValueError(f"a MuJoCo state of shape {s.shape}, not ({size},)")
            mujoco.mj_setState(self.robot, d, s, spec)
        for k, v in payload["bridge"].items():
            if k == "step_count":
                self.bridge.step_count = v
            else:
                getattr(self.bridge, k)[...] = v
        for k, v in payload["training"].items():
            getattr(self.training, k)[...] = v
        self.training.counters_set()
        self.training.memory = memory_from_state(payload["memory"], self.settings.n_trials)
        if self.recorder is not None and "recorder" in payload:
            self.recorder.restore(payload["recorder"])

    def extend(self, sessions: int) -> None:
        """After :meth:`restore` of a training of ``sessions`` sessions per trial (fewer than
        this one's): go on as a training of this one's sessions from the start would. Trials
        that finished in the checkpoint's step are reopened (:meth:`Training.reopen`), the
        recorder records as the longer training does, and a recording of session ``sessions``
        that only the shorter training made (its last) is removed."""
        try:
            reopened = self.training.reopen()
        except ValueError as e:  # resume checks this first; a checkpoint that lies about it
            raise InputError(f"cannot be extended exactly ({e})",
                             culprit=self.out / CHECKPOINT) from None
        if self.recorder is not None:
            self.recorder.extend(sessions, reopened)
            if not self.record.records(sessions, self.settings.n_sessions):
                for b in range(self.trial_offset, self.trial_offset + self.settings.n_trials):
                    stale = self.folder / "recordings" / f"trial{b:02d}_session{sessions:04d}"
                    remove_own(stale)  # what the user put there stays

    # ---- run
    def run(self) -> float:
        """Run until every trial has done its sessions and write the outputs; returns wall
        seconds. Raises :class:`TrainingStopped` (outputs written; the checkpoint at the step
        the stop was asked in, or if it came after that step's write, the last one) when the
        simulation ended first: Brian2 turns Ctrl-C into a request to stop the run. A
        divergence raises :class:`~astrocpg.errors.Diverged` itself (outputs written, the
        diverged session's row last; the checkpoint stays as last written)."""
        L_max = self.models.value("L_max")
        left = (self.settings.n_sessions - self.training.sessions_done.min()) * L_max
        t0 = time.perf_counter()
        self.bar = tqdm(total=self.settings.n_sessions * self.settings.n_trials,
                        initial=int(self.training.sessions_done.sum()), unit="session",
                        desc="train", disable=not self.progress, dynamic_ncols=True)
        try:
            if not self.training.done.all():
                # an upper bound: the session loop stops the network when all trials are done
                run_network(self.cpg.net, (left + 1.0) * second, namespace={})
        except Diverged:
            self.write_outputs()  # the sessions so far and the diverged one
            raise
        except KeyboardInterrupt:
            # Ctrl-C/SIGTERM outside Brian2's loop (while it prepares the run): stopped like
            # a stop inside it, the sessions done so far written (the checkpoint stays)
            pass
        finally:
            self.bar.close()
        self.write_outputs()
        if not self.training.done.all():
            raise TrainingStopped(int(self.training.sessions_done.sum()),
                                  self.settings.n_trials * self.settings.n_sessions)
        return time.perf_counter() - t0


__all__ = ["CHECKPOINT_SPACING", "Trainer", "TrainingStopped"]
