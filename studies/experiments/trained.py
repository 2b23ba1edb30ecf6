"""What a trained controller does: its gait (``astrocpg gait``) and the figures of its training
(``astrocpg plot``), from a run of its trained tables."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from ...errors import InputError
from ..analysis.gait import gait_label, leg_phases, phase_matrix, weight_structure
from ..files.folder import OutputFolder
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


FIGURES = "figures"


def plot_training(folder: str | Path, *, trial: int = 0, seconds: float = 10.0,
                  out: str | Path | None = None, overwrite: bool = False) -> list[Path]:
    """weights.png, training.png, thigh_extensor_activity.png and gait.png of one trial of the
    training in ``folder``, into ``out`` (default ``folder/figures``, which each plot replaces
    whole); returns the paths written."""
    from ..figures import plots

    folder = Path(folder)
    # the default folder belongs to this command: replaced whole on every plot
    target = Path(out) if out is not None else folder / FIGURES
    OutputFolder(target, overwrite=overwrite or out is None).check()
    result, weights = replay(folder, seconds=seconds, seed=1, progress=False)
    if not 0 <= trial < len(weights):
        raise InputError(f"{folder} has {len(weights)} trial(s)", culprit=f"--trial {trial}")
    b = trial
    names = ["weights.png", "training.png", "thigh_extensor_activity.png", "gait.png"]
    window = (max(0.0, seconds - 2.0), seconds)
    with OutputFolder(target, overwrite=overwrite or out is None) as tmp:
        plots.plot_weights(tmp / names[0], weights[b] * 1e3, trial=b)
        plots.plot_training_curves(tmp / names[1], folder / "sessions.csv")
        plots.plot_thigh_extensor_activity(tmp / names[2], result.spikes, result.cpg.layout,
                                           trial=b, window=window)
        t, i = result.spikes["motor"]
        g = leg_phases(t, i, result.cpg.layout, b, min(1.0, seconds / 5), seconds)
        plots.plot_gait(tmp / names[3], result.robot, b, phase_matrix(g["phases"]), g,
                        window=window)
    return [target / n for n in names]
