"""Trained controllers in other worlds (``astrocpg evaluate``): every trained table of a training
or of a study's runs drives the robot with learning off, in each world of a worlds file, and a
tidy table says how far and how fast it walked, whether and when it fell, and its gait.

A worlds file (TOML) names worlds by their world parameters (``astrocpg.models.world``)::

    [worlds.flat]
    [worlds.uphill]
    slope = "0.09"
    [worlds.rough]
    terrain_height = "0.02*meter"
    terrain_seed = "1"

``robustness`` (``studies/commands/robustness.toml``) holds the worlds of the paper's open
question: slopes of +-0.09 and +-0.17 rad, rough terrain of two heights, lower friction and a
lateral push.
"""

from __future__ import annotations

import csv
import hashlib
import io
import itertools
import json
import math
import os
import tomllib
import warnings
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Mapping, Sequence

import numpy as np

from ..runtime.cells import pending, run_cells
from ..runtime.cluster import check_scheduler, check_workers
from ..runtime.workers import default_workers
from ...errors import KEYWORDS, Diverged, InputError, setting
from ..settings.evaluation import EvaluateSettings
from ...support.reading import check_regular, loads_toml, read_bytes, read_json
from ...models import DEFAULT_MODELS, ModelSet
from ...network import codegen_target
from ..analysis.fall import first_fall
from ..analysis.gait import MEASURE_COLUMNS, NAMED, THRESHOLDS, trial_measures
from ..analysis.replication import gait_measures, group_by_table, interval_words, \
    over_tables, share_over_tables
from ..outputs.folder import OutputFolder, as_path, verify
from ..outputs.parts import PARTS_SUFFIX, CellParts
from ..outputs.study_index import INDEX as STUDY_INDEX, read_current
from ..outputs.writing import write_manifest
from ..outputs.weights import tables_state
from ..outputs.kept_tables import is_kept_tables, kept_controllers, kept_state, kept_weights
from ..runtime.resources import check_memory, estimate_bytes
from .run import controller_tables, trained_models, training_settings, with_variant
from ..settings.checks import STEP, check_grid
from ..settings.populations import population_table
from .simulate import simulate_closed_loop

BUILTIN_WORLDS = {"robustness": Path(__file__).with_name("robustness.toml")}
EVALUATION = "evaluation.csv"
SUMMARY = "summary.csv"
BASELINE = "baseline.csv"
COLUMNS = ("source", "condition", "point", "seed", "world", "repeat", "run_seed", "distance_m",
           "mean_speed_m_per_s", "fell", "time_to_fall_s", "upright_share", *MEASURE_COLUMNS)
"""One row per controller x world x repeat: the rhythm (``rhythm``, thigh-extensor bursts)
and the gait (``gait``, footfalls over the upright part; ``gait_reason`` when none) of each
run, so that every repeat's labels are kept."""
REPEATS = 5
"""Evaluation runs per controller and world by default: a gait is a share of runs."""


@dataclass
class WorldSet:
    """The settings a controller is evaluated in, by name: ``set`` (world parameters, absolute:
    ``NAME=VALUE`` texts) and ``scale`` (any model parameter times a factor, e.g. the torque per
    spike); ``axes``: a grid's axes [(name, value labels)] and ``cell``: each grid world's
    (i, j, ...) index, or empty."""

    worlds: dict[str, dict[str, Any]]
    axes: list[tuple[str, list[str]]]
    cell: dict[str, tuple[int, ...]]
    labels: dict[str, str]  # each axis as a figure labels it, e.g. "drive (x I_background_0)"

    def to_json(self) -> dict[str, Any]:
        return {"worlds": self.worlds, "axes": [[n, v] for n, v in self.axes]}


def read_worlds(source: str | Path, models: ModelSet, culprit: Any = None) -> WorldSet:
    """The worlds of a worlds file or a built-in name: ``[worlds.NAME]`` tables of world
    parameters (absolute values with units), and/or ``[grid.AXIS]`` tables whose product are
    worlds: ``values = [...]`` of the world parameter AXIS, or ``values = [factors]`` with
    ``scale = ["P", ...]``, model parameters multiplied together by each factor (e.g. the
    descending drive ``I_background_0``, the torques per spike ``I_thigh`` and ``I_calf``).
    Every name and value is checked (units, parse) here, each error naming its place:
    ``culprit`` where the file was named (default: the ``worlds`` setting with ``source``)."""
    where = setting("worlds", source) if culprit is None else culprit
    worlds, grid = _worlds_document(source, where)
    world_names = set(models.world.parameters)
    # the grid's size from its lengths alone, before a world of it is built or checked
    lengths = [len(t["values"]) for t in grid.values()
               if isinstance(t, dict) and isinstance(t.get("values"), list) and t["values"]]
    if len(lengths) == len(grid) and grid:
        check_grid(math.prod(lengths) + len(worlds),
                   f"worlds ({' x '.join(map(str, lengths))} grid values"
                   + (f", {len(worlds)} named" if worlds else "") + ")", culprit=where)

    def assignment(key: str, value: Any, at: str) -> str:
        if isinstance(value, dict):  # [worlds.a.b]: TOML reads the dot as a sub-table
            raise InputError(f"is a table, not a value (a name with a dot needs quotes: "
                             f'[worlds."a.b"])', culprit=f"{where} {at}")
        if key not in world_names:
            raise InputError(f"is not a world parameter ({', '.join(sorted(world_names))})",
                             culprit=f"{where} {at}")
        text = f"{key}={value}"
        models.parse_assignment(text)  # unit and parse check, named
        return text

    out: dict[str, dict[str, Any]] = {}
    for name, table in worlds.items():
        if not isinstance(table, dict):
            raise InputError("must be a table of world parameters", culprit=f"{where} {name}")
        out[str(name)] = {"set": [assignment(k, v, f"{name}.{k}") for k, v in table.items()],
                          "scale": {}}
    axes, labels, options = _grid_axes(grid, where, assignment, models)
    cell: dict[str, tuple[int, ...]] = {}
    for index in itertools.product(*(range(len(v)) for _, v in axes)) if axes else ():
        name = ", ".join(f"{axes[k][0]}={axes[k][1][i]}" for k, i in enumerate(index))
        merged: dict[str, Any] = {"set": [], "scale": {}}
        for k, i in enumerate(index):
            merged["set"] += options[k][i]["set"]
            merged["scale"].update(options[k][i]["scale"])
        out[name] = merged
        cell[name] = tuple(index)
    return WorldSet(worlds=out, axes=axes, cell=cell, labels=labels)


