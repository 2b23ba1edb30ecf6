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
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Mapping, Sequence

import numpy as np

from ..runtime.cells import pending, run_cells
from ..runtime.cluster import check_scheduler, check_workers
from ..runtime.workers import default_workers
from ...errors import InputError
from ...reading import check_regular, loads_toml, read_bytes, read_json
from ...models import DEFAULT_MODELS, ModelSet
from ...network import codegen_target
from ..analysis.fall import first_fall
from ..analysis.gait import MEASURE_COLUMNS, NAMED, trial_measures
from ..analysis.share import label_shares, wilson_interval
from ..outputs.folder import OutputFolder, as_path, verify
from ..outputs.parts import PARTS_SUFFIX, CellParts
from ..outputs.study_index import INDEX as STUDY_INDEX, read_current
from ..outputs.writing import write_manifest
from ..outputs.weights import load_weights
from ..outputs.kept_tables import is_kept_tables, kept_controllers, kept_weights
from ..runtime.resources import check_memory, estimate_bytes
from .run import trained_models, training_settings
from .settings import added_populations, check_grid, number, seed_number
from .simulate import STEP, check_duration, simulate_closed_loop

BUILTIN_WORLDS = {"robustness": Path(__file__).with_name("robustness.toml")}
EVALUATION = "evaluation.csv"
SUMMARY = "summary.csv"
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


