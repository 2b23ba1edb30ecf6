"""Gait learning: ``n_trials`` independent trials, each training for ``n_sessions`` sessions, in
one network. After every session the folder gets, atomically: ``sessions.csv`` (one row per
trial and session), ``weights.npz`` (each trial's table after each session) and
``checkpoint.pkl`` (everything needed to continue exactly: Brian2 state and random state,
MuJoCo states, the session loop's memory). ``resume`` continues a killed run and ends with the
same files as a run never interrupted.
"""

from __future__ import annotations

import csv
import dataclasses
import hashlib
import io
import pickle
import re
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import mujoco
import numpy as np
from brian2 import NetworkOperation, second
from tqdm.auto import tqdm

from ..coupling.assembly import build_closed_loop
from ..coupling.recorder import RecordPlan, SessionRecorder
from ..coupling.training import SESSION_COLUMNS, Training
from ..errors import InputError
from ..models import ModelSet
from ..network import interlimb_labels, run_network
from .outputs import _atomic, save_npz

CHECKPOINT = "checkpoint.pkl"
MAGIC = b"ASTROCPG-CHECKPOINT-1\n"


@dataclass
class TrainSettings:
    """What defines a training run (a resumed run must have the same)."""

    n_sessions: int
    seed: int
    n_trials: int
    astrocytes: bool
    overrides: list[str] = field(default_factory=list)
    equations: dict[str, str] = field(default_factory=dict)  # model -> equation text

    def fingerprint(self) -> str:
        text = repr((self.n_sessions, self.seed, self.n_trials, self.astrocytes,
                     sorted(self.overrides), sorted(self.equations.items())))
        return hashlib.sha256(text.encode()).hexdigest()


class TrainingStopped(RuntimeError):
    """The simulation ended before every session was done (e.g. Ctrl-C)."""

    def __init__(self, done: int, total: int) -> None:
        super().__init__(f"stopped after {done} of {total} sessions (interrupted)")
        self.done, self.total = done, total


