"""Replay one session of one trial of a training, alone and exactly.

A session starts from the trial's seed (its network and noise streams), the reset values, and
what a reset leaves: the astrocytes' state and the inter-limb weights, with the session's
Progress, t_learning_start and the network step of its first step. A training writes these
for every session (``session_starts.npz``); :func:`replay_session` builds a one-trial training with
the trial's seed, starts its single session from them, and records it. With the same Brian2
target the replayed session is the recorded one, step for step: the same spikes, the same
robot, the same final x as the row of ``sessions.csv``.

``astrocpg run`` (``ac.run``) runs it, given the training as ``weights``, a ``trial`` and a
``session``.
"""

from __future__ import annotations

import csv
import os
from pathlib import Path
from typing import Any, Sequence

import numpy as np

from ...coupling.training import SessionStart
from ...errors import InputError, setting
from ...support.reading import check_regular
from ...network.codegen import framework_target
from ..outputs.folder import OutputFolder, as_path, refuse_in_use
from ..outputs.result import Result
from ..outputs.writing import read_manifest
from ..settings.populations import population_models, population_table
from ..settings import TrainSettings
from .train import record_plan, train_from_start
from .train_files import SESSION_STARTS
from ...models.compose import model_set


def recorded_start(folder: Path, trial: int, session: int) -> SessionStart:
    """Session ``session`` (1-based) of trial ``trial`` as the training in ``folder`` recorded
    its start, or an InputError naming what is missing."""
    path = folder / SESSION_STARTS
    if not path.is_file():
        raise InputError(f"holds no {SESSION_STARTS}: it was trained before astrocpg kept "
                         f"each session's start, so its sessions cannot be replayed "
                         f"(train it again)", culprit=setting("weights", folder))
    check_regular(path, setting("weights", folder))  # a FIFO is refused, never waited on
    try:
        with np.load(path, allow_pickle=False) as z:
            arrays = {k: z[k] for k in z.files}
        steps = arrays["step"]
    except (OSError, ValueError, KeyError) as e:
        raise InputError(f"{SESSION_STARTS} cannot be read ({type(e).__name__})",
                         culprit=setting("weights", folder)) from None
    n_trials = steps.shape[0]
    if not 0 <= trial < n_trials:
        raise InputError(f"the training has trials 0..{n_trials - 1}, not {trial}",
                         culprit=setting("trial"))
    known = int((steps[trial] >= 0).sum())
    if not 1 <= session <= known:
        raise InputError(f"trial {trial} has sessions 1..{known} recorded, not {session}",
                         culprit=setting("session"))
    k = session - 1
    return SessionStart(step=int(steps[trial, k]),
                        progress=float(arrays["progress"][trial, k]),
                        t_learning_start=float(arrays["t_learning_start"][trial, k]),
                        state={name[len("state."):]: arrays[name][trial, k]
                               for name in arrays if name.startswith("state.")})


def recorded_row(folder: Path, trial: int, session: int) -> dict[str, str] | None:
    """The row of ``sessions.csv`` for (trial, session), as written (text), or None while that
    session was still running when the training stopped."""
    check_regular(folder / "sessions.csv", setting("weights", folder))
    try:
        with open(folder / "sessions.csv", newline="") as f:
            for row in csv.DictReader(f):
                if row.get("trial") == str(trial) and row.get("session") == str(session):
                    return row
    except OSError:
        return None
    return None