def _worlds_document(source: str | Path, where: str) -> tuple[dict[str, Any], dict[str, Any]]:
    """The ``[worlds]`` and ``[grid]`` tables of a worlds file or built-in name, read bounded
    (a regular file only: a FIFO is refused, never waited on)."""
    from ...support.shipped import resolve, unreadable
    path = BUILTIN_WORLDS.get(str(source)) or resolve(source, "worlds")
    try:
        doc = loads_toml(read_bytes(path, where).decode("utf-8"), where)
    except OSError as e:  # a misspelt name: its closest; a missing file: the environment's
        raise unreadable(source, "worlds", e, culprit=where,
                         builtin=tuple(BUILTIN_WORLDS)) from None
    except (UnicodeDecodeError, tomllib.TOMLDecodeError) as e:
        raise InputError(f"is not a TOML worlds file ({e})", culprit=where) from None
    worlds, grid = doc.get("worlds", {}), doc.get("grid", {})
    if (not isinstance(worlds, dict) or not isinstance(grid, dict) or not (worlds or grid)
            or set(doc) - {"worlds", "grid"}):
        raise InputError("needs [worlds.NAME] and/or [grid.AXIS] tables and nothing else",
                         culprit=where)
    return worlds, grid


def _grid_axes(grid: dict[str, Any], where: str, assignment: Any, models: ModelSet
               ) -> tuple[list[tuple[str, list[str]]], dict[str, str],
                          list[list[dict[str, Any]]]]:
    """Each ``[grid.AXIS]``, checked: its name and values, its label, and the world settings
    each of its values gives (a world parameter set, or model parameters scaled)."""
    axes: list[tuple[str, list[str]]] = []
    labels: dict[str, str] = {}
    options: list[list[dict[str, Any]]] = []
    touched: dict[str, str] = {}  # parameter -> the axis that sets or scales it
    for axis, table in grid.items():
        at = f"{where} grid.{axis}"
        if not isinstance(table, dict) or set(table) - {"values", "scale"}:
            raise InputError("needs values = [...] and, for factors, scale = [parameters]",
                             culprit=at)
        values = table.get("values")
        if not isinstance(values, list) or not values:
            raise InputError("needs a non-empty list of values", culprit=f"{at}.values")
        scale = table.get("scale")
        # one parameter, one axis: of two axes on it, one's value would win (or a factor
        # would be applied once) while each cell's label named both
        for p in ([str(axis)] if scale is None else
                  [str(p) for p in scale] if isinstance(scale, list) else []):
            if p in touched:
                other = touched[p]
                both = (f"grid.{other} and grid.{axis}" if other != axis
                        else f"grid.{axis}.scale")
                raise InputError(f"{'both set or scale' if other != axis else 'names twice'} "
                                 f"the parameter {p}: a cell would run at one value while its "
                                 f"label names {'both' if other != axis else 'it twice'}; "
                                 f"one axis per parameter", culprit=f"{where} {both}")
            touched[p] = str(axis)
        if scale is None:
            options.append([{"set": [assignment(axis, v, f"grid.{axis}")], "scale": {}}
                            for v in values])
            labels[str(axis)] = str(axis)
        else:
            options.append(_scale_options(scale, values, at, models))
            labels[str(axis)] = f"{axis} (x {', '.join(str(p) for p in scale)})"
        axes.append((str(axis), [str(v) for v in values]))
    return axes, labels, options


def _scale_options(scale: Any, values: list[Any], at: str, models: ModelSet
                   ) -> list[dict[str, Any]]:
    """A factor axis's settings: each positive factor scales every parameter of ``scale``."""
    if not isinstance(scale, list) or not scale:
        raise InputError("needs a list of parameter names", culprit=f"{at}.scale")
    for p in scale:
        models.parameter(str(p))  # an unknown name is named
    factors = []
    for v in values:
        if (isinstance(v, bool) or not isinstance(v, (int, float))
                or not math.isfinite(v) or v <= 0):
            raise InputError(f"a factor must be a positive number, got {v!r}",
                             culprit=f"{at}.values")
        factors.append(float(v))
    return [{"set": [], "scale": {str(p): f for p in scale}} for f in factors]


