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
NAME`` are ``ac.list_models()`` and ``ac.dump_model(NAME)``, ``astrocpg robot export PATH`` is
``ac.robot(PATH)``; ``study`` and ``report`` live in
:mod:`astrocpg.studies.parameter_studies.api`), with the command's settings as keyword
arguments: the settings' own names, which the command line's options are named after (where
an option is spelt otherwise, :mod:`astrocpg.studies.cli.words` maps the keyword to it:
``progress=False`` hides the progress bar, ``overrides`` are the ``NAME=VALUE`` texts,
``models`` the model files, ``conditions`` a study's conditions, ``fmt`` a plot's format). The
code-generation target is the process's choice, not a keyword: set ``ASTROCPG_CODEGEN`` in the
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

import numpy as np

from ...errors import InputError, setting
from ...models import ModelSet
from ..outputs.export import export as export_folder
from ..outputs.result import Result, Trace, load
from .run import run
from ...models.compose import Overrides, model_set
from .resume import resume
from .train import train
from .unit import unit


def describe(model: str | None = None, format: str = "text", *,
             overrides: Overrides | None = None,
             equations: Mapping[str, str] | None = None,
             models: Mapping[str, Any] | None = None, populations: Any = None) -> str:
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
    populations : sequence or mapping, optional
        Model files with a ``[population]`` table (as ``ac.unit`` takes them), whose models are
        described with the others (and ``overrides`` reach).

    Returns
    -------
    str
        The text, ending in a newline.
    """
    from ..figures.describe import describe as render
    from ..settings.populations import population_models

    return render(model, format, model_set(overrides, equations, models=models,
                                           added=population_models(populations)))


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
                             "export reads a folder", culprit=setting("folder"))
        folder = folder.folder
    if not isinstance(folder, (str, os.PathLike)):
        raise InputError(f"expected a folder (a path or a Result with one), got "
                         f"{type(folder).__name__}", culprit=setting("folder"))
    if not isinstance(format, str):
        raise InputError(f"expected 'nwb' or 'npz', got {format!r}", culprit=setting("format"))
    if out is not None and not isinstance(out, (str, os.PathLike)):
        raise InputError(f"expected a file path, got {type(out).__name__}", culprit=setting("out"))
    if isinstance(experimenter, str):  # one name, not its characters
        experimenter = (experimenter,)
    elif not all(isinstance(x, str) for x in experimenter or ()):
        raise InputError("expected names as text ('Last, First')", culprit=setting("experimenter"))
    if institution is not None and not isinstance(institution, str):
        raise InputError(f"expected text, got {type(institution).__name__}",
                         culprit=setting("institution"))
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
         rows: bool = False, overrides: Overrides | None = None,
         equations: Mapping[str, str] | None = None, models: Mapping[str, Any] | None = None,
         populations: Any = None, workers: int | None = None) -> list[str] | list[dict[str, Any]]:
    """The rhythm and the gait of trained tables: what ``astrocpg gait`` prints.

    Each trained table runs ``repeats`` times, learning off; each run's rhythm (thigh-extensor
    bursts) and gait (footfalls) are named; per table the share of its runs with each (Wilson
    95% intervals over its runs), and over all tables the shares with 95% intervals over
    tables, the gait's locking, its share at other locking thresholds and whether the tables
    differ.

    Parameters
    ----------
    folder : path
        A training folder, or a run folder (the ``out`` of ``astrocpg run``: each trial's
        table).
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
    overrides, equations, models, populations : optional
        A model variant over the controller's own models, as :func:`~astrocpg.run` takes them.
    workers : int, optional
        Processes the runs are split over (default: the cores this process may use; the same
        results for any number).

    Returns
    -------
    list of str, or list of dict
        The lines ``astrocpg gait`` prints; with ``rows``, one dict per run (table, repeat, seed,
        speed, fall, rhythm and gait columns).
    """
    from ..runtime.workers import resolve_workers
    from ..settings.checks import number, seed_number
    from .trained_controller import describe_gait, gait_runs

    if isinstance(world, str):  # one setting, not its characters
        world = [world]
    # named as the user's settings: each door names them its own way (errors.setting)
    kwargs = dict(seconds=number(seconds, setting("seconds"), positive=True),
                  repeats=number(repeats, setting("repeats"), integer=True, minimum=1),
                  seed=None if seed is None else seed_number(seed, setting("seed")),
                  world=list(world),
                  progress=progress,
                  variant={"overrides": overrides, "equations": equations, "models": models,
                           "populations": populations},
                  workers=resolve_workers(workers))
    if rows:
        return gait_runs(_path(folder, "folder"), **kwargs)[0]
    return describe_gait(_path(folder, "folder"), **kwargs)


def _run_window(result: Result, trial: int, start: float | None, stop: float | None
                ) -> tuple[np.ndarray, np.ndarray, float, float]:
    """The motor spikes of ``result`` and the window read (default: its second half), each
    checked; an InputError names the argument."""
    if not isinstance(result, Result):
        raise InputError(f"expected a Result (ac.run, ac.load of a run folder), got "
                         f"{type(result).__name__}", culprit="result")
    if result.seconds is None:
        raise InputError("has no run of its own (a training: ac.gait(folder) runs its tables)",
                         culprit=f"result of kind {result.kind!r}")
    if isinstance(trial, bool) or not isinstance(trial, (int, np.integer)) \
            or not 0 <= trial < result.n_trials:
        raise InputError(f"must be an integer in 0..{result.n_trials - 1}",
                         culprit=f"trial={trial!r}")
    if "motor" not in result.spikes:
        raise InputError("recorded no motor spikes (record them: spikes=('motor',))",
                         culprit="result")
    seconds = result.seconds
    start = seconds / 2 if start is None else float(start)
    stop = seconds if stop is None else float(stop)
    if not 0 <= start < stop <= seconds + 1e-9:
        raise InputError(f"must satisfy 0 <= start < stop <= {seconds:g} s (the run)",
                         culprit=f"start={start:g}, stop={stop:g}")
    t, i = result.spikes["motor"]
    return np.asarray(t, dtype=float), np.asarray(i), start, stop


def rhythm_of(result: Result, trial: int = 0, start: float | None = None,
              stop: float | None = None) -> dict[str, Any]:
    """The CPG's rhythm of one trial of a run: what its thigh-extensor bursts do, whether or
    not the robot stands.

    Parameters
    ----------
    result : Result
        A run (``ac.run(...)``, ``ac.unit(...)``, or ``ac.load`` of their folders) that
        recorded the motor spikes.
    trial : int
        Which trial (default 0).
    start, stop : float, optional
        The window read, in s (default: the run's second half, as ``astrocpg gait`` and
        ``evaluate`` read it).

    Returns
    -------
    dict
        ``rhythm``: the label (trot, pace, bound, walk or none;
        :func:`~astrocpg.studies.analysis.gait.phase_label`); ``rhythm_period_s``: FR's cycle;
        ``rhythm_phase_<leg>`` and ``rhythm_locking_<leg>`` for FL, RR and RL: each leg's burst
        phase relative to FR (0..1) and how locked it is (1: the same in every cycle).

    Raises
    ------
    ~astrocpg.errors.InputError
        The motor spikes were not recorded, or ``trial``, ``start`` or ``stop`` is out of
        range.

    Examples
    --------
    >>> r = ac.run(seconds=4, seed=1)                            # doctest: +SKIP
    >>> ac.rhythm_of(r)["rhythm"]                                # doctest: +SKIP
    """
    from ..analysis.gait import trial_rhythm

    t, i, start, stop = _run_window(result, trial, start, stop)
    return trial_rhythm(t, i, result.layout, trial, start, stop)


def gait_of(result: Result, trial: int = 0, start: float | None = None,
            stop: float | None = None) -> dict[str, Any]:
    """The gait of one trial of a run: what its feet do while the robot stands, read against
    the CPG's stepping cycles, with the measures its label thresholds; and its rhythm.

    The same classifier as ``astrocpg gait`` and ``evaluate`` (the training page, "The trained
    gait"), on a run you made with any controller: a model variant, your own table, a run
    folder loaded with ``ac.load``.

    Parameters
    ----------
    result : Result
        A closed-loop run (``ac.run(...)`` or ``ac.load`` of its folder) that recorded the
        motor spikes and the robot.
    trial : int
        Which trial (default 0).
    start, stop : float, optional
        The window read, in s (default: the run's second half).

    Returns
    -------
    dict
        The rhythm (:func:`rhythm_of`) and ``gait``: the label (trot, pace, bound, walk or
        none) with ``gait_reason`` (why it is none: fell at T s, no rhythm, too few steps, not
        periodic, no named pattern); ``gait_share``: the share of the window read (before the
        first fall); ``gait_period_s``, ``gait_duty_factor``; ``gait_phase_<leg>``: each
        foot's stance phase relative to FR's (FL, RR, RL); ``gait_locking_<leg>`` (all four
        feet) and ``gait_locking``, the smallest: the continuous measure the label thresholds
        (a named gait needs every foot at 0.7 or more); ``gait_at``: the label at the
        thresholds 0 (the footfall phases alone), 0.5, 0.6, 0.7 and 0.8
        (:func:`~astrocpg.studies.analysis.gait.gait_at`).

    Raises
    ------
    ~astrocpg.errors.InputError
        The motor spikes or the robot were not recorded (a unit has no robot), or an argument
        is out of range.

    Examples
    --------
    >>> r = ac.run(seconds=4, seed=1, weights="out/astro", trial=0)   # doctest: +SKIP
    >>> g = ac.gait_of(r)                                             # doctest: +SKIP
    >>> g["gait"], g["gait_locking"], g["gait_at"][0.6]               # doctest: +SKIP
    """
    from types import SimpleNamespace

    from ..analysis.gait import THRESHOLDS, gait_at, trial_measures

    t, i, start, stop = _run_window(result, trial, start, stop)
    robot = result.robot or {}
    if not all(k in robot for k in ("t", "alive", "foot_force")):
        raise InputError("holds no robot recording (a unit has no robot)",
                         culprit=f"result of kind {result.kind!r}")
    rec = SimpleNamespace(t=np.asarray(robot["t"], dtype=float),
                          alive=np.asarray(robot["alive"]),
                          foot_force=np.asarray(robot["foot_force"], dtype=float))
    out = trial_measures(t, i, result.layout, rec, trial, start, stop)
    out["gait_at"] = {x: gait_at(out, x) for x in (0.0, *THRESHOLDS)}
    return out


def evaluate(folder: str | os.PathLike, *, worlds: str | os.PathLike = "robustness",
             seconds: float = 10.0, repeats: int = 5, seed: int = 1,
             conditions: Sequence[str] | None = None, out: str | os.PathLike | None = None,
             overwrite: bool = False, progress: bool = True, workers: int | None = None,
             scheduler: str | None = None, session: int | None = None,
             point: Sequence[str] | str | None = None, baseline: str | None = None,
             overrides: Overrides | None = None, equations: Mapping[str, str] | None = None,
             models: Mapping[str, Any] | None = None,
             populations: Any = None) -> dict[str, Any]:
    """Trained controllers in a set of worlds, learning off: what ``astrocpg evaluate`` does.

    Parameters
    ----------
    folder : path
        A training, a run folder, a study (its finished runs) or a folder of kept tables.
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
    point : str or sequence of str, optional
        One sweep point of a study: ``NAME=VALUE`` per swept parameter, as the study file
        writes the value.
    baseline : str, optional
        A world (e.g. "flat") each other world's effect is taken relative to (``baseline.csv``).
    overrides, equations, models, populations : optional
        A model variant over each controller's own models.

    Returns
    -------
    dict
        Its ``rows``, ``summary``, ``baseline`` and ``out``.
    """
    from .evaluate import evaluate as evaluate_folder

    if isinstance(conditions, str):  # one condition, not its characters
        conditions = [conditions]
    if conditions is not None and not all(isinstance(c, str) for c in conditions):
        raise InputError("expected condition names as text", culprit=setting("conditions"))
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
                           session=session,
                           points=[point] if isinstance(point, str) else point,
                           baseline=baseline,
                           variant={"overrides": overrides, "equations": equations,
                                    "models": models, "populations": populations})


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
    from ..settings.power import PowerSettings
    from .power import power as measure_power

    return measure_power(PowerSettings(folder=_path(folder, "folder"), trial=trial,
                                       sessions=sessions, overrides=overrides),
                         progress=progress)


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
        Replace an existing file, only when it is an unchanged export of this A1 (a file of
        yours, a link or an edited export is refused).

    Returns
    -------
    pathlib.Path
        The file written.
    """
    from ...coupling.robot import A1Parameters, a1_xml
    from ...support.reading import check_regular
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
        raise InputError(f"exists; {setting('overwrite')} replaces it",
                         culprit=f"robot export {target}")
    refuse_in_use(target, culprit=f"robot export {target}")
    xml = a1_xml(A1Parameters())
    if os.path.lexists(target):  # overwrite: only an unchanged export of this A1 is replaced
        check_regular(target, f"robot export {target}")
        same = (target.is_file() and not target.is_symlink()
                and target.stat().st_size == len(xml.encode())
                and target.read_bytes() == xml.encode())
        if not same:
            raise InputError("is not the A1 model astrocpg writes (a file of yours, a link, or an "
                             f"export edited since); {setting('overwrite')} replaces only an "
                             f"unchanged export: choose another name, or move it first",
                             culprit=f"robot export {target}")
    atomic_path(target, lambda tmp: Path(tmp).write_text(xml))
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
    from ...support.shipped import DOCS
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