def replay_session(training: str | os.PathLike, *, trial: int = 0, session: int = 1,
           out: str | os.PathLike, record_stride: int = 1,
           spikes: tuple[str, ...] | None = None, traces: tuple[str, ...] | None = None,
           trace_dtype: str = "float32", overwrite: bool = False, progress: bool = True,
           inputs: Sequence[str | os.PathLike] = ()) -> Result:
    """Replay one session of a training alone, learning on: ``astrocpg run`` given the training
    as ``weights`` and a ``session``.

    The replay is a one-session training folder whose ``recordings/trial00_session0001/`` holds
    the session's spikes, traces and robot, and whose manifest's ``settings.replay_of`` names the
    training, trial, session and step. It needs the Brian2 target the training ran with; the
    populations the training added (``settings.populations`` of its manifest) are built too.

    Parameters
    ----------
    training : path
        A training folder, or a study's ``runs/<run id>/``.
    trial : int
        The trial whose session is replayed.
    session : int
        The session, 1-based.
    out : path
        The folder to write.
    record_stride : int
        Steps between the recorded trace and robot samples.
    spikes, traces : tuple of str, optional
        Which populations' spikes and which traces to record (None: all).
    trace_dtype : str
        The recorded traces kept as "float32" (default) or "float64" (full precision).
    overwrite : bool
        Replace an existing ``out`` (only a folder astrocpg wrote).
    progress : bool
        A progress bar on stderr.
    inputs : sequence of path
        Other files the caller read: ``out`` may not be or hold one.

    Returns
    -------
    Result
        The replay's Result (kind "train"); ``result.summary["replay"]`` gives the recorded and
        the replayed final x (``sessions.csv``'s text, 9 significant digits) and whether they are
        the same.
    """
    folder = as_path(training, setting("weights"))
    refuse_in_use(folder, culprit=setting("weights", folder))
    manifest = read_manifest(folder)
    if manifest is None or manifest.get("astrocpg_command") not in ("train", "study-run"):
        raise InputError("is neither a training folder nor a study's run (no training "
                         "manifest)", culprit=setting("weights", folder))
    trial, session = int(trial), int(session)
    start = recorded_start(folder, trial, session)
    started = manifest.get("codegen", "numpy")
    if framework_target() != started:
        raise InputError(f"the training ran on the {started} target; a replay is exact only "
                         f"on it (add {setting('codegen', started)})", culprit=setting("codegen"))
    settings = _session_settings(manifest["settings"], trial)
    models = model_set(settings.overrides, settings.equations, models=settings.models,
                       added=population_models(settings.populations))
    out_path = as_path(out, setting("out"))
    OutputFolder(out_path, overwrite=overwrite, inputs=[*inputs, folder]).check()
    row = recorded_row(folder, trial, session)
    origin = {"training": str(folder), "trial": trial, "session": session,
              "step": start.step, "seed": settings.seed,
              "recorded_final_x_m": None if row is None else row["final_x_m"]}
    # the populations the training added: the same network, recorded like its own
    plan = record_plan(1, record_stride, spikes, traces, trace_dtype,
                       rows=population_table(settings.populations))
    trainer = train_from_start(settings, out_path, plan, start, origin, models=models,
                               progress=progress, overwrite=overwrite)
    result = Result.from_training(trainer, out_path)
    replayed = f"{trainer.training.memory.rows[0]['final_x_m']:.9g}"
    result.summary["replay"] = origin | {
        "replayed_final_x_m": replayed,
        "same": None if row is None else row["final_x_m"] == replayed}
    return result


def _session_settings(recorded: dict[str, Any], trial: int) -> TrainSettings:
    """One session of one trial of a training, from its recorded settings (a training's, or a
    study run's: the same keys, equations aside)."""
    return TrainSettings(n_sessions=1, seed=int(recorded["seed"]) + trial, n_trials=1,
                         astrocytes=bool(recorded.get("astrocytes", True)),
                         overrides=list(recorded.get("overrides") or []),
                         equations=dict(recorded.get("equations") or {}),
                         models=dict(recorded.get("models") or {}),
                         populations=dict(recorded.get("populations") or {}))


def format_replay(result: Result) -> list[str]:
    """What the command line prints after a replay."""
    r = result.summary["replay"]
    head = (f"session {r['session']} of trial {r['trial']} of {r['training']} (seed "
            f"{r['seed']}, from step {r['step']}): final x {r['replayed_final_x_m']} m")
    if r["recorded_final_x_m"] is None:
        return [head + " (the training had not finished that session)"]
    verdict = "the same" if r["same"] else "DIFFERENT"
    return [head + f"; recorded {r['recorded_final_x_m']} m: {verdict}"]


__all__ = ["replay_session", "recorded_start", "recorded_row", "format_replay"]