def grid_values(world_set: WorldSet, world: str) -> dict[str, str]:
    """``grid_<axis>``: the world's value on each grid axis ("" for a world not on the grid)."""
    index = world_set.cell.get(world)
    return {f"grid_{a}": (values[index[k]] if index is not None else "")
            for k, (a, values) in enumerate(world_set.axes)}


def in_world(models: ModelSet, world: Mapping[str, Any]) -> ModelSet:
    """``models`` in a world: every world parameter at its default (a named world is the whole
    world, whatever the controller was trained in: ``flat`` is flat for a controller trained on
    rough terrain too), then the world's settings, then its scaled parameters (factors of the
    controller's own values)."""
    values = {name: p.value for name, p in DEFAULT_MODELS.world.parameters.items()
              if name in models.world.parameters}
    values.update(dict(models.parse_assignment(t) for t in world["set"]))
    for name, factor in world["scale"].items():
        values[name] = models.parameter(name).value * factor
    return models.with_values(values)


def _controllers(folder: Path) -> list[dict[str, Any]]:
    """The trained controllers under ``folder``: itself (a training, or a run folder: the tables
    its trials ran with), the finished runs its
    study file now names (a study), or the runs of a kept-tables folder
    (:mod:`~astrocpg.studies.outputs.kept_tables`), each with its settings and what identifies
    its trials (condition, swept point, seeds)."""
    if (folder / "weights.npz").is_file():
        settings = training_settings(folder)
        return [{"folder": folder, "settings": settings, "condition":
                 "astrocytes" if settings.get("astrocytes", True) else "no_astrocytes",
                 "point": "", "first_seed": int(settings.get("seed", 1))}]
    if (folder / "robot.npz").is_file() and not (folder / STUDY_INDEX).exists():
        settings = training_settings(folder)  # a run folder (astrocpg run's out): its tables
        return [{"folder": folder, "settings": settings, "condition": "run", "point": "",
                 "first_seed": int(settings.get("seed", 1))}]
    runs = folder / "runs"
    if not (folder / STUDY_INDEX).exists() and is_kept_tables(folder):
        return kept_controllers(folder)
    check_regular(folder / STUDY_INDEX)  # a FIFO is refused, never waited on
    if not runs.is_dir() or not (folder / STUDY_INDEX).is_file():
        raise InputError(f"is neither a training (weights.npz), a study folder (runs/ and "
                         f"{STUDY_INDEX}) nor a folder of kept tables (RUN.json and RUN.npz)",
                         culprit=str(folder))
    found = []
    # the runs the study file now names, not the runs/ of an earlier version of it
    for run in sorted(runs / run_id for run_id in read_current(folder, str(folder))):
        try:
            status = read_json(run / "status.json")
        except InputError:  # not a regular file, nested too deeply: refused, naming it
            raise
        except (OSError, ValueError):
            continue
        if status.get("state") != "finished":
            continue
        spec = status.get("spec") or {}
        point = ";".join(f"{k}={v}" for k, v in sorted((spec.get("point") or {}).items()))
        found.append({"folder": run, "settings": training_settings(run),
                      "condition": spec.get("condition", ""), "point": point,
                      "first_seed": int(spec.get("seed", 1))})
    if not found:
        raise InputError("holds no finished run to evaluate", culprit=str(folder))
    return found


def _tables_label(controllers: Sequence[Mapping[str, Any]], session: int | None) -> str:
    """What the evaluated tables are: "after session S" with ``session``; "final" when every
    training did all its sessions; otherwise the sessions they are after, with a warning for
    each training that is still running or stopped early (never called final)."""
    if session is not None:
        return f"after session {session}"
    labels = []
    for c in controllers:
        if "kept" in c:
            state = kept_state(c)
        elif (Path(c["folder"]) / "weights.npz").is_file():
            state = tables_state(c["folder"])
        else:  # a run folder: the tables its trials ran with, no sessions
            continue
        if state["warning"]:
            warnings.warn(KEYWORDS(state["warning"]), UserWarning, stacklevel=3)
        labels.append(state["label"])
    if not labels:  # run folders only: each ran with a fixed table
        return "as run"
    if all(label == "final" for label in labels):
        return "final"
    return "latest: " + ", ".join(sorted(set(labels), key=labels.index))


def _trial_rows(result: Any, b: int, seconds: float) -> dict[str, Any]:
    """What one trial did: distance, speed, fall, upright share, and its rhythm and gait over
    its second half (:func:`~astrocpg.studies.analysis.gait.trial_measures`)."""
    rec = result.robot
    x = rec.torso_position[b, :, 0]
    alive = np.asarray(rec.alive[b], dtype=bool)
    fall = first_fall(rec.t, alive)  # the one definition of a fall (its first sample down)
    fell = fall is not None
    t_fall = fall.t_s if fell else math.nan
    t, i = result.spikes["motor"]
    return {"distance_m": float(x[-1] - x[0]), "mean_speed_m_per_s":
            float(rec.torso_velocity[b, :, 0].mean()), "fell": int(fell),
            "time_to_fall_s": t_fall, "upright_share": float(alive.mean()),
            **trial_measures(t, i, result.cpg.layout, rec, b, seconds / 2, seconds)}


