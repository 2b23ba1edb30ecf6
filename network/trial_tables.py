"""Where a population's elements live among Brian2's objects.

Usually one population is one Brian2 object, trial-major: element ``k`` of the motor-neuron group
is motor neuron ``k`` of the files, in trial ``k // motor_per_trial``. With 0 ms inter-limb delays
the limbs integrate in stages (:mod:`astrocpg.network.delays`), so the motor neurons (and every
synapse that touches them) are split into one object per stage, and the pool group holds the
stages' pools one block after another. A :class:`Part` says which object holds which elements; a
:class:`TrialTable` gives the hot loop one ``(n_trials, per_trial)`` table of a variable in the
files' order either way: a live view of Brian2's array where the order allows, else a buffer
that :meth:`TrialTable.read` fills and :meth:`TrialTable.write` copies back, without allocating.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np


@dataclass(frozen=True)
class Part:
    """One Brian2 object holding (some of) a population.

    obj: the Brian2 group or synapses.
    number: the population number (trial-major, as in the files) of each of its elements; None
        where element ``k`` is number ``k``.
    per_trial: elements of the population per trial, so the trial of element ``k`` is
        ``number[k] // per_trial`` (``k // per_trial`` without ``number``).
    """

    obj: Any
    number: np.ndarray | None
    per_trial: int

    @property
    def name(self) -> str:
        return self.obj.name

    def numbers(self) -> np.ndarray:
        return np.arange(len(self.obj)) if self.number is None else self.number

    def trials(self) -> np.ndarray:
        """The trial of every element."""
        return self.numbers() // self.per_trial


class TrialTable:
    """``variable`` of a population as a ``(n_trials, per_trial)`` array in the files' order.

    Read :attr:`values` after :meth:`read`; after writing into it, call :meth:`write`. Where the
    population is one object in that order, :attr:`values` is Brian2's live array (``read`` and
    ``write`` do nothing), as fast as the raw array."""

    def __init__(self, arrays: list[tuple[np.ndarray, np.ndarray | None]], n_trials: int):
        self._parts = arrays
        if len(arrays) == 1 and arrays[0][1] is None:
            self.live = True
            self.values = arrays[0][0].reshape(n_trials, -1)
            self._flat = self.values.reshape(-1)
        else:
            self.live = False
            size = sum(len(a) for a, _ in arrays)
            self.values = np.zeros((n_trials, size // n_trials), dtype=arrays[0][0].dtype)
            self._flat = self.values.reshape(-1)
            self.read()

    def read(self) -> np.ndarray:
        """Bring :attr:`values` up to date with the simulation; returns it."""
        if not self.live:
            flat = self._flat
            for arr, number in self._parts:
                if number is None:
                    flat[:len(arr)] = arr
                else:
                    flat[number] = arr
        return self.values

    def write(self) -> None:
        """Copy :attr:`values` into the simulation."""
        if not self.live:
            flat = self._flat
            for arr, number in self._parts:
                if number is None:
                    arr[:] = flat[:len(arr)]
                else:
                    np.take(flat, number, out=arr)
