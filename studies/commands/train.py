"""Gait learning: ``n_trials`` independent trials, each training for ``n_sessions`` sessions, in
one network. At session ends the folder gets, atomically: ``sessions.csv`` (one row per
trial and session), ``weights.npz`` (each trial's table after each session),
``session_starts.npz`` (what each session started from: a replay reads it) and
``checkpoint.npz`` (everything needed to continue exactly: Brian2 state and random state,
MuJoCo states, the session loop's memory; data only, never code:
:mod:`astrocpg.studies.outputs.checkpoint`): after the first session end, then spaced so that
writing takes at most 2 % of the wall time (:data:`CHECKPOINT_SPACING`), at the last session
end and when the run is stopped. ``resume`` continues a killed run from its last checkpoint and
ends with the same files as a run never interrupted.
"""

from __future__ import annotations

import csv
import dataclasses
import hashlib
import io
import math
import os
import re
import time
import warnings
from pathlib import Path
from typing import Any, Callable, Mapping, NoReturn, Sequence

import mujoco
import numpy as np
from brian2 import Network, NetworkOperation, second

from ...coupling.assembly import build_closed_loop
from ...coupling.recorder import RecordPlan, SessionRecorder
from ...coupling.training import SESSION_COLUMNS, SessionMemory, SessionStart, Training
from ...errors import Diverged, EnvironmentFault, Field, InputError, advice, did_you_mean, setting
from ...models import ModelSet
from ...network import codegen_target, exclusive, interlimb_labels, run_network
from ...network.recording import overflow_words, overflowed
from ..outputs.checkpoint import (CHECKPOINT, LEGACY_CHECKPOINT, holds_checkpoint,
                               refuse_legacy, write_checkpoint as write_checkpoint_file)
from ..outputs.checkpoint import read_checkpoint as read_checkpoint_file
from ..outputs.folder import (FolderLock, OutputFolder, clean_stale_temporaries, clear_folder,
                            as_path, holds_results, refuse_in_use, remove_derived, remove_own,
                            file_sha256)
from ..outputs.writing import (atomic_write, read_manifest, save_npz, save_spikes_and_traces,
                             write_manifest)
from ..outputs.result import Result
from ..runtime.progress import Bar as tqdm  # warnings wait until the bar closes
from ..runtime.resources import check_memory, estimate_batched, estimate_bytes
from ..runtime.workers import resolve_workers, workers_words
from ..settings import TrainSettings
from ...models.compose import model_files_record, model_set, override_items
from .settings import (added_populations, number, population_models, population_rows,
                       same_populations, seed_number)
from .simulate import check_selection, check_trace_dtype

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
        loop = build_closed_loop(models, n_trials=settings.n_trials, seed=settings.seed)
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
                              f"does is listed in the training's manifest.json)", UserWarning,
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
        brian_state = net._stored_state.pop("checkpoint")
        # the same training writes the same checkpoint, byte for byte: in sorted order
        # (Brian2 stores its objects in an order that varies between processes), each clock
        # under its stem (the suffix a clock's name gets when the name
        # was taken earlier in the process is no part of the training; _rename_clocks)
        brian_state = {_CLOCK.sub(r"\1", k): dict(sorted(v.items())) if isinstance(v, dict)
                       else v for k, v in sorted(brian_state.items(),
                                                 key=lambda kv: _CLOCK.sub(r"\1", kv[0]))}
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
            "memory": _memory_state(tr.memory, self.cpg.interlimb_weights().shape[1:]),
        }
        if self.recorder is not None:
            payload["record_plan"] = dataclasses.asdict(self.record)
            payload["recorder"] = self.recorder.state()
        write_checkpoint_file(self.out / CHECKPOINT, *_split(payload))

    def restore(self, payload: dict[str, Any]) -> None:
        """Continue from a checkpoint's payload (:func:`read_checkpoint`). A payload that does
        not fit this network (a tampered or foreign checkpoint whose archive is whole) is an
        InputError naming the checkpoint, whatever part of it is off."""
        # an exact resume needs the target the training started with (_same_codegen)
        _same_codegen(payload.get("codegen", "numpy"), self.cpg.codegen)
        try:
            self._restore(payload)
        except InputError:
            raise
        except (KeyError, ValueError, TypeError, IndexError, AttributeError) as e:
            raise InputError(f"does not fit this training ({type(e).__name__}: "
                             f"{str(e)[:120]})", culprit=self.out / CHECKPOINT) from None

    def _restore(self, payload: dict[str, Any]) -> None:
        net = self.cpg.net
        net._stored_state["checkpoint"] = _rename_clocks(payload["brian"], net)
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
        self.training.memory = _memory_from_state(payload["memory"], self.settings.n_trials)
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


def write_training_files(out: Path, mem: SessionMemory, sessions_done: np.ndarray,
                     final_weights_mV: np.ndarray, n_trials: int) -> None:
    """sessions.csv, weights.npz and session_starts.npz of a training's session memory."""
    rows = mem.rows
    buf = io.StringIO()
    writer = csv.DictWriter(buf, fieldnames=SESSION_COLUMNS, lineterminator="\n", restval=0)
    writer.writeheader()
    for r in rows:
        writer.writerow({k: (f"{v:.9g}" if isinstance(v, float) else v) for k, v in r.items()})
    data = buf.getvalue().encode()
    atomic_write(out / "sessions.csv", lambda f: f.write(data))
    n_max = max(len(w) for w in mem.weights)
    table = np.full((n_trials, n_max, 8, 8), np.nan)
    for b, ws in enumerate(mem.weights):
        if ws:
            table[b, :len(ws)] = np.array(ws) * 1e3
    save_npz(out / "weights.npz", {
        "weights_mV": table, "sessions_done": sessions_done.copy(),
        "final_weights_mV": final_weights_mV,
        "labels": np.array(interlimb_labels()),
    })
    save_npz(out / SESSION_STARTS, session_starts_arrays(mem.starts))


_CLOCK = re.compile(r"^(.*_clock)(_\d+)?$")


def _same_codegen(started: str, now: str) -> None:
    """A training continues under the Brian2 target it started with (checkpoints written before
    targets were recorded: numpy). The targets draw the same noise, but C's and numpy's
    floating point can part after many sessions: an exact resume needs the same one."""
    if started != now:
        raise InputError(f"this training started with Brian2's {started} target and continues "
                         f"only with it (now: {now}); resume with {advice('codegen', started)}",
                         culprit=advice("codegen"))


def _rename_clocks(state: dict[str, Any], net) -> dict[str, Any]:
    """Brian2 names the clock of an object with its own ``dt`` ``<object>_clock``, plus a
    suffix (``_1``...) if that name was taken earlier in the process, so a checkpoint written
    by one process may name the clocks differently from the network rebuilt in another (a Dask
    worker that trained other runs before). Object names are fixed; match clocks by stem."""
    from brian2.core.network import _get_all_objects

    current = {_CLOCK.sub(r"\1", obj.clock.name): obj.clock.name
               for obj in _get_all_objects(net.objects)}
    out, stored = {}, []
    for key, value in state.items():
        m = _CLOCK.match(key)
        if not m:
            out[key] = value
            continue
        stored.append(value)
        if m.group(1) in current:
            out[current[m.group(1)]] = value
    # a checkpoint written when every object had its own clock, resumed by a network whose
    # objects share one (cpg_clock): the clocks stepped together, so any of them has its time
    # (and the clocks the network no longer has are left out: Brian2 refuses unknown names)
    for name in current.values():
        if name not in out and stored:
            out[name] = stored[0]
    return out


