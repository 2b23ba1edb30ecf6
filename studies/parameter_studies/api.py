"""The Python API of the parameter studies, ``ac.study`` and ``ac.report``: what ``astrocpg
study`` and ``astrocpg report`` do, with their options as keyword arguments (see
:mod:`astrocpg.studies.commands.api` for the others)."""

from __future__ import annotations

import os
from pathlib import Path
from typing import Any, Callable

from ...errors import InputError, setting
from ..settings.checks import number


def _path(value: Any, culprit: str) -> Path:
    if not isinstance(value, (str, os.PathLike)):
        raise InputError(f"expected a path, got {type(value).__name__}", culprit=culprit)
    return Path(value)


def study(file: str | os.PathLike, *, out: str | os.PathLike | None = None,
          seeds: str | int | list[int] | None = None, sessions: int | None = None,
          overrides: Any = None,
          workers: int | None = None, scheduler: str | None = None,
          plan_from: str | os.PathLike | None = None, overwrite: bool = False,
          progress: bool = True,
          announce: Callable[[str], None] | None = None) -> dict[str, Any]:
    """Run a parameter study on Dask: what ``astrocpg study`` does.

    Parameters
    ----------
    file : path or str
        A study file, or a shipped study's name (quick, ablation, ...).
    out : path, optional
        The study folder (default ``out/<study name>``); a second call continues it.
    seeds : str, int or list of int, optional
        "1-3", "1,4,9", a count (that many from the file's first seed) or a list of ints, in
        place of the file's seeds.
    sessions : int, optional
        Sessions per trial, in place of the file's.
    overrides : sequence of str or mapping, optional
        ``["NAME=VALUE", ...]`` or ``{name: value}``, over the file's ``[base]``.
        The study folder records ``seeds``, ``sessions`` and ``overrides``; a second call into it
        must give the same.
    workers : int, optional
        Processes of a local Dask cluster.
    scheduler : str, optional
        The address of a running Dask scheduler, instead of a local cluster.
    plan_from : path, optional
        An earlier study of the same conditions (its folder or results table) whose seeds'
        training lengths cost the runs when the seeds are split into runs (the batch is then
        chosen as ``batch = "auto"`` chooses it).
    overwrite : bool
        Replace an existing ``out`` (only a folder astrocpg wrote).
    progress : bool
        A progress bar on stderr.
    announce : callable, optional
        Called before the runs start with each line saying what the study will run (its runs,
        trials and sessions, and how ``batch = "auto"`` chose); ``astrocpg study`` prints them.

    Returns
    -------
    dict
        The counts of runs by status, the rows of the results table, the runs not finished
        (``failed``) and their errors, the study's ``name``, its ``runs`` (how many) and its
        folder (``out``).
    """
    from ..settings.study import StudySettings
    from .study import load_study, prepare_study, run_study

    if scheduler is not None and not isinstance(scheduler, str):
        raise InputError(f"expected an address as text, got {type(scheduler).__name__}",
                         culprit=setting("scheduler"))
    value = StudySettings(file=_path(file, "file"), seeds=seeds, sessions=sessions,
                          overrides=overrides)
    loaded = load_study(Path(value.file), overrides=value.changes)
    folder = Path("out") / loaded.name if out is None else _path(out, "out")
    plan = None if plan_from is None else _path(plan_from, "plan_from")
    loaded = prepare_study(loaded, folder, workers=workers, scheduler=scheduler,
                           overwrite=overwrite, progress=progress, plan_from=plan)
    for line in plan_lines(loaded, folder) if announce is not None else ():
        announce(line)
    res = run_study(loaded, folder, workers=workers, scheduler=scheduler, progress=progress,
                    overwrite=overwrite, plan_from=plan)
    return res | {"name": loaded.name, "runs": len(loaded.runs), "out": folder}