class Trainer:
    """Builds the network, robot, bridge and session loop; runs; checkpoints; resumes."""

    def __init__(self, models: ModelSet, settings: TrainSettings, out: Path,
                 progress: bool = True, record: RecordPlan | None = None) -> None:
        self.settings, self.out = settings, out
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
        if record is not None:
            self.recorder = SessionRecorder(
                self.cpg, self.bridge, record, n_sessions=settings.n_sessions,
                max_steps=self.training.max_steps,
                step_in_session=self.training.step_in_session, on_recorded=self._write_recording)
        # after the weight update of the step (interlimb_learning, order 10)
        self.cpg.net.add(NetworkOperation(self._maybe_checkpoint, dt=self.cpg.dt, when="end",
                                          order=20, name="checkpoint"))
        self._pending = False
        total = settings.n_sessions * settings.n_trials
        self.bar = tqdm(total=total, unit="session", desc="train", disable=not progress,
                        dynamic_ncols=True)

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
        if self._pending:
            self._pending = False
            self.write_outputs()
            self.write_checkpoint()

    # ---- files
    def _write_recording(self, trial: int, session: int, arrays: dict[str, Any]) -> None:
        """One recorded session as a folder that ``astrocpg export`` reads like a run."""
        from ..network import Layout
        from .outputs import save_npz, save_spikes_and_traces, write_manifest

        folder = self.out / "recordings" / f"trial{trial:02d}_session{session:04d}"
        folder.mkdir(parents=True, exist_ok=True)
        files = save_spikes_and_traces(folder, arrays["spikes"], arrays["traces"])
        robot = {k: (v if k == "t" else v[None]) for k, v in arrays["robot"].items()}
        save_npz(folder / "robot.npz", robot | {"legs": np.array(list(self.cpg.layout.legs)),
                                                "joints": np.array(["hip", "thigh", "calf"])})
        from .cli import _layout_json
        layout = Layout(n_trials=1, pool_size=self.cpg.layout.pool_size,
                        legs=self.cpg.layout.legs)
        write_manifest(folder, command="train-session", seed=self.settings.seed + trial,
                       settings={"training": str(self.out), "trial": trial, "session": session,
                                 "record": dataclasses.asdict(self.record),
                                 "overrides": list(self.settings.overrides),
                                 "astrocytes": self.settings.astrocytes,
                                 "seconds": self.training.memory.rows[-1]["length_s"]},
                       models_json=self.models.to_json(),
                       files=files | {"robot.npz": "t (s); joint_angles, torques (1, t, leg, "
                                                   "joint); torso_position, torso_velocity "
                                                   "(1, t, xyz)"},
                       results={"layout": _layout_json(layout), "dt_s": float(self.cpg.dt)})

    def write_outputs(self) -> None:
        rows = self.training.memory.rows
        buf = io.StringIO()
        writer = csv.DictWriter(buf, fieldnames=SESSION_COLUMNS, lineterminator="\n", restval=0)
        writer.writeheader()
        for r in rows:
            writer.writerow({k: (f"{v:.9g}" if isinstance(v, float) else v) for k, v in r.items()})
        data = buf.getvalue().encode()
        _atomic(self.out / "sessions.csv", lambda f: f.write(data))
        mem = self.training.memory
        n_max = max(len(w) for w in mem.weights)
        table = np.full((self.settings.n_trials, n_max, 8, 8), np.nan)
        for b, ws in enumerate(mem.weights):
            if ws:
                table[b, :len(ws)] = np.array(ws) * 1e3
        save_npz(self.out / "weights.npz", {
            "weights_mV": table, "sessions_done": self.training.sessions_done.copy(),
            "final_weights_mV": self.cpg.interlimb_weights() * 1e3,
            "labels": np.array(interlimb_labels()),
        })

    def write_checkpoint(self) -> None:
        net = self.cpg.net
        net.store("checkpoint")
        brian_state = net._stored_state.pop("checkpoint")
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
            "settings": self.settings.__dict__,
            "brian": brian_state,
            "mujoco": mj,
            "bridge": {k: getattr(br, k).copy() for k in
                       ("qpos", "qvel", "hip_integral", "ctrl", "reward", "alive")}
            | {"step_count": br.step_count},
            "training": {k: getattr(tr, k).copy() for k in
                         ("step_in_session", "non_alive", "ring", "ring_sum", "reward_sum",
                          "speed_sum", "pool_counts", "count_base_in", "count_base_ado",
                          "sessions_done", "done", "progress", "t_learning_start")},
            "memory": tr.memory,
        }
        if self.recorder is not None:
            payload["record_plan"] = dataclasses.asdict(self.record)
            payload["recorder"] = self.recorder.state()
        body = pickle.dumps(payload, protocol=pickle.HIGHEST_PROTOCOL)
        digest = hashlib.sha256(body).hexdigest().encode() + b"\n"
        _atomic(self.out / CHECKPOINT, lambda f: (f.write(MAGIC), f.write(digest), f.write(body)))

    def restore(self, payload: dict[str, Any]) -> None:
        net = self.cpg.net
        net._stored_state["checkpoint"] = _rename_clocks(payload["brian"], net)
        net.restore("checkpoint", restore_random_state=True)
        del net._stored_state["checkpoint"]
        spec = mujoco.mjtState.mjSTATE_INTEGRATION
        for d, s in zip(self.bridge.data, payload["mujoco"]):
            mujoco.mj_setState(self.robot, d, s, spec)
        for k, v in payload["bridge"].items():
            if k == "step_count":
                self.bridge.step_count = v
            else:
                getattr(self.bridge, k)[...] = v
        for k, v in payload["training"].items():
            getattr(self.training, k)[...] = v
        self.training.memory = payload["memory"]
        if self.recorder is not None and "recorder" in payload:
            self.recorder.restore(payload["recorder"])
        self.bar.update(int(self.training.sessions_done.sum()))

    # ---- run
    def run(self) -> float:
        """Run until every trial has done its sessions and write the outputs; returns wall
        seconds. Raises :class:`TrainingStopped` (outputs and checkpoint written) when the
        simulation ended first: Brian2 turns Ctrl-C into a request to stop the run. A
        divergence raises :class:`~astrocpg.errors.Diverged` itself, the diverged session's
        row in ``training.memory`` (outputs not written: :meth:`write_outputs`)."""
        import time
        L_max = float(np.asarray(self.models.progress.parameters["L_max"].value))
        left = (self.settings.n_sessions - self.training.sessions_done.min()) * L_max
        t0 = time.perf_counter()
        try:
            if not self.training.done.all():
                # an upper bound: the session loop stops the network when all trials are done
                run_network(self.cpg.net, (left + 1.0) * second, namespace={})
        finally:
            self.bar.close()
        self.write_outputs()
        if not self.training.done.all():
            raise TrainingStopped(int(self.training.sessions_done.sum()),
                                  self.settings.n_trials * self.settings.n_sessions)
        return time.perf_counter() - t0


_CLOCK = re.compile(r"^(.*_clock)(_\d+)?$")


def _rename_clocks(state: dict[str, Any], net) -> dict[str, Any]:
    """Brian2 names the clock of an object with its own ``dt`` ``<object>_clock``, plus a
    suffix (``_1``...) if that name was taken earlier in the process, so a checkpoint written
    by one process may name the clocks differently from the network rebuilt in another (a Dask
    worker that trained other runs before). Object names are fixed; match clocks by stem."""
    from brian2.core.network import _get_all_objects

    current = {_CLOCK.sub(r"\1", obj.clock.name): obj.clock.name
               for obj in _get_all_objects(net.objects)}
    out = {}
    for key, value in state.items():
        m = _CLOCK.match(key)
        out[current.get(m.group(1), key) if m else key] = value
    return out


def read_checkpoint(path: Path) -> dict[str, Any]:
    """Load and verify a checkpoint; a corrupt or foreign file is an ``InputError``."""
    try:
        raw = path.read_bytes()
    except OSError as e:
        raise InputError(f"--resume: cannot read {path} ({e.strerror})") from None
    if not raw.startswith(MAGIC):
        raise InputError(f"--resume: {path} is not an astrocpg checkpoint")
    rest = raw[len(MAGIC):]
    digest, _, body = rest.partition(b"\n")
    if hashlib.sha256(body).hexdigest().encode() != digest:
        raise InputError(f"--resume: {path} is corrupt (checksum mismatch)")
    try:
        return pickle.loads(body)
    except Exception:
        raise InputError(f"--resume: {path} is corrupt (cannot be read)") from None