#: The payload's entries stored in the checkpoint's readable ``meta`` (JSON); the rest is the
#: state tree (:mod:`astrocpg.studies.outputs.checkpoint`).
_META_KEYS = ("fingerprint", "settings", "codegen", "record_plan")


def _split(payload: dict[str, Any]) -> tuple[dict[str, Any], dict[str, Any]]:
    meta = {k: payload[k] for k in _META_KEYS if k in payload}
    meta["sessions_done"] = [int(n) for n in payload["training"]["sessions_done"]]
    return meta, {k: v for k, v in payload.items() if k not in _META_KEYS}


#: Each session's start (step, Progress, t_learning_start, the state a reset leaves) per trial:
#: what a replay of one session reads (:func:`astrocpg.replay_session`).
SESSION_STARTS = "session_starts.npz"


def session_starts_arrays(starts: list[list[SessionStart]]) -> dict[str, np.ndarray]:
    """The session starts as (trial, session, ...) arrays: ``step`` (-1 where none), ``progress``
    and ``t_learning_start`` (NaN where none) and ``state.<population>.<variable>`` (trial,
    session, element), session 1 first."""
    n_trials, n = len(starts), max((len(x) for x in starts), default=0)
    out: dict[str, np.ndarray] = {
        "step": np.full((n_trials, n), -1, dtype=np.int64),
        "progress": np.full((n_trials, n), np.nan),
        "t_learning_start": np.full((n_trials, n), np.nan)}
    for b, trial in enumerate(starts):
        for k, x in enumerate(trial):
            out["step"][b, k] = x.step
            out["progress"][b, k] = x.progress
            out["t_learning_start"][b, k] = x.t_learning_start
            for key, v in x.state.items():
                name = f"state.{key}"
                if name not in out:
                    out[name] = np.full((n_trials, n, len(v)), np.nan)
                out[name][b, k] = v
    return out


def _memory_state(memory: SessionMemory, shape: tuple[int, ...]) -> dict[str, Any]:
    """The session memory as data: each trial's tables after each session as one array, the
    rows as one array per column (thousands of rows: a few arrays, not a JSON value each)."""
    return {"lengths": [np.asarray(x, dtype=np.float64) for x in memory.lengths],
            "weights": [np.stack(ws) if ws else np.zeros((0,) + tuple(shape))
                        for ws in memory.weights],
            "rows": _rows_state(memory.rows),
            "starts": [_starts_state(st) for st in memory.starts]}


def _starts_state(starts: list[SessionStart]) -> dict[str, Any]:
    """One trial's session starts as one array per field (one row per session)."""
    keys = list(starts[0].state) if starts else []
    return {"step": np.asarray([x.step for x in starts], dtype=np.int64),
            "progress": np.asarray([x.progress for x in starts], dtype=np.float64),
            "t_learning_start": np.asarray([x.t_learning_start for x in starts],
                                           dtype=np.float64),
            "state": {k: np.stack([x.state[k] for x in starts]) for k in keys}}


def _starts_from_state(state: dict[str, Any]) -> list[SessionStart]:
    steps = np.asarray(state["step"], dtype=np.int64)
    values = {k: np.asarray(v, dtype=np.float64) for k, v in state["state"].items()}
    if any(len(v) != len(steps) for v in values.values()):
        raise ValueError("session starts of unequal lengths")
    return [SessionStart(step=int(steps[i]), progress=float(state["progress"][i]),
                         t_learning_start=float(state["t_learning_start"][i]),
                         state={k: v[i] for k, v in values.items()})
            for i in range(len(steps))]


def _rows_state(rows: list[dict[str, Any]]) -> dict[str, Any]:
    keys = list(rows[0]) if rows else list(SESSION_COLUMNS)
    if any(list(r) != keys for r in rows):  # not one table: row by row
        return {"rows": rows}
    columns: dict[str, Any] = {}
    for k in keys:
        values = [r[k] for r in rows]
        if all(isinstance(v, (int, np.integer)) and not isinstance(v, (bool, np.bool_))
               for v in values):
            columns[k] = np.asarray(values, dtype=np.int64)
        elif all(isinstance(v, (float, np.floating)) for v in values):
            columns[k] = np.asarray(values, dtype=np.float64)
        else:
            columns[k] = values
    return {"columns": keys, "values": columns, "n": len(rows)}


def _rows_from_state(state: dict[str, Any]) -> list[dict[str, Any]]:
    if "rows" in state:
        rows = state["rows"]
    else:
        keys, n = state["columns"], state["n"]
        columns = [state["values"][k] for k in keys]
        columns = [c.tolist() if isinstance(c, np.ndarray) else list(c) for c in columns]
        if any(len(c) != n for c in columns):
            raise ValueError("session rows of unequal lengths")
        rows = [dict(zip(keys, values)) for values in zip(*columns)] if keys else [{}] * n
    if not isinstance(rows, list) or not all(isinstance(r, dict) for r in rows):
        raise ValueError("session rows that are not rows")
    return rows


def _memory_from_state(state: dict[str, Any], n_trials: int) -> SessionMemory:
    lengths, weights = state["lengths"], state["weights"]
    if not len(lengths) == len(weights) == n_trials:
        raise ValueError("a session memory of another number of trials")
    starts = state.get("starts")  # none in checkpoints written before session starts were kept
    if starts is not None and len(starts) != n_trials:
        raise ValueError("session starts of another number of trials")
    return SessionMemory(lengths=[np.asarray(x, dtype=np.float64).tolist() for x in lengths],
                         weights=[list(np.asarray(w, dtype=np.float64)) for w in weights],
                         rows=_rows_from_state(state["rows"]),
                         starts=[_starts_from_state(x) for x in starts] if starts is not None
                         else [[] for _ in range(n_trials)])


def memory_state(memory: SessionMemory, shape: tuple[int, ...]) -> dict[str, Any]:
    """The session memory as a checkpoint holds it (``shape``: a table's, (8, 8))."""
    return _memory_state(memory, shape)


def memory_from_state(state: dict[str, Any], n_trials: int) -> SessionMemory:
    """A checkpoint's session memory (its ``memory`` entry) as the session loop keeps it."""
    return _memory_from_state(state, n_trials)


def write_payload(path: Path, payload: dict[str, Any]) -> None:
    """``payload`` (what :func:`read_checkpoint` returns) written as the checkpoint ``path``."""
    write_checkpoint_file(path, *_split(payload))


