"""Figures drawn from what a unit, a closed-loop run or a recorded training session recorded
(no new simulation): rasters, pool activity, motor-neuron Ca2+, each astrocyte's state, joint
angles and torques, the torso's path and the gait diagram.

Every function takes a loaded :class:`~astrocpg.studies.outputs.result.Result`, a trial and a
time window (s), and returns ``{name: Figure}`` (matplotlib Figures outside pyplot, empty when
the result holds nothing to draw); :func:`trace_figures` collects them all.
"""

from __future__ import annotations

import os
from typing import Any, Callable

import numpy as np
from matplotlib.figure import Figure

from ...network.layout import LEGS
from ...network.populations import trace_sources
from ..analysis.gait import leg_phases
from ..analysis.rhythm import pool_activity
from .plots import POOL_COLOURS, mark_fall
from .save import FORMATS, save_figures  # noqa: F401  (drawn here, written there)

JOINT_COLOURS = {"hip": "tab:green", "thigh": "tab:blue", "calf": "tab:purple"}
DT = 1e-3  # s, bin of pool activity (one network step)


def _unit(result: Any, name: str) -> str:
    """The unit of a recorded trace (as the folder's rows say) as a label shows it."""
    return trace_sources(result.layout.rows)[name][3].replace("uM", "µM")


def _figure(figsize: Any) -> Figure:
    # constrained layout: titles, labels and legends stay inside the figure
    return Figure(figsize=figsize, layout="constrained")


def recorded_span(result: Any) -> tuple[float, float]:
    """(0, end) of the recording in s: the result's seconds, else the last spike, trace or
    robot sample."""
    if result.seconds:
        return 0.0, float(result.seconds)
    ends = [float(np.max(t)) for t, _ in result.spikes.values() if len(t)]
    ends += [float(np.max(t)) for t, _ in result.traces.values() if len(t)]
    if result.robot is not None and len(result.robot.get("t", ())):
        ends.append(float(np.max(result.robot["t"])))
    return 0.0, max(ends, default=1.0)


def _legs(result: Any) -> tuple[str, ...]:
    return tuple(result.layout.legs)


# ---------------------------------------------------------------- spikes
def raster_figures(result: Any, trial: int, window: tuple[float, float]) -> dict[str, Figure]:
    """rasters: one panel per recorded population, in the order of the folder's population
    rows, each drawn as its row's ``raster`` says (motor neurons coloured by pool,
    interneurons, astrocytes' adenosine releases, then any added population, cells by limb)."""
    L, (t0, t1) = result.layout, window
    rows = [r for r in L.rows if r.spikes and r.name in result.spikes]
    if not rows:
        return {}
    heights = [float(r.raster.get("height", 2)) for r in rows]
    fig = _figure((11, 2.2 + 1.3 * sum(heights)))
    axes = np.atleast_1d(fig.subplots(len(rows), 1, sharex=True,
                                      gridspec_kw={"height_ratios": heights}))
    for ax, row in zip(axes, rows):
        t, i = (np.asarray(a) for a in result.spikes[row.name])
        keep = (t >= t0) & (t < t1)
        _raster_panel(ax, row, L, trial, t[keep], i[keep])
    axes[0].set_title(f"Spike rasters (trial {trial})")
    axes[-1].set_xlim(t0, t1)
    axes[-1].set_xlabel("time (s)")
    return {"rasters": fig}


