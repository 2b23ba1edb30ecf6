"""A training run, from its settings to its finished folder: own the folder (one process per
training folder), build the trainer, run it in this process or split over processes
(:mod:`.train_batched`), and write the manifest as the training stands (running, interrupted,
diverged, finished). What :func:`~.train.train`, :func:`~.resume.resume` and a replay run."""

from __future__ import annotations

import dataclasses
import os
from pathlib import Path
from typing import Any

import numpy as np

from ...coupling.recorder import RecordPlan
from ...coupling.training import SessionStart
from ...errors import Diverged, EnvironmentFault, InputError, setting
from ...models import ModelSet
from ...models.compose import model_set
from ...network import exclusive
from ..outputs.folder import (FolderLock, clean_stale_temporaries, clear_folder, holds_results,
                              remove_derived)
from ..outputs.writing import write_manifest
from ..settings import TrainSettings
from ..settings.populations import population_models
from .train_files import TRAIN_FILES
from .train_summary import recorded_overflow, train_summary
from .trainer import Trainer, TrainingStopped


@exclusive  # the whole training in one hold: Brian2 is not thread-safe (network/runlock.py)
def run_training(settings: TrainSettings, out: Path, plan: RecordPlan | None,
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
    ``settings``' (:func:`~astrocpg.studies.commands.resume.resume` with more
    ``sessions``)."""
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
            if replace:  # overwrite: the old run goes whole, never mixed with the new one
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


__all__ = ["run_training"]