def read_checkpoint(path: Path, culprit: Any = None) -> dict[str, Any]:
    """Load and check a checkpoint (data only: :mod:`astrocpg.studies.outputs.checkpoint`); a
    corrupt or foreign file, or one of the old pickled format, is an ``InputError`` naming it.
    Returns the payload :meth:`Trainer.restore` takes."""
    meta, state = read_checkpoint_file(path, culprit=culprit)
    bad = InputError("is corrupt (not a training's checkpoint)", culprit=path) if culprit is None \
        else InputError(f"{path} is corrupt (not a training's checkpoint)", culprit=culprit)
    if not isinstance(state, dict) or not isinstance(meta.get("settings"), dict) \
            or "fingerprint" not in meta:
        raise bad
    payload = dict(state) | {k: meta[k] for k in _META_KEYS if k in meta}
    try:
        TrainSettings(**payload["settings"])
        np.asarray(payload["training"]["sessions_done"], dtype=np.int64)
    except (KeyError, TypeError, ValueError):
        raise bad from None
    return payload


def _checkpoint_as_listed(out: Path) -> None:
    """A training that stopped cleanly (finished, interrupted, diverged) listed its last
    checkpoint's sha256 in its manifest after writing it: a checkpoint that differs was changed
    since (a damaged byte the archive's CRC-32 does not cover, such as a header field, or a file
    copied in), and is refused naming it. A manifest still saying ``running`` belongs to a
    process that was killed, possibly between the checkpoint and its manifest: the archive's own
    checks are all there is then."""
    manifest = read_manifest(out)
    if (not isinstance(manifest, dict) or manifest.get("astrocpg_command") != "train"
            or not isinstance(manifest.get("results"), dict)
            or manifest["results"].get("status") == "running"
            or CHECKPOINT not in (manifest.get("inventory") or {})):
        return
    listed = manifest["inventory"][CHECKPOINT]
    try:
        same = (isinstance(listed, dict) and (out / CHECKPOINT).stat().st_size == listed.get("bytes")
                and file_sha256(out / CHECKPOINT) == listed.get("sha256"))
    except OSError as e:
        raise EnvironmentFault.from_os_error(e, out / CHECKPOINT, "cannot read") from None
    if not same:
        raise InputError("has changed since its training's manifest.json was written (size or "
                         "sha256 differs): damaged, or copied in from elsewhere; nothing was changed",
                         culprit=out / CHECKPOINT)


def check_belongs(out: Path, settings: TrainSettings) -> int:
    """A folder holds one run: the checkpoint's settings (``settings``) must be those its
    folder's manifest records (a checkpoint copied or linked in from another training, e.g.
    of another seed, is refused naming the file and what differs, before anything changes).
    Returns the sessions per trial the folder plans: the checkpoint's, or more where the
    manifest records an extension (``--resume --sessions``) stopped before its first
    checkpoint (everything else the same)."""
    manifest = read_manifest(out)
    if not isinstance(manifest, dict) or manifest.get("astrocpg_command") != "train" \
            or not isinstance(manifest.get("settings"), dict):
        return settings.n_sessions
    recorded = {k: v for k, v in manifest["settings"].items() if k not in ("record", "replay_of")}
    try:
        mine = TrainSettings(**recorded)
    except TypeError:
        raise InputError("manifest.json records settings this astrocpg cannot read",
                         culprit=setting("resume", out)) from None
    if mine.fingerprint() == settings.fingerprint():
        return settings.n_sessions
    if (isinstance(mine.n_sessions, int) and mine.n_sessions > settings.n_sessions
            and dataclasses.replace(mine, n_sessions=settings.n_sessions).fingerprint()
            == settings.fingerprint()):
        return mine.n_sessions
    differ = [f"{k} {v!r} (folder: {recorded.get(k)!r})"
              for k, v in settings.record().items() if recorded.get(k) != v] or ["its fingerprint"]
    raise InputError(f"belongs to another training than its folder: {', '.join(differ[:3])}; "
                     f"a folder holds one run (resume the folder that checkpoint came from)",
                     culprit=out / CHECKPOINT)


TRAIN_FILES = {
    "sessions.csv": "one row per trial and session: " + ", ".join(SESSION_COLUMNS),
    "weights.npz": "weights_mV (trial, session, 8, 8): each trial's inter-limb table after "
                   "each session (NaN after a trial's last); final_weights_mV; labels",
    SESSION_STARTS: "per trial and session (session 1 first): step (the network step of its "
                    "first step), progress, t_learning_start and state.<population>.<variable> "
                    "(what a session reset leaves: astrocytes, inter-limb weights in SI), what "
                    "a replay of one session reads",
    CHECKPOINT: "state to continue exactly (astrocpg train --resume DIR): a NumPy archive of "
                "plain arrays and JSON (meta, state), no code",
    "recordings/": "with --record-every: trialTT_sessionSSSS/ per recorded session (spikes, "
                   "traces, robot, manifest; astrocpg export reads it)",
}


def record_plan(every: int | None, stride: int | None = None,
                spikes: tuple[str, ...] | None = None,
                traces: tuple[str, ...] | None = None,
                trace_dtype: str | None = None) -> RecordPlan | None:
    """The new training's RecordPlan from the options (a resumed one keeps its own:
    :func:`~astrocpg.studies.commands.train.check_resume_options`)."""
    if every is None:
        if stride is not None:
            raise InputError(f"a training records sessions only with "
                             f"{setting('record_every', 'N')}",
                             culprit=setting("record_stride"))
        if spikes is not None or traces is not None:
            raise InputError(f"a training records spikes and traces only with "
                             f"{setting('record_every', 'N')}",
                             culprit=f"{setting('spikes')}/{setting('traces')}")
        if trace_dtype is not None:
            raise InputError(f"a training records traces only with {setting('record_every', 'N')}",
                             culprit=setting("trace_dtype"))
        return None
    stride = 1 if stride is None else stride
    if every < 1:
        raise InputError(f"must be at least 1, got {every}", culprit=setting("record_every"))
    if stride < 1:
        raise InputError(f"must be at least 1, got {stride}", culprit=setting("record_stride"))
    spikes, traces = check_selection(spikes, traces)
    dtype = "float32" if trace_dtype is None else check_trace_dtype(trace_dtype)
    return RecordPlan(every=every, spikes=spikes, traces=traces, stride=stride, dtype=dtype)


def _last(n: int, of: int) -> str:
    """"the last 20" when there were at least 20, else "all 3": say how many there were."""
    return f"the last {n}" if of >= n else f"all {of}"


def _trial_line(b: Any, x: Mapping[str, Any]) -> str:
    """The summary line of one trial (``x``: its entry of :func:`train_summary`'s per_trial;
    a manifest written before the counts and falls were kept gives the counts from
    ``sessions``)."""
    n = int(x["sessions"])
    speed_n = int(x.get("speed_sessions", min(n, SPEED_LAST)))
    full_n = int(x.get("full_sessions", min(n, FULL_LAST)))
    line = (f"trial {b}: {n} sessions; mean forward speed over {_last(SPEED_LAST, speed_n)} "
            f"sessions: {x['mean_speed_last20_m_per_s']:.3f} m/s; "
            f"{x['full_length_share_last50']:.0%} of {_last(FULL_LAST, full_n)} sessions "
            f"reached L_max")
    falls = x.get("falls")
    if falls:
        line += (f"; the robot fell in {falls} of {n} sessions (last: session "
                 f"{x['last_fall_session']}, ended at {x['last_fall_length_s']:.2f} s once "
                 f"not upright for L_non_alive)")
    elif falls == 0:
        line += "; it never fell"
    return line