def _raster_panel(ax: Any, row: Any, L: Any, trial: int, t: np.ndarray, i: np.ndarray) -> None:
    """One population's spikes of ``trial`` (cells in index order, limb after limb)."""
    style = row.raster
    labels = row.labels(L.pool_size)
    n = L.n_legs * len(labels)
    base = trial * n
    sel = (i >= base) & (i < base + n)
    t, local = t[sel], i[sel] - base
    marker, size = str(style.get("marker", "|")), float(style.get("size", 3))
    if style.get("colour") == "by label":  # one colour per label (the motor pools)
        label_of = np.array(labels * L.n_legs)
        for label in dict.fromkeys(labels):
            mine = label_of[local] == label
            ax.plot(t[mine], local[mine], marker, ms=size, color=POOL_COLOURS.get(label),
                    label=label)
        ax.legend(loc="upper left", bbox_to_anchor=(1.0, 1.0), fontsize=7,
                  title="pool", title_fontsize=7, markerscale=3)
    else:
        ax.plot(t, local, marker, ms=size, color=str(style.get("colour", "tab:purple")))
    if style.get("ticks") == "cell":  # one tick per cell: its limb and label
        prefix = os.path.commonprefix(list(labels)) if len(labels) > 1 else ""
        prefix = prefix[:prefix.rfind("_") + 1]
        ax.set_yticks(range(n), [f"{leg} {c[len(prefix):]}" for leg in L.legs for c in labels],
                      fontsize=6)
    else:
        ax.set_yticks([(k + 0.5) * len(labels) for k in range(L.n_legs)], list(L.legs))
    ax.set_ylim(-0.5, n - 0.5)
    ax.set_ylabel(str(style.get("label", f"{row.name} (leg)")))


def _activity_row(result: Any) -> Any:
    """The recorded population whose spikes are the pools' activity (its row's ``activity``),
    or None."""
    return next((r for r in result.layout.rows if r.activity and r.name in result.spikes), None)


def _cells_of(L: Any, row: Any, trial: int, leg_i: int, label: str) -> np.ndarray:
    """The indices (in the population) of ``trial``'s cells of ``label`` in limb ``leg_i``."""
    labels = row.labels(L.pool_size)
    start = trial * L.n_legs * len(labels) + leg_i * len(labels)
    return start + np.array([k for k, x in enumerate(labels) if x == label], dtype=np.intp)


def _activity(result: Any, row: Any, trial: int, leg_i: int, pool: str,
              window: tuple[float, float]):
    t, i = result.spikes[row.name]
    t0, t1 = window
    act = pool_activity(np.asarray(t), np.asarray(i),
                        _cells_of(result.layout, row, trial, leg_i, pool), t1, DT, t0)
    return t0 + np.arange(len(act)) * DT, act


def activity_figures(result: Any, trial: int, window: tuple[float, float]) -> dict[str, Figure]:
    """pool_activity: each leg's pools, cells spiking per 1 ms step (the population whose row
    says its spikes are the pools' activity: the motor neurons)."""
    row = _activity_row(result)
    if row is None:
        return {}
    legs = _legs(result)
    fig = _figure((11, 1.0 + 1.6 * len(legs)))
    axes = np.atleast_1d(fig.subplots(len(legs), 1, sharex=True, sharey=True))
    for leg_i, (ax, leg) in enumerate(zip(axes, legs)):
        for pool in dict.fromkeys(row.labels(result.layout.pool_size)):
            x, act = _activity(result, row, trial, leg_i, pool, window)
            ax.plot(x, act, lw=0.6, color=POOL_COLOURS.get(pool), label=pool)
        ax.set_ylabel(f"{leg}\nneurons / ms")
    axes[0].legend(loc="upper left", bbox_to_anchor=(1.0, 1.0), fontsize=7, title="pool",
                   title_fontsize=7)
    axes[0].set_title(f"Motor pool activity (trial {trial}, neurons spiking per 1 ms step)")
    axes[-1].set_xlim(*window)
    axes[-1].set_xlabel("time (s)")
    return {"pool_activity": fig}


# ---------------------------------------------------------------- traces
def _trace(result: Any, name: str, window: tuple[float, float]):
    """(t, values) of a recorded trace within the window, values (samples, columns)."""
    t, v = result.traces[name]
    t, v = np.asarray(t, dtype=float), np.asarray(v, dtype=float)
    if v.ndim == 1:
        v = v[:, None]
    keep = (t >= window[0]) & (t <= window[1])
    return t[keep], v[keep]


def _traced_rows(result: Any, style: str) -> list[tuple[Any, list[str]]]:
    """(row, its recorded traces) of the rows whose traces are drawn in ``style``."""
    out = []
    for row in result.layout.rows:
        names = [n for n in row.traces if n in result.traces]
        if names and row.trace_plot.get("style", "label mean") == style:
            out.append((row, names))
    return out


