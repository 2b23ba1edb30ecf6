"""Gait learning: ``n_trials`` independent trials, each training for ``n_sessions`` sessions, in
one network. At session ends the folder gets, atomically: ``sessions.csv`` (one row per
trial and session), ``weights.npz`` (each trial's table after each session) and
``checkpoint.pkl`` (everything needed to continue exactly: Brian2 state and random state,
MuJoCo states, the session loop's memory): after the first session end, then spaced so that
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
import pickle
import re
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Callable

import mujoco
import numpy as np
from brian2 import Network, NetworkOperation, second
from tqdm.auto import tqdm

from ...coupling.assembly import build_closed_loop
from ...coupling.recorder import RecordPlan, SessionRecorder
from ...coupling.training import SESSION_COLUMNS, Training
from ...errors import Diverged, EnvironmentFault, InputError
from ...models import ModelSet
from ...network import codegen_target, interlimb_labels, run_network
from ..files.folder import (FolderLock, OutputFolder, clean_stale_temporaries, clear_folder,
                            as_path, holds_results, refuse_in_use)
from ..files.outputs import (atomic_write, read_manifest, save_npz, save_spikes_and_traces,
                             write_manifest)
from ..files.result import Result
from .resources import check_memory, estimate_bytes
from .settings import model_files_record, model_set, number, override_items, seed_number
from .simulate import check_selection

CHECKPOINT = "checkpoint.pkl"
# Writing the outputs and the checkpoint costs time that grows with the sessions done (20 trials
# x 400 sessions: about 0.2 s a write, and with 20 trials a session ends about twice per
# simulated second). So after a write the next one waits CHECKPOINT_SPACING times as long as it
# took: at most 1 / (1 + CHECKPOINT_SPACING) of the wall time goes to writing, a small training
# still writes at about every session end, the first session end and the last are always written.
CHECKPOINT_SPACING = 49.0
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
    # model -> {"sha256", "content"} of a model file (TOML)
    models: dict[str, dict[str, str]] = field(default_factory=dict)

    def fingerprint(self) -> str:
        text = repr((self.n_sessions, self.seed, self.n_trials, self.astrocytes,
                     sorted(self.overrides), sorted(self.equations.items()))
                    + ((sorted((k, v["sha256"]) for k, v in self.models.items()),)
                       if self.models else ()))
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

        folder = self.out / "recordings" / f"trial{trial:02d}_session{session:04d}"
        folder.mkdir(parents=True, exist_ok=True)
        files = save_spikes_and_traces(folder, arrays["spikes"], arrays["traces"])
        robot = {k: (v if k == "t" else v[None]) for k, v in arrays["robot"].items()}
        save_npz(folder / "robot.npz", robot | {"legs": np.array(list(self.cpg.layout.legs)),
                                                "joints": np.array(["hip", "thigh", "calf"])})
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
                                                   "(1, t, xyz); torso_quaternion (1, t, "
                                                   "wxyz)"},
                       results={"layout": layout.to_json(), "dt_s": float(self.cpg.dt)})

    def write_outputs(self) -> None:
        rows = self.training.memory.rows
        buf = io.StringIO()
        writer = csv.DictWriter(buf, fieldnames=SESSION_COLUMNS, lineterminator="\n", restval=0)
        writer.writeheader()
        for r in rows:
            writer.writerow({k: (f"{v:.9g}" if isinstance(v, float) else v) for k, v in r.items()})
        data = buf.getvalue().encode()
        atomic_write(self.out / "sessions.csv", lambda f: f.write(data))
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
            "memory": tr.memory,
        }
        if self.recorder is not None:
            payload["record_plan"] = dataclasses.asdict(self.record)
            payload["recorder"] = self.recorder.state()
        body = pickle.dumps(payload, protocol=pickle.HIGHEST_PROTOCOL)
        digest = hashlib.sha256(body).hexdigest().encode() + b"\n"
        atomic_write(self.out / CHECKPOINT, lambda f: (f.write(MAGIC), f.write(digest), f.write(body)))

    def restore(self, payload: dict[str, Any]) -> None:
        # an exact resume needs the target the training started with (_same_codegen)
        _same_codegen(payload.get("codegen", "numpy"), self.cpg.codegen)
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

    # ---- run
    def run(self) -> float:
        """Run until every trial has done its sessions and write the outputs; returns wall
        seconds. Raises :class:`TrainingStopped` (outputs written; the checkpoint at the step
        the stop was asked in, or if it came after that step's write, the last one) when the
        simulation ended first: Brian2 turns Ctrl-C into a request to stop the run. A
        divergence raises :class:`~astrocpg.errors.Diverged` itself (outputs written, the
        diverged session's row last; the checkpoint stays as last written)."""
        L_max = float(np.asarray(self.models.progress.parameters["L_max"].value))
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


_CLOCK = re.compile(r"^(.*_clock)(_\d+)?$")


def _same_codegen(started: str, now: str) -> None:
    """A training continues under the Brian2 target it started with (checkpoints written before
    targets were recorded: numpy). The targets draw the same noise, but C's and numpy's
    floating point can part after many sessions: an exact resume needs the same one."""
    if started != now:
        raise InputError(f"this training started with Brian2's {started} target and continues "
                         f"only with it (now: {now}); resume with --codegen {started}",
                         culprit="--codegen")


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
        raise InputError(f"cannot read {path} ({e.strerror})", culprit=f"--resume") from None
    if not raw.startswith(MAGIC):
        raise InputError(f"{path} is not an astrocpg checkpoint", culprit=f"--resume")
    rest = raw[len(MAGIC):]
    digest, _, body = rest.partition(b"\n")
    if hashlib.sha256(body).hexdigest().encode() != digest:
        raise InputError(f"{path} is corrupt (checksum mismatch)", culprit=f"--resume")
    try:
        return pickle.loads(body)
    except Exception:
        raise InputError(f"{path} is corrupt (cannot be read)", culprit=f"--resume") from None


TRAIN_FILES = {
    "sessions.csv": "one row per trial and session: " + ", ".join(SESSION_COLUMNS),
    "weights.npz": "weights_mV (trial, session, 8, 8): each trial's inter-limb table after "
                   "each session (NaN after a trial's last); final_weights_mV; labels",
    "checkpoint.pkl": "state to continue exactly (astrocpg train --resume DIR)",
    "recordings/": "with --record-every: trialTT_sessionSSSS/ per recorded session (spikes, "
                   "traces, robot, manifest; astrocpg export reads it)",
}


def record_plan(every: int | None, stride: int = 1, spikes: tuple[str, ...] | None = None,
                traces: tuple[str, ...] | None = None,
                stored: dict[str, Any] | None = None) -> RecordPlan | None:
    """The training's RecordPlan: from the options, or (resuming) the checkpoint's ``stored``."""
    if stored is not None:
        if every is not None and every != stored["every"]:
            raise InputError(f"that run records every {stored['every']} sessions, not {every}",
                             culprit="--record-every")
        return RecordPlan.from_dict(stored)
    if every is None:
        if spikes is not None or traces is not None:
            raise InputError("a training records spikes and traces only with --record-every N",
                             culprit="--spikes/--traces")
        return None
    if every < 1:
        raise InputError(f"must be at least 1, got {every}", culprit="--record-every")
    if stride < 1:
        raise InputError(f"must be at least 1, got {stride}", culprit="--record-stride")
    spikes, traces = check_selection(spikes, traces)
    return RecordPlan(every=every, spikes=spikes, traces=traces, stride=stride)


def format_train(result: Result) -> list[str]:
    """One line per trial of a training's summary: sessions, speed, share of full sessions."""
    lines = []
    for b, x in sorted((result.summary.get("per_trial") or {}).items(), key=lambda kv: int(kv[0])):
        lines.append(f"trial {b}: {x['sessions']} sessions; mean forward speed over the last "
                     f"20: {x['mean_speed_last20_m_per_s']:.3f} m/s; sessions reaching L_max in "
                     f"the last 50: {x['full_length_share_last50']:.0%}")
    return lines


def train_summary(rows: list[dict], n_trials: int, L_max: float) -> dict[str, Any]:
    """Per trial: sessions done, mean forward speed over the last 20, share of the last 50
    sessions that reached L_max; and a printable line per trial."""
    per_trial: dict[int, dict[str, float]] = {}
    lines: dict[int, str] = {}
    for b in range(n_trials):
        mine = [r for r in rows if r["trial"] == b]
        if not mine:
            continue
        last20, last50 = mine[-20:], mine[-50:]
        speed = float(np.mean([r["mean_forward_speed_m_per_s"] for r in last20]))
        full = float(np.mean([r["length_s"] >= L_max - 1e-6 for r in last50]))
        per_trial[b] = {"sessions": len(mine), "mean_speed_last20_m_per_s": speed,
                        "full_length_share_last50": full}
        lines[b] = (f"trial {b}: {len(mine)} sessions; mean forward speed over the last 20: "
                    f"{speed:.3f} m/s; sessions reaching L_max in the last 50: {full:.0%}")
    return {"per_trial": per_trial, "lines": lines}


def train(*, out: str | Path, sessions: int = 400, seed: int = 1, trials: int = 1,
          astrocytes: bool = True, overrides: Any = None,
          equations: dict[str, str] | None = None, models: dict[str, str] | None = None,
          record_every: int | None = None,
          record_stride: int = 1, spikes: tuple[str, ...] | None = None,
          traces: tuple[str, ...] | None = None, overwrite: bool = False,
          progress: bool = True) -> Result:
    """Train ``trials`` independent trials (seeds seed, seed+1, ...) for ``sessions`` sessions
    each, writing ``out`` (sessions.csv, weights.npz, checkpoint.pkl, manifest.json) after every
    session: what ``astrocpg train`` runs. ``astrocytes=False`` is the paper's ablation;
    overrides/equations as for :func:`~astrocpg.studies.experiments.run.run` (e.g.
    ``["L_max=0.5*second"]`` for short sessions). ``record_every=N`` records sessions 1, 1+N,
    ... and each trial's last into ``out/recordings/`` (``record_stride`` steps between trace
    and robot samples; ``spikes``/``traces`` pick what).

    Returns a :class:`~astrocpg.studies.files.result.Result` of kind "train", read back from
    ``out`` (``sessions`` DataFrame, ``weights`` (trial, session, 8, 8) mV, ``recording(trial,
    session)``), with the live ``network`` and ``trainer`` (the :class:`Trainer`:
    ``trainer.training.memory.rows``, ``trainer.cpg``). Raises TrainingStopped if interrupted
    (continue with :func:`resume`)."""
    n_trials = number(trials, "--trials", integer=True, minimum=1)
    settings = TrainSettings(
        n_sessions=number(sessions, "--sessions", integer=True, minimum=1),
        seed=seed_number(seed, trials=n_trials), n_trials=n_trials,
        astrocytes=bool(astrocytes), overrides=override_items(overrides),
        equations=dict(equations or {}), models=model_files_record(models))
    model_set(settings.overrides, settings.equations, models=settings.models)  # before any file
    out = as_path(out, "--out")
    if (out / CHECKPOINT).exists() and not overwrite:
        raise InputError(f"already holds a training run (continue it with --resume {out}, or "
                         f"replace it with --overwrite)", culprit=f"--out {out}")
    OutputFolder(out, overwrite=overwrite).check()
    plan = record_plan(record_every, record_stride, spikes, traces)
    check_memory(estimate_bytes(trials=settings.n_trials, seconds=0.0, spikes=False,
                                sessions=settings.n_sessions),
                 culprit=f"--sessions {settings.n_sessions} x --trials {settings.n_trials}")
    return Result.from_training(_train(settings, out, plan, None, progress, replace=overwrite,
                                       new=True), out)


def resume(folder: str | Path, *, progress: bool = True, record_every: int | None = None,
           expect: dict[str, Any] | None = None) -> Result:
    """Continue the training in ``folder`` from its checkpoint (``astrocpg train --resume``)
    and end with the same files as a training never interrupted; ``expect`` (e.g. the options
    given again on the command line) must agree with the stored settings. Returns the
    training's Result, like :func:`train`."""
    out = as_path(folder, "--resume")
    # a training (or a study's run) that another process is training now: its files are in
    # flux and its lock is that process's, whatever they say
    refuse_in_use(out, culprit=f"--resume {out}")
    if not (out / CHECKPOINT).exists():
        # stopped before its first checkpoint: nothing was trained, so start again from the
        # settings its manifest recorded
        manifest = read_manifest(out)
        if manifest is None or manifest.get("astrocpg_command") != "train":
            raise InputError("holds no training (no checkpoint.pkl, no training manifest)",
                             culprit=f"--resume {out}")
        stored_settings = {k: v for k, v in manifest["settings"].items() if k != "record"}
        payload = {"settings": stored_settings, "record_plan": manifest["settings"].get("record")}
        settings = TrainSettings(**stored_settings)
        payload["fingerprint"] = settings.fingerprint()
        fresh = True
    else:
        payload = read_checkpoint(out / CHECKPOINT)
        settings = TrainSettings(**payload["settings"])
        fresh = False
    if payload["fingerprint"] != settings.fingerprint():
        raise InputError(f"{out / CHECKPOINT} is not consistent with its settings",
                         culprit="--resume")
    stored = {"sessions": settings.n_sessions, "seed": settings.seed,
              "trials": settings.n_trials, "astrocytes": settings.astrocytes,
              "overrides": sorted(settings.overrides), "equations": settings.equations,
              "models": settings.models}
    for key, value in (expect or {}).items():
        if value is not None and value != stored[key]:
            if key in ("overrides", "equations", "models"):
                files = (f"; model files: {', '.join(sorted(settings.models))}"
                         if settings.models else "")
                raise InputError(f"that run has other model settings "
                                 f"({', '.join(settings.overrides) or 'defaults'}{files})",
                                 culprit=f"--resume {out}")
            raise InputError(f"that run has {key}={stored[key]}, not {value}",
                             culprit=f"--resume {out}")
    if not fresh:
        _same_codegen(payload.get("codegen", "numpy"), codegen_target())
    if not fresh and bool(np.all(np.asarray(payload["training"]["sessions_done"])
                                 >= settings.n_sessions)):
        raise InputError(f"the training is already finished ({settings.n_sessions} sessions per "
                         f"trial); nothing was changed", culprit=f"--resume {out}")
    plan = record_plan(record_every, stored=payload.get("record_plan"))
    if plan is None and record_every is not None:
        raise InputError("that run records no sessions", culprit="--record-every")
    return Result.from_training(_train(settings, out, plan, None if fresh else payload,
                                       progress), out)


def _train(settings: TrainSettings, out: Path, plan: RecordPlan | None,
           payload: dict[str, Any] | None, progress: bool, replace: bool = False,
           new: bool = False) -> "Trainer":
    """Build, own ``out`` (a lock: one process per training folder), train, write."""
    models = model_set(settings.overrides, settings.equations, models=settings.models)
    trainer = Trainer(models, settings, out, progress=progress, record=plan)  # validates
    try:
        out.mkdir(parents=True, exist_ok=True)
    except OSError as e:
        raise EnvironmentFault.from_os_error(e, out, "cannot create the folder") from None
    with FolderLock(out, culprit="--out" if payload is None else "--resume"):
        if replace:  # --overwrite: the old run goes whole, never mixed with the new one
            clear_folder(out)
        elif new and holds_results(out):  # another process filled it since the first check
            raise InputError("is not empty; --overwrite replaces it whole",
                             culprit=f"--out {out}")
        clean_stale_temporaries(out)
        return _train_locked(trainer, settings, out, plan, payload)


def _train_locked(trainer: "Trainer", settings: TrainSettings, out: Path,
                  plan: RecordPlan | None, payload: dict[str, Any] | None) -> "Trainer":
    if payload is not None:
        trainer.restore(payload)
    record_json = None if plan is None else dataclasses.asdict(plan)
    manifest = dict(command="train", seed=settings.seed,
                    settings=settings.__dict__ | {"record": record_json},
                    models_json=trainer.models.to_json(), files=TRAIN_FILES)

    def progress_manifest() -> None:  # the inventory follows every checkpoint
        done = trainer.training.sessions_done.tolist()
        write_manifest(out, **manifest, results={"status": "running", "sessions_done": done},
                       history=True)

    trainer.on_checkpoint = progress_manifest
    try:
        try:
            write_manifest(out, **manifest, results={"status": "running"}, history=True)
            wall = trainer.run()  # raises TrainingStopped (files written) when interrupted
        except KeyboardInterrupt:  # outside the network's run: stopped all the same
            raise TrainingStopped(int(trainer.training.sessions_done.sum()),
                                  settings.n_trials * settings.n_sessions) from None
    except TrainingStopped as e:
        write_manifest(out, **manifest, results={"status": "interrupted", "error": str(e)},
                       history=True)
        raise
    except Diverged as e:
        write_manifest(out, **manifest, results={"status": "diverged", "error": e.line},
                       history=True)
        raise
    rows = trainer.training.memory.rows
    L_max = float(np.asarray(trainer.models.progress.parameters["L_max"].value))
    summary = train_summary(rows, settings.n_trials, L_max)
    trainer.summary = summary
    write_manifest(out, **manifest,
                   results={"status": "finished", "wall_seconds_last_invocation": wall,
                            "per_trial": summary["per_trial"]}, history=True)
    return trainer
