"""A study's runs executed: one run trained on a Dask worker (:func:`execute_run`, which never
raises for the run's own failure: its status says), the pending runs dispatched on the
cluster longest first with the study's progress bar, and the runs that did not finish written
to ``failures.csv``.

How a run ends (its ``status.json`` state, and its manifest's status): ``finished``;
``diverged`` (a state left the numbers, :class:`~astrocpg.errors.Diverged`: the sessions up to
the diverged one are written, its error says where and when); ``failed`` (any other error);
``stopped`` (interrupted; its manifest says ``interrupted``). A run that ended ``finished`` or
``diverged`` is never run again: a diverged run is a function of its settings and would
diverge again (:data:`ENDED`).
"""

from __future__ import annotations

import csv
import io
import os
import socket
import sys
import time
import traceback
from dataclasses import asdict
from pathlib import Path
from typing import Any, Callable

import numpy as np

from ...errors import Diverged, InputError
from ...support.reading import read_json
from ...network import exclusive
from ..runtime.cells import run_cells
from ...models.compose import model_set
from ..settings.populations import population_models
from ..commands.train_state import CHECKPOINT, read_checkpoint
from ..commands.trainer import Trainer, TrainingStopped
from ..outputs.checkpoint import refuse_legacy
from ..outputs.folder import FolderLock, remember_written
from ..outputs.writing import atomic_write, prepare_output_dir, save_json, write_manifest
from ..outputs.weights import WEIGHTS
from .layout import ENDED, FAILURES, GAITS, STATUS, as_it_stands, run_files
from .study_file import RunSpec


# ---------------------------------------------------------------- one run (on a worker)

def ended_status(folder: Path) -> dict[str, Any] | None:
    """The status of the run in ``folder`` if it ended (:data:`ENDED`: it is never run again),
    else None: the store the runtime's engine reads to leave a study's ended runs out
    (:func:`~astrocpg.studies.runtime.cells.pending`)."""
    status = read_status(folder)
    return status if status.get("state") in ENDED else None


def read_status(folder: Path) -> dict[str, Any]:
    try:
        status = read_json(folder / STATUS)
    except InputError:  # not a regular file, nested too deeply: refused, naming it
        raise
    except (OSError, ValueError):
        return {}
    return as_it_stands(folder, status) if isinstance(status, dict) else {}


def _write_status(folder: Path, status: dict[str, Any]) -> None:
    save_json(folder / STATUS, status)


#: How often a run given out again waits for the worker that still trains it (seconds)
RUN_LOCK_POLL_S = 5.0


@exclusive  # a worker's tasks are threads: one Brian2 training at a time (network/runlock.py)
def execute_run(spec: RunSpec, folder: str) -> dict[str, Any]:
    """Train one run in ``folder`` (resuming from its checkpoint if there is one).

    Runs on a Dask worker. Never raises for a failure of the run itself: the error and its
    traceback go into ``status.json`` and the returned dict, so one failed run does not stop
    the study. Returns the final status.
    """
    import warnings

    warnings.filterwarnings("ignore", module="brian2")

    out = prepare_output_dir(folder)
    # the run folder is this worker's while it trains (inside the study's folder, which the
    # study's process holds): resuming it as a training or overwriting it as a run's out is refused
    lock = FolderLock(out, culprit=f"run folder {out}", inside=out.parent.parent)
    refused = 0
    while True:
        try:
            lock.acquire()
            break
        except InputError as e:
            if not (lock.held_elsewhere() and FolderLock(out.parent.parent).held_elsewhere()):
                refused += 1  # let go just now (try again), or refused for another reason
                if refused < 2:
                    continue
                return {"run_id": spec.run_id, "state": "failed", "error": f"InputError: {e}",
                        "not_written": True}  # write nothing into it
            # Another worker of this study trains it (the study that gave this run out holds
            # its folder, so no other command can): the scheduler gave the run out again because that worker stopped
            # answering for a while (a paused or suspended machine), not because it died.
            # Wait for it; once it lets go, the run's status says how it ended (a finished run
            # is not trained again) or the run continues from its checkpoint.
            time.sleep(RUN_LOCK_POLL_S)
    try:
        return _execute_run_locked(spec, out)
    finally:
        lock.release()