def read_worlds(source: str | Path, models: ModelSet) -> WorldSet:
    """The worlds of a worlds file or a built-in name: ``[worlds.NAME]`` tables of world
    parameters (absolute values with units), and/or ``[grid.AXIS]`` tables whose product are
    worlds: ``values = [...]`` of the world parameter AXIS, or ``values = [factors]`` with
    ``scale = ["P", ...]``, model parameters multiplied together by each factor (e.g. the
    descending drive ``I_background_0``, the torques per spike ``I_thigh`` and ``I_calf``).
    Every name and value is checked (units, parse) here, each error naming its place."""
    from ...shipped import resolve
    path = BUILTIN_WORLDS.get(str(source)) or resolve(source, "worlds")
    where = f"--worlds {source}"
    try:
        # a regular file only (a FIFO is refused, never waited on), nesting bounded
        doc = loads_toml(read_bytes(path, where).decode("utf-8"), where)
    except OSError as e:
        raise InputError(f"cannot read it ({e.strerror}); built-in: "
                         f"{', '.join(BUILTIN_WORLDS)}", culprit=where) from None
    except (UnicodeDecodeError, tomllib.TOMLDecodeError) as e:
        raise InputError(f"is not a TOML worlds file ({e})", culprit=where) from None
    worlds, grid = doc.get("worlds", {}), doc.get("grid", {})
    if (not isinstance(worlds, dict) or not isinstance(grid, dict) or not (worlds or grid)
            or set(doc) - {"worlds", "grid"}):
        raise InputError("needs [worlds.NAME] and/or [grid.AXIS] tables and nothing else",
                         culprit=where)
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
            options.append([{"set": [], "scale": {str(p): f for p in scale}} for f in factors])
            labels[str(axis)] = f"{axis} (x {', '.join(str(p) for p in scale)})"
        axes.append((str(axis), [str(v) for v in values]))
    cell: dict[str, tuple[int, ...]] = {}
    if axes:
        for index in itertools.product(*(range(len(v)) for _, v in axes)):
            name = ", ".join(f"{axes[k][0]}={axes[k][1][i]}" for k, i in enumerate(index))
            merged: dict[str, Any] = {"set": [], "scale": {}}
            for k, i in enumerate(index):
                merged["set"] += options[k][i]["set"]
                merged["scale"].update(options[k][i]["scale"])
            out[name] = merged
            cell[name] = tuple(index)
    return WorldSet(worlds=out, axes=axes, cell=cell, labels=labels)


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
    """The trained trainings under ``folder``: itself (a training), the finished runs its
    study file now names (a study), or the runs of a kept-tables folder
    (:mod:`~astrocpg.studies.outputs.kept_tables`), each with its settings and what identifies
    its trials (condition, swept point, seeds)."""
    if (folder / "weights.npz").is_file():
        settings = training_settings(folder)
        return [{"folder": folder, "settings": settings, "condition":
                 "astrocytes" if settings.get("astrocytes", True) else "no_astrocytes",
                 "point": "", "first_seed": int(settings.get("seed", 1))}]
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
    with added_populations(controller["settings"].get("populations")):
        result = simulate_closed_loop(here, seconds=seconds, seed=seed, n_trials=len(batch),
                                      weights=batch, record_traces=False, spikes=("motor",),
                                      progress=progress)
    rows = []
    for b in range(len(batch)):
        r, k = divmod(b, n)
        rows.append({"source": controller.get("source", Path(controller["folder"]).name),
                     "condition": controller["condition"], "point": controller["point"],
                     "seed": controller["first_seed"] + k, "world": world, **grid,
                     "repeat": r, "run_seed": seed + b, **_trial_rows(result, b, seconds)})
    return rows


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
             scheduler: str | None = None, session: int | None = None) -> dict[str, Any]:
    """Run every trained controller under ``folder`` in each world of ``worlds`` for
    ``seconds``, ``repeats`` times (different noise, seeds seed, seed+1, ... per repeat: all
    controllers of a training and all repeats run as trials of one network per world), learning
    off (``conditions``: only a study's runs of these conditions). Writes ``evaluation.csv``
    (one row per controller x world x repeat), ``summary.csv`` (mean and std over controllers
    and repeats per condition x point x world: distance, speed, fall rate, time to fall, share
    of runs with each gait and each rhythm, with Wilson 95% intervals), ``gait_map.png`` for a two-axis grid, and ``manifest.json`` into ``out`` (default
    ``folder/evaluation``, replaced whole). Returns {"rows", "summary", "out", "figures"}.

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
    seconds = number(seconds, "--seconds", positive=True)
    check_duration(seconds, STEP)
    repeats = number(repeats, "--repeats", integer=True, minimum=1)
    seed = seed_number(seed)
    if scheduler is None:
        check_workers(workers)
    elif workers is not None and workers < 1:
        raise InputError(f"must be at least 1, got {workers}", culprit="--workers")
    else:
        check_scheduler(scheduler)
    target = Path(out) if out is not None else folder / "evaluation"
    # what it reads (the training or study, a worlds file) is never replaced nor written into
    # but at folder/evaluation
    inputs = [folder, *([worlds] if isinstance(worlds, (str, os.PathLike))
                        and os.path.isfile(worlds) else [])]
    OutputFolder(target, overwrite=overwrite or out is None, inputs=inputs).check()
    controllers = _controllers(folder)
    if conditions:
        known = sorted({c["condition"] for c in controllers})
        for name in conditions:
            if name not in known:
                raise InputError(f"no finished run of that condition (conditions: "
                                 f"{', '.join(known)})", culprit=f"--condition {name}")
        controllers = [c for c in controllers if c["condition"] in conditions]
    plans = []
    for c in controllers:
        if "kept" in c:  # a kept table: its .npz is the one its .json names (sha256)
            tables = kept_weights(c, session)
        else:
            verify(c["folder"], strict=False)
            tables = load_weights(c["folder"], culprit="", session=session)
        plans.append((c, tables, trained_models(c["settings"])))
    world_set = read_worlds(worlds, plans[0][2])
    check_grid(len(plans) * len(world_set.worlds),
               f"cells ({len(plans)} training(s) x {len(world_set.worlds)} world(s))",
               culprit=f"evaluate {folder} --worlds {worlds}")
    _check_worlds(plans, world_set, worlds)
    n_max = max(len(t) for _, t, _ in plans) * repeats
    check_memory(estimate_bytes(trials=n_max, seconds=seconds, dt=STEP, robot_stride=1),
                 culprit=f"--seconds {seconds:g} x {n_max} trials")
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
    summary = summarise(rows)
    columns = list(COLUMNS)
    columns[columns.index("world") + 1:columns.index("world") + 1] = list(
        grid_values(world_set, ""))
    from ..figures.gait_map import gait_map_figures, world_bars
    from ..figures.save import save_figure

    figures = {}
    if len(world_set.axes) == 2:
        figures = gait_map_figures(rows, world_set.axes, world_set.labels)
    named = [s for s in summary if s["world"] not in world_set.cell]
    if len({s["world"] for s in named}) >= 2:
        figures["worlds.png"] = world_bars(named)
    settings = {"folder": str(folder), **world_set.to_json(),
                "worlds_source": str(worlds), "seconds": seconds, "repeats": repeats,
                "seed": seed, "conditions": list(conditions or []),
                "tables": "final" if session is None else f"after session {session}",
                "trainings": [str(c["folder"]) for c, _, _ in plans],
                "workers": workers, "scheduler": scheduler,
                "cells_reused": len(cells) - len(todo)}
    with OutputFolder(target, overwrite=overwrite or out is None, inputs=inputs) as tmp:
        (tmp / EVALUATION).write_text(_csv(rows, tuple(columns)))
        (tmp / SUMMARY).write_text(_csv(summary, tuple(summary[0]) if summary else ()))
        for name, fig in figures.items():
            save_figure(fig, tmp / name)
        write_manifest(tmp, command="evaluate", seed=seed, settings=settings,
                       models_json=plans[0][2].to_json(),
                       files={EVALUATION: "one row per trained controller x world x repeat",
                              SUMMARY: "mean and std per condition x point x world",
                              **{n: "gait map over the grid's two axes: the most common gait "
                                    "label per cell (colour), mean speed (contours)"
                                 for n in figures if n.startswith("gait_map")},
                              **({"worlds.png": "speed and fall share per named world, "
                                                "one bar per condition"}
                                 if "worlds.png" in figures else {})},
                       results={"status": "finished", "rows": len(rows)})
    parts.remove()
    return {"rows": rows, "summary": summary, "out": target, "figures": sorted(figures)}


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
                raise InputError(f"world '{name}': {e}", culprit=f"--worlds {source}") from None


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
    """Mean and std over controllers and repeats per (condition, point, world)."""
    groups: dict[tuple[str, str, str], list[Mapping[str, Any]]] = {}
    for r in rows:
        groups.setdefault((r["condition"], r["point"], r["world"]), []).append(r)
    out = []
    for (condition, point, world), rs in groups.items():
        entry: dict[str, Any] = {"condition": condition, "point": point, "world": world,
                                 **{k: v for k, v in rs[0].items() if k.startswith("grid_")},
                                 "n": len(rs)}
        for key in ("distance_m", "mean_speed_m_per_s", "fell", "upright_share"):
            v = np.array([r[key] for r in rs], dtype=float)
            entry[f"{key}_mean"] = float(v.mean())
            entry[f"{key}_std"] = float(v.std(ddof=1)) if len(v) > 1 else math.nan
        falls = np.array([r["time_to_fall_s"] for r in rs], dtype=float)
        entry["time_to_fall_s_median"] = (float(np.nanmedian(falls))
                                          if np.isfinite(falls).any() else math.nan)
        for kind in ("gait", "rhythm"):  # the feet's gait and the CPG's rhythm, both named
            shares = label_shares([r[kind] for r in rs], NAMED)
            for label in ("trot", "any"):
                sh = shares.get(label, {"share": 0.0, **dict(zip(
                    ("low", "high"), wilson_interval(0, len(rs))))})
                entry[f"{kind}_{label}_share"] = sh["share"]
                entry[f"{kind}_{label}_low"] = sh["low"]
                entry[f"{kind}_{label}_high"] = sh["high"]
        out.append(entry)
    return out


def _csv(rows: list[Mapping[str, Any]], columns: tuple[str, ...]) -> str:
    buf = io.StringIO()
    w = csv.DictWriter(buf, fieldnames=list(columns), lineterminator="\n")
    w.writeheader()
    for r in rows:
        w.writerow({k: (f"{v:.6g}" if isinstance(v, float) else v) for k, v in r.items()})
    return buf.getvalue()


def format_summary(summary: list[Mapping[str, Any]]) -> list[str]:
    """One line per condition x point x world."""
    lines = []
    for s in summary:
        where = f"{s['condition']}{' ' + s['point'] if s['point'] else ''}"
        lines.append(f"{where:<28} {s['world']:<16} distance {s['distance_m_mean']:+.2f} "
                     f"+- {s['distance_m_std']:.2f} m, speed {s['mean_speed_m_per_s_mean']:+.3f} "
                     f"m/s, falls {s['fell_mean']:.0%}, gait (footfalls) trot "
                     f"{s['gait_trot_share']:.0%} ({s['gait_trot_low']:.0%}-"
                     f"{s['gait_trot_high']:.0%}), rhythm (thigh bursts) trot "
                     f"{s['rhythm_trot_share']:.0%} ({s['rhythm_trot_low']:.0%}-"
                     f"{s['rhythm_trot_high']:.0%}) (n = {s['n']} runs; 95% Wilson intervals)")
    return lines
