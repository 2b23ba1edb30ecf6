"""What a training session starts from (docs/model.md, "Sessions"; paper "Training Process"):
when a session ends, a trial's network is set back to its initial state, except the
astrocytes, which keep theirs, and the inter-limb weights, which are what is learnt. The rule
lives here, with the training that applies it (:mod:`astrocpg.coupling.training`); the
network (:class:`~astrocpg.network.CPG`) only gives its arrays.

Array writes only (no code generation): a reset costs a few microseconds per array.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from ..errors import InputError
from ..network import CPG
from ..network.trial_tables import Part

#: The populations whose state a session reset keeps: the astrocytes (docs/model.md).
KEPT = ("astrocyte",)


def reset_trial(cpg: CPG, trial: int, keep: tuple[str, ...] = KEPT) -> None:
    """Reset one trial's state to the start of a session: every state variable of the
    groups not in ``keep`` and every dynamic variable of the inter-limb synapses except the
    weights."""
    for name in ("motor", *cpg.groups, "interlimb"):
        if name in keep or (name == "interlimb" and name not in cpg.synapse_kinds):
            continue
        for part in cpg.parts(name):
            where = cpg.trial_slices(part)[trial]
            for var, arr in _reset_arrays(cpg, part.name, part.obj):
                arr[where] = _initial(cpg, name, var)


def persistent_state(cpg: CPG, trial: int, keep: tuple[str, ...] = KEPT
                     ) -> dict[str, np.ndarray]:
    """What a session reset (:func:`reset_trial`) leaves of ``trial``'s state: every dynamic
    variable of the kept populations and of the inter-limb synapses (their weights), as
    ``{"population.variable": values}`` in the files' order. With the seed, the step and the
    reset values, it is all a session starts from (a replay)."""
    out: dict[str, list[np.ndarray]] = {}
    for name, part in _persistent_parts(cpg, keep):
        where = cpg.trial_slices(part)[trial]
        for var, arr in _persistent_arrays(cpg, part.name, part.obj):
            out.setdefault(f"{name}.{var}", []).append(np.array(arr[where], dtype=float))
    return {k: np.concatenate(v) for k, v in out.items()}


def set_persistent_state(cpg: CPG, trial: int, state: dict[str, np.ndarray],
                         shift_s: float = 0.0, keep: tuple[str, ...] = KEPT) -> None:
    """Set what :func:`persistent_state` gave (``shift_s``: subtracted from the spike times
    ``lastspike``, for a network whose clock starts that much later)."""
    taken: dict[str, int] = {}
    for name, part in _persistent_parts(cpg, keep):
        where = cpg.trial_slices(part)[trial]
        for var, arr in _persistent_arrays(cpg, part.name, part.obj):
            key = f"{name}.{var}"
            if key not in state:
                raise InputError(f"the recorded state lacks {key}", culprit="session start")
            n = len(arr[where])
            values = np.asarray(state[key], dtype=float)[taken.get(key, 0):][:n]
            if len(values) != n:
                raise InputError(f"{key} holds {len(state[key])} values, not those of "
                                 f"this network", culprit="session start")
            taken[key] = taken.get(key, 0) + n
            arr[where] = values - shift_s if var == "lastspike" else values


def _persistent_parts(cpg: CPG, keep: tuple[str, ...]) -> list[tuple[str, Part]]:
    names = [*keep, *(("interlimb",) if "interlimb" in cpg.synapse_kinds else ())]
    return [(name, part) for name in names for part in cpg.parts(name)]


def _persistent_arrays(cpg: CPG, name: str, obj: Any) -> list[tuple[str, np.ndarray]]:
    out = list(_reset_arrays(cpg, name, obj))
    if "w" in obj.variables and all(v != "w" for v, _ in out):
        out.append(("w", cpg.array(name, "w")))
    return out


def _reset_arrays(cpg: CPG, name: str, obj: Any) -> list[tuple[str, np.ndarray]]:
    """(variable, live array) of what a session reset sets back: the model's differential
    equations and non-constant parameters (not linked ones, not the weights ``w``)."""
    def make() -> list[tuple[str, np.ndarray]]:
        out = []
        for var, eq in obj.equations.items():
            if eq.type == "subexpression" or var == "w":
                continue
            if {"constant", "linked", "shared"} & set(eq.flags):
                continue
            out.append((var, cpg.array(name, var)))
        for var in ("lastspike", "not_refractory"):
            if var in obj.variables and all(v != var for v, _ in out):
                out.append((var, cpg.array(name, var)))
        return out
    return cpg.memo(("reset", name), make)


def _initial(cpg: CPG, group: str, var: str) -> Any:
    if var == "lastspike":
        return -1e4  # Brian2's "never spiked"
    if var == "not_refractory":
        return True
    model = (cpg.models.interlimb_synapse if group == "interlimb"
             else cpg.layout.row(group).model_in(cpg.models))
    value = model.initial_values.get(var, 0.0)
    if isinstance(value, str):
        raise InputError("a session reset needs a number, not an expression",
                         culprit=f"{model.name}.initial_values.{var}")
    return float(np.asarray(value))


__all__ = ["KEPT", "persistent_state", "reset_trial", "set_persistent_state"]