def label_mean_figures(result: Any, trial: int,
                       window: tuple[float, float]) -> dict[str, Figure]:
    """One figure per trace of a "label mean" row (motor_calcium: each pool's mean motor-neuron
    Ca2+, band: min..max over the pool): per limb, each label's mean and its min..max band."""
    L, legs, figs = result.layout, _legs(result), {}
    for row, names in _traced_rows(result, "label mean"):
        style = row.trace_plot
        labels = list(dict.fromkeys(row.labels(L.pool_size)))
        for name in names:
            t, v = _trace(result, name, window)
            unit = _unit(result, name)
            fig = _figure((11, 1.0 + 1.6 * len(legs)))
            axes = np.atleast_1d(fig.subplots(len(legs), 1, sharex=True, sharey=True))
            for leg_i, (ax, leg) in enumerate(zip(axes, legs)):
                for label in labels:
                    cols = v[:, _cells_of(L, row, trial, leg_i, label)]
                    colour = POOL_COLOURS.get(label)
                    ax.plot(t, cols.mean(axis=1), lw=0.8, color=colour, label=label)
                    ax.fill_between(t, cols.min(axis=1), cols.max(axis=1), color=colour,
                                    alpha=0.15, lw=0)
                ax.set_ylabel(f"{leg}\n{style.get('ylabel', name)} ({unit})")
            axes[0].legend(loc="upper left", bbox_to_anchor=(1.0, 1.0), fontsize=7,
                           title="pool", title_fontsize=7)
            axes[0].set_title(f"{style.get('title', name)} (trial {trial}, pool mean, band: "
                              f"min..max)")
            axes[-1].set_xlim(*window)
            axes[-1].set_xlabel("time (s)")
            figs[dict(style.get("figures") or {}).get(name, name)] = fig
    return figs


def per_cell_figures(result: Any, trial: int, window: tuple[float, float]) -> dict[str, Figure]:
    """POPULATION_LEG_LABEL for each cell of a "per cell" row (astrocyte_FR_thigh_flexor: one
    astrocyte's Ca2+, IP3, 2-AG and adenosine, its adenosine releases marked (dashed lines),
    and the activity of the thigh pool it sits on)."""
    L, figs = result.layout, {}
    active = _activity_row(result)
    for row, names in _traced_rows(result, "per cell"):
        style = row.trace_plot
        shown = dict(style.get("labels") or {})
        events_name = str(style.get("events", "spike"))
        spikes = tuple(np.asarray(a) for a in result.spikes[row.name]) \
            if row.name in result.spikes else None
        pools = set(active.labels(L.pool_size)) if active is not None else set()
        labels = row.labels(L.pool_size)
        for leg_i, leg in enumerate(_legs(result)):
            for k, label in enumerate(labels):
                col = (trial * L.n_legs + leg_i) * len(labels) + k
                panels = names + (["activity"] if label in pools else [])
                fig = _figure((10, 1.0 + 1.35 * len(panels)))
                axes = np.atleast_1d(fig.subplots(len(panels), 1, sharex=True))
                events = np.zeros(0)
                if spikes is not None:
                    st, si = spikes
                    events = st[(si == col) & (st >= window[0]) & (st < window[1])]
                for ax, panel in zip(axes, panels):
                    if panel == "activity":
                        x, act = _activity(result, active, trial, leg_i, label, window)
                        ax.plot(x, act, lw=0.6, color=POOL_COLOURS.get(label))
                        ax.set_ylabel("pool activity\n(neurons / ms)")
                    else:
                        t, v = _trace(result, panel, window)
                        text = shown.get(panel, panel)
                        ax.plot(t, v[:, col], lw=1.0, color=style.get("colour", "tab:purple"),
                                label=text)
                        ax.set_ylabel(f"{text}\n({_unit(result, panel)})")
                    for e_k, e in enumerate(events):
                        ax.axvline(e, color="k", ls="--", lw=0.7,
                                   label=events_name if e_k == 0 and ax is axes[0] else None)
                if len(events):
                    axes[0].legend(loc="upper right", fontsize=7)
                axes[0].set_title(f"{style.get('title', row.name)} of {leg} {label} (trial "
                                  f"{trial}): {len(events)} {events_name.split()[-1]}(s) in "
                                  f"the window")
                axes[-1].set_xlim(*window)
                axes[-1].set_xlabel("time (s)")
                figs[f"{row.name}_{leg}_{label}"] = fig
    return figs


