"""A training's checkpoint as data: the network's Brian2 state with its clocks named as any
process names them, the session loop's memory as arrays and back, the payload split into the
checkpoint's readable ``meta`` and its state tree (:mod:`astrocpg.studies.outputs.checkpoint`),
read back and checked; and the Brian2 target a training continues with."""

from __future__ import annotations

import re
from pathlib import Path
from typing import Any

import numpy as np

from ...coupling.training import SESSION_COLUMNS, SessionMemory, SessionStart
from ...errors import InputError, advice
from ..outputs.checkpoint import CHECKPOINT, write_checkpoint as write_checkpoint_file
from ..outputs.checkpoint import read_checkpoint as read_checkpoint_file
from ..settings import TrainSettings

#: A clock's name in a Brian2 state: its stem (``<object>_clock``) and the suffix (``_1``...)
#: it gets where that name was taken earlier in the process (:func:`rename_clocks`).
CLOCK = re.compile(r"^(.*_clock)(_\d+)?$")


#: The entries of Brian2's random generator state that hold a C address (the Cython target's
#: buffers of ``rand()`` and ``randn()`` draws): where a buffer lies in this process's memory,
#: not a state of the training (:func:`portable_random_state`).
RANDOM_ADDRESSES = ("rand_buffer", "randn_buffer")


def portable_random_state(state: dict[str, Any]) -> dict[str, Any]:
    """Brian2's stored random generator state without its buffers' addresses (0, as in a
    process that has drawn nothing on the Cython target): the address depends on what ran in
    the process before (a Cython network that drew ``randn()``), so two identical trainings
    would write different checkpoints, and restored in another process it would point into
    memory that process never allocated. astrocpg's networks draw from their own streams
    (:mod:`astrocpg.network.noise`), never from these buffers."""
    random = state.get("_random_generator_state")
    if not isinstance(random, dict):
        return state
    random = {k: (np.zeros_like(v) if k in RANDOM_ADDRESSES else v) for k, v in random.items()}
    return {**state, "_random_generator_state": random}


def local_random_state(state: dict[str, Any]) -> dict[str, Any]:
    """A checkpoint's Brian2 state with the buffers' addresses of this process (Brian2's
    ``restore`` writes them back into its device), so that restoring never points Brian2's
    Cython buffers at an address written by another process (:func:`portable_random_state`)."""
    from brian2.devices.device import get_device

    random = state.get("_random_generator_state")
    if not isinstance(random, dict):
        return state
    device = get_device()
    random = {k: (np.array(getattr(device, k)) if k in RANDOM_ADDRESSES and hasattr(device, k)
                  else v) for k, v in random.items()}
    return {**state, "_random_generator_state": random}


def same_codegen(started: str, now: str) -> None:
    """A training continues under the Brian2 target it started with (checkpoints written before
    targets were recorded: numpy). The targets draw the same noise, but C's and numpy's
    floating point can part after many sessions: an exact resume needs the same one."""
    if started != now:
        raise InputError(f"this training started with Brian2's {started} target and continues "
                         f"only with it (now: {now}); resume with {advice('codegen', started)}",
                         culprit=advice("codegen"))


def rename_clocks(state: dict[str, Any], net) -> dict[str, Any]:
    """Brian2 names the clock of an object with its own ``dt`` ``<object>_clock``, plus a
    suffix (``_1``...) if that name was taken earlier in the process, so a checkpoint written
    by one process may name the clocks differently from the network rebuilt in another (a Dask
    worker that trained other runs before). Object names are fixed; match clocks by stem."""
    from brian2.core.network import _get_all_objects

    current = {CLOCK.sub(r"\1", obj.clock.name): obj.clock.name
               for obj in _get_all_objects(net.objects)}
    out, stored = {}, []
    for key, value in state.items():
        m = CLOCK.match(key)
        if not m:
            out[key] = value
            continue
        stored.append(value)
        if m.group(1) in current:
            out[current[m.group(1)]] = value
    # a checkpoint written when every object had its own clock, resumed by a network whose
    # objects share one (cpg_clock): the clocks stepped together, so any of them has its time
    # (and the clocks the network no longer has are left out: Brian2 refuses unknown names)
    for name in current.values():
        if name not in out and stored:
            out[name] = stored[0]
    return out


#: The payload's entries stored in the checkpoint's readable ``meta`` (JSON); the rest is the
#: state tree (:mod:`astrocpg.studies.outputs.checkpoint`).
_META_KEYS = ("fingerprint", "settings", "codegen", "record_plan")


def _split(payload: dict[str, Any]) -> tuple[dict[str, Any], dict[str, Any]]:
    meta = {k: payload[k] for k in _META_KEYS if k in payload}
    meta["sessions_done"] = [int(n) for n in payload["training"]["sessions_done"]]
    return meta, {k: v for k, v in payload.items() if k not in _META_KEYS}


def _memory_state(memory: SessionMemory, shape: tuple[int, ...]) -> dict[str, Any]:
    """The session memory as data: each trial's tables after each session as one array, the
    rows as one array per column (thousands of rows: a few arrays, not a JSON value each)."""
    return {"lengths": [np.asarray(x, dtype=np.float64) for x in memory.lengths],
            "weights": [np.stack(ws) if ws else np.zeros((0,) + tuple(shape))
                        for ws in memory.weights],
            "rows": _rows_state(memory.rows),
            "starts": [_starts_state(st) for st in memory.starts]}


