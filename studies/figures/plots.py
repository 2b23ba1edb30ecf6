"""Figures of a unit or a closed-loop run: each function draws one and returns the matplotlib
``Figure``; :func:`~astrocpg.studies.figures.save.save_figure` writes it (the one saver)."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np
from matplotlib.figure import Figure

from ...network import INTERNEURONS, LEGS, POOLS, Layout
from ..analysis.fall import fall_words, first_fall
from ..analysis.rhythm import pool_activity

POOL_COLOURS = {"thigh_flexor": "tab:blue", "thigh_extensor": "tab:red",
                "calf_flexor": "tab:cyan", "calf_extensor": "tab:orange"}


def _subplots(*args: Any, figsize: Any = None, **kwargs: Any) -> tuple[Figure, Any]:
    """A figure outside pyplot (written to a file, never shown): drawing one leaves the
    caller's backend and open figures alone, e.g. a notebook's inline plots."""
    fig = Figure(figsize=figsize)
    return fig, fig.subplots(*args, **kwargs)


def mark_fall(axes: Any, t: Any, alive: Any) -> str:
    """On each of ``axes`` (time on x), the time the robot was not upright shaded and a red
    line where it fell (:func:`~astrocpg.studies.analysis.fall.first_fall`); returns the words
    for the figure's title (``""`` when it did not fall): a figure of a fallen robot says so."""
    fall = first_fall(t, alive)
    if fall is None:
        return ""
    t = np.asarray(t, dtype=float).reshape(-1)
    down = ~np.asarray(alive, dtype=bool).reshape(-1)
    edges = np.diff(np.concatenate([[0], down.astype(int), [0]]))
    step = float(np.median(np.diff(t))) if len(t) > 1 else 1e-3
    for ax in np.atleast_1d(axes).ravel():
        for a, b in zip(np.flatnonzero(edges == 1), np.flatnonzero(edges == -1)):
            ax.axvspan(t[a], t[b - 1] + step, color="tab:red", alpha=0.12, lw=0)
        ax.axvline(fall.t_s, color="tab:red", ls="--", lw=1.0)
    return f"robot {fall_words(fall)}; shaded: not upright"


def plot_unit(spikes: dict, layout: Layout, *, trial: int = 0,
              window: tuple[float, float] | None = None, dt: float = 1e-3) -> Figure:
    """Raster of one unit's 80 motor neurons and 6 interneurons, and each pool's activity
    (neurons spiking per step, as in the paper's Fig. 1c)."""
    t, i = spikes["motor"]
    ti, ii = spikes["interneuron"]
    t_end = max(float(t.max()) if len(t) else 1.0, 1.0)
    t0, t1 = window or (max(0.0, t_end - 3.0), t_end)
    fig, (ax_r, ax_i, ax_a) = _subplots(3, 1, figsize=(11, 7), sharex=True,
                                           gridspec_kw={"height_ratios": [4, 1, 2]})
    base = trial * layout.motor_per_trial
    for k, name in enumerate(POOLS):
        ids = layout.motor_neurons(trial, 0, name)
        sel = (i >= ids[0]) & (i <= ids[-1]) & (t >= t0) & (t < t1)
        ax_r.plot(t[sel], i[sel] - base, "|", ms=3, color=POOL_COLOURS[name], label=name)
        act = pool_activity(t, i, ids, t1, dt, t0)
        ax_a.plot(t0 + np.arange(len(act)) * dt, act, lw=0.7, color=POOL_COLOURS[name])
    ibase = trial * layout.interneurons_per_trial
    sel = (ii >= ibase) & (ii < ibase + len(INTERNEURONS)) & (ti >= t0) & (ti < t1)
    ax_i.plot(ti[sel], ii[sel] - ibase, "|", ms=5, color="k")
    ax_i.set_yticks(range(len(INTERNEURONS)), [n.replace("_to_", "→") for n, *_ in INTERNEURONS],
                    fontsize=6)
    ax_r.set_ylabel("motor neuron")
    ax_r.legend(loc="upper right", fontsize=7, ncol=4)
    ax_a.set_ylabel("neurons spiking\nper step")
    ax_a.set_xlabel("time (s)")
    ax_r.set_title("Locomotion unit, open loop")
    fig.tight_layout()
    return fig


def plot_thigh_extensor_activity(spikes: dict, layout: Layout, *, trial: int = 0,
                                 window: tuple[float, float] | None = None,
                                 smooth: float = 0.01, dt: float = 1e-3) -> Figure:
    """Thigh-extensor activity of the four limbs (the paper's Fig. 3b style)."""
    t, i = spikes["motor"]
    t_end = float(t.max()) if len(t) else 1.0
    t0, t1 = window or (max(0.0, t_end - 2.0), t_end)
    fig, axes = _subplots(len(layout.legs), 1, figsize=(10, 6), sharex=True)
    # Gaussian smoothing (sigma = smooth) hides the ~18 ms volleys inside a burst
    half = int(round(4 * smooth / dt))
    kernel = np.exp(-0.5 * (np.arange(-half, half + 1) * dt / smooth) ** 2)
    kernel /= kernel.sum()
    for ax, (leg_i, leg) in zip(np.atleast_1d(axes), enumerate(layout.legs)):
        ids = layout.motor_neurons(trial, leg_i, "thigh_extensor")
        act = pool_activity(t, i, ids, t1, dt, t0)
        # "full" then centred: also right for a window shorter than the kernel
        rate = np.convolve(act, kernel, "full")[half:half + len(act)] / (dt * layout.pool_size)
        x = t0 + np.arange(len(act)) * dt
        ax.fill_between(x, rate, color="tab:red", alpha=0.6, lw=0)
        ax.set_ylabel(f"{leg}\n(Hz/neuron)", rotation=0, labelpad=25, fontsize=8)
    np.atleast_1d(axes)[-1].set_xlabel("time (s)")
    np.atleast_1d(axes)[0].set_title(f"Thigh extensor activity (trial {trial}, "
                                     f"Gaussian smoothing sigma {smooth * 1e3:.0f} ms)")
    # fixed margins (room for the two-line labels): tight_layout measured every tick label and
    # took about a third of a second, on the path of every `astrocpg run`
    fig.subplots_adjust(left=0.12, right=0.98, bottom=0.08, top=0.94, hspace=0.12)
    return fig