def evaluate_cell(controller: Mapping[str, Any], tables: np.ndarray, world: str,
                  setting: Mapping[str, Any], grid: Mapping[str, str], seconds: float, seed: int,
                  repeats: int, progress: bool = False) -> list[dict[str, Any]]:
    """One training's controllers in one world: its trials x ``repeats`` as the trials of one
    network (trial ``r*n + k``: controller ``k``, repeat ``r``), learning off; one row each.
    Runs here or on a Dask worker (everything it takes is picklable). The populations the
    training added are built too: its network."""
    here = in_world(trained_models(controller["settings"]), setting)
    n = len(tables)
    batch = np.concatenate([tables] * repeats)
    try:
        result = simulate_closed_loop(
            here, seconds=seconds, seed=seed, n_trials=len(batch), weights=batch,
            record_traces=False, spikes=("motor",), progress=progress,
            populations=population_table(controller["settings"].get("populations")))
    except Diverged as e:
        raise _in_cell(e, controller, world, n, repeats) from None
    rows = []
    for b in range(len(batch)):
        r, k = divmod(b, n)
        rows.append({"source": controller.get("source", Path(controller["folder"]).name),
                     "condition": controller["condition"], "point": controller["point"],
                     "seed": controller["first_seed"] + k, "world": world, **grid,
                     "repeat": r, "run_seed": seed + b, **_trial_rows(result, b, seconds)})
    return rows


def _in_cell(e: Diverged, controller: Mapping[str, Any], world: str, n: int,
             repeats: int) -> Diverged:
    """The divergence of a cell's network, naming its world and the controller (its training,
    condition and seed; the repeat when there are several) of the trial that diverged."""
    source = controller.get("source", Path(controller["folder"]).name)
    if e.trial is not None and 0 <= e.trial < n * repeats:
        r, k = divmod(int(e.trial), n)
        who = (f"controller {source} (condition {controller['condition']}, seed "
               f"{controller['first_seed'] + k}" + (f", repeat {r}" if repeats > 1 else "")
               + ")")
    else:
        who = f"a controller of {source} (condition {controller['condition']})"
    return Diverged(e.raw_line, culprit=f"world '{world}', {who}", t=e.t, trial=e.trial)


def _fingerprint(plans: Sequence[tuple[dict[str, Any], np.ndarray, ModelSet]],
                 world_set: "WorldSet", seconds: float, repeats: int, seed: int) -> str:
    h = hashlib.sha256()
    h.update(json.dumps({"worlds": world_set.to_json(), "seconds": seconds, "repeats": repeats,
                         "seed": seed, "codegen": codegen_target(),
                         "controllers": [(str(c["folder"]), c["condition"], c["point"],
                                          c["first_seed"], c["settings"]) for c, _, _ in plans]},
                        sort_keys=True, default=str).encode())
    for _, tables, _ in plans:
        h.update(np.ascontiguousarray(tables, dtype=float).tobytes())
    return h.hexdigest()


def evaluate(folder: str | Path, *, worlds: str | Path = "robustness", seconds: float = 10.0,
             repeats: int = REPEATS, seed: int = 1, conditions: Sequence[str] | None = None,
             out: str | Path | None = None, overwrite: bool = False,
             progress: bool = True, workers: int | None = None,
             scheduler: str | None = None, session: int | None = None,
             points: Sequence[str] | None = None, baseline: str | None = None,
             variant: Mapping[str, Any] | None = None) -> dict[str, Any]:
    """Run every trained controller under ``folder`` in each world of ``worlds`` for
    ``seconds``, ``repeats`` times (different noise, seeds seed, seed+1, ... per repeat: all
    controllers of a training and all repeats run as trials of one network per world), learning
    off (``conditions``: only a study's runs of these conditions). Writes ``evaluation.csv``
    (one row per controller x world x repeat), ``summary.csv`` (per condition x point x world,
    each figure over the trained tables with its 95% interval over tables: distance, speed,
    fall rate, time to fall, share of runs with each gait and each rhythm, the gait's locking
    and its trot share at other thresholds, whether the tables differ: :func:`summarise`),
    ``gait_map.png`` for a two-axis grid, ``baseline.csv`` with ``baseline``, and
    ``manifest.json`` into ``out`` (default ``folder/evaluation``, replaced whole). Returns
    {"rows", "summary", "baseline", "out", "figures"}.

    Each (training, world) is one *cell*. The cells run on a Dask cluster (a local one of
    ``workers`` processes, by default the cores this process may use, or a running
    ``scheduler``), as a study's runs do; with one worker (or one cell), here, one after the
    other. Every finished cell is kept in
    ``<out>.parts/`` until the folder is written, so an interrupted evaluation, started again
    with the same arguments, runs only the cells it had not finished.

    ``session``: evaluate each training's tables after that session (every trial must have
    done it) rather than its final tables, e.g. a long study's tables after 120 and 200 of its
    400 sessions, evaluated the same way as the final ones."""
    folder = as_path(folder, "folder")
    value = EvaluateSettings(folder=folder, worlds=worlds, seconds=seconds, repeats=repeats,
                             seed=seed, conditions=conditions, points=points,
                             baseline=baseline, variant=variant, session=session)
    seconds, repeats, seed = value.seconds, value.repeats, value.seed
    _check_runner(workers, scheduler)
    target = Path(out) if out is not None else folder / "evaluation"
    # what it reads (the training or study, a worlds file) is never replaced nor written into
    # but at folder/evaluation
    inputs = [folder, *([worlds] if isinstance(worlds, (str, os.PathLike))
                        and os.path.isfile(worlds) else [])]
    OutputFolder(target, overwrite=overwrite or out is None, inputs=inputs).check()
    controllers = _chosen_controllers(folder, value.conditions, value.points, value.variant)
    plans = _controller_plans(controllers, value.session)
    tables_label = _tables_label(controllers, value.session)  # its warning before the work
    world_set = read_worlds(worlds, plans[0][2])
    if baseline is not None and baseline not in world_set.worlds:
        raise InputError(f"is not a world of {setting('worlds', worlds)} (worlds: "
                         f"{', '.join(world_set.worlds)})", culprit=setting("baseline", baseline))
    check_grid(len(plans) * len(world_set.worlds),
               f"cells ({len(plans)} training(s) x {len(world_set.worlds)} world(s))",
               culprit=f"evaluate {folder} {setting('worlds', worlds)}")
    _check_worlds(plans, world_set, worlds)
    n_max = max(len(t) for _, t, _ in plans) * repeats
    check_memory(estimate_bytes(trials=n_max, seconds=seconds, dt=STEP, robot_stride=1),
                 culprit=f"{setting('seconds', f'{seconds:g}')} x {n_max} trials")
    parts = CellParts(target.with_name(target.name + PARTS_SUFFIX),
                      _fingerprint(plans, world_set, seconds, repeats, seed))
    cells = {f"{ci:04d}-{wi:04d}": (c, tables, world, setting, grid_values(world_set, world))
             for ci, (c, tables, _) in enumerate(plans)
             for wi, (world, setting) in enumerate(world_set.worlds.items())}
    done, todo = pending(cells, parts.load)  # the cells kept by an interrupted evaluation
    todo = {cell: (c, tables, world, setting, grid, seconds, seed, repeats)
            for cell, (c, tables, world, setting, grid) in todo.items()}
    if todo:
        _run_cells(todo, done, parts, workers=workers, scheduler=scheduler, progress=progress,
                   n_cells=len(cells))
    rows: list[dict[str, Any]] = [row for cell in cells for row in done[cell]]
    # the settings (read back by EvaluateSettings.from_record), then what the evaluation found
    settings = {**value.record(), **world_set.to_json(), "tables": tables_label,
                "trainings": [str(c["folder"]) for c, _, _ in plans],
                "workers": workers, "scheduler": scheduler,
                "cells_reused": len(cells) - len(todo)}
    out_files = _write_evaluation(target, overwrite or out is None, inputs, rows, world_set,
                                  baseline, settings, plans[0][2])
    parts.remove()
    return {"out": target, **out_files}


