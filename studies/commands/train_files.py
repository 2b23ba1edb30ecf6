"""A training's files beside its checkpoint: ``sessions.csv``, ``weights.npz`` and
``session_starts.npz`` written from the session memory, and what each file of a training
folder holds (:data:`TRAIN_FILES`, its manifest's ``files``)."""

from __future__ import annotations

import csv
import io
from pathlib import Path

import numpy as np

from ...coupling.training import SESSION_COLUMNS, SessionMemory, SessionStart
from ...network import interlimb_labels
from ..outputs.checkpoint import CHECKPOINT
from ..outputs.writing import atomic_write, save_npz


def write_training_files(out: Path, mem: SessionMemory, sessions_done: np.ndarray,
                         final_weights_mV: np.ndarray, n_trials: int) -> None:
    """sessions.csv, weights.npz and session_starts.npz of a training's session memory."""
    rows = mem.rows
    buf = io.StringIO()
    writer = csv.DictWriter(buf, fieldnames=SESSION_COLUMNS, lineterminator="\n", restval=0)
    writer.writeheader()
    for r in rows:
        writer.writerow({k: (f"{v:.9g}" if isinstance(v, float) else v) for k, v in r.items()})
    data = buf.getvalue().encode()
    atomic_write(out / "sessions.csv", lambda f: f.write(data))
    n_max = max(len(w) for w in mem.weights)
    table = np.full((n_trials, n_max, 8, 8), np.nan)
    for b, ws in enumerate(mem.weights):
        if ws:
            table[b, :len(ws)] = np.array(ws) * 1e3
    save_npz(out / "weights.npz", {
        "weights_mV": table, "sessions_done": sessions_done.copy(),
        "final_weights_mV": final_weights_mV,
        "labels": np.array(interlimb_labels()),
    })
    save_npz(out / SESSION_STARTS, session_starts_arrays(mem.starts))


#: Each session's start (step, Progress, t_learning_start, the state a reset leaves) per trial:
#: what a replay of one session reads (:func:`astrocpg.replay_session`).
SESSION_STARTS = "session_starts.npz"


def session_starts_arrays(starts: list[list[SessionStart]]) -> dict[str, np.ndarray]:
    """The session starts as (trial, session, ...) arrays: ``step`` (-1 where none), ``progress``
    and ``t_learning_start`` (NaN where none) and ``state.<population>.<variable>`` (trial,
    session, element), session 1 first."""
    n_trials, n = len(starts), max((len(x) for x in starts), default=0)
    out: dict[str, np.ndarray] = {
        "step": np.full((n_trials, n), -1, dtype=np.int64),
        "progress": np.full((n_trials, n), np.nan),
        "t_learning_start": np.full((n_trials, n), np.nan)}
    for b, trial in enumerate(starts):
        for k, x in enumerate(trial):
            out["step"][b, k] = x.step
            out["progress"][b, k] = x.progress
            out["t_learning_start"][b, k] = x.t_learning_start
            for key, v in x.state.items():
                name = f"state.{key}"
                if name not in out:
                    out[name] = np.full((n_trials, n, len(v)), np.nan)
                out[name][b, k] = v
    return out


TRAIN_FILES = {
    "sessions.csv": "one row per trial and session: " + ", ".join(SESSION_COLUMNS),
    "weights.npz": "weights_mV (trial, session, 8, 8): each trial's inter-limb table after "
                   "each session (NaN after a trial's last); final_weights_mV; labels",
    SESSION_STARTS: "per trial and session (session 1 first): step (the network step of its "
                    "first step), progress, t_learning_start and state.<population>.<variable> "
                    "(what a session reset leaves: astrocytes, inter-limb weights in SI), what "
                    "a replay of one session reads",
    CHECKPOINT: "state to continue exactly (resume the training): a NumPy archive of plain "
                "arrays and JSON (meta, state), no code",
    "recordings/": "with record_every: trialTT_sessionSSSS/ per recorded session (spikes, "
                   "traces, robot, manifest; export reads it)",
}


__all__ = ["SESSION_STARTS", "TRAIN_FILES", "session_starts_arrays", "write_training_files"]
