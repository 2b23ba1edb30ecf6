"""The Python API, ``import astrocpg as ac``: the functions the ``astrocpg`` commands call.

    ac.unit(seconds=2, seed=1)                   # one locomotion unit, open loop -> Result
    ac.run(seconds=1, seed=1, out="out/run")     # the closed loop, written like `astrocpg run`
    ac.train(out="out/astro", sessions=10)       # gait learning -> Result of kind "train"
    ac.resume("out/astro")                       # continue a stopped training -> Result
    ac.load("out/run")                           # any output folder -> Result
    ac.describe("astrocyte")                     # equations and parameter table (markdown)
    ac.export("out/run", "nwb")                  # out/run.nwb: NWB (or npz) file of a folder
    ac.gait("out/astro")                         # rhythm and gait of each run, shares per table
    ac.evaluate("out/astro")                     # trained controllers in other worlds
    ac.power("out/astro")                        # SNN vs RL power estimate -> (path, figures)
    ac.list_models(); ac.dump_model("astrocyte")  # the model set; one model as TOML text
    ac.robot("a1.xml")                           # the project's A1 as an MJCF file
    ac.study("quick"); ac.report("out/quick")    # a parameter study; its report

Each command of ``astrocpg`` has its function here (``astrocpg models list`` and ``models dump
NAME`` are ``ac.list_models()`` and ``ac.dump_model(NAME)``, ``astrocpg robot export PATH`` is ``ac.robot(PATH)``; ``study`` and
``report`` live in :mod:`astrocpg.studies.parameter_studies.api`), with the command's options as keyword
arguments named like them (``--no-progress``: ``progress=False``; ``--set``: ``overrides``;
``--model``: ``models``; ``--condition``: ``conditions``; ``plot --format``: ``fmt``).
``--codegen`` is the process's choice, not a keyword: set ``ASTROCPG_CODEGEN`` in the
environment (see :mod:`astrocpg.network.codegen`).

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
from ...models import ModelSet
from ..outputs.export import export as export_folder
from ..outputs.result import Result, Trace, load
from .run import run
from ...models.compose import Overrides, model_set
from .train import resume, train
from .unit import unit


def describe(model: str | None = None, format: str = "markdown", *,
             overrides: Overrides | None = None,
             equations: Mapping[str, str] | None = None,
             models: Mapping[str, Any] | None = None, populations: Any = None) -> str:
    """The equations (rendered with sympy) and the parameter table of ``model`` (e.g.
    "astrocyte"; None: every model; a parameter's name, e.g. "tau_motor": its value, the model
    declaring it and the statements using it) as markdown or LaTeX text (``format``), with parameter
    ``overrides`` and replaced ``equations`` applied: what ``astrocpg describe`` prints.
    ``populations``: model files with a ``[population]`` table (as ``ac.unit`` takes them),
    whose models are described with the others (and ``overrides`` reach)."""
    from ..figures.describe import describe as render
    from .settings import population_models

    return render(model, format, model_set(overrides, equations, models=models,
                                           added=population_models(populations)))


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


def _path(value: Any, culprit: str) -> Path:
    """``value`` as a path (a Result written to a folder: its folder), else an InputError
    naming the argument."""
    if isinstance(value, Result):
        if value.folder is None:
            raise InputError("this Result was not written to a folder (run it with out=...)",
                             culprit=culprit)
        value = value.folder
    if not isinstance(value, (str, os.PathLike)):
        raise InputError(f"expected a path, got {type(value).__name__}", culprit=culprit)
    return Path(value)


def gait(folder: str | os.PathLike, *, seconds: float = 10.0, repeats: int = 5,
         seed: int | None = None, world: Sequence[str] = (), progress: bool = True,
         rows: bool = False) -> list[str] | list[dict[str, Any]]:
    """Run each trained table of the training in ``folder`` ``repeats`` times for ``seconds``,
    learning off (run ``b`` with seed ``seed + b``; by default the training's own seed;
    ``world``: ``NAME=VALUE`` world parameters over the training's world) and name, per run,
    its rhythm (thigh-extensor bursts) and its gait (footfalls), and per table the share of
    runs with each (Wilson 95% intervals): the lines ``astrocpg gait`` prints; with ``rows``,
    one dict per run instead (table, repeat, seed, speed, fall, rhythm and gait columns)."""
    from .settings import number, seed_number
    from .trained_controller import describe_gait, gait_runs

    if isinstance(world, str):  # one setting, not its characters
        world = [world]
    # named as the command's options; ac.gait names its keywords (astrocpg._in_keywords)
    kwargs = dict(seconds=number(seconds, "--seconds", positive=True),
                  repeats=number(repeats, "--repeats", integer=True, minimum=1),
                  seed=None if seed is None else seed_number(seed, "--seed"), world=list(world),
                  progress=progress)
    if rows:
        return gait_runs(_path(folder, "folder"), **kwargs)[0]
    return describe_gait(_path(folder, "folder"), **kwargs)


def evaluate(folder: str | os.PathLike, *, worlds: str | os.PathLike = "robustness",
             seconds: float = 10.0, repeats: int = 5, seed: int = 1,
             conditions: Sequence[str] | None = None, out: str | os.PathLike | None = None,
             overwrite: bool = False, progress: bool = True, workers: int | None = None,
             scheduler: str | None = None, session: int | None = None) -> dict[str, Any]:
    """The trained controllers under ``folder`` (a training, or a study's finished runs of
    ``conditions``), learning off, in each world of ``worlds`` (a worlds file, or
    "robustness"), ``repeats`` times each: what ``astrocpg evaluate`` does. ``session``: the
    tables after that session instead of the final ones. Writes ``out`` (default
    ``folder/evaluation``); returns its rows, summary and ``out``."""
    from .evaluate import evaluate as evaluate_folder

    if isinstance(conditions, str):  # one condition, not its characters
        conditions = [conditions]
    if conditions is not None and not all(isinstance(c, str) for c in conditions):
        raise InputError("expected condition names as text", culprit="conditions")
    if not isinstance(worlds, (str, os.PathLike)):
        raise InputError(f"expected a worlds file or 'robustness', got "
                         f"{type(worlds).__name__}", culprit="worlds")
    if scheduler is not None and not isinstance(scheduler, str):
        raise InputError(f"expected an address as text, got {type(scheduler).__name__}",
                         culprit="scheduler")
    return evaluate_folder(_path(folder, "folder"), worlds=worlds, seconds=seconds,
                           repeats=repeats, seed=seed, conditions=conditions,
                           out=None if out is None else _path(out, "out"), overwrite=overwrite,
                           progress=progress, workers=workers, scheduler=scheduler,
                           session=session)


def power(folder: str | os.PathLike, *, trial: int = 0, sessions: int = 10,
          overrides: Overrides | None = None,
          progress: bool = True) -> tuple[Path, dict[str, Any]]:
    """The SNN vs RL power estimate of trial ``trial``'s trained controller in ``folder``,
    measured over ``sessions`` sessions and written to ``folder/power_trial<K>.json``: what
    ``astrocpg power`` does. ``overrides`` (``{"limit_margin": "0*radian"}``) set parameters
    over the training's models for this measurement; the file is then
    ``power_trial<K>_<NAME=VALUE>.json``. Returns that file's path and the figures."""
    from ...models.compose import override_items
    from .power import power as measure_power
    from .settings import number

    return measure_power(_path(folder, "folder"),
                         trial=number(trial, "--trial", integer=True, minimum=0),
                         sessions=number(sessions, "--sessions", integer=True, minimum=1),
                         progress=progress, overrides=override_items(overrides))


def list_models(*, overrides: Overrides | None = None,
                equations: Mapping[str, str] | None = None,
                models: Mapping[str, Any] | None = None) -> ModelSet:
    """The models, as one :class:`~astrocpg.models.ModelSet` (``.items()``: each model's name
    and model, its kind and parameters), with ``overrides``, replaced ``equations`` and model
    files ``models`` applied: what ``astrocpg models list`` lists. (Not ``ac.models``: that is
    the package :mod:`astrocpg.models`.)"""
    return model_set(overrides, equations, models=models)


def dump_model(name: str, *, overrides: Overrides | None = None,
               equations: Mapping[str, str] | None = None,
               models: Mapping[str, Any] | None = None) -> str:
    """Model ``name`` as a model file (TOML text), with ``overrides``, replaced ``equations``
    and model files ``models`` applied: what ``astrocpg models dump NAME`` prints."""
    from ...errors import did_you_mean
    from ...models.files import model_to_toml

    known = dict(list_models(overrides=overrides, equations=equations, models=models).items())
    if not isinstance(name, str) or name not in known:
        raise InputError(f"unknown model{did_you_mean(str(name), known)} (models: "
                         f"{', '.join(known)})", culprit="name")
    return model_to_toml(known[name])


def robot(path: str | os.PathLike, *, overwrite: bool = False) -> Path:
    """Write the project's A1 model as an MJCF file at ``path`` (ending in .xml; an existing
    file only with ``overwrite``) and return it: what ``astrocpg robot export PATH`` does."""
    from ...coupling.robot import A1Parameters, export_xml
    from ..outputs.folder import refuse_in_use
    from ..outputs.writing import atomic_path

    target = _path(path, "path")
    if target.suffix.lower() != ".xml":
        raise InputError("the file name must end in .xml", culprit=f"robot export {target}")
    if not target.parent.exists():
        raise InputError(f"folder '{target.parent}' does not exist",
                         culprit=f"robot export {target}")
    if target.is_dir():
        raise InputError("is a folder; name the file to write", culprit=f"robot export {target}")
    if target.exists() and not overwrite:
        raise InputError("exists; --overwrite replaces it", culprit=f"robot export {target}")
    refuse_in_use(target, culprit=f"robot export {target}")
    atomic_path(target, lambda tmp: export_xml(tmp, A1Parameters()))
    return target


__all__ = ["unit", "run", "train", "resume", "load", "describe", "export", "gait", "evaluate",
           "power", "list_models", "dump_model", "robot", "Result", "Trace"]