def format_train(result: Result) -> list[str]:
    """One line per trial of a training's summary: sessions, speed, share of full sessions,
    and its falls (how many, and the last one's session and time)."""
    return [_trial_line(b, x) for b, x in sorted((result.summary.get("per_trial") or {}).items(),
                                                  key=lambda kv: int(kv[0]))]


SPEED_LAST, FULL_LAST = 20, 50  # sessions the summary's speed and full-length share cover


def train_summary(rows: list[dict], n_trials: int, L_max: float) -> dict[str, Any]:
    """Per trial: sessions done, mean forward speed over the last 20 (``speed_sessions``:
    how many there were), share of the last 50 (``full_sessions``) that reached L_max, and its
    falls: ``falls`` sessions that ended before L_max without diverging (a session ends early
    only once the robot has been not upright for L_non_alive), ``last_fall_session`` and
    ``last_fall_length_s`` (when, in the session's simulated s, that session ended); and a
    printable line per trial."""
    per_trial: dict[int, dict[str, Any]] = {}
    lines: dict[int, str] = {}
    for b in range(n_trials):
        mine = [r for r in rows if r["trial"] == b]
        if not mine:
            continue
        last_speed, last_full = mine[-SPEED_LAST:], mine[-FULL_LAST:]
        speed = float(np.mean([r["mean_forward_speed_m_per_s"] for r in last_speed]))
        full = float(np.mean([r["length_s"] >= L_max - 1e-6 for r in last_full]))
        fell = [r for r in mine
                if r["length_s"] < L_max - 1e-6 and not _true(r.get("diverged", False))]
        per_trial[b] = {"sessions": len(mine), "mean_speed_last20_m_per_s": speed,
                        "full_length_share_last50": full, "speed_sessions": len(last_speed),
                        "full_sessions": len(last_full), "falls": len(fell),
                        "last_fall_session": int(fell[-1]["session"]) if fell else None,
                        "last_fall_length_s": float(fell[-1]["length_s"]) if fell else None}
        lines[b] = _trial_line(b, per_trial[b])
    return {"per_trial": per_trial, "lines": lines}


def _true(value: Any) -> bool:
    """A session row's flag, as the loop keeps it (bool) or a CSV gives it back ("1")."""
    return value in (True, 1, "1", "True", "true")


def train(*, out: str | Path | None, sessions: int = 400, seed: int = 1, trials: int = 1,
          astrocytes: bool = True, overrides: Any = None,
          equations: dict[str, str] | None = None, models: dict[str, str] | None = None,
          record_every: int | None = None,
          record_stride: int | None = None, spikes: tuple[str, ...] | None = None,
          traces: tuple[str, ...] | None = None, trace_dtype: str | None = None,
          overwrite: bool = False,
          progress: bool = True, inputs: Sequence[str | os.PathLike] = (),
          populations: Any = None, workers: int | None = None) -> Result:
    """Train inter-limb weights, writing ``out`` after every session: what ``astrocpg train`` runs.

    Parameters
    ----------
    out : path
        The training folder: sessions.csv, weights.npz, checkpoint.npz and manifest.json,
        rewritten after every session.
    sessions : int
        Sessions per trial.
    seed : int
        Seed of trial 0; trial k has seed ``seed + k``.
    trials : int
        Independent trials trained together.
    astrocytes : bool
        False: the paper's ablation (no adenosine term).
    overrides : mapping or sequence of str, optional
        Parameter values with units: ``{"tau_motor": "9*ms"}`` or ``["tau_motor=9*ms"]``.
    equations : mapping of str to str, optional
        ``{model: equation text}`` replacing a model's Brian2 equation string.
    models : mapping, optional
        ``{model: model file text}`` (TOML, as ``astrocpg models dump`` writes) replacing whole
        models.
    record_every : int, optional
        Record sessions 1, 1+N, ... and each trial's last into ``out/recordings/``.
    record_stride : int, optional
        Steps between the recorded trace and robot samples.
    spikes, traces : tuple of str, optional
        Which populations' spikes and which traces to record (None: all).
    trace_dtype : str, optional
        With ``record_every``: the recorded traces kept as "float32" (default; a value beyond
        float32's range is kept as inf, counted and warned about) or "float64".
    overwrite : bool
        Replace an existing ``out``: only a folder astrocpg wrote, none of ``inputs`` and holding
        none of them.
    progress : bool
        A progress bar on stderr.
    inputs : sequence of path
        Other files the caller read (e.g. model files).
    populations : sequence or mapping, optional
        Model files with a ``[population]`` table (texts, or ``{file: text}``), populations
        added to every session's network: recorded with the sessions, their files kept with the
        settings, so that :func:`resume` and the replays rebuild them.
    workers : int, optional
        Processes the trials are split over (default: the cores this process may use); the
        sessions, tables and recordings are the same whatever the number (a split training's
        ``checkpoint.npz`` holds one state per batch).

    Returns
    -------
    Result
        A :class:`~astrocpg.studies.outputs.result.Result` of kind "train", read back from
        ``out`` (``sessions`` DataFrame, ``weights`` (trial, session, 8, 8) mV,
        ``recording(trial, session)``), with the live ``network`` and ``trainer``. An
        interrupted training raises ``TrainingStopped``; continue it with :func:`resume`.

    """
    if out is None or (isinstance(out, str) and not out):
        raise InputError(f"is required (or {advice('resume', 'DIR')})", culprit=setting("out"))
    settings, models = _train_settings(sessions, seed, trials, astrocytes, overrides, equations,
                                       models, populations)
    out = _checked_new_training(out, overwrite, inputs)
    procs = min(resolve_workers(workers), settings.n_trials)
    with added_populations(settings.populations):  # recorded and built like the others
        plan = record_plan(record_every, record_stride, spikes, traces, trace_dtype)
        check_memory(estimate_batched(procs, trials=settings.n_trials, seconds=0.0, spikes=False,
                                      sessions=settings.n_sessions),
                     culprit=f"{setting('sessions', settings.n_sessions)} x "
                             f"{setting('trials', settings.n_trials)}{workers_words(procs)}")
        return Result.from_training(_train(settings, out, plan, None, progress,
                                           replace=overwrite, new=True, models=models,
                                           workers=procs), out)


def _train_settings(sessions: Any, seed: Any, trials: Any, astrocytes: Any, overrides: Any,
                    equations: Any, models: Any, populations: Any) -> tuple[TrainSettings, Any]:
    """A new training's settings, checked, and its model set (composed once, before any file
    is touched, and handed to the training)."""
    population_record = population_rows(populations)[1]  # each file parsed and checked
    n_trials = number(trials, setting("trials"), integer=True, minimum=1)
    settings = TrainSettings(
        n_sessions=number(sessions, setting("sessions"), integer=True, minimum=1),
        seed=seed_number(seed, trials=n_trials), n_trials=n_trials,
        astrocytes=bool(astrocytes), overrides=override_items(overrides),
        equations=dict(equations or {}), models=model_files_record(models),
        populations=population_record)
    return settings, model_set(settings.overrides, settings.equations, models=settings.models,
                               added=population_models(settings.populations))


