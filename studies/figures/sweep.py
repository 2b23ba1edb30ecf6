"""Figures of a parameter study's final figures against the swept values.

``measure_vs_value``: one panel per measure, the measure against one swept axis, mean ± std
across seeds, one line per condition. ``measure_heatmap``: one measure over two swept axes, one
panel per condition, a shared colour scale. Both return a matplotlib ``Figure`` (outside pyplot:
the caller's backend is left alone); the caller saves it.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Mapping, Sequence

import numpy as np

from ..analysis.final_figures import Measure


@dataclass(frozen=True)
class Axis:
    """A swept axis as drawn: ``values`` as written in the study file (in its order),
    ``positions`` where each value sits on the axis (the number for a numeric axis, 0..n-1 for
    a categorical one), ``ticks`` the tick labels, ``label`` the axis label (with its unit)."""

    name: str
    values: tuple[str, ...]
    positions: tuple[float, ...]
    ticks: tuple[str, ...]
    label: str
    categorical: bool


# per condition: mean, std and number of seeds at each value of the axis (NaN where none)
Series = Mapping[str, tuple[np.ndarray, np.ndarray, np.ndarray]]


def measure_vs_value(axis: Axis, measures: Sequence[Measure], series: Mapping[str, Series],
                     title: str):
    """One panel per measure: the measure against ``axis``; ``series[measure.key][condition]``
    = (mean, std, n) per value of the axis; error bars are ± std across seeds."""
    from matplotlib.figure import Figure

    # constrained layout keeps the figure title clear of the first panel's title
    fig = Figure(figsize=(7, 2.3 * len(measures) + 0.8), layout="constrained")
    axes = np.atleast_1d(fig.subplots(len(measures), 1, sharex=True))
    x = np.asarray(axis.positions, dtype=float)
    for ax, m in zip(axes, measures):
        for k, (condition, (mean, std, n)) in enumerate(series[m.key].items()):
            ok = np.isfinite(mean)
            seeds = ", ".join(sorted({str(int(v)) for v in n[ok]})) or "0"
            ax.errorbar(x[ok], mean[ok], yerr=np.nan_to_num(std[ok]), color=f"C{k}", marker="o",
                        ms=4, capsize=3, lw=1.2, label=f"{condition} (n={seeds} seeds)")
        ax.set_ylabel(m.label)
        ax.set_title(m.title, fontsize=9)
        ax.grid(alpha=0.3)
    axes[0].legend(fontsize=8, loc="best")
    axes[-1].set_xlabel(axis.label)
    axes[-1].set_xticks(x, list(axis.ticks))
    if axis.categorical:
        axes[-1].set_xlim(x.min() - 0.5, x.max() + 0.5)
    fig.suptitle(title, fontsize=10)
    return fig


def measure_heatmap(x: Axis, y: Axis, measure: Measure,
                    grids: Mapping[str, tuple[np.ndarray, np.ndarray, np.ndarray]], title: str):
    """``measure`` over the grid of two swept axes, one panel per condition:
    ``grids[condition]`` = (mean, std, n), each of shape (len(y.values), len(x.values)); cells
    without seeds stay blank; each cell is annotated with mean ± std and its number of seeds."""
    from matplotlib.figure import Figure

    conditions = list(grids)
    fig = Figure(figsize=(1.2 + 0.9 * len(x.values) * len(conditions) + 1.2,
                          1.6 + 0.7 * len(y.values)), layout="constrained")
    axes = np.atleast_1d(fig.subplots(1, len(conditions), squeeze=False)[0])
    finite = np.concatenate([g[0][np.isfinite(g[0])] for g in grids.values()])
    vmin, vmax = (float(finite.min()), float(finite.max())) if len(finite) else (0.0, 1.0)
    if vmin == vmax:
        vmin, vmax = vmin - 0.5, vmax + 0.5
    image = None
    for ax, condition in zip(axes, conditions):
        mean, std, n = grids[condition]
        image = ax.imshow(np.ma.masked_invalid(mean), origin="lower", aspect="auto",
                          cmap="viridis", vmin=vmin, vmax=vmax)
        for (i, j), v in np.ndenumerate(mean):
            if np.isfinite(v):
                dark = (v - vmin) / (vmax - vmin) < 0.5
                ax.text(j, i, f"{v:.3g}\n±{std[i, j]:.2g}\nn={int(n[i, j])}", ha="center",
                        va="center", fontsize=7, color="white" if dark else "black")
        ax.set_xticks(range(len(x.values)), list(x.ticks))
        ax.set_yticks(range(len(y.values)), list(y.ticks))
        ax.set_xlabel(x.label)
        ax.set_ylabel(y.label)
        ax.set_title(condition, fontsize=9)
    bar = fig.colorbar(image, ax=list(axes))
    bar.set_label(f"{measure.label}, mean across seeds")
    fig.suptitle(title, fontsize=10)
    return fig
