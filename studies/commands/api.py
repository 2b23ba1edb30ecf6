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


def describe(model: str | None = None, format: str = "text", *,
             overrides: Overrides | None = None,
             equations: Mapping[str, str] | None = None,
             models: Mapping[str, Any] | None = None) -> str:
    """The equations and the parameter table of a model: what ``astrocpg describe`` prints.

    Parameters
    ----------
    model : str or None
        A model ("astrocyte"), a parameter's name ("tau_motor": its value, the model declaring
        it and every statement using it), "senses" (the robot senses a neuron model may read),
        or None: every model.
    format : {"text", "markdown", "latex"}
        Plain text for a terminal (the statements as the model file states them, in its order,
        with their units; the parameters with units and symbols), Markdown, or LaTeX (the
        equations rendered by sympy with the paper's symbols, terms in the order written).
    overrides : mapping or sequence of str, optional
        Parameter values with units (``{"tau_motor": "9*ms"}`` or ``["tau_motor=9*ms"]``):
        the values described.
    equations : mapping of str to str, optional
        ``{model: equation text}`` replacing a model's Brian2 equation string.
    models : mapping, optional
        ``{model: model file text}`` replacing whole models.

    Returns
    -------
    str
        The text, ending in a newline.
    """
    from ..figures.describe import describe as render

    return render(model, format, model_set(overrides, equations, models=models))


def export(folder: str | os.PathLike, format: str = "nwb",
           out: str | os.PathLike | None = None, *, overwrite: bool = False,
           experimenter: Sequence[str] = (), institution: str | None = None) -> Path:
    """Write a unit, run or recorded session as one NWB or npz file: what ``astrocpg export`` does.

    Read the NWB file with ``pynwb.NWBHDF5IO(path, "r").read()``; the cell of each trace column
    is in ``processing["misc"]["astrocyte_trace_columns"]`` / ``["motor_trace_columns"]``.

    Parameters
    ----------
    folder : path or Result
        The output folder (a Result written to a folder: its folder).
    format : {"nwb", "npz"}
        The file's format.
    out : path, optional
        The file (default ``<folder>.<format>`` beside the folder).
    overwrite : bool
        Replace an existing file.
    experimenter : sequence of str
        Names as "Last, First", recorded in the file.
    institution : str, optional
        Where it was run, recorded in the file.

    Returns
    -------
    pathlib.Path
        The file written.
    """
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
    """The rhythm and the gait of a training's trained tables: what ``astrocpg gait`` prints.

    Each trained table runs ``repeats`` times, learning off; each run's rhythm (thigh-extensor
    bursts) and gait (footfalls) are named, and per table the share of runs with each (Wilson 95%
    intervals).

    Parameters
    ----------
    folder : path
        A training folder.
    seconds : float
        Simulated time of each run, in s (rhythm and gait are read from its second half).
    repeats : int
        Runs per trained table, each with its own noise.
    seed : int, optional
        Seed of run 0; run b has seed ``seed + b`` (default: the training's own seed).
    world : sequence of str
        ``NAME=VALUE`` world parameters over the training's world.
    progress : bool
        A progress bar on stderr.
    rows : bool
        Return one dict per run instead of the lines.

    Returns
    -------
    list of str, or list of dict
        The lines ``astrocpg gait`` prints; with ``rows``, one dict per run (table, repeat, seed,
        speed, fall, rhythm and gait columns).
    """
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
    """Trained controllers in a set of worlds, learning off: what ``astrocpg evaluate`` does.

    Parameters
    ----------
    folder : path
        A training, a study (its finished runs) or a folder of kept tables.
    worlds : path or str
        A worlds file, or a shipped worlds name ("robustness").
    seconds : float
        Simulated time of each run, in s.
    repeats : int
        Runs per controller and world.
    seed : int
        Seed of the first run.
    conditions : sequence of str, optional
        A study's conditions to evaluate (default: all).
    out : path, optional
        Where to write (default ``folder/evaluation``).
    overwrite : bool
        Replace an existing ``out`` (only a folder astrocpg wrote).
    progress : bool
        A progress bar on stderr.
    workers : int, optional
        Processes of a local Dask cluster.
    scheduler : str, optional
        The address of a running Dask scheduler.
    session : int, optional
        The tables after that session instead of the final ones.

    Returns
    -------
    dict
        Its ``rows``, ``summary`` and ``out``.
    """
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
    """The SNN vs RL power estimate of a trained controller: what ``astrocpg power`` does.

    Parameters
    ----------
    folder : path
        A training folder (or a study's run).
    trial : int
        The trial whose trained controller is measured.
    sessions : int
        Sessions the rates are measured over.
    overrides : mapping or sequence of str, optional
        Parameters set over the training's models for this measurement
        (``{"limit_margin": "0*radian"}``); the file is then ``power_trial<K>_<NAME=VALUE>.json``.
    progress : bool
        A progress bar on stderr.

    Returns
    -------
    tuple of (pathlib.Path, dict)
        The file written (``folder/power_trial<K>.json``) and the figures.
    """
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
    """The models: what ``astrocpg models list`` lists.

    (Not ``ac.models``: that is the package :mod:`astrocpg.models`.)

    Parameters
    ----------
    overrides : mapping or sequence of str, optional
        Parameter values with units: ``{"tau_motor": "9*ms"}`` or ``["tau_motor=9*ms"]``.
    equations : mapping of str to str, optional
        ``{model: equation text}`` replacing a model's Brian2 equation string.
    models : mapping, optional
        ``{model: model file text}`` replacing whole models.

    Returns
    -------
    ModelSet
        One :class:`~astrocpg.models.ModelSet` (``.items()``: each model's name and model, its
        kind and parameters), with the overrides, equations and model files applied.
    """
    return model_set(overrides, equations, models=models)