def _check_runner(workers: Any, scheduler: Any) -> None:
    """An evaluation's workers, or its scheduler (how it runs: not among its settings, which
    do not change its rows)."""
    if scheduler is None:
        check_workers(workers)
    elif workers is not None and workers < 1:
        raise InputError(f"must be at least 1, got {workers}", culprit=setting("workers"))
    else:
        check_scheduler(scheduler)


def _chosen_controllers(folder: Path, conditions: Sequence[str] | None,
                        points: Sequence[str] | None,
                        variant: Mapping[str, Any] | None) -> list[dict[str, Any]]:
    """The trained controllers under ``folder``: only those of ``conditions`` and at
    ``points`` where given, each with the ``variant`` over its own settings."""
    controllers = _controllers(folder)
    if conditions:
        known = sorted({c["condition"] for c in controllers})
        for name in conditions:
            if name not in known:
                raise InputError(f"no finished run of that condition (conditions: "
                                 f"{', '.join(known)})", culprit=setting("conditions", name))
        controllers = [c for c in controllers if c["condition"] in conditions]
    if points:
        controllers = at_points(controllers, points)
    if variant and any(variant.values()):
        controllers = [{**c, "settings": with_variant(c["settings"], **variant)}
                       for c in controllers]
    return controllers


def _controller_plans(controllers: Sequence[dict[str, Any]], session: int | None
                      ) -> list[tuple[dict[str, Any], np.ndarray, ModelSet]]:
    """Each controller with its tables (after ``session``, else its final ones) and its
    training's model set."""
    plans = []
    for c in controllers:
        if "kept" in c:  # a kept table: its .npz is the one its .json names (sha256)
            tables = kept_weights(c, session)
        else:
            verify(c["folder"], strict=False)
            tables = controller_tables(c["folder"], session=session)
        population_table(c["settings"].get("populations"))  # its rows checked now
        plans.append((c, tables, trained_models(c["settings"])))
    return plans


