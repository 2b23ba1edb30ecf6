"""A training split over worker processes (``workers``).

The trials split into contiguous batches (:func:`~astrocpg.studies.runtime.workers.split_trials`);
each worker trains its batch session by session with the one-process :class:`~.trainer.Trainer`
(seed ``seed + first``: a trial is the same in any batch) in a folder of its own under the
training's ``.workers/``, checkpointing as a training does, its recorded sessions written
straight into the training's ``recordings/`` under their trials' numbers. The parent gathers
the batches' session memories from their checkpoints, as they are written, into the
training's ``sessions.csv``, ``weights.npz`` and ``session_starts.npz`` (rows in the order one
network ends them: by the step a session ended, then by trial) and packs the batches'
checkpoints into the training's ``checkpoint.npz`` (:func:`packed_payload`), from which
a resume continues every batch where its checkpoint left it.

When every batch has finished, those three files are the one-process training's, byte for byte,
and so are the recordings; the manifest differs in its timings and worker count. The packed
``checkpoint.npz`` differs (it holds one network state per batch). A resume with more
``sessions`` extends each batch as one network extends its trials (a trial that ran idle in its
batch refuses it, as in one network). A batch that diverges stops the others: the folder keeps
the sessions so far and says it diverged.
"""

from __future__ import annotations

import dataclasses
import math
import shutil
import time
from pathlib import Path
from typing import Any, Callable

import numpy as np

from ...errors import Diverged, EnvironmentFault, InputError

#: The batches' own folders, inside the training's, while it trains.
WORK = ".workers"


class _BatchEnded(Exception):
    """A batch ended without finishing (stopped, or diverged): the others are stopped."""

    def __init__(self, outcome: dict[str, Any]) -> None:
        super().__init__(outcome.get("line") or outcome["status"])
        self.outcome = outcome


def train_batch(spec: dict[str, Any], first: int, count: int, folder: str,
                payload: dict[str, Any] | None) -> dict[str, Any]:
    """Trials ``[first, first + count)`` of the training ``spec`` in this process, into
    ``folder`` (its sessions.csv, weights.npz, checkpoint.npz...), from ``payload`` (a batch
    checkpoint's) when given. Returns ``{"status": "finished" | "stopped" | "diverged"}``."""
    from ...coupling.recorder import RecordPlan
    from ...models.compose import model_set
    from ..settings import TrainSettings
    from ..settings.populations import population_models
    from .trainer import Trainer, TrainingStopped

    settings = TrainSettings(**spec["settings"])
    batch = dataclasses.replace(settings, seed=settings.seed + first, n_trials=count)
    plan = None if spec["plan"] is None else RecordPlan.from_dict(spec["plan"])
    # the training's models, its added populations' too (its overrides may set theirs)
    models = model_set(settings.overrides, settings.equations, models=settings.models,
                       added=population_models(settings.populations))
    Path(folder).mkdir(parents=True, exist_ok=True)
    trainer = Trainer(models, batch, Path(folder), progress=False, record=plan,
                      trial_offset=first, folder=Path(spec["out"]))
    if payload is not None:
        trainer.restore(payload)
        trained_to = int(payload["settings"]["n_sessions"])
        if trained_to < batch.n_sessions:  # an extension (more sessions): as one network
            trainer.extend(trained_to)
    try:
        trainer.run()
    except TrainingStopped:
        return {"status": "stopped"}
    except Diverged as e:  # the sessions so far and the diverged one, for the files
        from .train_state import memory_state
        return {"status": "diverged", "line": e.line,
                "memory": memory_state(trainer.training.memory,
                                       trainer.cpg.interlimb_weights().shape[1:])}
    return {"status": "finished"}


def packed_payload(settings: Any, plan: dict[str, Any] | None, codegen: str,
                   batches: list[tuple[int, int, dict[str, Any] | None]]) -> dict[str, Any]:
    """The training's checkpoint payload of batches ``(first, count, payload or None)``:
    the training's settings and sessions done, each batch's own checkpoint payload."""
    done = np.concatenate([np.zeros(n, dtype=np.int64) if p is None
                           else np.asarray(p["training"]["sessions_done"], dtype=np.int64)
                           for _, n, p in batches])
    out = {"fingerprint": settings.fingerprint(), "settings": settings.record(),
           "codegen": codegen, "training": {"sessions_done": done},
           "batches": [{"first": a, "count": n, "payload": p} for a, n, p in batches]}
    if plan is not None:
        out["record_plan"] = plan
    return out