def _execute_run_locked(spec: RunSpec, out: Path) -> dict[str, Any]:
    status = read_status(out)
    if status.get("state") in ENDED:
        return status
    worker, worker_name = _this_worker()
    status.update({
        "run_id": spec.run_id, "state": "running", "attempts": status.get("attempts", 0) + 1,
        "host": socket.gethostname(), "pid": os.getpid(), "worker": worker,
        "worker_name": worker_name, "started": time.time(), "spec": asdict(spec),
    })
    status.pop("error", None)
    status.pop("finished", None)
    # every attempt keeps its own line (the timeline of the study): a killed attempt stays
    # without an end
    status["history"] = status.get("history", []) + [
        {k: status[k] for k in ("attempts", "worker", "worker_name", "host", "pid", "started")}]
    t0 = time.perf_counter()
    manifest: dict[str, Any] = {}  # once written, the run's manifest says how it ended
    layout: dict[str, Any] = {}  # the network's population rows, once it is built
    try:
        _write_status(out, status)
        settings = spec.train_settings()
        payload = None
        refuse_legacy(out)  # an old pickled checkpoint is never loaded
        if (out / CHECKPOINT).exists():
            payload = read_checkpoint(out / CHECKPOINT, culprit=out)
            if payload["fingerprint"] != settings.fingerprint():
                raise InputError("its checkpoint belongs to other settings", culprit=out)
            # an earlier attempt's (its worker killed before it listed it): this attempt
            # continues from it, so it is the run's file, listed while it stays as read
            remember_written(out / CHECKPOINT)
        models = model_set(settings.overrides, {}, models=settings.models,
                           added=population_models(spec.populations))
        trainer = Trainer(models, settings, out, progress=False, record=spec.record_plan())

        def seen() -> None:
            # at each checkpoint: the attempt's time so far, so that a killed attempt (no end
            # written) still counts up to its last checkpoint in the study's wall time
            status["history"][-1]["last_seen"] = time.time()
            _write_status(out, status)
        trainer.on_checkpoint = seen
        if payload is not None:
            trainer.restore(payload)
        status["sessions_at_start"] = int(trainer.training.sessions_done.sum())
        _write_status(out, status)
        layout["layout"] = trainer.cpg.layout.to_json()
        manifest.update(command="study-run", seed=spec.seed, settings=asdict(spec),
                        models_json=trainer.models.to_json(), files=run_files())
        write_manifest(out, **manifest, results={"status": "running"} | layout)
        wall = trainer.run()
        _write_gaits(out, trainer)
        status.update({"state": "finished", "finished": time.time(),
                       "wall_seconds": status.get("wall_seconds", 0.0) + time.perf_counter() - t0})
        _end_attempt(status)
        _write_status(out, status)
        # last: the manifest's inventory lists the run's files as they stay (status included)
        write_manifest(out, command="study-run", seed=spec.seed, settings=asdict(spec),
                       models_json=trainer.models.to_json(), files=run_files(),
                       results={"status": "finished", "wall_seconds_last_attempt": wall}
                       | layout)
        return status
    except TrainingStopped as e:
        status.update({"state": "stopped", "error": str(e), "finished": time.time()})
    except Diverged as e:  # its sessions so far are written (the diverged one last)
        status.update({"state": "diverged", "error": f"Diverged: {e.line}",
                       "diverged": {"line": e.line, "t_s": e.t, "trial": e.trial},
                       "finished": time.time()})
    except Exception as e:  # recorded, not raised: the other runs go on
        status.update({"state": "failed", "error": f"{type(e).__name__}: {e}",
                       "traceback": traceback.format_exc(), "finished": time.time()})
    _end_attempt(status)
    _write_status(out, status)
    if manifest:  # never left "running": the manifest says how the attempt ended
        ended = {"stopped": "interrupted"}.get(status["state"], status["state"])
        write_manifest(out, **manifest, results={"status": ended,
                                                 "error": str(status.get("error", ""))} | layout)
    return status


def _write_gaits(out: Path, trainer: Trainer) -> None:
    """``gait.csv``: each trial's rhythm and gait with its final tables, learning off (a short
    run; :data:`~astrocpg.studies.commands.trained_controller.GAIT_COLUMNS`), each
    on its own network and noise (the seed it trained with), so that a seed's row does not
    depend on the batch it trained in."""
    from ..commands.trained_controller import GAIT_COLUMNS, final_gaits

    with np.load(out / WEIGHTS, allow_pickle=False) as z:  # written by this process a moment ago
        tables = np.asarray(z["final_weights_mV"], dtype=float) * 1e-3
    rows = final_gaits(trainer.models, tables, seed=trainer.settings.seed,
                       populations=trainer.cpg.layout.rows)  # the network it trained
    buf = io.StringIO()  # a reason is text: quoted where it needs it
    w = csv.writer(buf, lineterminator="\n")
    w.writerow(["trial", *GAIT_COLUMNS])
    for b, row in enumerate(rows):
        w.writerow([b, *(row[c] for c in GAIT_COLUMNS)])
    data = buf.getvalue().encode()
    atomic_write(out / GAITS, lambda f: f.write(data))


def _this_worker() -> tuple[str, str]:
    """(address, name) of the Dask worker running this task; empty outside a worker."""
    try:
        from distributed import get_worker

        w = get_worker()
        return str(w.address), str(w.name)
    except (ImportError, ValueError):
        return "", ""


def _end_attempt(status: dict[str, Any]) -> None:
    last = status["history"][-1]
    last.update({"state": status["state"], "ended": status["finished"],
                 "duration_s": status["finished"] - last["started"]})