def dump_model(name: str, *, overrides: Overrides | None = None,
               equations: Mapping[str, str] | None = None,
               models: Mapping[str, Any] | None = None) -> str:
    """A model as a model file: what ``astrocpg models dump NAME`` prints.

    Parameters
    ----------
    name : str
        The model ("astrocyte"; ``list_models()`` names them).
    overrides : mapping or sequence of str, optional
        Parameter values with units: ``{"tau_motor": "9*ms"}`` or ``["tau_motor=9*ms"]``.
    equations : mapping of str to str, optional
        ``{model: equation text}`` replacing a model's Brian2 equation string.
    models : mapping, optional
        ``{model: model file text}`` replacing whole models.

    Returns
    -------
    str
        The model file (TOML text).
    """
    from ...errors import did_you_mean
    from ...models.files import model_to_toml

    known = dict(list_models(overrides=overrides, equations=equations, models=models).items())
    if not isinstance(name, str) or name not in known:
        raise InputError(f"unknown model{did_you_mean(str(name), known)} (models: "
                         f"{', '.join(known)})", culprit="name")
    return model_to_toml(known[name])


def robot(path: str | os.PathLike, *, overwrite: bool = False) -> Path:
    """Write the project's A1 model as an MJCF file: what ``astrocpg robot export PATH`` does.

    Parameters
    ----------
    path : path
        The file to write, ending in .xml.
    overwrite : bool
        Replace an existing file.

    Returns
    -------
    pathlib.Path
        The file written.
    """
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


def docs(*, path: bool = False, open: bool = False) -> Path:
    """Where the manual is: it comes with the package. What ``astrocpg docs`` prints.

    Parameters
    ----------
    path : bool
        Return the folder of the manual's pages and of the files its recipes read
        (``examples/interlimb_table.csv``, the trained tables under ``benchmarks/`` and
        ``ablation/``), rather than its first page.
    open : bool
        Also open the manual in a web browser (where there is none, nothing opens).

    Returns
    -------
    pathlib.Path
        The folder (``path``), or the manual's first page: the built manual's ``index.html``
        where it was built (a checkout's ``docs/_build/html``, or astrocpg's cache folder's
        ``manual/``), else the pages' ``index.md``.
    """
    from ...errors import EnvironmentFault
    from ...shipped import DOCS
    from ..runtime.caches import cache_dir

    if not (DOCS / "index.md").is_file():
        raise EnvironmentFault("this copy of astrocpg holds no manual (installed without its "
                               "package data?)", culprit=str(DOCS))
    built = [p for p in (DOCS / "_build" / "html" / "index.html",
                         cache_dir() / "manual" / "index.html") if p.is_file()]
    page = built[0] if built else DOCS / "index.md"
    if open:
        import webbrowser
        webbrowser.open(page.as_uri())
    return DOCS if path else page