def merged_memory(batches: list[tuple[int, int, dict[str, Any] | None]], dt: float) -> Any:
    """The batches' session memories as one training's: per trial in trial order, the rows in
    the order one network appends them (the step each session ended, then the trial)."""
    from ...coupling.training import SessionMemory
    from .train_state import memory_from_state

    lengths: list = []
    weights: list = []
    starts: list = []
    keyed = []
    for first, count, payload in batches:
        if payload is None:
            mem = SessionMemory(lengths=[[] for _ in range(count)],
                                weights=[[] for _ in range(count)],
                                starts=[[] for _ in range(count)])
        else:
            mem = memory_from_state(payload["memory"], count)
        lengths += mem.lengths
        weights += mem.weights
        starts += mem.starts
        ended = [0] * count
        for row in mem.rows:
            b = int(row["trial"])
            ended[b] += int(round(float(row["length_s"]) / dt))
            keyed.append(((ended[b], first + b), dict(row, trial=first + b)))
    keyed.sort(key=lambda x: x[0])
    return SessionMemory(lengths=lengths, weights=weights, rows=[r for _, r in keyed],
                         starts=starts)


class Gatherer:
    """The parent's side: reads the batches' checkpoints when they change and writes the
    training's files and packed checkpoint from them (at most 1 / (1 + CHECKPOINT_SPACING)
    of the wall time, always on :meth:`gather` with ``force``)."""

    def __init__(self, out: Path, settings: Any, plan: dict[str, Any] | None, codegen: str,
                 spans: list[tuple[int, int]], previous: list[dict[str, Any] | None],
                 dt: float, on_gathered: Callable[[np.ndarray], None]) -> None:
        self.out, self.settings, self.plan, self.codegen = out, settings, plan, codegen
        self.spans, self.previous, self.dt = spans, previous, dt
        self.on_gathered = on_gathered
        self.seen: list[Any] = [None] * len(spans)
        self.rows: list[dict[str, Any]] = []  # the training's session rows, last gathered
        self.next_at = -math.inf

    def folder(self, k: int) -> Path:
        return self.out / WORK / f"batch{self.spans[k][0]:04d}"

    def poll(self) -> None:
        now = time.monotonic()
        if now >= self.next_at and self._changed():
            self.gather()
            done = time.monotonic()
            from .trainer import CHECKPOINT_SPACING
            self.next_at = done + CHECKPOINT_SPACING * (done - now)

    def _stamps(self) -> list[Any]:
        stamps = []
        for k in range(len(self.spans)):
            try:
                st = (self.folder(k) / "checkpoint.npz").stat()
                stamps.append((st.st_mtime_ns, st.st_size))
            except OSError:
                stamps.append(None)
        return stamps

    def _changed(self) -> bool:
        return self._stamps() != self.seen

    def gather(self, memories: dict[int, dict[str, Any]] | None = None) -> np.ndarray | None:
        """Write the training's files from the batches' latest checkpoints (batch ``k``'s
        session memory from ``memories[k]`` where given: a batch that diverged, whose
        checkpoint stays as last written); returns the sessions done per trial (None when no
        batch has a checkpoint or a memory and none was resumed)."""
        from .train_files import write_training_files
        from .train_state import CHECKPOINT, read_checkpoint, write_payload

        self.seen = self._stamps()
        batches = []
        for k, (first, count) in enumerate(self.spans):
            path = self.folder(k) / CHECKPOINT
            payload = read_checkpoint(path) if path.exists() else self.previous[k]
            batches.append((first, count, payload))
        memories = memories or {}
        rows = [(a, n, memories[k] if k in memories else p)
                for k, (a, n, p) in enumerate(batches)]
        if all(p is None for _, _, p in rows):
            return None
        mem = merged_memory(rows, self.dt)
        self.rows = mem.rows
        done = np.asarray([len(x) for x in mem.lengths], dtype=np.int64)
        final = np.concatenate([self._final_weights(k, n, p)
                                for k, (_, n, p) in enumerate(rows)])
        write_training_files(self.out, mem, done, final, self.settings.n_trials)
        if any(p is not None for _, _, p in batches):
            packed = packed_payload(self.settings, self.plan, self.codegen, batches)
            write_payload(self.out / CHECKPOINT, packed)
        self.on_gathered(done)
        return done

    def _final_weights(self, k: int, count: int, payload: dict[str, Any] | None) -> np.ndarray:
        """Batch ``k``'s tables (mV) as its weights.npz last gave them."""
        path = self.folder(k) / "weights.npz"
        if path.exists():
            with np.load(path, allow_pickle=False) as f:
                return np.asarray(f["final_weights_mV"])
        if payload is not None and len(payload["memory"]["weights"]):
            return np.stack([np.asarray(w)[-1] * 1e3 if len(w) else np.zeros((8, 8))
                             for w in payload["memory"]["weights"]])
        return np.zeros((count, 8, 8))


