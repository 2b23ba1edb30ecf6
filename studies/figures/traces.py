"""Figures drawn from what a unit, a closed-loop run or a recorded training session recorded
(no new simulation): rasters, pool activity, motor-neuron Ca2+, each astrocyte's state, joint
angles and torques, the torso's path and the gait diagram.

Every function takes a loaded :class:`~astrocpg.studies.outputs.result.Result`, a trial and a
time window (s), and returns ``{name: Figure}`` (matplotlib Figures outside pyplot, empty when
the result holds nothing to draw); :func:`trace_figures` collects them all.
"""

from __future__ import annotations

from typing import Any, Callable

import numpy as np
from matplotlib.figure import Figure

from ...network.layout import INTERNEURONS, LEGS, POOLS, THIGH_POOLS
from ...network.recordable import TRACE_SOURCES, spike_populations
from ..analysis.gait import leg_phases
from ..analysis.rhythm import pool_activity
from .plots import POOL_COLOURS, mark_fall
from .save import FORMATS, save_figures  # noqa: F401  (drawn here, written there)

JOINT_COLOURS = {"hip": "tab:green", "thigh": "tab:blue", "calf": "tab:purple"}
ASTRO_ROWS = (("astrocyte_Ca", "Ca²⁺"), ("astrocyte_IP3", "IP3"), ("astrocyte_AG", "2-AG"),
              ("astrocyte_ADO", "adenosine"))
DT = 1e-3  # s, bin of pool activity (one network step)


def _unit(name: str) -> str:
    """The unit of a recorded trace as a label shows it."""
    return TRACE_SOURCES[name][3].replace("uM", "µM")


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
    """rasters: one panel per recorded population (motor neurons coloured by pool,
    interneurons, astrocytes' adenosine releases, then any population added to the table,
    cells by limb)."""
    known = spike_populations()
    pops = [p for p in known if p in result.spikes]
    if not pops:
        return {}
    L, (t0, t1) = result.layout, window
    heights = {"motor": 4, "interneuron": 2, "astrocyte": 1.2}
    fig = _figure((11, 2.2 + 1.3 * sum(heights.get(p, 2) for p in pops)))
    axes = np.atleast_1d(fig.subplots(
        len(pops), 1, sharex=True, gridspec_kw={"height_ratios": [heights.get(p, 2)
                                                                  for p in pops]}))
    for ax, pop in zip(axes, pops):
        t, i = (np.asarray(a) for a in result.spikes[pop])
        keep = (t >= t0) & (t < t1)
        t, i = t[keep], i[keep]
        if pop == "motor":
            base = trial * L.motor_per_trial
            for name in POOLS:
                sel = np.zeros(len(i), dtype=bool)
                for leg_i in range(L.n_legs):
                    ids = L.motor_neurons(trial, leg_i, name)
                    sel |= (i >= ids[0]) & (i <= ids[-1])
                ax.plot(t[sel], i[sel] - base, "|", ms=2, color=POOL_COLOURS[name], label=name)
            per_leg = L.motor_per_trial // L.n_legs
            ax.set_yticks([(k + 0.5) * per_leg for k in range(L.n_legs)], _legs(result))
            ax.set_ylim(-0.5, L.motor_per_trial - 0.5)
            ax.set_ylabel("motor neuron (leg)")
            ax.legend(loc="upper left", bbox_to_anchor=(1.0, 1.0), fontsize=7,
                      title="pool", title_fontsize=7, markerscale=3)
            ax.set_title(f"Spike rasters (trial {trial})")
        elif pop == "interneuron":
            base = trial * L.interneurons_per_trial
            sel = (i >= base) & (i < base + L.interneurons_per_trial)
            ax.plot(t[sel], i[sel] - base, "|", ms=3, color="k")
            ax.set_yticks([(k + 0.5) * len(INTERNEURONS) for k in range(L.n_legs)],
                          _legs(result))
            ax.set_ylim(-0.5, L.interneurons_per_trial - 0.5)
            ax.set_ylabel("interneuron (leg)")
        elif pop != "astrocyte":  # an added population: its cells, limb by limb
            n = L.cells_per_trial(pop)
            base = trial * n
            sel = (i >= base) & (i < base + n)
            ax.plot(t[sel], i[sel] - base, "|", ms=3, color="tab:purple")
            ax.set_yticks([(k + 0.5) * n / L.n_legs for k in range(L.n_legs)], _legs(result))
            ax.set_ylim(-0.5, n - 0.5)
            ax.set_ylabel(f"{pop} (leg)")
        else:
            base = trial * L.thigh_pools_per_trial
            sel = (i >= base) & (i < base + L.thigh_pools_per_trial)
            ax.plot(t[sel], i[sel] - base, "v", ms=4, color="tab:olive")
            labels = [f"{leg} {p.replace('thigh_', '')}" for leg in _legs(result)
                      for p in THIGH_POOLS]
            ax.set_yticks(range(len(labels)), labels, fontsize=6)
            ax.set_ylim(-0.5, len(labels) - 0.5)
            ax.set_ylabel("astrocyte\n(adenosine release)")
    axes[-1].set_xlim(t0, t1)
    axes[-1].set_xlabel("time (s)")
    return {"rasters": fig}


