"""Continue a training from its checkpoint (:func:`resume`): the folder's settings read back,
the checkpoint checked to belong to its folder and to be the file its run wrote, the settings
given again checked (:mod:`.resume_options`), an extension to more sessions checked to end as
a longer training would; then the run (:mod:`.train_run`) ends with the same files as a
training never interrupted."""

from __future__ import annotations

import dataclasses
from pathlib import Path
from typing import Any, Mapping

import numpy as np

from ...coupling.recorder import RecordPlan
from ...errors import EnvironmentFault, InputError, advice, setting
from ...models.compose import model_files_record, override_items
from ...network import codegen_target
from ..outputs.checkpoint import refuse_legacy
from ..outputs.folder import as_path, file_sha256, refuse_in_use
from ..outputs.result import Result
from ..outputs.writing import read_manifest
from ..runtime.resources import check_memory, estimate_bytes
from ..runtime.workers import resolve_workers
from ..settings import TrainSettings
from .resume_options import check_resume_options
from ..settings.checks import number
from ..settings.populations import population_rows
from .train_run import run_training
from .train_state import CHECKPOINT, read_checkpoint, same_codegen


def resume(folder: str | Path, *, sessions: int | None = None, progress: bool = True,
           record_every: int | None = None,
           record_stride: int | None = None, spikes: tuple[str, ...] | None = None,
           traces: tuple[str, ...] | None = None, trace_dtype: str | None = None,
           seed: int | None = None,
           trials: int | None = None, astrocytes: bool | None = None, overrides: Any = None,
           equations: Mapping[str, str] | None = None, models: Mapping[str, Any] | None = None,
           out: str | Path | None = None, overwrite: bool = False, populations: Any = None,
           workers: int | None = None) -> Result:
    """Continue the training in ``folder`` from its checkpoint.

    It ends with the same files as a training never interrupted (what later commands derived
    from the earlier weights, ``evaluation/`` and ``figures/``, is removed: it would be stale).
    A resumed training keeps the settings it started with, the populations it added included;
    options given again must agree with them, or the resume is refused with the option and both
    values named (:func:`~astrocpg.studies.commands.resume_options.check_resume_options`).

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
    given = _given_again(seed, trials, astrocytes, overrides, equations, models, populations)
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
    if overwrite:  # never ignored: it would replace what the resume continues
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
        same_codegen(payload.get("codegen", "numpy"), codegen_target())
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
    return Result.from_training(run_training(settings, out, stored_plan,
                                             None if fresh else payload, progress, resumed=True,
                                             extend_from=extend_from,
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
                         f"sessions per trial; extend the study instead, into a new study "
                         f"folder ({advice('extend_study', target)})",
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
    manifest records an extension (a resume with more ``sessions``) stopped before its first
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


__all__ = ["check_belongs", "resume"]