def _checked_new_training(out: Any, overwrite: bool, inputs: Sequence[Any]) -> Path:
    """``out`` as a path a new training may write: not a training that holds a checkpoint
    (that is resumed, or replaced with ``overwrite``), not holding an input."""
    out = as_path(out, setting("out"))
    if not overwrite:
        refuse_legacy(out)  # --resume would refuse it too: say what to do with it
    if holds_checkpoint(out) and not overwrite:
        raise InputError(f"already holds a training run (continue it with "
                         f"{advice('resume', out)}, or "
                         f"replace it with {setting('overwrite')})", culprit=setting("out", out))
    OutputFolder(out, overwrite=overwrite, inputs=inputs, command="train").check()
    return out


def resume(folder: str | Path, *, sessions: int | None = None, progress: bool = True,
           record_every: int | None = None,
           record_stride: int | None = None, spikes: tuple[str, ...] | None = None,
           traces: tuple[str, ...] | None = None, trace_dtype: str | None = None,
           seed: int | None = None,
           trials: int | None = None, astrocytes: bool | None = None, overrides: Any = None,
           equations: Mapping[str, str] | None = None, models: Mapping[str, Any] | None = None,
           out: str | Path | None = None, overwrite: bool = False,
           expect: dict[str, Any] | None = None, populations: Any = None,
           workers: int | None = None) -> Result:
    """Continue the training in ``folder`` from its checkpoint: ``astrocpg train --resume``.

    It ends with the same files as a training never interrupted (what later commands derived
    from the earlier weights, ``evaluation/`` and ``figures/``, is removed: it would be stale).
    A resumed training keeps the settings it started with, the populations it added included;
    options given again must agree with them, or the resume is refused with the option and both
    values named (:func:`~astrocpg.studies.commands.train.check_resume_options`).

    Parameters
    ----------
    folder : path
        The training folder (or a study's run folder).
    sessions : int, optional
        More than the training's sessions per trial extends it, finished or not, exactly as a
        training asked for ``sessions`` from the start would have gone on (its manifest records
        the new number). Fewer than it has done or plans is refused. A training of several
        trials is extended only while no trial ran idle; a study's run is not extended.
    progress : bool
        A progress bar on stderr.
    record_every, record_stride, spikes, traces, trace_dtype : optional
        As for :func:`train`: given again, each must agree with the training's own.
    seed, trials, astrocytes, overrides, equations, models, populations : optional
        As for :func:`train`: given again, each must agree with the training's own.
    out : path, optional
        Only ``folder`` itself (a resume writes where it continues).
    overwrite : bool
        Refused when true (it would replace what the resume continues).
    expect : dict, optional
        The same checks, as ``{option: value}``.
    workers : int, optional
        The processes a training split over processes (``checkpoint.npz`` of batches) continues
        its batches on (default: the cores this process may use); a training of one network
        continues in this process.

    Returns
    -------
    Result
        The training's Result, as :func:`train` returns it.
    """
    procs = resolve_workers(workers)
    out = _resume_folder(folder, out, overwrite)
    given = _given_again(seed, trials, astrocytes, overrides, equations, models, populations) \
        | dict(expect or {})
    asked = given.pop("sessions", None)
    if sessions is None:
        sessions = asked
    elif asked is not None and asked != sessions:
        raise InputError(f"given twice ({asked} and {sessions})", culprit=setting("sessions"))
    if sessions is not None:
        sessions = number(sessions, setting("sessions"), integer=True, minimum=1)
    payload, settings, fresh = _stored_training(out)
    if payload["fingerprint"] != settings.fingerprint():
        raise InputError(f"{out / CHECKPOINT} is not consistent with its settings",
                         culprit=setting("resume"))
    planned = settings.n_sessions
    if not fresh:  # a checkpoint copied or linked in from another training
        # an extension stopped before its first checkpoint: the manifest plans more sessions
        planned = check_belongs(out, settings)
    with added_populations(settings.populations):  # its recording plan may name them
        return _resume_checked(out, settings, payload, fresh, planned, sessions, given,
                               dict(record_every=record_every, record_stride=record_stride,
                                    spikes=spikes, traces=traces, trace_dtype=trace_dtype),
                               progress, procs)


def _resume_folder(folder: Any, out: Any, overwrite: bool) -> Path:
    """The folder a resume continues (and writes into): ``out``, if given, must be it, and
    ``overwrite`` is refused (it would replace what the resume continues)."""
    out_given = None if out is None else as_path(out, setting("out"))
    folder = as_path(folder, setting("resume"))
    if out_given is not None and Path(out_given).resolve() != folder.resolve():
        raise InputError(f"{advice('resume')} writes into its own folder; drop {setting('out')}",
                         culprit=setting("out"))
    if overwrite:  # never ignored: it would replace what --resume continues
        raise InputError(f"replaces a training, {advice('resume')} continues one: use one of them",
                         culprit=setting("overwrite"))
    return folder


def _stored_training(out: Path) -> tuple[dict[str, Any], TrainSettings, bool]:
    """A training folder's checkpoint payload and settings, and whether it is ``fresh``:
    stopped before its first checkpoint, so nothing was trained and it starts again from the
    settings its manifest recorded."""
    # a training (or a study's run) that another process is training now: its files are in
    # flux and its lock is that process's, whatever they say
    refuse_in_use(out, culprit=setting("resume", out))
    refuse_legacy(out)
    if (out / CHECKPOINT).exists():
        payload = read_checkpoint(out / CHECKPOINT)
        return payload, TrainSettings(**payload["settings"]), False
    manifest = read_manifest(out)
    if manifest is None or manifest.get("astrocpg_command") != "train":
        raise InputError(f"holds no training (no {CHECKPOINT}, no training manifest)",
                         culprit=setting("resume", out))
    settings = TrainSettings.from_record(manifest["settings"])
    payload = {"settings": settings.record(), "record_plan": manifest["settings"].get("record")}
    payload["fingerprint"] = settings.fingerprint()
    return payload, settings, True


def _resume_checked(out: Path, settings: TrainSettings, payload: dict[str, Any], fresh: bool,
                    planned: int, sessions: int | None, given: dict[str, Any],
                    recording: dict[str, Any], progress: bool, workers: int = 1) -> Result:
    """:func:`resume` once the folder's settings are read (and its populations added): the
    options given again checked against them, the sessions to train to, the training."""
    try:
        stored_plan = (None if payload.get("record_plan") is None
                       else RecordPlan.from_dict(payload["record_plan"]))
    except (TypeError, ValueError):
        raise InputError(f"{out / CHECKPOINT} is corrupt (its recording plan)",
                         culprit=setting("resume")) from None
    check_resume_options(settings, stored_plan, given | recording)
    if not fresh:
        _same_codegen(payload.get("codegen", "numpy"), codegen_target())
    if not fresh:  # its content passed every check above: is it the file its run wrote?
        _checkpoint_as_listed(out)
    done = (np.zeros(settings.n_trials, dtype=np.int64) if fresh
            else np.asarray(payload["training"]["sessions_done"], dtype=np.int64))
    target = planned if sessions is None else sessions
    if target < int(done.max(initial=0)):
        raise InputError(f"{target} sessions per trial is fewer than the {int(done.max())} this "
                         f"training has done; a training is extended, never shortened",
                         culprit=setting("sessions"))
    if target < planned:
        raise InputError(f"{target} sessions per trial is fewer than the {planned} this training "
                         f"trains to; a training is extended, never shortened",
                         culprit=setting("sessions"))
    if not fresh and bool(np.all(done >= target)) and _sealed(out):
        raise InputError(f"the training is already finished ({target} sessions per trial); "
                         f"nothing was changed ({setting('sessions', 'N')}, more, extends it)",
                         culprit=setting("resume", out))
    # every session done but not sealed (stopped after its last session, before its manifest
    # said finished, as its interruption line said): the resume trains nothing and seals it
    extend_from = None
    if target != settings.n_sessions:
        _check_extension(out, settings.n_sessions, target,
                         None if fresh else _loop_state(payload))
        check_memory(estimate_bytes(trials=settings.n_trials, seconds=0.0, spikes=False,
                                    sessions=target),
                     culprit=f"{setting('sessions', target)} x "
                             f"{setting('trials', settings.n_trials)}")
        extend_from = None if fresh else settings.n_sessions
        settings = dataclasses.replace(settings, n_sessions=target)
    return Result.from_training(_train(settings, out, stored_plan, None if fresh else payload,
                                       progress, resumed=True, extend_from=extend_from,
                                       workers=min(workers, settings.n_trials)), out)


