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

``robustness`` (``studies/experiments/robustness.toml``) holds the worlds of the paper's open
question: slopes of +-0.09 and +-0.17 rad, rough terrain of two heights, lower friction and a
lateral push.
"""

from __future__ import annotations

import csv
import io
import itertools
import math
import tomllib
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Mapping, Sequence

import numpy as np

from ...errors import InputError
from ...models import DEFAULT_MODELS, ModelSet
from ..analysis.gait import trial_gait
from ..files.folder import OutputFolder, verify
from ..files.outputs import write_manifest
from ..files.weights import load_weights
from .resources import check_memory, estimate_bytes
from .run import training_settings
from .settings import model_set, number, seed_number
from .simulate import STEP, simulate_closed_loop

BUILTIN_WORLDS = {"robustness": Path(__file__).with_name("robustness.toml")}
EVALUATION = "evaluation.csv"
SUMMARY = "summary.csv"
COLUMNS = ("source", "condition", "point", "seed", "world", "repeat", "distance_m",
           "mean_speed_m_per_s", "fell", "time_to_fall_s", "upright_share", "gait",
           "period_s", "locking_FL", "locking_RR", "locking_RL", "phase_FL", "phase_RR",
           "phase_RL")


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
    path = BUILTIN_WORLDS.get(str(source), Path(source))
    where = f"--worlds {source}"
    try:
        doc = tomllib.loads(path.read_bytes().decode("utf-8"))
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
    for axis, table in grid.items():
        at = f"{where} grid.{axis}"
        if not isinstance(table, dict) or set(table) - {"values", "scale"}:
            raise InputError("needs values = [...] and, for factors, scale = [parameters]",
                             culprit=at)
        values = table.get("values")
        if not isinstance(values, list) or not values:
            raise InputError("needs a non-empty list of values", culprit=f"{at}.values")
        scale = table.get("scale")
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
    """The trained trainings under ``folder``: itself (a training), or a study's finished runs,
    each with its settings and what identifies its trials (condition, swept point, seeds)."""
    if (folder / "weights.npz").is_file():
        settings = training_settings(folder)
        return [{"folder": folder, "settings": settings, "condition":
                 "astrocytes" if settings.get("astrocytes", True) else "no_astrocytes",
                 "point": "", "first_seed": int(settings.get("seed", 1))}]
    runs = folder / "runs"
    if not runs.is_dir():
        raise InputError("is neither a training (weights.npz) nor a study folder (runs/)",
                         culprit=str(folder))
    import json

    found = []
    for run in sorted(p for p in runs.iterdir() if p.is_dir()):
        try:
            status = json.loads((run / "status.json").read_text())
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
    """What one trial did: distance, speed, fall, upright share, gait over its second half."""
    rec = result.robot
    x = rec.torso_position[b, :, 0]
    alive = np.asarray(rec.alive[b], dtype=bool)
    fell = not bool(alive.all())
    t_fall = float(np.argmin(alive) + 1) * STEP if fell else math.nan
    t, i = result.spikes["motor"]
    return {"distance_m": float(x[-1] - x[0]), "mean_speed_m_per_s":
            float(rec.torso_velocity[b, :, 0].mean()), "fell": int(fell),
            "time_to_fall_s": t_fall, "upright_share": float(alive.mean()),
            **trial_gait(t, i, result.cpg.layout, b, seconds / 2, seconds)}


def evaluate(folder: str | Path, *, worlds: str | Path = "robustness", seconds: float = 10.0,
             repeats: int = 2, seed: int = 1, conditions: Sequence[str] | None = None,
             out: str | Path | None = None, overwrite: bool = False,
             progress: bool = True) -> dict[str, Any]:
    """Run every trained controller under ``folder`` in each world of ``worlds`` for
    ``seconds``, ``repeats`` times (different noise, seeds seed, seed+1, ... per repeat: all
    controllers of a training and all repeats run as trials of one network per world), learning
    off (``conditions``: only a study's runs of these conditions). Writes ``evaluation.csv``
    (one row per controller x world x repeat), ``summary.csv`` (mean and std over controllers
    and repeats per condition x point x world: distance, speed, fall rate, time to fall, share
    of trot), ``gait_map.png`` for a two-axis grid, and ``manifest.json`` into ``out`` (default
    ``folder/evaluation``, replaced whole). Returns {"rows", "summary", "out", "figures"}."""
    folder = Path(folder)
    seconds = number(seconds, "--seconds", positive=True)
    repeats = number(repeats, "--repeats", integer=True, minimum=1)
    seed = seed_number(seed)
    target = Path(out) if out is not None else folder / "evaluation"
    OutputFolder(target, overwrite=overwrite or out is None).check()
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
        verify(c["folder"], strict=False)
        tables = load_weights(c["folder"], culprit="")
        s = c["settings"]
        models = model_set(s.get("overrides", []), s.get("equations", {}),
                           models=s.get("models"))
        if not s.get("astrocytes", True):
            models = models.with_values({"astrocyte_regulation": 0.0})
        plans.append((c, tables, models))
    world_set = read_worlds(worlds, plans[0][2])
    n_max = max(len(t) for _, t, _ in plans) * repeats
    check_memory(estimate_bytes(trials=n_max, seconds=seconds, dt=STEP, robot_stride=1),
                 culprit=f"--seconds {seconds:g} x {n_max} trials")
    rows: list[dict[str, Any]] = []
    for c, tables, models in plans:
        n = len(tables)
        batch = np.concatenate([tables] * repeats)  # trial r*n + k: controller k, repeat r
        for world, setting in world_set.worlds.items():
            here = in_world(models, setting)
            result = simulate_closed_loop(here, seconds=seconds, seed=seed, n_trials=len(batch),
                                          weights=batch, record_traces=False,
                                          spikes=("motor",), progress=progress)
            for b in range(len(batch)):
                r, k = divmod(b, n)
                rows.append({"source": c["folder"].name, "condition": c["condition"],
                             "point": c["point"], "seed": c["first_seed"] + k, "world": world,
                             **grid_values(world_set, world), "repeat": r,
                             **_trial_rows(result, b, seconds)})
    summary = summarise(rows)
    columns = list(COLUMNS)
    columns[columns.index("world") + 1:columns.index("world") + 1] = list(
        grid_values(world_set, ""))
    from ..figures.gait_map import gait_map_figures, world_bars

    figures = {}
    if len(world_set.axes) == 2:
        figures = gait_map_figures(rows, world_set.axes, world_set.labels)
    named = [s for s in summary if s["world"] not in world_set.cell]
    if len({s["world"] for s in named}) >= 2:
        figures["worlds.png"] = world_bars(named)
    settings = {"folder": str(folder), **world_set.to_json(),
                "worlds_source": str(worlds), "seconds": seconds, "repeats": repeats,
                "seed": seed, "conditions": list(conditions or []),
                "trainings": [str(c["folder"]) for c, _, _ in plans]}
    with OutputFolder(target, overwrite=overwrite or out is None) as tmp:
        (tmp / EVALUATION).write_text(_csv(rows, tuple(columns)))
        (tmp / SUMMARY).write_text(_csv(summary, tuple(summary[0]) if summary else ()))
        for name, fig in figures.items():
            fig.savefig(tmp / name, dpi=120)
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
    return {"rows": rows, "summary": summary, "out": target, "figures": sorted(figures)}


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
        entry["trot_share"] = float(np.mean([r["gait"] == "trot" for r in rs]))
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
                     f"m/s, falls {s['fell_mean']:.0%}, trot {s['trot_share']:.0%} "
                     f"(n = {s['n']})")
    return lines