def _write_evaluation(target: Path, overwrite: bool, inputs: Sequence[Any],
                      rows: list[dict[str, Any]], world_set: Any, baseline: str | None,
                      settings: dict[str, Any], models: ModelSet) -> dict[str, Any]:
    """The evaluation's folder, whole or nothing: its rows, their summary, the baseline's
    effects and the figures, with its manifest. Returns {"rows", "summary", "baseline",
    "figures"}."""
    from ..figures.gait_map import gait_map_figures, world_bars
    from ..figures.save import save_figure

    summary = summarise(rows)
    effects = baseline_effects(rows, baseline) if baseline is not None else []
    columns = list(COLUMNS)
    columns[columns.index("world") + 1:columns.index("world") + 1] = list(
        grid_values(world_set, ""))
    figures = {}
    if len(world_set.axes) == 2:
        figures = gait_map_figures(rows, world_set.axes, world_set.labels)
    named = [s for s in summary if s["world"] not in world_set.cell]
    if len({s["world"] for s in named}) >= 2:
        figures["worlds.png"] = world_bars(named)
    with OutputFolder(target, overwrite=overwrite, inputs=inputs) as tmp:
        (tmp / EVALUATION).write_text(_csv(rows, tuple(columns)))
        (tmp / SUMMARY).write_text(_csv(summary, tuple(summary[0]) if summary else ()))
        if baseline is not None:
            (tmp / BASELINE).write_text(_csv(effects, BASELINE_COLUMNS))
        for name, fig in figures.items():
            save_figure(fig, tmp / name)
        write_manifest(tmp, command="evaluate", seed=settings["seed"], settings=settings,
                       models_json=models.to_json(), files=_evaluation_files(baseline, figures),
                       results={"status": "finished", "rows": len(rows)})
    return {"rows": rows, "summary": summary, "baseline": effects, "figures": sorted(figures)}


def _evaluation_files(baseline: str | None, figures: Mapping[str, Any]) -> dict[str, str]:
    """What each file of an evaluation's folder holds (its manifest's ``files``)."""
    return {EVALUATION: "one row per trained controller x world x repeat",
            SUMMARY: "per condition x point x world: each figure over tables (each table's runs "
                     "first), with 95% intervals over tables",
            **({BASELINE: f"each world's effect relative to {baseline}: per table world minus "
                          "baseline, over tables; between conditions the difference of the "
                          "differences, paired by seed"}
               if baseline is not None else {}),
            **{n: "gait map over the grid's two axes: the most common gait label per cell "
                  "(colour), mean speed (contours)"
               for n in figures if n.startswith("gait_map")},
            **({"worlds.png": "speed and fall share per named world, one bar per condition"}
               if "worlds.png" in figures else {})}


def _check_worlds(plans: Sequence[tuple[dict[str, Any], np.ndarray, ModelSet]],
                  world_set: "WorldSet", source: Any) -> None:
    """Every world as each (distinct) controller's models meet it, checked as a build would
    check it (terrain grid, values; :func:`~astrocpg.coupling.assembly.check_models`) before
    any cell runs: a bad world stops the evaluation at once, not after the others ran."""
    from ...coupling.assembly import check_models

    seen: set[str] = set()
    for c, _, models in plans:
        key = json.dumps(c["settings"], sort_keys=True, default=str)
        if key in seen:
            continue
        seen.add(key)
        for name, world in world_set.worlds.items():
            try:
                check_models(in_world(models, world))
            except InputError as e:
                raise InputError(f"world '{name}': {e.raw_line}",
                                 culprit=setting("worlds", source)) from None


def _run_cells(todo: dict[str, tuple], done: dict[str, list[dict[str, Any]]],
               parts: CellParts, *, workers: int | None, scheduler: str | None,
               progress: bool, n_cells: int) -> None:
    """Run the cells of ``todo`` on the runtime's engine (:func:`~astrocpg.studies.runtime.cells.
    run_cells`, the one that runs a study's runs): here, one after the other, or on Dask,
    handed out as threads free up, largest batches first (no cell waits on a busy worker while
    another is idle); each is saved as it ends (into ``done`` and ``parts``)."""
    from ..runtime.progress import Bar as tqdm  # warnings wait until the bar closes

    bar = tqdm(total=n_cells, initial=len(done), unit="cell", desc="evaluate",
               disable=not progress, dynamic_ncols=True)

    def ended(cell: str, outcome: Any) -> None:
        rows = outcome.result()  # a cell's error (Diverged, ...) comes out as itself
        done[cell] = rows
        parts.save(cell, rows)
        bar.update()

    # the commands' one default (the cores this process may use); one process, or one cell:
    # here, without a cluster
    n = default_workers() if workers is None else workers
    here = scheduler is None and (n == 1 or len(todo) <= 1)
    order = list(todo) if here else sorted(todo, key=lambda cell: -len(todo[cell][1]))
    run_cells(evaluate_cell, [(cell, todo[cell]) for cell in order], ended, bar=bar, here=here,
              workers=n, scheduler=scheduler)