def plan_lines(study: Any, out: Path) -> list[str]:
    """What a prepared ``study`` will run into ``out``: how ``batch = "auto"`` chose (when it
    did), then its runs, trials and sessions."""
    lines = []
    c = study.batch_choice or {}
    if study.batch_setting == "auto" or "plan_from" in c:
        projected = c.get("projected_s", 0.0)
        span = f"{projected / 60:.0f} min" if projected >= 120 else f"{projected:.0f} s"
        lengths = (f"each seed as long as it trained in {c['plan_from']}" if "plan_from" in c
                   else "every session lasts L_max")
        from .study_file import run_group

        groups = sorted({run_group(r.run_id) for r in study.runs})
        measured = c.get("measured_groups")
        if isinstance(measured, list) and len(measured) < len(groups):
            lengths += (f" ({len(measured)} of {len(groups)} conditions and points measured "
                        f"there; the others as if every session lasts L_max)")
        cost = c.get("cost") if isinstance(c.get("cost"), dict) else {}
        on = ("on the cost per trial fitted to " + str(cost.get("note"))
              if cost.get("source") == "timeline" else "on this machine's measured cost per trial"
              + (f" ({c['plan_from']}: {cost['note']})" if cost.get("note") else ""))
        how = c.get("reason") or (f"{c['runs']} runs on {c['workers']} workers: {span} if "
                                  f"{lengths}, {on}")
        lines.append(f"batch auto: {study.batch} seeds per run ({how})")
        for group in sorted(study.split):
            sizes = [str(r.n_trials) for r in study.runs if run_group(r.run_id) == group]
            lines.append(f"  {group}: runs of {' + '.join(sizes)} seeds (split so that no "
                         f"worker idles at the end)")
    n_trials = sum(r.n_trials for r in study.runs)
    lines.append(f"study {study.name}: {len(study.runs)} runs ({n_trials} trials x "
                 f"{study.n_sessions} sessions) -> {out}/")
    return lines


def report(folder: str | os.PathLike, *, smooth: int = 1, last: int = 50,
           out: str | os.PathLike | None = None, overwrite: bool = False) -> dict[str, Any]:
    """The report of a study, its figures and tables: what ``astrocpg report`` does.

    The report holds the paper's Fig. 3c curves of each condition and the final figures of
    every seed, with the tests between conditions.

    Parameters
    ----------
    folder : path
        The study folder.
    smooth : int
        Sessions of each seed's trailing mean in the curves.
    last : int
        Sessions the final figures average over.
    out : path, optional
        Where to write (default ``folder/report``, replaced whole).
    overwrite : bool
        Replace an existing ``out`` elsewhere (only a folder astrocpg wrote).

    Returns
    -------
    dict
        The files written, the rows, the text and the figures.
    """
    from .report import report as write_report

    return write_report(_path(folder, "folder"),
                        # named as the command's options; ac.report names its keywords
                        last=number(last, setting("last"), integer=True, minimum=1),
                        smooth=number(smooth, setting("smooth"), integer=True, minimum=1),
                        out=None if out is None else _path(out, "out"), overwrite=overwrite)


def study_status(folder: str | os.PathLike, *, workers: int | None = None) -> Any:
    """What a study has done and what is left: the status ``astrocpg study`` prints of a folder.

    Reads only: safe while the study runs in another process.

    Parameters
    ----------
    folder : path
        The study folder.
    workers : int, optional
        Processes the projection of the time left assumes (default: those the study runs on,
        as its manifest records).

    Returns
    -------
    StudyProgress
        A :class:`~astrocpg.studies.parameter_studies.status.StudyProgress`: each run's state and
        sessions, and ``left_s``, the projected wall seconds left (``.text()`` is what the command
        prints).
    """
    from .status import study_status as progress

    return progress(_path(folder, "folder"),
                    workers=None if workers is None
                    else number(workers, "workers", integer=True, minimum=1))


__all__ = ["study", "study_status", "report"]