def _sealed(out: Path) -> bool:
    """Does the training's manifest say it finished (not interrupted after its last session,
    before its end was written)?"""
    manifest = read_manifest(out) or {}
    results = manifest.get("results")
    return isinstance(results, dict) and results.get("status") == "finished"


def _given_again(seed: int | None, trials: int | None, astrocytes: bool | None,
                 overrides: Any, equations: Mapping[str, str] | None,
                 models: Mapping[str, Any] | None, populations: Any = None) -> dict[str, Any]:
    """The settings a resume was given again, as :func:`check_resume_options` compares them
    (None: not given)."""
    items = override_items(overrides)
    return {"seed": seed, "trials": trials,
            "astrocytes": None if astrocytes is None else bool(astrocytes),
            "overrides": sorted(items) or None, "equations": dict(equations or {}) or None,
            "models": model_files_record(models) or None,
            "populations": population_rows(populations)[1] or None}


def _loop_state(payload: dict[str, Any]) -> dict[str, Any]:
    """A checkpoint's session-loop state (``done``, ``step_in_session`` per trial); of a
    training split over processes, its batches' side by side (a batch not started yet: not
    done, no step)."""
    if "batches" not in payload:
        return payload["training"]
    parts = [(b["payload"]["training"] if b["payload"] is not None else
              {"done": np.zeros(b["count"], dtype=bool),
               "step_in_session": np.zeros(b["count"], dtype=np.int64)})
             for b in payload["batches"]]
    return {k: np.concatenate([np.asarray(x[k]) for x in parts])
            for k in ("done", "step_in_session")}


def _check_extension(out: Path, sessions: int, target: int,
                     state: Mapping[str, Any] | None) -> None:
    """Refuse an extension from ``sessions`` to ``target`` sessions per trial that could not end
    as a training of ``target`` sessions from the start would: of a study's run, or of a
    training where a trial finished before the step its checkpoint was taken (it ran on idle,
    learning off, which a longer training would not have done). ``state``: the checkpoint's
    session-loop state (None: nothing trained yet)."""
    manifest = read_manifest(out)
    if isinstance(manifest, dict) and manifest.get("astrocpg_command") == "study-run":
        raise InputError(f"{out} is a run of a study, which trains the study's {sessions} "
                         f"sessions per trial; extend the study instead (astrocpg study FILE "
                         f"{setting('sessions', target)}, a new study folder)",
                         culprit=setting("sessions"))
    if state is None:
        return
    finished = np.asarray(state["done"], dtype=bool)
    idle = np.asarray(state["step_in_session"], dtype=np.int64)
    late = [int(b) for b in np.flatnonzero(finished & (idle != 0))]
    if late:
        which = ", ".join(f"trial {b} ({int(idle[b])} steps)" for b in late[:5])
        raise InputError(
            f"cannot extend this training exactly to {target} sessions per trial: {which} "
            f"finished its {sessions} sessions before the last trial did and ran on idle "
            f"(learning off) until then, which a {target}-session training would not have "
            f"done; start a new training with {setting('sessions', target)}",
            culprit=setting("sessions"))


#: Relative difference below which two values of a parameter are the same value spelled
#: differently (``1000*ms`` and ``1*second``; ``0.1*second`` and ``100*ms`` differ in the last
#: bit of their SI numbers).
SAME_VALUE_RTOL = 1e-12


def check_resume_options(settings: TrainSettings, plan: RecordPlan | None,
                         given: dict[str, Any]) -> None:
    """Refuse every option given to a resume that differs from what the training recorded
    (an InputError naming the option, the recorded value and the given one); an option given
    with the recorded value is accepted (the run continues with it). ``given``: ``sessions``,
    ``seed``, ``trials``, ``astrocytes`` (bool), ``models`` ({model: {"sha256", "content"}}),
    ``equations`` ({model: text}), ``overrides`` (``NAME=VALUE`` items), ``populations``
    ({name: {"sha256", "content"}} of ``--population`` files), ``record_every``,
    ``record_stride``, ``spikes``, ``traces``; None: not given.

    Parameter values are compared as quantities in SI (:data:`SAME_VALUE_RTOL`), not as
    spelled; model files by what they define (a file that differs only in comments or
    spelling is the same model); equation files by their text."""
    refuse = _refuse_resume
    for key, option, recorded, noun in (
            ("sessions", setting("sessions"), settings.n_sessions, "sessions per trial"),
            ("seed", setting("seed"), settings.seed, "as its seed"),
            ("trials", setting("trials"), settings.n_trials, "trials")):
        value = given.get(key)
        if value is not None and value != recorded:
            refuse(option, f"that run has {recorded} {noun}, not {value}")
    astro = given.get("astrocytes")
    if astro is not None and bool(astro) != settings.astrocytes:
        refuse(setting("astrocytes"), "that run trained with astrocytes (recorded: astrocytes on, "
                                  "given: off)" if settings.astrocytes else
               "that run trained without astrocytes (recorded: off, given: on)")
    for name, record in model_files_record(given.get("models")).items():  # texts or records
        _check_model_file(name, settings.models.get(name), record, refuse)
    _check_populations(settings.populations, given.get("populations") or {}, refuse)
    _check_equations_given(settings, given.get("equations") or {})
    _check_overrides_given(settings, given.get("overrides") or [])
    _check_recording_given(plan, given)


def _refuse_resume(option: Field, message: str) -> NoReturn:
    raise InputError(f"{message}; a resumed training keeps the settings it started with "
                     f"(start a new one with {advice('train', 'DIR')})", culprit=option)


def _check_equations_given(settings: TrainSettings, equations: Mapping[str, str]) -> None:
    """Equation files given to a resume: each must be the text the training used (the model's
    built-in equations where it used none)."""
    if not equations:
        return
    known = dict(model_set(models=settings.models).items())
    for name, text in equations.items():
        if name not in known:
            raise InputError(f"unknown model '{name}'{did_you_mean(name, known)} (models: "
                             f"{', '.join(known)})", culprit=setting("equations"))
        recorded_text = settings.equations.get(name)
        if recorded_text is None:  # the model's own equations, as trained
            if text.strip() != known[name].code.strip():
                _refuse_resume(setting("equations", name), f"that run was trained with the "
                                                      f"built-in equations of {name}, not "
                                                      f"these (sha256 {_short_sha(text)})")
        elif text.strip() != recorded_text.strip():
            _refuse_resume(setting("equations", name), f"that run was trained with other equations "
                                                  f"of {name} (recorded sha256 "
                                                  f"{_short_sha(recorded_text)}, given "
                                                  f"{_short_sha(text)})")