def summarise(rows: list[Mapping[str, Any]]) -> list[dict[str, Any]]:
    """Per (condition, point, world): each trained table's figures over its repeats first,
    then the mean over tables with a 95% interval over tables
    (:mod:`~astrocpg.studies.analysis.replication`: the runs of one table are not independent
    samples). ``n``: runs (``n_runs`` too), ``n_tables``: tables; ``<measure>_mean``, and
    ``<measure>_low``/``_high`` over tables for distance, speed, falls and upright share
    (``<measure>_std``: over runs, as before); each gait and rhythm share
    (``<kind>_<label>_share``, ``_low``, ``_high``) over tables; ``gait_locking_mean``: the
    continuous measure the gait label thresholds (the smallest foot locking, mean over tables
    of the runs read that far); ``gait_trot_share_at_<x>``: the trot gait share at locking
    thresholds :data:`~astrocpg.studies.analysis.gait.THRESHOLDS` (``_at_0``: the footfall
    phases alone); ``gait_trot_tables_differ_p``: whether the tables differ from each other in
    their trot gait share (:func:`~astrocpg.studies.analysis.replication.tables_differ`)."""
    groups: dict[tuple[str, str, str], list[Mapping[str, Any]]] = {}
    for r in rows:
        groups.setdefault((r["condition"], r["point"], r["world"]), []).append(r)
    out = []
    for (condition, point, world), rs in groups.items():
        tables = list(group_by_table(rs).values())
        entry: dict[str, Any] = {"condition": condition, "point": point, "world": world,
                                 **{k: v for k, v in rs[0].items() if k.startswith("grid_")},
                                 "n": len(rs), "n_runs": len(rs), "n_tables": len(tables)}
        for key in ("distance_m", "mean_speed_m_per_s", "fell", "upright_share"):
            v = np.array([r[key] for r in rs], dtype=float)
            s = over_tables([np.mean([float(r[key]) for r in t]) for t in tables],
                            share=key in ("fell", "upright_share"))
            entry[f"{key}_mean"] = s["mean"]
            entry[f"{key}_std"] = float(v.std(ddof=1)) if len(v) > 1 else math.nan
            entry[f"{key}_low"], entry[f"{key}_high"] = s["low"], s["high"]
        falls = np.array([r["time_to_fall_s"] for r in rs], dtype=float)
        entry["time_to_fall_s_median"] = (float(np.nanmedian(falls))
                                          if np.isfinite(falls).any() else math.nan)
        for kind in ("gait", "rhythm"):  # the feet's gait and the CPG's rhythm, both named
            labels = [[r[kind] for r in t] for t in tables]
            for label in ("trot", "any"):
                sh = share_over_tables(labels, set(NAMED) if label == "any" else label)
                entry[f"{kind}_{label}_share"] = sh["mean"]
                entry[f"{kind}_{label}_low"] = sh["low"]
                entry[f"{kind}_{label}_high"] = sh["high"]
        entry.update(gait_measures(tables))
        out.append(entry)
    return out


def at_points(controllers: list[dict[str, Any]], points: Sequence[str]
              ) -> list[dict[str, Any]]:
    """The controllers of a study at one sweep point: ``points`` are ``NAME=VALUE`` texts (the
    swept parameter and its value as the study file writes it, spaces ignored); a name that is
    not swept, or a value no finished run has, is refused, naming the option and what there
    is."""
    def parts(point: str) -> dict[str, str]:
        return dict(p.split("=", 1) for p in point.split(";") if "=" in p)

    have = [parts(c["point"]) for c in controllers]
    swept = sorted({k for h in have for k in h})
    want: dict[str, str] = {}
    for text in points:
        name, sep, value = (x.strip() for x in str(text).partition("="))
        where = setting("point", text)
        if not sep or not name or not value:
            raise InputError("expected NAME=VALUE (a swept parameter and its value)",
                             culprit=where)
        if not swept:
            raise InputError("the folder has no sweep points (not a study with a [sweep])",
                             culprit=where)
        if name not in swept:
            raise InputError(f"is not a swept parameter (swept: {', '.join(swept)})",
                             culprit=where)
        values = sorted({h[name] for h in have if name in h})
        if value.replace(" ", "") not in {v.replace(" ", "") for v in values}:
            raise InputError(f"no finished run at that value ({name}: {', '.join(values)})",
                             culprit=where)
        want[name] = value.replace(" ", "")
    kept = [c for c, h in zip(controllers, have)
            if all(h.get(k, "").replace(" ", "") == v for k, v in want.items())]
    if not kept:
        raise InputError("no finished run at that point (each value exists, not together)",
                         culprit=" ".join(str(setting("point", p)) for p in points))
    return kept


EFFECT_MEASURES = (("fell", "falls (share of runs)"), ("mean_speed_m_per_s", "speed (m/s)"),
                   ("distance_m", "distance (m)"), ("gait_trot", "trot gait (share of runs)"))
BASELINE_COLUMNS = ("condition", "point", "world", "baseline", "measure", "n_tables",
                    "in_world", "in_baseline", "effect", "effect_low", "effect_high",
                    "p", "reading")
"""The columns of ``baseline.csv``: one row per condition x point x world x measure (its
effect: world minus baseline per table, mean and 95% interval over tables), and, where a
point has two conditions, one row per pair (``condition`` "A - B": the difference of their
effects, paired by seed, with its 95% bootstrap interval, sign-flip permutation p and what
it supports in words)."""


def _table_value(rs: Sequence[Mapping[str, Any]], key: str) -> float:
    if key == "gait_trot":
        return float(np.mean([r["gait"] == "trot" for r in rs]))
    return float(np.mean([float(r[key]) for r in rs]))


