"""What a trained controller does: its gait (``astrocpg gait``) and the figures of its training
(``astrocpg plot``), from a run of its trained tables."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from ...errors import InputError
from ..analysis.gait import gait_label, leg_phases, phase_matrix, weight_structure
from .run import replay


def describe_gait(folder: str | Path, *, seconds: float = 10.0, seed: int = 1,
                  progress: bool = True) -> list[str]:
    """Run every trial's trained table for ``seconds``; one line per trial: leg phases relative
    to FR, the gait label, speed, upright share and the weight structure."""
    result, weights = replay(folder, seconds=seconds, seed=seed, progress=progress)
    w_max = float(np.asarray(result.cpg.models.interlimb_synapse.parameters["w_max"].value))
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
        lines.append(
            f"trial {b}: phases relative to FR: {ph}; gait: {label}; "
            f"mean forward speed {speed:.3f} m/s; upright {rec.alive[b].mean():.0%}; "
            f"weights: {ws['mixed_limb_pairs']} of {ws['limb_pairs']} limb pairs with two "
            f"inhibitory and two excitatory synapses, {ws['share_above_0.9_w_max']:.0%} "
            f"above 0.9 w_max")
    return lines


def plot_training(folder: str | Path, *, trial: int = 0, seconds: float = 10.0) -> list[Path]:
    """weights.png, training.png, thigh_extensor_activity.png and gait.png of one trial of the
    training in ``folder``; returns the paths written."""
    from ..figures import plots

    folder = Path(folder)
    result, weights = replay(folder, seconds=seconds, seed=1, progress=False)
    if not 0 <= trial < len(weights):
        raise InputError(f"{folder} has {len(weights)} trial(s)", culprit=f"--trial {trial}")
    b = trial
    written = [folder / "weights.png", folder / "training.png",
               folder / "thigh_extensor_activity.png", folder / "gait.png"]
    plots.plot_weights(written[0], weights[b] * 1e3, trial=b)
    plots.plot_training_curves(written[1], folder / "sessions.csv")
    window = (max(0.0, seconds - 2.0), seconds)
    plots.plot_thigh_extensor_activity(written[2], result.spikes, result.cpg.layout, trial=b,
                                       window=window)
    t, i = result.spikes["motor"]
    g = leg_phases(t, i, result.cpg.layout, b, min(1.0, seconds / 5), seconds)
    plots.plot_gait(written[3], result.robot, b, phase_matrix(g["phases"]), g, window=window)
    return written