def remove_work(out: Path) -> None:
    """The batches' folders, once the training's files hold what they had."""
    work = out / WORK
    if work.exists():
        try:
            shutil.rmtree(work)
        except OSError as e:
            raise EnvironmentFault.from_os_error(e, work, "cannot remove") from None


def run_batched_training(out: Path, settings: Any, plan: Any, payload: dict[str, Any] | None,
                         workers: int, progress: bool, codegen: str, dt: float,
                         on_gathered: Callable[[np.ndarray], None]
                         ) -> tuple[float, str, list[dict[str, Any]]]:
    """Train ``settings`` into ``out`` over ``workers`` processes (from the packed ``payload``
    when resuming). Returns (wall seconds, status: "finished", "stopped" or the diverged
    line prefixed "diverged: ") and the session rows; the training's files are written
    whatever the status."""
    from ..runtime.workers import run_batches, split_trials
    from .batched import QuietBar

    if payload is not None:
        spans = [(int(b["first"]), int(b["count"])) for b in payload["batches"]]
        previous = [b["payload"] for b in payload["batches"]]
    else:
        spans = split_trials(settings.n_trials, workers)
        previous = [None] * len(spans)
    plan_json = None if plan is None else dataclasses.asdict(plan)
    remove_work(out)
    total = settings.n_trials * settings.n_sessions
    bar = QuietBar(total=total, unit="session",
                   desc=f"train ({min(workers, len(spans))} processes)",
                   disable=not progress, dynamic_ncols=True)

    def gathered(done: np.ndarray) -> None:
        bar.update(int(done.sum()) - bar.n)
        on_gathered(done)

    gatherer = Gatherer(out, settings, plan_json, codegen, spans, previous, dt, gathered)
    spec = {"settings": settings.record(), "plan": plan_json, "out": str(out)}
    calls = [(spec, a, n, str(gatherer.folder(k)), previous[k])
             for k, (a, n) in enumerate(spans)]

    def ended(k: int, outcome: dict[str, Any]) -> None:
        if outcome["status"] != "finished":
            raise _BatchEnded(dict(outcome, batch=k))

    t0 = time.perf_counter()
    status = "finished"
    memories: dict[int, dict[str, Any]] = {}
    try:
        try:
            run_batches(train_batch, calls, workers, ended=ended, poll=gatherer.poll)
        except _BatchEnded as e:
            status = "stopped"
            if e.outcome["status"] == "diverged":
                status = "diverged: " + str(e.outcome.get("line"))
                memories[e.outcome["batch"]] = {"memory": e.outcome["memory"]}
        except KeyboardInterrupt:
            status = "stopped"
        except InputError:
            raise
        except Exception as e:  # a worker that died (killed): its checkpoint stays
            from concurrent.futures.process import BrokenProcessPool
            if not isinstance(e, BrokenProcessPool):
                raise
            status = "stopped"
        gatherer.gather(memories)
    finally:
        bar.close()
    remove_work(out)
    return time.perf_counter() - t0, status, gatherer.rows


__all__ = ["Gatherer", "WORK", "merged_memory", "packed_payload", "remove_work",
           "run_batched_training", "train_batch"]
