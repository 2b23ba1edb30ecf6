"""The figures of a parameter study's report: Fig. 3c (the curves over sessions, one line per
group), the final figures against the swept values (one axis: a panel per measure; two axes
as a grid: a heatmap per measure; otherwise each sweep point as a category) and the gait map
over two swept axes. Each returns matplotlib Figures with the file names the report gives
them and what each shows; the numbers come from
:mod:`astrocpg.studies.analysis.final_figures`, the files are the report's to write."""

from __future__ import annotations

import re
from pathlib import Path
from typing import Any, Sequence

import numpy as np

from ...models import DEFAULT_MODELS
from ..analysis.final_figures import CURVES, Measure, cell_stats
from .plots import session_ticks
from .sweep import Axis, measure_heatmap, measure_vs_value

_NUMBER = re.compile(r"\s*([-+]?(?:\d+\.?\d*|\.\d+)(?:[eE][-+]?\d+)?)\s*(?:\*\s*(.+?))?\s*")


def fig3c(name: str, curves: Sequence[tuple[int, str, Sequence[tuple[np.ndarray, np.ndarray]]]],
          smooth: int) -> Any:
    """The paper's Fig. 3c for a study: per session, mean +- std across seeds of each of
    :data:`~astrocpg.studies.analysis.final_figures.CURVES`, one line per group. ``curves``:
    (the group's index: its colour, its legend label, (mean, std) per curve)."""
    # heavy: only when a report is drawn; outside pyplot, so the caller's backend is left alone
    from matplotlib.figure import Figure

    fig = Figure(figsize=(8, 8))
    axes = fig.subplots(3, 1, sharex=True)
    for k, label, stats in curves:
        color = f"C{k}"
        for ax, (_, ylabel), (mean, std) in zip(axes, CURVES, stats):
            x = np.arange(1, len(mean) + 1)
            ax.plot(x, mean, color=color, lw=1.2, label=label)
            ax.fill_between(x, mean - std, mean + std, color=color, alpha=0.25, lw=0)
            ax.set_ylabel(ylabel)
    axes[0].legend(fontsize=8, loc="best")
    axes[-1].set_xlabel("session")
    session_ticks(axes[-1])
    axes[0].set_title(f"Study {name}: mean +- std across seeds "
                      f"(paper Fig. 3c)"
                      + (f", trailing mean over {smooth} sessions" if smooth > 1 else ""))
    fig.tight_layout()
    return fig


def swept_axis(name: str, values: list[str]) -> Axis:
    """How a swept axis is drawn: numeric (sorted by value, labelled with the unit the study
    file writes) when every value is a number with one same unit; otherwise categorical in the
    study file's order, model files by their stem."""
    if name in dict(DEFAULT_MODELS.items()):
        return Axis(name, tuple(values), tuple(float(i) for i in range(len(values))),
                    tuple(Path(v).stem for v in values), f"{name} (model file)", True)
    parsed = [_NUMBER.fullmatch(v) for v in values]
    if all(parsed) and len({m.group(2) for m in parsed}) == 1:
        unit = parsed[0].group(2) or "dimensionless"
        order = sorted(range(len(values)), key=lambda i: float(parsed[i].group(1)))
        return Axis(name, tuple(values[i] for i in order),
                    tuple(float(parsed[i].group(1)) for i in order),
                    tuple(parsed[i].group(1) for i in order), f"{name} ({unit})", False)
    return Axis(name, tuple(values), tuple(float(i) for i in range(len(values))),
                tuple(values), f"{name} (as in the study file)", True)


