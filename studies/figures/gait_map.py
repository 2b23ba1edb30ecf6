"""Gait maps: the gait found at each point of a two-axis grid (colour: the most common label
over seeds and repeats, its share written in the cell) with the mean forward speed as
contours. Used by ``astrocpg evaluate`` for a worlds file with a two-axis ``[grid]``."""

from __future__ import annotations

import re
from collections import Counter
from typing import Any, Mapping, Sequence

import numpy as np

GAITS = ("trot", "pace", "bound", "walk", "none")
_COLOURS = {"trot": "#4c9a2a", "pace": "#2a6f9a", "bound": "#9a2a6f", "walk": "#d9a21b",
            "none": "#d0d0d0"}


def gait_grid(rows: Sequence[Mapping[str, Any]], axes: Sequence[tuple[str, Sequence[str]]],
              condition: str, key: str = "gait"
              ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """For one condition: (label index into GAITS, share of that label, mean speed m/s, fall
    share) per cell (axis 0 along y, axis 1 along x); NaN/-1 where no row fell in the cell.
    ``key``: the rows' label read (``gait``, from the feet, or ``rhythm``, the CPG's)."""
    (ya, yv), (xa, xv) = axes
    shape = (len(yv), len(xv))
    label = np.full(shape, -1)
    share, speed, falls = (np.full(shape, np.nan) for _ in range(3))
    for i, y in enumerate(yv):
        for j, x in enumerate(xv):
            cell = [r for r in rows if r["condition"] == condition
                    and r.get(f"grid_{ya}") == y and r.get(f"grid_{xa}") == x]
            if not cell:
                continue
            counts = Counter(r[key] for r in cell)
            top, n = max(counts.items(), key=lambda kv: (kv[1], -GAITS.index(kv[0])
                                                           if kv[0] in GAITS else 0))
            label[i, j] = GAITS.index(top) if top in GAITS else GAITS.index("none")
            share[i, j] = n / len(cell)
            speed[i, j] = float(np.mean([r["mean_speed_m_per_s"] for r in cell]))
            falls[i, j] = float(np.mean([r["fell"] for r in cell]))
    return label, share, speed, falls


_VALUE = re.compile(r"\s*([-+]?(?:\d+\.?\d*|\.\d+)(?:[eE][-+]?\d+)?)\s*(?:\*\s*(.+?))?\s*")


def axis_ticks(values: Sequence[str], label: str) -> tuple[list[str], str]:
    """Tick labels and the axis label of a grid axis: values that are numbers with one same
    unit (``1104*mV/second``) are ticked by their numbers, the unit going to the axis label
    (once); other values as written."""
    parsed = [_VALUE.fullmatch(str(v)) for v in values]
    if not all(parsed) or len({m.group(2) for m in parsed}) != 1:
        return [str(v) for v in values], label
    unit = parsed[0].group(2)
    if unit and unit not in label:
        label = f"{label} ({unit})"
    return [f"{float(m.group(1)):g}" for m in parsed], label


def _cell_text(label: str, share: float, falls: float, room: tuple[float, float]
               ) -> tuple[str, float]:
    """What a cell says and its font size, fitted to the cell (``room``: its width and height in
    points): the gait, its share and the falls on three lines, or less where that does not fit
    at a readable size."""
    full = [label, f"{share:.0%}"] + ([f"falls {falls:.0%}"] if falls > 0 else [])
    size = 0.0
    for lines in (full, full[:2], [f"{label} {share:.0%}"], [label]):
        width = max(len(x) for x in lines) * 0.62  # a character's width, in font sizes
        size = min(7.0, 0.9 * room[0] / width, 0.85 * room[1] / (1.25 * len(lines)))
        if size >= 4.5:
            break
    return "\n".join(lines), max(size, 3.0)


def gait_map_figures(rows: Sequence[Mapping[str, Any]],
                     axes: Sequence[tuple[str, Sequence[str]]],
                     labels: Mapping[str, str] | None = None,
                     measures: Sequence[tuple[str, str]] = (("gait", "gait"),)
                     ) -> dict[str, Any]:
    """``{"gait_map.png": Figure}``: one panel per condition and measure; ``labels``: axis
    titles; ``measures``: (the rows' key, its name in the titles) per panel of a condition,
    e.g. ``(("gait", "gait (feet)"), ("rhythm", "rhythm (thigh bursts)"))``. The panels grow
    with the grid, and each cell's text is fitted to its cell, above the speed contours."""
    labels = dict(labels or {})
    from matplotlib.colors import ListedColormap
    from matplotlib.figure import Figure
    from matplotlib.patches import Patch

    conditions = sorted({r["condition"] for r in rows})
    (ya, yv), (xa, xv) = axes
    xticks, xlabel = axis_ticks(xv, labels.get(xa, xa))
    yticks, ylabel = axis_ticks(yv, labels.get(ya, ya))
    shown_panels = [(c, m) for c in conditions for m in measures]
    # at least 0.75 in per column and 0.45 in per row of cells
    panel_w, panel_h = max(4.0, 0.75 * len(xv)), max(3.4, 0.45 * len(yv))
    fig = Figure(figsize=((panel_w + 1.2) * len(shown_panels) + 1.6, panel_h + 1.2),
                 layout="constrained")
    panels = np.atleast_1d(fig.subplots(1, len(shown_panels), squeeze=False)[0])
    cmap = ListedColormap([_COLOURS[g] for g in GAITS])
    room = (72 * panel_w / len(xv), 72 * panel_h / len(yv))
    for ax, (condition, (key, name)) in zip(panels, shown_panels):
        label, share, speed, falls = gait_grid(rows, axes, condition, key)
        shown = np.ma.masked_less(label, 0)
        ax.imshow(shown, cmap=cmap, vmin=-0.5, vmax=len(GAITS) - 0.5, origin="lower",
                  aspect="auto")
        if np.isfinite(speed).sum() >= 4 and len(xv) > 1 and len(yv) > 1:
            cs = ax.contour(np.arange(len(xv)), np.arange(len(yv)), speed, colors="k",
                            linewidths=0.8, levels=6, zorder=2)
            ax.clabel(cs, fmt="%.2f m/s", fontsize=6, zorder=2)
        for i in range(len(yv)):
            for j in range(len(xv)):
                if label[i, j] >= 0:
                    text, size = _cell_text(GAITS[label[i, j]], share[i, j], falls[i, j], room)
                    ax.text(j, i, text, ha="center", va="center", fontsize=size, zorder=4,
                            bbox={"boxstyle": "round,pad=0.15", "facecolor": "white",
                                  "alpha": 0.75, "linewidth": 0})
        long = max(len(t) for t in xticks) * 6 > 72 * panel_w / len(xv)
        ax.set_xticks(range(len(xv)), xticks, rotation=30 if long else 0,
                      ha="right" if long else "center")
        ax.set_yticks(range(len(yv)), yticks)
        ax.set_xlabel(xlabel)
        ax.set_ylabel(ylabel)
        ax.set_title(f"{condition}: most common {name} (share), mean speed (contours)",
                     fontsize=9)
    fig.legend(handles=[Patch(color=_COLOURS[g], label=g) for g in GAITS], loc="outside right",
               fontsize=8, title=" / ".join(name.split(" (")[0] for _, name in measures))
    return {"gait_map.png": fig}


__all__ = ["GAITS", "axis_ticks", "gait_grid", "gait_map_figures", "world_bars"]


def world_bars(summary: Sequence[Mapping[str, Any]]) -> Any:
    """Speed and fall share per world, one bar per condition, each with its 95% interval over
    trained tables where the summary has one (``<measure>_low``/``_high``: each table's runs
    first), else mean +- std: the robustness of trained controllers across named worlds
    (``summary`` rows of ``astrocpg evaluate``)."""
    from matplotlib.figure import Figure

    worlds = list(dict.fromkeys(s["world"] for s in summary))
    groups = list(dict.fromkeys((s["condition"], s["point"]) for s in summary))
    fig = Figure(figsize=(max(6.0, 0.9 * len(worlds) + 2), 6.4), layout="constrained")
    speed_ax, fall_ax = fig.subplots(2, 1, sharex=True)
    width = 0.8 / max(1, len(groups))
    x = np.arange(len(worlds))
    over_tables = all("mean_speed_m_per_s_low" in s for s in summary)

    def column(rows: Mapping[str, Any], key: str) -> np.ndarray:
        return np.array([rows[w].get(key, np.nan) if w in rows else np.nan for w in worlds],
                        dtype=float)

    for k, (condition, point) in enumerate(groups):
        rows = {s["world"]: s for s in summary
                if s["condition"] == condition and s["point"] == point}
        mean = column(rows, "mean_speed_m_per_s_mean")
        falls = column(rows, "fell_mean")
        if over_tables:
            speed_err = np.nan_to_num(np.abs([mean - column(rows, "mean_speed_m_per_s_low"),
                                              column(rows, "mean_speed_m_per_s_high") - mean]))
            fall_err = np.nan_to_num(np.abs([falls - column(rows, "fell_low"),
                                             column(rows, "fell_high") - falls])) * 100
            n = max((rows[w].get("n_tables", 0) for w in rows), default=0)
            label = f"{condition}{' ' + point if point else ''} ({n} tables)"
        else:
            speed_err = np.nan_to_num(column(rows, "mean_speed_m_per_s_std"))
            fall_err = None
            n = max((rows[w]["n"] for w in rows), default=0)
            label = f"{condition}{' ' + point if point else ''} (n={n})"
        offset = (k - (len(groups) - 1) / 2) * width
        speed_ax.bar(x + offset, mean, width, yerr=speed_err, capsize=2,
                     color=f"C{k}", label=label)
        fall_ax.bar(x + offset, 100 * falls, width, yerr=fall_err, capsize=2, color=f"C{k}",
                    label=label)
    what = ("mean over trained tables, 95% interval over tables" if over_tables else
            "mean ± std over controllers and repeats")
    speed_ax.set_ylabel("mean forward speed (m/s)")
    speed_ax.set_title(f"trained controllers, learning off: speed ({what})", fontsize=9)
    speed_ax.legend(fontsize=8)
    speed_ax.axhline(0, color="k", lw=0.6)
    fall_ax.set_ylabel("runs that fell (%)")
    fall_ax.set_ylim(0, 100)
    fall_ax.set_title(f"falls ({what})", fontsize=9)
    fall_ax.set_xticks(x, worlds, rotation=30, ha="right")
    fall_ax.set_xlabel("world")
    return fig