def _starts_state(starts: list[SessionStart]) -> dict[str, Any]:
    """One trial's session starts as one array per field (one row per session)."""
    keys = list(starts[0].state) if starts else []
    return {"step": np.asarray([x.step for x in starts], dtype=np.int64),
            "progress": np.asarray([x.progress for x in starts], dtype=np.float64),
            "t_learning_start": np.asarray([x.t_learning_start for x in starts],
                                           dtype=np.float64),
            "state": {k: np.stack([x.state[k] for x in starts]) for k in keys}}


def _starts_from_state(state: dict[str, Any]) -> list[SessionStart]:
    steps = np.asarray(state["step"], dtype=np.int64)
    values = {k: np.asarray(v, dtype=np.float64) for k, v in state["state"].items()}
    if any(len(v) != len(steps) for v in values.values()):
        raise ValueError("session starts of unequal lengths")
    return [SessionStart(step=int(steps[i]), progress=float(state["progress"][i]),
                         t_learning_start=float(state["t_learning_start"][i]),
                         state={k: v[i] for k, v in values.items()})
            for i in range(len(steps))]


def _rows_state(rows: list[dict[str, Any]]) -> dict[str, Any]:
    keys = list(rows[0]) if rows else list(SESSION_COLUMNS)
    if any(list(r) != keys for r in rows):  # not one table: row by row
        return {"rows": rows}
    columns: dict[str, Any] = {}
    for k in keys:
        values = [r[k] for r in rows]
        if all(isinstance(v, (int, np.integer)) and not isinstance(v, (bool, np.bool_))
               for v in values):
            columns[k] = np.asarray(values, dtype=np.int64)
        elif all(isinstance(v, (float, np.floating)) for v in values):
            columns[k] = np.asarray(values, dtype=np.float64)
        else:
            columns[k] = values
    return {"columns": keys, "values": columns, "n": len(rows)}


def _rows_from_state(state: dict[str, Any]) -> list[dict[str, Any]]:
    if "rows" in state:
        rows = state["rows"]
    else:
        keys, n = state["columns"], state["n"]
        columns = [state["values"][k] for k in keys]
        columns = [c.tolist() if isinstance(c, np.ndarray) else list(c) for c in columns]
        if any(len(c) != n for c in columns):
            raise ValueError("session rows of unequal lengths")
        rows = [dict(zip(keys, values)) for values in zip(*columns)] if keys else [{}] * n
    if not isinstance(rows, list) or not all(isinstance(r, dict) for r in rows):
        raise ValueError("session rows that are not rows")
    return rows


def _memory_from_state(state: dict[str, Any], n_trials: int) -> SessionMemory:
    lengths, weights = state["lengths"], state["weights"]
    if not len(lengths) == len(weights) == n_trials:
        raise ValueError("a session memory of another number of trials")
    starts = state.get("starts")  # none in checkpoints written before session starts were kept
    if starts is not None and len(starts) != n_trials:
        raise ValueError("session starts of another number of trials")
    return SessionMemory(lengths=[np.asarray(x, dtype=np.float64).tolist() for x in lengths],
                         weights=[list(np.asarray(w, dtype=np.float64)) for w in weights],
                         rows=_rows_from_state(state["rows"]),
                         starts=[_starts_from_state(x) for x in starts] if starts is not None
                         else [[] for _ in range(n_trials)])


def memory_state(memory: SessionMemory, shape: tuple[int, ...]) -> dict[str, Any]:
    """The session memory as a checkpoint holds it (``shape``: a table's, (8, 8))."""
    return _memory_state(memory, shape)


def memory_from_state(state: dict[str, Any], n_trials: int) -> SessionMemory:
    """A checkpoint's session memory (its ``memory`` entry) as the session loop keeps it."""
    return _memory_from_state(state, n_trials)


def write_payload(path: Path, payload: dict[str, Any]) -> None:
    """``payload`` (what :func:`read_checkpoint` returns) written as the checkpoint ``path``."""
    write_checkpoint_file(path, *_split(payload))


def read_checkpoint(path: Path, culprit: Any = None) -> dict[str, Any]:
    """Load and check a checkpoint (data only: :mod:`astrocpg.studies.outputs.checkpoint`); a
    corrupt or foreign file, or one of the old pickled format, is an ``InputError`` naming it.
    Returns the payload :meth:`Trainer.restore` takes."""
    meta, state = read_checkpoint_file(path, culprit=culprit)
    bad = InputError("is corrupt (not a training's checkpoint)", culprit=path) if culprit is None \
        else InputError(f"{path} is corrupt (not a training's checkpoint)", culprit=culprit)
    if not isinstance(state, dict) or not isinstance(meta.get("settings"), dict) \
            or "fingerprint" not in meta:
        raise bad
    payload = dict(state) | {k: meta[k] for k in _META_KEYS if k in meta}
    try:
        TrainSettings(**payload["settings"])
        np.asarray(payload["training"]["sessions_done"], dtype=np.int64)
    except (KeyError, TypeError, ValueError):
        raise bad from None
    return payload


__all__ = ["CHECKPOINT", "CLOCK", "memory_from_state", "memory_state", "read_checkpoint",
           "rename_clocks", "same_codegen", "write_payload"]
