"""Gait learning: ``n_trials`` independent trials, each training for ``n_sessions`` sessions, in
one network. At session ends the folder gets, atomically: ``sessions.csv`` (one row per
trial and session), ``weights.npz`` (each trial's table after each session),
``session_starts.npz`` (what each session started from: a replay reads it) and
``checkpoint.npz`` (everything needed to continue exactly: Brian2 state and random state,
MuJoCo states, the session loop's memory; data only, never code:
:mod:`astrocpg.studies.outputs.checkpoint`): after the first session end, then spaced so that
writing takes at most 2 % of the wall time (:data:`~.trainer.CHECKPOINT_SPACING`), at the last
session end and when the run is stopped. ``resume`` continues a killed run from its last
checkpoint and ends with the same files as a run never interrupted.

This module starts a new training (:func:`train`: its settings checked, its folder, its
recording plan; :func:`train_from_start` for a replay). The rest has rooms of its own: the
settings value (:class:`~astrocpg.studies.settings.TrainSettings`), the network that trains
(:mod:`.trainer`), the run from settings to finished folder (:mod:`.train_run`), the
checkpoint's contents (:mod:`.train_state`), the files beside it (:mod:`.train_files`), the
summary (:mod:`.train_summary`) and the resume (:mod:`.resume`, :mod:`.resume_options`).
"""

from __future__ import annotations

import os
from pathlib import Path
from typing import Any, Sequence

from ...coupling.recorder import RecordPlan
from ...coupling.training import SessionStart
from ...errors import InputError, advice, setting
from ...models import ModelSet
from ...models.compose import model_files_record, model_set, override_items
from ..outputs.checkpoint import holds_checkpoint, refuse_legacy
from ..outputs.folder import OutputFolder, as_path
from ..outputs.result import Result
from ..runtime.resources import check_memory, estimate_batched
from ..runtime.workers import resolve_workers, workers_words
from ..settings import TrainSettings
from ..settings.checks import check_selection, check_trace_dtype, number, seed_number
from ..settings.populations import population_models, population_rows, population_table
from .train_run import run_training
from .train_summary import train_summary
from .trainer import Trainer


def record_plan(every: int | None, stride: int | None = None,
                spikes: tuple[str, ...] | None = None,
                traces: tuple[str, ...] | None = None,
                trace_dtype: str | None = None, rows: Any = None) -> RecordPlan | None:
    """The new training's RecordPlan from the options (a resumed one keeps its own:
    :func:`~astrocpg.studies.commands.resume_options.check_resume_options`), the names
    those of the population table ``rows`` (None: the built-in rows)."""
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
    spikes, traces = check_selection(spikes, traces, rows)
    dtype = "float32" if trace_dtype is None else check_trace_dtype(trace_dtype)
    return RecordPlan(every=every, spikes=spikes, traces=traces, stride=stride, dtype=dtype)


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
    plan = record_plan(record_every, record_stride, spikes, traces, trace_dtype,
                       rows=population_table(settings.populations))  # its populations too
    check_memory(estimate_batched(procs, trials=settings.n_trials, seconds=0.0, spikes=False,
                                  sessions=settings.n_sessions),
                 culprit=f"{setting('sessions', settings.n_sessions)} x "
                         f"{setting('trials', settings.n_trials)}{workers_words(procs)}")
    return Result.from_training(run_training(settings, out, plan, None, progress,
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
        refuse_legacy(out)  # a resume would refuse it too: say what to do with it
    if holds_checkpoint(out) and not overwrite:
        raise InputError(f"already holds a training run (continue it with "
                         f"{advice('resume', out)}, or "
                         f"replace it with {setting('overwrite')})", culprit=setting("out", out))
    OutputFolder(out, overwrite=overwrite, inputs=inputs, command="train").check()
    return out


def train_from_start(settings: TrainSettings, out: Path, plan: RecordPlan | None,
                     start: SessionStart, origin: dict[str, Any], *, models: ModelSet,
                     progress: bool = True, overwrite: bool = False) -> "Trainer":
    """A new one-trial training of ``settings`` into ``out`` whose first session starts from
    ``start`` (a session another training recorded); ``origin`` is what its manifest records
    of where that session comes from (``settings.replay_of``)."""
    return run_training(settings, out, plan, None, progress, replace=overwrite, new=True,
                        models=models, start=(start, origin))


# TrainSettings, Trainer and train_summary live in rooms of their own (above); the tests import
# them from here too
__all__ = ["TrainSettings", "Trainer", "record_plan", "train", "train_from_start", "train_summary"]