def _check_overrides_given(settings: TrainSettings, items: Sequence[str]) -> None:
    """``--set`` values given to a resume: each must equal the training's, as a quantity."""
    from ...models.files import value_text

    if not items:
        return
    recorded_models = model_set(settings.overrides, settings.equations, models=settings.models,
                                added=population_models(settings.populations))
    for item in override_items(items):
        name, value = recorded_models.parse_assignment(item)
        was = recorded_models.parameter(name).value
        if not _same_quantity(was, value):
            _refuse_resume(setting("overrides", name),
                           f"that run has {name}={value_text(was)}, not {value_text(value)}")


def _check_recording_given(plan: RecordPlan | None, given: dict[str, Any]) -> None:
    """The recording options given to a resume: each must be the training's plan."""
    refuse = _refuse_resume
    every, stride = given.get("record_every"), given.get("record_stride")
    spikes, traces = given.get("spikes"), given.get("traces")
    dtype = given.get("trace_dtype")
    if plan is None:
        for option, value in ((setting("record_every"), every),
                              (setting("record_stride"), stride), (setting("spikes"), spikes),
                              (setting("traces"), traces), (setting("trace_dtype"), dtype)):
            if value is not None:
                refuse(option, f"that run records no sessions (given "
                               f"{option.given(_option_text(value))})")
        return
    if every is not None and every != plan.every:
        refuse(setting("record_every"),
               f"that run records every {plan.every} sessions, not {every}")
    if dtype is not None and dtype != plan.dtype:
        refuse(setting("trace_dtype"), f"that run keeps its traces as {plan.dtype}, not {dtype}")
    if stride is not None and stride != plan.stride:
        refuse(setting("record_stride"),
               f"that run records every {plan.stride} steps, not {stride}")
    want_spikes, want_traces = check_selection(spikes, traces)
    if spikes is not None and set(want_spikes) != set(plan.spikes):
        refuse(setting("spikes"), f"that run records the spikes of {_option_text(plan.spikes)}, "
                           f"not {_option_text(want_spikes)}")
    if traces is not None and set(want_traces) != set(plan.traces):
        refuse(setting("traces"), f"that run records the traces {_option_text(plan.traces)}, "
                           f"not {_option_text(want_traces)}")


def _check_populations(recorded: dict[str, dict[str, str]], given: Mapping[str, Any],
                       refuse: Callable[[str, str], NoReturn]) -> None:
    """``--population FILE`` given to a resume: each must be a file the training added (the
    same file, or one that defines the same population and model)."""
    name = same_populations(recorded, given)
    if name is None:
        return
    sha = given[name]["sha256"][:12]
    if name not in recorded:
        had = ", ".join(sorted(recorded)) or "none"
        refuse(setting("populations"), f"that run did not add the population {name} (sha256 {sha}; "
                               f"added: {had})")
    refuse(setting("populations"), f"that run added {name} from another file (recorded sha256 "
                           f"{recorded[name]['sha256'][:12]}, given {sha})")


def _option_text(value: Any) -> str:
    if isinstance(value, (tuple, list)):
        return ",".join(map(str, value)) or "none"
    return str(value)


def _short_sha(text: str) -> str:
    return hashlib.sha256(text.encode()).hexdigest()[:12]


def _same_quantity(a: Any, b: Any) -> bool:
    """Same dimensions and the same SI numbers (to :data:`SAME_VALUE_RTOL`)."""
    from brian2 import get_dimensions

    if get_dimensions(a) != get_dimensions(b):
        return False
    x, y = np.asarray(a, dtype=float), np.asarray(b, dtype=float)
    return x.shape == y.shape and bool(np.all(
        (x == y) | np.isclose(x, y, rtol=SAME_VALUE_RTOL, atol=0.0)))


def _check_model_file(name: str, recorded: dict[str, str] | None, given: dict[str, str],
                      refuse: Callable[[str, str], NoReturn]) -> None:
    """``--model NAME=FILE`` against the model file the training recorded for NAME."""
    option = setting("models", name)
    if recorded is not None and recorded["sha256"] == given["sha256"]:
        return
    # the same model spelled otherwise (comments, order, number spelling) is the same model;
    # a file given for a model the run did not replace must define the built-in one
    given_json = model_set(models={name: given["content"]},
                           option=setting("models")).to_json()[name]
    recorded_json = (model_set() if recorded is None
                     else model_set(models={name: recorded["content"]})).to_json()[name]
    if given_json == recorded_json:
        return
    if recorded is None:
        refuse(option, f"that run was trained with the built-in {name} model, not this model "
                       f"file (sha256 {given['sha256'][:12]})")
    refuse(option, f"that run was trained with another {name} model file (recorded sha256 "
                   f"{recorded['sha256'][:12]}, given {given['sha256'][:12]})")


def train_from_start(settings: TrainSettings, out: Path, plan: RecordPlan | None,
                     start: SessionStart, origin: dict[str, Any], *, models: ModelSet,
                     progress: bool = True, overwrite: bool = False) -> "Trainer":
    """A new one-trial training of ``settings`` into ``out`` whose first session starts from
    ``start`` (a session another training recorded); ``origin`` is what its manifest records
    of where that session comes from (``settings.replay_of``)."""
    return _train(settings, out, plan, None, progress, replace=overwrite, new=True,
                  models=models, start=(start, origin))


