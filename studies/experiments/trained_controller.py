"""What a trained controller does: its gait (``astrocpg gait``) and the figures of its training
(``astrocpg plot``), from a run of its trained tables."""

from __future__ import annotations

import os
from pathlib import Path
from typing import Any

import numpy as np

from ...errors import InputError
from ..analysis.gait import (gait_label, leg_phases, phase_matrix, trial_gait,
                             weight_structure)
from ..analysis.fall import fall_words, first_fall
from ..outputs.folder import OutputFolder, as_path
from ..outputs.writing import write_manifest
from .progress import Bar
from .run import replay


def describe_gait(folder: str | Path, *, seconds: float = 10.0, seed: int | None = None,
                  progress: bool = True) -> list[str]:
    """Run every trial's trained table for ``seconds``; one line per trial: leg phases relative
    to FR, the gait label, speed, upright share, the fall if the robot fell (when, in simulated
    s) and the weight structure."""
    result, weights = replay(folder, seconds=seconds, seed=seed, progress=progress)
    w_max = result.cpg.models.value("w_max")
    t, i = result.spikes["motor"]
    rec = result.robot
    lines = []
    for b in range(result.cpg.n_trials):
        g = leg_phases(t, i, result.cpg.layout, b, min(1.0, seconds / 5), seconds)
        label = gait_label(g["phases"], g["locking"])
        speed = float(rec.torso_velocity[b, :, 0].mean())
        ph = ", ".join(f"{leg} {g['phases'][leg]:.2f} (lock {g['locking'][leg]:.2f})"
                       for leg in ("FR", "FL", "RR", "RL"))
        ws = weight_structure(weights[b], w_max)
        fall = fall_words(first_fall(rec.t, rec.alive[b]))
        lines.append(
            f"trial {b}: phases relative to FR: {ph}; gait: {label}; "
            f"mean forward speed {speed:.3f} m/s; alive (torso level) {rec.alive[b].mean():.0%}, "
            f"torso centre at least {rec.torso_position[b, :, 2].min():.2f} m above the ground"
            f"{'; ' + fall if fall else ''}; "
            f"weights: {ws['mixed_limb_pairs']} of {ws['limb_pairs']} limb pairs with two "
            f"inhibitory and two excitatory synapses, {ws['share_above_0.9_w_max']:.0%} "
            f"above 0.9 w_max")
    return lines


GAIT_COLUMNS = ("final_gait", "final_speed_m_per_s", "final_period_s", "final_phase_FL",
                "final_phase_RR", "final_phase_RL", "final_locking_FL", "final_locking_RR",
                "final_locking_RL")
"""What :func:`final_gaits` says of each trained trial (study results carry them per seed)."""


def final_gaits(models, tables: np.ndarray, *, seconds: float = 5.0,
                seed: int = 1) -> list[dict[str, Any]]:
    """The gait of each trained table (volt, (trials, 8, 8)) with learning off: one run of
    ``seconds`` for all of them, leg phases relative to FR and their locking over its second
    half, the gait label and the mean forward speed; one dict of :data:`GAIT_COLUMNS` per
    trial. Table ``b`` runs with seed ``seed + b`` (give a training's seed: each table on the
    network and noise it trained with)."""
    from .simulate import simulate_closed_loop

    result = simulate_closed_loop(models, seconds=seconds, seed=seed, n_trials=len(tables),
                                  weights=tables, record_traces=False, spikes=("motor",),
                                  progress=False)
    t, i = result.spikes["motor"]
    rows = []
    for b in range(len(tables)):
        g = trial_gait(t, i, result.cpg.layout, b, seconds / 2, seconds)
        rows.append({"final_speed_m_per_s": float(result.robot.torso_velocity[b, :, 0].mean()),
                     **{f"final_{k}": v for k, v in g.items()}})
    return rows


FIGURES = "figures"