def sweep_figures(name: str, swept: list[str], runs: list[dict[str, Any]],
                   per_seed: list[dict[str, Any]], measures: list[Measure],
                   figures: dict[str, Any], shows: dict[str, str]) -> None:
    """The final figures against the swept values: one axis, a panel per measure; two axes
    swept as a grid, a heatmap per measure; otherwise each sweep point as a category."""
    conditions = list(dict.fromkeys(o["condition"] for o in per_seed))
    points = list(dict.fromkeys(tuple(str(r["spec"]["point"].get(k, "")) for k in swept)
                                for r in runs))
    values = [list(dict.fromkeys(p[i] for p in points)) for i in range(len(swept))]
    grid = len(swept) == 2 and len(points) == len(values[0]) * len(values[1])
    if len(swept) == 1 or not grid:
        if len(swept) == 1:
            axis, where = swept_axis(swept[0], values[0]), (lambda p: p[0])
        else:  # zip mode or more than two axes: the points in the study's order
            labels = [", ".join(f"{k}={v}" for k, v in zip(swept, p)) for p in points]
            axis = Axis("sweep point", tuple(labels), tuple(map(float, range(len(labels)))),
                        tuple(labels), "sweep point (values as in the study file)", True)
            where = (lambda p: ", ".join(f"{k}={v}" for k, v in zip(swept, p)))
        series = {m.key: {c: cell_stats([[o[m.key] for o in per_seed
                                      if o["condition"] == c and where(o["point"]) == v
                                      and m.key in o] for v in axis.values])
                          for c in conditions} for m in measures}
        file = f"sweep_{file_slug(axis.name)}.png"
        figures[file] = measure_vs_value(
            axis, measures, series, f"Study {name}: final figures against {axis.name}, "
                                    f"mean ± std across seeds")
        shows[file] = (f"each final figure ({', '.join(m.title for m in measures)}) against "
                       f"{axis.name}, mean ± std across seeds, one line per condition")
        return
    x_axis, y_axis = swept_axis(swept[0], values[0]), swept_axis(swept[1], values[1])
    gait_map(name, x_axis, y_axis, runs, figures, shows)
    for m in measures:
        grids = {}
        for c in conditions:
            cells = [[[o[m.key] for o in per_seed if o["condition"] == c and m.key in o
                       and o["point"] == (xv, yv)] for xv in x_axis.values]
                     for yv in y_axis.values]
            mean, std, n = cell_stats([v for row in cells for v in row])
            shape = (len(y_axis.values), len(x_axis.values))
            grids[c] = (mean.reshape(shape), std.reshape(shape), n.reshape(shape))
        file = f"heatmap_{file_slug(m.key)}.png"
        figures[file] = measure_heatmap(
            x_axis, y_axis, m, grids, f"Study {name}: {m.title} ({m.unit}) over "
                                      f"{x_axis.name} and {y_axis.name}, mean across seeds")
        shows[file] = (f"{m.title} ({m.unit}), mean (± std, n) across seeds over {x_axis.name} "
                       f"x {y_axis.name}, one panel per condition")


def gait_map(name: str, x_axis: Axis, y_axis: Axis, runs: list[dict[str, Any]],
              figures: dict[str, Any], shows: dict[str, str]) -> None:
    """``gait_map.png`` over the two swept axes from the runs' ``gait.csv`` (each seed's gait
    with its final tables): the most common label per cell as colour, mean speed as contours.
    Nothing when no run wrote one."""
    from .gait_map import gait_map_figures

    seeds = []
    old = False  # a gait.csv without final_rhythm: its final_gait is the thigh-pool rhythm
    for r in runs:
        g = r.get("gaits")
        if g is None:
            continue
        old = old or "final_rhythm" not in g.columns
        point = r["spec"]["point"]
        for row in g.to_dict("records"):
            reason = str(row.get("final_gait_reason", "") or "")
            seeds.append({"condition": r["spec"]["condition"], "gait": row["final_gait"],
                          "mean_speed_m_per_s": row["final_speed_m_per_s"],
                          "fell": int(reason.startswith("fell")),
                          f"grid_{y_axis.name}": str(point.get(y_axis.name, "")),
                          f"grid_{x_axis.name}": str(point.get(x_axis.name, ""))})
    if not seeds:
        return
    fig = gait_map_figures(seeds, [(y_axis.name, list(y_axis.values)),
                                   (x_axis.name, list(x_axis.values))],
                           {y_axis.name: y_axis.label, x_axis.name: x_axis.label})
    figures["gait_map.png"] = fig["gait_map.png"]
    what = ("rhythm (thigh-extensor bursts: these runs were written before the gait was read "
            "from the feet)" if old else "gait (footfalls over the upright part)")
    shows["gait_map.png"] = (f"each seed's final {what} (learning off, 5 s) over {x_axis.name} x "
                             f"{y_axis.name}: the most common label per cell (colour, its share "
                             f"written), mean forward speed (contours), one panel per condition")


def file_slug(text: str) -> str:
    return re.sub(r"[^A-Za-z0-9.+-]+", "_", text).strip("_") or "x"


__all__ = ["fig3c", "file_slug", "gait_map", "sweep_figures", "swept_axis"]