def baseline_effects(rows: Sequence[Mapping[str, Any]], baseline: str) -> list[dict[str, Any]]:
    """Each world's effect relative to the world ``baseline`` (e.g. flat ground): per trained
    table (source and seed) its figure in the world minus its figure in the baseline (each over
    its repeats), then the mean over tables with a 95% t interval over tables; where a point
    has two or more conditions, each pair's difference of those differences, paired by seed
    (difference-in-differences: "falls less in this world" is then the world's effect beyond
    the flat-ground difference, not the raw falls). Rows of :data:`BASELINE_COLUMNS`."""
    from ..analysis.compare import compare, reading_words

    per: dict[tuple, dict[str, dict[tuple, list[Mapping[str, Any]]]]] = {}
    for r in rows:
        per.setdefault((r["condition"], r["point"]), {}).setdefault(r["world"], {}) \
            .setdefault((r["source"], r["seed"]), []).append(r)
    out: list[dict[str, Any]] = []
    effects: dict[tuple, dict[Any, float]] = {}  # (condition, point, world, key) -> seed -> d
    for (condition, point), worlds in per.items():
        base = worlds.get(baseline, {})
        for world, tables in worlds.items():
            if world == baseline:
                continue
            for key, label in EFFECT_MEASURES:
                d = {t[1]: _table_value(rs, key) - _table_value(base[t], key)
                     for t, rs in tables.items() if t in base}
                effects[(condition, point, world, key)] = d
                s = over_tables(list(d.values()))
                out.append({"condition": condition, "point": point, "world": world,
                            "baseline": baseline, "measure": label, "n_tables": s["n_tables"],
                            "in_world": float(np.mean([_table_value(rs, key)
                                                       for rs in tables.values()])),
                            "in_baseline": float(np.mean([_table_value(rs, key)
                                                          for rs in base.values()]))
                            if base else math.nan,
                            "effect": s["mean"], "effect_low": s["low"],
                            "effect_high": s["high"], "p": math.nan, "reading": ""})
    conditions = list(dict.fromkeys(c for c, _ in per))
    for point in dict.fromkeys(p for _, p in per):
        for a, b in itertools.combinations([c for c in conditions if (c, point) in per], 2):
            for world in per[(a, point)]:
                if world == baseline:
                    continue
                for key, label in EFFECT_MEASURES:
                    da = effects.get((a, point, world, key), {})
                    db = effects.get((b, point, world, key), {})
                    seeds = sorted(set(da) & set(db), key=str)
                    t = compare([da[k] for k in seeds], [db[k] for k in seeds], paired=True)
                    out.append({"condition": f"{a} - {b}", "point": point, "world": world,
                                "baseline": baseline, "measure": label,
                                "n_tables": len(seeds), "in_world": math.nan,
                                "in_baseline": math.nan, "effect": t["difference"],
                                "effect_low": t["difference_low"],
                                "effect_high": t["difference_high"],
                                "p": t["perm_p"], "reading": reading_words(t)})
    return out


def format_baseline(effects: Sequence[Mapping[str, Any]]) -> list[str]:
    """One line per world and condition (or pair of conditions) per measure: its effect
    relative to the baseline world with its 95% interval over tables."""
    lines = []
    for e in effects:
        where = f"{e['condition']}{' ' + e['point'] if e['point'] else ''}"
        iv = ("" if e["effect_low"] is None or not np.isfinite(e["effect_low"]) else
              f" [{e['effect_low']:+.3g}, {e['effect_high']:+.3g}]")
        pair = " - " in e["condition"]
        lines.append(f"{where:<28} {e['world']:<16} {e['measure']}, {e['world']} minus "
                     f"{e['baseline']}: {e['effect']:+.3g}{iv}"
                     + (f" (difference of the conditions' effects, paired by seed, "
                        f"n = {e['n_tables']}; {e['reading']})" if pair else
                        f" (n = {e['n_tables']} tables; 95% interval over tables)"))
    return lines


def _csv(rows: list[Mapping[str, Any]], columns: tuple[str, ...]) -> str:
    buf = io.StringIO()
    w = csv.DictWriter(buf, fieldnames=list(columns), lineterminator="\n")
    w.writeheader()
    for r in rows:
        w.writerow({k: (f"{v:.6g}" if isinstance(v, float) else v) for k, v in r.items()})
    return buf.getvalue()


def format_summary(summary: list[Mapping[str, Any]]) -> list[str]:
    """One line per condition x point x world, then what the trot gait share rests on: each
    figure is the mean over trained tables (each table's runs first) with its 95% interval over
    tables, n given as tables x runs."""
    lines = []
    for s in summary:
        where = f"{s['condition']}{' ' + s['point'] if s['point'] else ''}"

        def iv(kind: str, fmt: str = ".0%") -> str:
            return interval_words({"mean": s[f"{kind}_share"] if f"{kind}_share" in s
                                   else s[f"{kind}_mean"], "low": s[f"{kind}_low"],
                                   "high": s[f"{kind}_high"], "n_tables": s["n_tables"]}, fmt)

        thresholds = ", ".join(f"{s[f'gait_trot_share_at_{x:g}']:.0%} at {x:g}"
                               for x in THRESHOLDS)
        differ = s["gait_trot_tables_differ_p"]
        lines.append(
            f"{where:<28} {s['world']:<16} distance {s['distance_m_mean']:+.2f} "
            f"+- {s['distance_m_std']:.2f} m, speed {iv('mean_speed_m_per_s', '+.3f')} m/s, "
            f"falls {iv('fell')}, gait (footfalls) trot {iv('gait_trot')}, rhythm (thigh "
            f"bursts) trot {iv('rhythm_trot')} (n = {s['n_tables']} table"
            f"{'s' if s['n_tables'] != 1 else ''} x {s['n_runs'] // max(s['n_tables'], 1)} "
            f"runs; 95% intervals over tables)")
        lines.append(
            f"{'':<28} {'':<16} gait locking (the smallest foot's; the label needs 0.7) "
            f"{s['gait_locking_mean']:.2f}; trot gait share by locking threshold: "
            f"{thresholds}; footfall phases alone {s['gait_trot_share_at_0']:.0%}; do the tables "
            + (f"differ in their trot share? permutation p = {differ:.2g}"
               if np.isfinite(differ) else "differ? one table only"))
    return lines