# ---------------------------------------------------------------- robot
def _robot(result: Any, trial: int, window: tuple[float, float]):
    rob = result.robot
    t = np.asarray(rob["t"], dtype=float)
    keep = (t >= window[0]) & (t <= window[1])
    return rob, t[keep], keep


def _fall_note(result: Any, trial: int, axes: Any) -> str:
    """The fall marked on ``axes`` (:func:`~.plots.mark_fall`) from the recording's upright
    samples, and its words for a title ("" when the robot did not fall or none was kept)."""
    rob = result.robot
    if rob is None or "alive" not in rob or "t" not in rob:
        return ""
    return mark_fall(axes, rob["t"], np.asarray(rob["alive"])[trial])


def joint_figures(result: Any, trial: int, window: tuple[float, float]) -> dict[str, Figure]:
    """joints: each leg's hip, thigh and calf angles (deg) and applied torques (N m)."""
    if result.robot is None or "joint_angles" not in result.robot:
        return {}
    rob, t, keep = _robot(result, trial, window)
    joints = [str(j) for j in rob.get("joints", ("hip", "thigh", "calf"))]
    legs = [str(leg) for leg in rob.get("legs", LEGS)]
    fig = _figure((12, 1.2 + 1.7 * len(legs)))
    axes = fig.subplots(len(legs), 2, sharex=True, squeeze=False)
    angles = np.degrees(np.asarray(rob["joint_angles"])[trial][keep])
    torques = np.asarray(rob["torques"])[trial][keep]
    for k, leg in enumerate(legs):
        for j, joint in enumerate(joints):
            c = JOINT_COLOURS.get(joint)
            axes[k, 0].plot(t, angles[:, k, j], lw=0.8, color=c, label=joint)
            axes[k, 1].plot(t, torques[:, k, j], lw=0.8, color=c, label=joint)
        axes[k, 0].set_ylabel(f"{leg}\nangle (deg)")
        axes[k, 1].set_ylabel(f"{leg}\ntorque (N m)")
    fell = _fall_note(result, trial, axes)
    if fell:
        fig.suptitle(fell, color="tab:red")
    axes[0, 0].set_title(f"Joint angles (trial {trial})")
    axes[0, 1].set_title(f"Applied torques (trial {trial})")
    axes[0, 1].legend(loc="upper left", bbox_to_anchor=(1.0, 1.0), fontsize=7, title="joint",
                      title_fontsize=7)
    for ax in axes[-1]:
        ax.set_xlabel("time (s)")
        ax.set_xlim(*window)
    return {"joints": fig}


def torso_figures(result: Any, trial: int, window: tuple[float, float]) -> dict[str, Figure]:
    """torso_path: the torso's path seen from above (x, y) and its height over time."""
    if result.robot is None or "torso_position" not in result.robot:
        return {}
    rob, t, keep = _robot(result, trial, window)
    pos = np.asarray(rob["torso_position"])[trial][keep]
    fig = _figure((11, 4.2))
    ax, az = fig.subplots(1, 2, gridspec_kw={"width_ratios": [1.3, 1]})
    if len(pos):
        sc = ax.scatter(pos[:, 0], pos[:, 1], c=t, s=2, cmap="viridis")
        ax.plot(pos[:1, 0], pos[:1, 1], "o", color="tab:green", label="start")
        ax.plot(pos[-1:, 0], pos[-1:, 1], "s", color="tab:red", label="end")
        fig.colorbar(sc, ax=ax, label="time (s)")
        ax.legend(loc="best", fontsize=7)
    ax.set_aspect("equal", adjustable="datalim")
    ax.set_xlabel("x (m, forward at start)")
    ax.set_ylabel("y (m)")
    ax.set_title(f"Torso path from above (trial {trial})")
    az.plot(t, pos[:, 2] if len(pos) else t, lw=0.8, color="k")
    az.set_xlabel("time (s)")
    az.set_ylabel("torso height z (m)")
    az.set_title("Torso height")
    fell = _fall_note(result, trial, az)
    if fell:  # the figure's own title: the fall is the first thing it says
        fig.suptitle(fell, color="tab:red")
    if len(t):
        az.set_xlim(*window)
    return {"torso_path": fig}