def plot_weights(table_mV: np.ndarray, *, trial: int = 0) -> Figure:
    """The 8x8 inter-limb table as a diverging heatmap (the paper's Fig. 3a)."""
    from ...network import interlimb_labels

    labels = [lab.replace("thigh_", "").replace("flexor", "F").replace("extensor", "E")
              for lab in interlimb_labels()]
    lim = max(float(np.nanmax(np.abs(table_mV))), 1e-9)
    fig, ax = _subplots(figsize=(5.6, 4.8))
    im = ax.imshow(table_mV, cmap="RdBu_r", vmin=-lim, vmax=lim)
    ax.set_xticks(range(8), labels, rotation=45)
    ax.set_yticks(range(8), labels)
    ax.set_xlabel("to (target pool)")
    ax.set_ylabel("from (source pool)")
    for k in range(1, 4):
        ax.axhline(2 * k - 0.5, color="k", lw=0.5)
        ax.axvline(2 * k - 0.5, color="k", lw=0.5)
    fig.colorbar(im, ax=ax, label="weight (mV)")
    ax.set_title(f"Inter-limb weights (trial {trial})")
    fig.tight_layout()
    return fig


def session_ticks(ax: Any) -> None:
    """Whole sessions on a session axis: a 3-session figure is ticked 1, 2, 3, not 1.25."""
    from matplotlib.ticker import MaxNLocator

    ax.xaxis.set_major_locator(MaxNLocator(integer=True))


def plot_training_curves(sessions_csv: Path) -> Figure:
    """Mean reward, final x and session length per session: mean +- std over trials (Fig. 3c)."""
    import csv

    with open(sessions_csv) as f:
        rows = list(csv.DictReader(f))
    trials = sorted({int(r["trial"]) for r in rows})
    n = max(int(r["session"]) for r in rows)
    fig, axes = _subplots(3, 1, figsize=(8, 7), sharex=True)
    for ax, key, label in zip(axes, ("mean_reward", "final_x_m", "length_s"),
                              ("mean reward", "final x (m)", "session length (s)")):
        table = np.full((len(trials), n), np.nan)
        for r in rows:
            table[trials.index(int(r["trial"])), int(r["session"]) - 1] = float(r[key])
        mean, std = np.nanmean(table, axis=0), np.nanstd(table, axis=0)
        x = np.arange(1, n + 1)
        ax.plot(x, mean, lw=1)
        ax.fill_between(x, mean - std, mean + std, alpha=0.3, lw=0)
        ax.set_ylabel(label)
    axes[-1].set_xlabel("session")
    session_ticks(axes[-1])
    axes[0].set_title(f"Training ({len(trials)} trial(s), mean +- std)")
    fig.tight_layout()
    return fig


def plot_gait(recording, trial: int, phases: np.ndarray, gait: dict,
              window: tuple[float, float], labels: str = "") -> Figure:
    """Gait diagram (stance = foot contact, or thigh-extensor bursts without touch sensors)
    and the rhythm's inter-limb phase matrix (thigh-extensor bursts); ``labels``: the run's
    rhythm and gait labels, named, for the title."""
    fig, (ax, axm) = _subplots(1, 2, figsize=(11, 3.6), gridspec_kw={"width_ratios": [3, 1]})
    t = recording.t
    sel = (t >= window[0]) & (t < window[1])
    force = recording.foot_force[trial]
    for k, leg in enumerate(LEGS):
        if np.all(np.isfinite(force[:, k])):
            stance = force[sel, k] > 0
            x = t[sel]
            edges = np.diff(np.concatenate([[0], stance.astype(int), [0]]))
            for a, b in zip(np.flatnonzero(edges == 1), np.flatnonzero(edges == -1)):
                ax.broken_barh([(x[a], x[b - 1] - x[a] + 1e-3)], (k - 0.4, 0.8), color="k")
        else:
            for a, b in gait["bursts"][leg]:
                if b >= window[0] and a < window[1]:
                    ax.broken_barh([(a, b - a)], (k - 0.4, 0.8), color="tab:red")
    ax.set_yticks(range(len(LEGS)), LEGS)
    ax.invert_yaxis()
    ax.set_xlim(*window)
    ax.set_xlabel("time (s)")
    fell = mark_fall(ax, t, recording.alive[trial])
    ax.set_title("Gait diagram (black: foot contact)" + (f"; {labels}" if labels else "")
                 + (f"\n{fell}" if fell else ""),
                 **({"color": "tab:red"} if fell else {}))
    im = axm.imshow(phases, cmap="twilight", vmin=0, vmax=1)
    axm.set_xticks(range(4), LEGS)
    axm.set_yticks(range(4), LEGS)
    for i in range(4):
        for j in range(4):
            axm.text(j, i, f"{phases[i, j]:.2f}", ha="center", va="center", fontsize=7,
                     color="w" if 0.25 < phases[i, j] < 0.75 else "k")
    axm.set_title("rhythm: thigh-extensor burst\nphase of column vs row", fontsize=9)
    fig.colorbar(im, ax=axm, fraction=0.046)
    fig.tight_layout()
    return fig