@exclusive  # the whole training in one hold: Brian2 is not thread-safe (network/runlock.py)
def _train(settings: TrainSettings, out: Path, plan: RecordPlan | None,
           payload: dict[str, Any] | None, progress: bool, replace: bool = False,
           new: bool = False, resumed: bool = False,
           models: ModelSet | None = None,
           start: tuple[SessionStart, dict[str, Any]] | None = None,
           extend_from: int | None = None, workers: int = 1) -> "Trainer":
    """Build, own ``out`` (a lock: one process per training folder), train, write. ``resumed``:
    the training continues, so what later commands derived from its earlier weights (figures/,
    evaluation/, videos, power estimates) is removed first (:func:`remove_derived`).
    ``models``: the set composed from ``settings`` when the caller has it already. ``start``:
    a one-trial training that replays a recorded session (its start, and what the manifest
    records of where it comes from: :mod:`astrocpg.studies.commands.replay`).
    ``extend_from``: the sessions per trial of ``payload``'s training, fewer than
    ``settings``' (:func:`resume` with more ``sessions``)."""
    if models is None:
        models = model_set(settings.overrides, settings.equations, models=settings.models,
                           added=population_models(settings.populations))
    batched = start is None and (payload is not None and "batches" in payload
                                 or payload is None and workers > 1 and settings.n_trials > 1)
    if batched:  # a network of one trial checks the models as the batches' will be built
        trainer: Any = Trainer(models, dataclasses.replace(settings, n_trials=1), out,
                               progress=False, record=plan)
    else:
        trainer = Trainer(models, settings, out, progress=progress, record=plan)  # validates
    if start is not None:
        trainer.training.begin_at(0, start[0])
    created = not os.path.lexists(out)
    try:
        out.mkdir(parents=True, exist_ok=True)
    except OSError as e:
        raise EnvironmentFault.from_os_error(e, out, "cannot create the folder") from None
    cleared = False
    try:
        with FolderLock(out, culprit=setting("out") if payload is None else setting("resume")):
            if replace:  # --overwrite: the old run goes whole, never mixed with the new one
                clear_folder(out, culprit=setting("out", out))
            elif new and holds_results(out):  # another process filled it since the check
                raise InputError(f"is not empty; {setting('overwrite')} replaces it whole",
                                 culprit=setting("out", out))
            clean_stale_temporaries(out)
            if resumed:  # made from the weights this run is about to change: stale from now on
                remove_derived(out)
            try:
                if batched:
                    return _train_batched_locked(trainer, settings, out, plan, payload, workers,
                                                 progress)
                return _train_locked(trainer, settings, out, plan, payload,
                                     replay_of=None if start is None else start[1],
                                     extend_from=extend_from)
            except InputError:
                # refused once it ran (a parameter whose arithmetic overflows at the first
                # step): a new training with no session done leaves nothing behind
                if payload is None and not batched and not trainer.training.sessions_done.any():
                    clear_folder(out)
                    cleared = True
                raise
    except InputError:
        if cleared and created:  # its lock files went with the lock
            try:
                os.rmdir(out)
            except OSError:
                pass
        raise


def _train_locked(trainer: "Trainer", settings: TrainSettings, out: Path,
                  plan: RecordPlan | None, payload: dict[str, Any] | None,
                  replay_of: dict[str, Any] | None = None,
                  extend_from: int | None = None) -> "Trainer":
    if payload is not None:
        trainer.restore(payload)
    if extend_from is not None:
        trainer.extend(extend_from)
    record_json = None if plan is None else dataclasses.asdict(plan)
    extra = {} if replay_of is None else {"replay_of": replay_of}
    manifest = dict(command="train", seed=settings.seed,
                    settings=settings.record() | {"record": record_json} | extra,
                    models_json=trainer.models.to_json(), files=TRAIN_FILES,
                    invocation={"sessions": settings.n_sessions})
    # the network's population rows (added ones included): the folder describes itself
    layout = {"layout": trainer.cpg.layout.to_json()}

    def progress_manifest() -> None:  # the inventory follows every checkpoint
        done = trainer.training.sessions_done.tolist()
        write_manifest(out, **manifest,
                       results={"status": "running", "sessions_done": done} | layout,
                       history=True)

    trainer.on_checkpoint = progress_manifest
    try:
        try:
            write_manifest(out, **manifest, results={"status": "running"} | layout, history=True)
            wall = trainer.run()  # raises TrainingStopped (files written) when interrupted
        except KeyboardInterrupt:  # outside the network's run: stopped all the same
            raise TrainingStopped(int(trainer.training.sessions_done.sum()),
                                  settings.n_trials * settings.n_sessions) from None
    except TrainingStopped as e:
        write_manifest(out, **manifest, results={"status": "interrupted", "error": str(e)} | layout,
                       history=True)
        raise
    except Diverged as e:
        write_manifest(out, **manifest, results={"status": "diverged", "error": e.line} | layout,
                       history=True)
        raise
    rows = trainer.training.memory.rows
    L_max = trainer.models.value("L_max")
    summary = train_summary(rows, settings.n_trials, L_max)
    trainer.summary = summary
    over = recorded_overflow(out)
    write_manifest(out, **manifest,
                   results={"status": "finished", "wall_seconds_last_invocation": wall,
                            "per_trial": summary["per_trial"]} | layout
                   | ({"trace_overflow": over} if over else {}), history=True)
    return trainer


def recorded_overflow(out: Path) -> dict[str, dict[str, Any]]:
    """``{recorded session folder: {trace: counts}}`` of the training's recordings whose
    traces overflowed float32 (their manifests say so), read from the folder so that it holds
    across resumes."""
    found: dict[str, dict[str, Any]] = {}
    for folder in sorted((out / "recordings").glob("trial*_session*")):
        manifest = read_manifest(folder) or {}
        over = (manifest.get("results") or {}).get("trace_overflow")
        if over:
            found[folder.name] = over
    return found


def _train_batched_locked(check: "Trainer", settings: TrainSettings, out: Path,
                          plan: RecordPlan | None, payload: dict[str, Any] | None,
                          workers: int, progress: bool) -> Any:
    """:func:`_train_locked` over ``workers`` processes (``train_batched.py``); ``check``: the
    one-trial trainer that checked the models. Returns what :meth:`Result.from_training`
    reads of a trainer (no live network: it stayed in the workers)."""
    import types

    from ...network.layout import Layout
    from .train_batched import run_batched_training

    record_json = None if plan is None else dataclasses.asdict(plan)
    manifest = dict(command="train", seed=settings.seed,
                    settings=settings.record() | {"record": record_json},
                    models_json=check.models.to_json(), files=TRAIN_FILES,
                    invocation={"sessions": settings.n_sessions})
    one = check.cpg.layout
    layout = {"layout": Layout(n_trials=settings.n_trials, pool_size=one.pool_size,
                               legs=one.legs, stages=one.stages,
                               populations=one.populations).to_json()}
    n_procs = min(workers, len(payload["batches"]) if payload else settings.n_trials)
    running = {"status": "running", "workers": n_procs} | layout

    def gathered(done: np.ndarray) -> None:  # the inventory follows every checkpoint
        write_manifest(out, **manifest, results=running | {"sessions_done": done.tolist()},
                       history=True)

    write_manifest(out, **manifest, results=running, history=True)
    try:
        wall, status, rows = run_batched_training(out, settings, plan, payload, workers,
                                                  progress, check.cpg.codegen,
                                                  float(check.cpg.dt), gathered)
    except KeyboardInterrupt:  # while the files were gathered: stopped all the same
        wall, status, rows = 0.0, "stopped", []
    done = len(rows)
    total = settings.n_trials * settings.n_sessions
    if status == "stopped" or (status == "finished" and done < total):
        error = str(TrainingStopped(done, total))
        write_manifest(out, **manifest, results={"status": "interrupted", "error": error,
                                                 "workers": n_procs} | layout, history=True)
        raise TrainingStopped(done, total)
    if status.startswith("diverged"):
        line = status.partition(": ")[2]
        write_manifest(out, **manifest, results={"status": "diverged", "error": line,
                                                 "workers": n_procs} | layout, history=True)
        raise Diverged(line)
    summary = train_summary(rows, settings.n_trials, check.models.value("L_max"))
    over = recorded_overflow(out)
    write_manifest(out, **manifest,
                   results={"status": "finished", "wall_seconds_last_invocation": wall,
                            "workers": n_procs, "per_trial": summary["per_trial"]} | layout
                   | ({"trace_overflow": over} if over else {}), history=True)
    return types.SimpleNamespace(cpg=types.SimpleNamespace(net=None), models=check.models,
                                 summary=summary, trainer=None)