def gait_figures(result: Any, trial: int, window: tuple[float, float]) -> dict[str, Figure]:
    """gait: stance phases per leg: foot contact (touch sensors), or thigh-extensor bursts
    where the robot has no touch sensors or none was recorded."""
    rob = result.robot
    force = None
    if rob is not None and "foot_force" in rob:
        force = np.asarray(rob["foot_force"])[trial]
        if not np.all(np.isfinite(force)):
            force = None
    bursts = None
    if force is None:
        active = _activity_row(result)  # the pools' activity: the motor neurons' spikes
        if active is None:
            return {}
        t, i = (np.asarray(a) for a in result.spikes[active.name])
        bursts = leg_phases(t, i, result.layout, trial, window[0], window[1])["bursts"]
    legs = _legs(result)
    fig = _figure((11, 1.4 + 0.45 * len(legs)))
    ax = fig.subplots()
    if force is not None:
        t = np.asarray(rob["t"], dtype=float)
        sel = (t >= window[0]) & (t <= window[1])
        x = t[sel]
        step = float(np.median(np.diff(t))) if len(t) > 1 else DT
        for k in range(len(legs)):
            stance = force[sel, k] > 0
            edges = np.diff(np.concatenate([[0], stance.astype(int), [0]]))
            for a, b in zip(np.flatnonzero(edges == 1), np.flatnonzero(edges == -1)):
                ax.broken_barh([(x[a], x[b - 1] - x[a] + step)], (k - 0.4, 0.8), color="k")
        what = "black: foot on the ground (touch sensors)"
    else:
        for k, leg in enumerate(legs):
            for a, b in bursts[leg]:
                if b >= window[0] and a < window[1]:
                    ax.broken_barh([(a, b - a)], (k - 0.4, 0.8), color="tab:red")
        what = "red: thigh-extensor bursts (no foot contact recorded)"
    ax.set_yticks(range(len(legs)), legs)
    ax.set_ylim(len(legs) - 0.5, -0.5)
    ax.set_xlim(*window)
    ax.set_xlabel("time (s)")
    ax.set_ylabel("leg")
    fell = _fall_note(result, trial, ax) if rob is not None else ""
    kind = "Gait" if force is not None else "Rhythm"  # bursts are the CPG's, not the feet's
    ax.set_title(f"{kind} diagram (trial {trial}; {what})" + (f"\n{fell}" if fell else ""),
                 **({"color": "tab:red"} if fell else {}))
    return {"gait_diagram": fig}


#: The figure makers :func:`trace_figures` calls in turn, each for what the recording holds.
FIGURE_FUNCTIONS = (raster_figures, activity_figures, label_mean_figures, per_cell_figures,
                    joint_figures, torso_figures, gait_figures)


def trace_figures(result: Any, trial: int = 0,
                  window: tuple[float, float] | None = None, *,
                  on_part: Callable[[], None] | None = None) -> dict[str, Figure]:
    """Every figure the result's recording allows, {name: Figure}; ``window`` (s) defaults to
    the whole recording. ``on_part`` is called after each of :data:`FIGURE_FUNCTIONS` (a
    progress bar's step)."""
    window = window or recorded_span(result)
    figs: dict[str, Figure] = {}
    for fn in FIGURE_FUNCTIONS:
        figs.update(fn(result, trial, window))
        if on_part is not None:
            on_part()
    return figs


__all__ = ["trace_figures", "save_figures", "FORMATS", "recorded_span", "FIGURE_FUNCTIONS", "raster_figures",
           "activity_figures", "label_mean_figures", "per_cell_figures", "joint_figures",
           "torso_figures", "gait_figures"]
