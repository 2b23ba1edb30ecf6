"""The Python API, ``import astrocpg as ac``: the functions the ``astrocpg`` commands call.

    ac.unit(seconds=2, seed=1)                   # one locomotion unit, open loop -> Result
    ac.run(seconds=1, seed=1, out="out/run")     # the closed loop, written like `astrocpg run`
    ac.train(out="out/astro", sessions=10)       # gait learning -> Result of kind "train"
    ac.resume("out/astro")                       # continue a stopped training -> Result
    ac.load("out/run")                           # any output folder -> Result
    ac.describe("astrocyte")                     # equations and parameter table (markdown)
    ac.export("out/run", "nwb")                  # out/run.nwb: NWB (or npz) file of a folder

Every function takes the settings of its command (seconds, seed, trials, ``overrides`` with
units, ``equations``, weights, robot, what to record) as keyword arguments; bad input raises
:class:`astrocpg.errors.InputError` naming the culprit, before anything is written.

Threads: Brian2 is not thread-safe, so the functions that simulate (``unit``, ``run``, ``train``,
``resume``, and ``plot`` where it replays a training) run one at a time per process
(:data:`astrocpg.network.RUN_LOCK`): called from several threads, each waits for the one before
and returns exactly what it would have alone, the command line's result for the same settings.
For simulations in parallel, use processes (``astrocpg study`` does).
"""

from __future__ import annotations

import os
from pathlib import Path
from typing import Any, Mapping, Sequence

from ...errors import InputError
from ..files.export import export as export_folder
from ..files.result import Result, Trace, load
from .run import run
from ...models.compose import Overrides, model_set
from .train import resume, train
from .unit import unit


def describe(model: str | None = None, format: str = "markdown", *,
             overrides: Overrides | None = None,
             equations: Mapping[str, str] | None = None,
             models: Mapping[str, Any] | None = None) -> str:
    """The equations (rendered with sympy) and the parameter table of ``model`` (e.g.
    "astrocyte"; None: every model) as markdown or LaTeX text (``format``), with parameter
    ``overrides`` and replaced ``equations`` applied: what ``astrocpg describe`` prints."""
    from ..figures.describe import describe as render

    return render(model, format, model_set(overrides, equations, models=models))


def export(folder: str | os.PathLike, format: str = "nwb",
           out: str | os.PathLike | None = None, *, overwrite: bool = False,
           experimenter: Sequence[str] = (), institution: str | None = None) -> Path:
    """Write the unit, run or recorded session in ``folder`` as one NWB (``format="nwb"``) or
    npz file, at ``out`` (default ``<folder>.<format>`` beside the folder; an existing file
    only with ``overwrite``); returns its path. What ``astrocpg export`` does. ``experimenter``
    (names as "Last, First") and ``institution`` are recorded in the file. Read the NWB file
    with ``pynwb.NWBHDF5IO(path, "r").read()``; the cell of each trace column is in
    ``processing["misc"]["astrocyte_trace_columns"]`` / ``["motor_trace_columns"]``."""
    if isinstance(folder, Result):  # a result written to a folder: that folder
        if folder.folder is None:
            raise InputError("this Result was not written to a folder (run it with out=...); "
                             "export reads a folder", culprit="folder")
        folder = folder.folder
    if not isinstance(folder, (str, os.PathLike)):
        raise InputError(f"expected a folder (a path or a Result with one), got "
                         f"{type(folder).__name__}", culprit="folder")
    if not isinstance(format, str):
        raise InputError(f"expected 'nwb' or 'npz', got {format!r}", culprit="format")
    if out is not None and not isinstance(out, (str, os.PathLike)):
        raise InputError(f"expected a file path, got {type(out).__name__}", culprit="out")
    if isinstance(experimenter, str):  # one name, not its characters
        experimenter = (experimenter,)
    elif not all(isinstance(x, str) for x in experimenter or ()):
        raise InputError("expected names as text ('Last, First')", culprit="experimenter")
    if institution is not None and not isinstance(institution, str):
        raise InputError(f"expected text, got {type(institution).__name__}",
                         culprit="institution")
    return export_folder(Path(folder), format, None if out is None else Path(out),
                         overwrite=overwrite, experimenter=experimenter,
                         institution=institution)


__all__ = ["unit", "run", "train", "resume", "load", "describe", "export", "Result", "Trace"]