def plot_training(folder: str | Path, *, trial: int = 0, seconds: float = 10.0,
                  out: str | Path | None = None, overwrite: bool = False, fmt: str = "png",
                  window: tuple[float, float] | None = None,
                  progress: bool = True) -> list[Path]:
    """weights, training, thigh_extensor_activity and gait figures of one trial of the
    training in ``folder`` (from a run of ``seconds`` with its trained weights; ``window``
    within it, default its last 2 s), and the trace figures of the trial's last recorded
    session (``train --record-every``) if any, in ``recording_trialTT_sessionSSSS/``; into
    ``out`` (default ``folder/figures``, which each plot replaces whole); returns the paths."""
    from ..figures import plots
    from ..figures.save import save_figure, save_figures
    from ..figures.traces import FIGURE_FUNCTIONS, trace_figures
    from ..outputs.result import load

    folder = as_path(folder, "folder")
    # the default folder belongs to this command: replaced whole on every plot
    target = Path(out) if out is not None else folder / FIGURES
    OutputFolder(target, overwrite=overwrite or out is None, inputs=[folder]).check()
    training = load(folder)
    if not 0 <= trial < training.n_trials:
        raise InputError(f"{folder} has {training.n_trials} trial(s)", culprit=f"--trial {trial}")
    if window is not None and window[0] >= seconds:
        raise InputError(f"starts after the {seconds:g} s run with the trained weights "
                         f"(--seconds)", culprit=f"--window {window[0]:g} {window[1]:g}")
    recorded = sorted(s for b, s in training.recordings if b == trial)
    result, weights = replay(folder, seconds=seconds, progress=progress)
    b = trial
    names = [f"{n}.{fmt}" for n in ("weights", "training", "thigh_extensor_activity", "gait")]
    window = (window[0], min(window[1], seconds)) if window is not None \
        else (max(0.0, seconds - 2.0), seconds)
    written = [target / n for n in names]
    # a step per figure; a recorded session adds a step per kind of figure, then per file
    bar = Bar(total=len(names) + (len(FIGURE_FUNCTIONS) if recorded else 0), unit="step",
              desc="plot", disable=not progress)
    with bar, OutputFolder(target, overwrite=overwrite or out is None, inputs=[folder]) as tmp:
        save_figure(plots.plot_weights(weights[b] * 1e3, trial=b), tmp / names[0])
        bar.update(1)
        save_figure(plots.plot_training_curves(folder / "sessions.csv"), tmp / names[1])
        bar.update(1)
        save_figure(plots.plot_thigh_extensor_activity(result.spikes, result.cpg.layout,
                                                       trial=b, window=window), tmp / names[2])
        bar.update(1)
        t, i = result.spikes["motor"]
        g = leg_phases(t, i, result.cpg.layout, b, min(1.0, seconds / 5), seconds)
        save_figure(plots.plot_gait(result.robot, b, phase_matrix(g["phases"]), g,
                                    window=window), tmp / names[3])
        bar.update(1)
        if recorded:
            session = recorded[-1]
            rec = training.recording(trial, session)
            sub = f"recording_trial{trial:02d}_session{session:04d}"
            # a recorded session is one trial (0); the window: within it, else all of it
            figures = trace_figures(rec, 0, on_part=lambda: bar.update(1))
            bar.total += len(figures)
            paths = save_figures(figures, tmp / sub, fmt, on_saved=lambda: bar.update(1))
            written += [target / sub / p.name for p in paths]
        files = dict(zip(names, FIGURE_FILES))
        if recorded:
            files[sub + "/"] = "figures of the trial's last recorded session"
        write_manifest(tmp, command="plot", seed=1, models_json={}, files=files,
                       settings={"training": os.path.abspath(folder), "trial": b,
                                 "seconds": seconds, "window": window, "format": fmt})
    return written


FIGURE_FILES = ("the trial's trained 8x8 inter-limb table (mV)",
                "mean reward, final x and session length per session (mean +- std over trials)",
                "thigh-extensor activity of the 4 limbs in the window",
                "gait diagram and inter-limb phase matrix")