# ---------------------------------------------------------------- the runs on the cluster
class _SessionsDone:
    """Rows in a run's ``sessions.csv``, counted again only when the file has changed: the
    progress bar asks every second, a training replaces the file (atomically) at its
    checkpoints only, and a run of 20 seeds x 400 sessions has 4 MiB of rows."""

    def __init__(self) -> None:
        self._seen: dict[Path, tuple[tuple[int, int, int], int]] = {}

    def __call__(self, folder: Path) -> int:
        path = folder / "sessions.csv"
        try:
            with open(path, "rb") as f:
                st = os.fstat(f.fileno())
                stamp = (st.st_ino, st.st_size, st.st_mtime_ns)
                known = self._seen.get(path)
                if known is not None and known[0] == stamp:
                    return known[1]
                n = max(0, sum(1 for _ in f) - 1)
        except OSError:
            return 0
        self._seen[path] = (stamp, n)
        return n


def dispatch(study, pending, folders, client, progress, total_sessions, n_done_before,
              tqdm) -> dict[str, str]:
    """Run ``pending`` on the cluster of ``client``, longest first, one run per free worker
    thread, on the runtime's engine (:func:`~astrocpg.studies.runtime.cells.run_cells`, the one
    that runs an evaluation's cells), with the study's progress bar. Returns the errors of runs
    that could not write their status (their folder was held by another process): {run_id:
    error}."""
    unwritten: dict[str, str] = {}
    waiting = sorted(pending, key=_projection(study, pending), reverse=True)
    by_id = {r.run_id: r for r in waiting}
    counts = {"failed": 0, "finished": 0}
    sessions_done = _SessionsDone()
    done_sessions = sum(sessions_done(f) for f in folders.values())
    bar = tqdm(total=total_sessions, initial=done_sessions, unit="session",
               desc=f"study {study.name}", disable=not progress, dynamic_ncols=True,
               smoothing=0.05, **({"mininterval": 0.5} if sys.stderr.isatty() else {}))

    def ended(run_id: str, future: Any) -> None:
        counts["finished"] += 1
        if not _collect(future, by_id[run_id], folders[run_id], unwritten):
            counts["failed"] += 1

    def tick(running: int) -> None:
        now = sum(sessions_done(f) for f in folders.values())
        bar.update(max(0, now - bar.n))
        bar.set_postfix_str(f"runs done {n_done_before + counts['finished'] - counts['failed']}/"
                            f"{len(study.runs)}, running {running}, failed {counts['failed']}")

    run_cells(execute_run, [(r.run_id, (r, str(folders[r.run_id]))) for r in waiting], ended,
              bar=bar, client=client, tick=tick)
    return unwritten


def _projection(study: Any, pending: list[RunSpec]) -> Callable[[RunSpec], float]:
    """What orders the runs, longest first: the seconds ``batch = "auto"`` projected for each
    (measured lengths with ``plan_from``), else each run's bound (every session at L_max)."""
    planned = (study.batch_choice or {}).get("run_seconds")
    if isinstance(planned, dict) and all(r.run_id in planned for r in pending):
        return lambda r: float(planned[r.run_id])
    return lambda r: r.estimated_seconds()


def _collect(future: Any, spec: RunSpec, folder: Path, unwritten: dict[str, str]) -> bool:
    """True when the run of ``future`` finished; a run that failed on its worker has said so in
    its status.json; one that could not run (e.g. KilledWorker after repeated worker deaths, or
    a cancelled task) is recorded as failed here; one whose folder another process held wrote
    nothing there: its error goes into ``unwritten``."""
    if future.status == "finished":
        status = future.result()
        if status.get("not_written"):
            unwritten[spec.run_id] = str(status.get("error", ""))
        return status.get("state") == "finished"
    if future.status == "error":
        exc = future.exception()
        error = f"{type(exc).__name__}: {exc}"
    else:
        error = f"the task was {future.status}"
    prepare_output_dir(folder)
    status = read_status(folder)
    status.update({"run_id": spec.run_id, "state": "failed", "error": error})
    _write_status(folder, status)
    return False


def write_failures(out: Path, failed: list[RunSpec], folders: dict[str, Path],
                    unwritten: dict[str, str] | None = None) -> dict[str, str]:
    """``failures.csv``: the runs that did not finish and their errors (removed when none);
    returns {run_id: error}. ``unwritten``: errors of runs whose folder another process held
    (their status.json is not theirs to tell)."""
    path = out / FAILURES
    unwritten = unwritten or {}
    if not failed:
        if path.exists():
            path.unlink()
        return {}
    lines = ["run_id,state,attempts,error"]
    errors: dict[str, str] = {}
    for r in failed:
        s = read_status(folders[r.run_id])
        if r.run_id in unwritten:
            s = {"state": "failed", "attempts": s.get("attempts", 0),
                 "error": unwritten[r.run_id]}
        state = s.get("state", "not run")
        err = str(s.get("error", "") or ("not run" if state == "not run" else state))
        errors[r.run_id] = " ".join(err.split())
        err = err.replace('"', "'").replace("\n", " ")
        lines.append(f'{r.run_id},{state},{s.get("attempts", 0)},"{err}"')
    data = ("\n".join(lines) + "\n").encode()
    atomic_write(path, lambda f: f.write(data))
    return errors