def _activity(result: Any, trial: int, leg_i: int, pool: str, window: tuple[float, float]):
    t, i = result.spikes["motor"]
    t0, t1 = window
    act = pool_activity(np.asarray(t), np.asarray(i), result.layout.motor_neurons(trial, leg_i, pool),
                        t1, DT, t0)
    return t0 + np.arange(len(act)) * DT, act


def activity_figures(result: Any, trial: int, window: tuple[float, float]) -> dict[str, Figure]:
    """pool_activity: each leg's four motor pools, neurons spiking per 1 ms step."""
    if "motor" not in result.spikes:
        return {}
    legs = _legs(result)
    fig = _figure((11, 1.0 + 1.6 * len(legs)))
    axes = np.atleast_1d(fig.subplots(len(legs), 1, sharex=True, sharey=True))
    for leg_i, (ax, leg) in enumerate(zip(axes, legs)):
        for pool in POOLS:
            x, act = _activity(result, trial, leg_i, pool, window)
            ax.plot(x, act, lw=0.6, color=POOL_COLOURS[pool], label=pool)
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


def motor_calcium_figures(result: Any, trial: int,
                          window: tuple[float, float]) -> dict[str, Figure]:
    """motor_calcium: each pool's mean motor-neuron Ca2+ (band: min..max over the pool)."""
    if "motor_Ca" not in result.traces:
        return {}
    L, legs = result.layout, _legs(result)
    t, v = _trace(result, "motor_Ca", window)
    unit = _unit("motor_Ca")
    fig = _figure((11, 1.0 + 1.6 * len(legs)))
    axes = np.atleast_1d(fig.subplots(len(legs), 1, sharex=True, sharey=True))
    for leg_i, (ax, leg) in enumerate(zip(axes, legs)):
        for pool in POOLS:
            cols = v[:, L.motor_neurons(trial, leg_i, pool)]
            ax.plot(t, cols.mean(axis=1), lw=0.8, color=POOL_COLOURS[pool], label=pool)
            ax.fill_between(t, cols.min(axis=1), cols.max(axis=1), color=POOL_COLOURS[pool],
                            alpha=0.15, lw=0)
        ax.set_ylabel(f"{leg}\nCa²⁺ ({unit})")
    axes[0].legend(loc="upper left", bbox_to_anchor=(1.0, 1.0), fontsize=7, title="pool",
                   title_fontsize=7)
    axes[0].set_title(f"Motor-neuron Ca²⁺ (trial {trial}, pool mean, band: min..max)")
    axes[-1].set_xlim(*window)
    axes[-1].set_xlabel("time (s)")
    return {"motor_calcium": fig}


def astrocyte_figures(result: Any, trial: int, window: tuple[float, float]) -> dict[str, Figure]:
    """astrocyte_LEG_POOL: one astrocyte's Ca2+, IP3, 2-AG and adenosine, its adenosine
    releases marked (dashed lines), and the activity of the thigh pool it sits on."""
    names = [n for n, _ in ASTRO_ROWS if n in result.traces]
    if not names:
        return {}
    L = result.layout
    releases = None
    if "astrocyte" in result.spikes:
        releases = tuple(np.asarray(a) for a in result.spikes["astrocyte"])
    figs = {}
    for leg_i, leg in enumerate(_legs(result)):
        for pool in THIGH_POOLS:
            col = L.thigh_pool(trial, leg_i, pool)
            rows = names + (["activity"] if "motor" in result.spikes else [])
            fig = _figure((10, 1.0 + 1.35 * len(rows)))
            axes = np.atleast_1d(fig.subplots(len(rows), 1, sharex=True))
            events = np.zeros(0)
            if releases is not None:
                rt, ri = releases
                events = rt[(ri == col) & (rt >= window[0]) & (rt < window[1])]
            for ax, row in zip(axes, rows):
                if row == "activity":
                    x, act = _activity(result, trial, leg_i, pool, window)
                    ax.plot(x, act, lw=0.6, color=POOL_COLOURS[pool])
                    ax.set_ylabel("pool activity\n(neurons / ms)")
                else:
                    t, v = _trace(result, row, window)
                    label = dict(ASTRO_ROWS)[row]
                    ax.plot(t, v[:, col], lw=1.0, color="tab:olive", label=label)
                    ax.set_ylabel(f"{label}\n({_unit(row)})")
                for k, e in enumerate(events):
                    ax.axvline(e, color="k", ls="--", lw=0.7,
                               label="adenosine release" if k == 0 and ax is axes[0] else None)
            if len(events):
                axes[0].legend(loc="upper right", fontsize=7)
            axes[0].set_title(f"Astrocyte of {leg} {pool} (trial {trial}): "
                              f"{len(events)} release(s) in the window")
            axes[-1].set_xlim(*window)
            axes[-1].set_xlabel("time (s)")
            figs[f"astrocyte_{leg}_{pool}"] = fig
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
        if "motor" not in result.spikes:
            return {}
        t, i = (np.asarray(a) for a in result.spikes["motor"])
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
FIGURE_FUNCTIONS = (raster_figures, activity_figures, motor_calcium_figures, astrocyte_figures,
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
           "activity_figures", "motor_calcium_figures", "astrocyte_figures", "joint_figures",
           "torso_figures", "gait_figures"]
