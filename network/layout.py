"""Where every element of the CPG sits in the Brian2 groups, for ``n_trials`` copies.

Per trial (copy) and limb (FR, FL, RR, RL), four pools of motor neurons; the six interneurons of
a limb; one astrocyte per thigh pool; one torque trace per thigh and calf joint. Every group is
trial-major, so the state of trial ``b`` is one contiguous slice of each group.

Inter-limb table: rows and columns are the thigh pools in the order
FR flexor, FR extensor, FL flexor, FL extensor, RR ..., RL ...; ``w[x, y]`` is from pool x to y.

Motor neurons are numbered trial-major (``motor_index`` of :meth:`Layout.to_json`) in every file
and table. Where inter-limb delays of 0 ms make the limbs integrate in *stages* one after another
within a step (:mod:`astrocpg.network.delays`), each stage has its own motor-neuron group
(trial-major within the stage), and the pool group holds the stages' pools one block after
another, so that each stage's pools form one contiguous sub-group; :meth:`Layout.stage_motor_index`
and :meth:`Layout.pool_number` map them back to the trial-major numbering.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

# The names of the limbs, pools, joints and interneurons live in the population table
# (populations.py), which this layout reads for every population's cells.
from . import populations as _table
from .populations import INTERNEURONS, JOINTS_DRIVEN, LEGS, POOLS, THIGH_POOLS


def interlimb_labels(legs: tuple[str, ...] = LEGS) -> list[str]:
    """Row/column labels of the inter-limb table, e.g. ``FR thigh_flexor``."""
    return [f"{leg} {pool}" for leg in legs for pool in THIGH_POOLS]


@dataclass(frozen=True)
class Layout:
    """Index arithmetic for ``n_trials`` copies of a CPG with ``legs`` and ``pool_size``."""

    n_trials: int
    pool_size: int
    legs: tuple[str, ...] = LEGS
    #: positions in ``legs`` of the limbs of each stage, in the order the stages integrate within
    #: a step; None: one stage of every limb (no 0 ms inter-limb delay)
    stages: tuple[tuple[int, ...], ...] | None = None
    #: the population rows this layout places (a built network's, or a folder's manifest's);
    #: None: the built-in rows (:data:`astrocpg.network.populations.BUILT_IN`)
    populations: tuple[_table.Population, ...] | None = field(default=None, compare=False)

    @property
    def rows(self) -> tuple[_table.Population, ...]:
        """Its population rows (:attr:`populations`, else the built-in rows)."""
        return self.populations if self.populations is not None else _table.BUILT_IN

    def row(self, population: str) -> _table.Population:
        """The row of ``population`` among :attr:`rows` (KeyError if there is none)."""
        return _table.row(population, self.rows)

    @property
    def limb_stages(self) -> tuple[tuple[int, ...], ...]:
        return self.stages if self.stages is not None else (tuple(range(self.n_legs)),)

    @property
    def staged(self) -> bool:
        """Do the limbs integrate in more than one stage (0 ms inter-limb delays)?"""
        return len(self.limb_stages) > 1

    def stage_of(self, leg: int) -> tuple[int, int]:
        """(stage, position of ``leg`` within its stage)."""
        for s, members in enumerate(self.limb_stages):
            if leg in members:
                return s, members.index(leg)
        raise ValueError(f"leg {leg} is in no stage")

    def stage_pool_range(self, stage: int) -> tuple[int, int]:
        """[start, stop) of the stage's pools in the pool group."""
        start = sum(self.n_trials * len(m) * len(POOLS) for m in self.limb_stages[:stage])
        return start, start + self.n_trials * len(self.limb_stages[stage]) * len(POOLS)

    def stage_motor_index(self, stage: int) -> np.ndarray:
        """The trial-major motor-neuron number of each neuron of the stage's group, in the
        group's order (trial, leg of the stage, pool, neuron)."""
        members = self.limb_stages[stage]
        b, m, k = np.meshgrid(np.arange(self.n_trials), np.array(members, dtype=np.intp),
                              np.arange(len(POOLS) * self.pool_size), indexing="ij")
        return (b * self.motor_per_trial + m * len(POOLS) * self.pool_size + k).ravel()

    def motor_local(self, motor: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(stage, index in the stage's group) of trial-major motor-neuron numbers."""
        motor = np.asarray(motor, dtype=np.intp)
        per_leg = len(POOLS) * self.pool_size
        b, r = np.divmod(motor, self.motor_per_trial)
        leg, k = np.divmod(r, per_leg)
        stage = np.empty_like(motor)
        local = np.empty_like(motor)
        for s, members in enumerate(self.limb_stages):
            for pos, m in enumerate(members):
                here = leg == m
                stage[here] = s
                local[here] = (b[here] * len(members) + pos) * per_leg + k[here]
        return stage, local

    @property
    def pool_number(self) -> np.ndarray:
        """For every pool of the pool group, its trial-major number ``trial*pools_per_trial +
        leg*4 + pool`` (the identity when there is one stage)."""
        out = np.empty(self.n_trials * self.pools_per_trial, dtype=np.intp)
        for b in range(self.n_trials):
            for leg in range(self.n_legs):
                for p, name in enumerate(POOLS):
                    out[self.pool(b, leg, name)] = b * self.pools_per_trial + leg * len(POOLS) + p
        return out

    @property
    def n_legs(self) -> int:
        return len(self.legs)

    def to_json(self) -> dict:
        """The index layout, for manifests: how a population's index maps to trial, leg, pool."""
        return {
            "n_trials": self.n_trials, "legs": list(self.legs), "pools": list(POOLS),
            "pool_size": self.pool_size,
            "motor_index": "trial*motor_per_trial + (leg*4 + pool)*pool_size + k",
            "motor_per_trial": self.motor_per_trial,
            "interneurons": [n for n, *_ in INTERNEURONS],
            "interneuron_index": "trial*interneurons_per_trial + leg*6 + interneuron",
            "interneurons_per_trial": self.interneurons_per_trial,
            "astrocyte_index": "trial*thigh_pools_per_trial + leg*2 + (0 flexor, 1 extensor)",
            "thigh_pools": list(THIGH_POOLS),
            # every population's cell labels in one limb (the export's and Result's cells)
            "cells_per_leg": {p.name: list(p.labels(self.pool_size)) for p in self.rows},
            # the rows themselves: a folder describes itself (populations.rows_of)
            "populations": [p.to_json(self.pool_size) for p in self.rows],
        }

    @classmethod
    def from_json(cls, data: dict) -> "Layout":
        """The layout a manifest's ``results.layout`` (:meth:`to_json`) describes, with the
        rows it holds (the built-in rows for a folder written before manifests held them)."""
        return cls(n_trials=int(data["n_trials"]), pool_size=int(data["pool_size"]),
                   legs=tuple(data.get("legs", LEGS)), populations=_table.rows_of(data))

    # ---- sizes per trial
    def cells_per_trial(self, population: str) -> int:
        """How many cells of ``population`` (a row of the population table) one trial has."""
        return self.n_legs * len(self.row(population).labels(self.pool_size))

    @property
    def pools_per_trial(self) -> int:
        return self.n_legs * len(POOLS)

    @property
    def motor_per_trial(self) -> int:
        return self.pools_per_trial * self.pool_size  # the table's motor row: pool_size per pool

    @property
    def interneurons_per_trial(self) -> int:
        return self.cells_per_trial("interneuron")

    @property
    def thigh_pools_per_trial(self) -> int:
        return self.n_legs * len(THIGH_POOLS)

    @property
    def joints_per_trial(self) -> int:
        return self.cells_per_trial("torque")

    # ---- global indices
    def pool(self, trial: int, leg: int, pool: str) -> int:
        """Index into the pool group (trial-major with one stage; stage by stage otherwise)."""
        if self.stages is None:
            return trial * self.pools_per_trial + leg * len(POOLS) + POOLS.index(pool)
        s, pos = self.stage_of(leg)
        start, _ = self.stage_pool_range(s)
        per_trial = len(self.limb_stages[s]) * len(POOLS)
        return start + trial * per_trial + pos * len(POOLS) + POOLS.index(pool)

    def motor_neurons(self, trial: int, leg: int, pool: str) -> np.ndarray:
        """Trial-major motor-neuron numbers of one pool (files, tables)."""
        start = (trial * self.pools_per_trial + leg * len(POOLS) + POOLS.index(pool)) \
            * self.pool_size
        return np.arange(start, start + self.pool_size)

    def interneuron(self, trial: int, leg: int, name: str) -> int:
        names = [n for n, *_ in INTERNEURONS]
        return trial * self.interneurons_per_trial + leg * len(INTERNEURONS) + names.index(name)

    def thigh_pool(self, trial: int, leg: int, pool: str) -> int:
        """Index into the astrocyte group and the inter-limb table (``pool`` is a thigh pool)."""
        return trial * self.thigh_pools_per_trial + leg * len(THIGH_POOLS) + THIGH_POOLS.index(pool)

    def joint(self, trial: int, leg: int, joint: str) -> int:
        """Index into the torque group."""
        return trial * self.joints_per_trial + leg * len(JOINTS_DRIVEN) + JOINTS_DRIVEN.index(joint)

    # ---- vectorised maps
    @property
    def pool_of_motor_neuron(self) -> np.ndarray:
        """For every motor neuron (trial-major number), the index of its pool in the pool
        group."""
        number = np.repeat(np.arange(self.n_trials * self.pools_per_trial), self.pool_size)
        if self.stages is None:
            return number
        index_of_number = np.argsort(self.pool_number)
        return index_of_number[number]

    @property
    def pool_of_astrocyte(self) -> np.ndarray:
        """For every astrocyte, the pool-group index of the thigh pool it listens to."""
        return np.array([
            self.pool(b, leg, p)
            for b in range(self.n_trials) for leg in range(self.n_legs) for p in THIGH_POOLS
        ], dtype=np.intp)

    def pool_names(self) -> list[str]:
        """``FR thigh_flexor`` ... for the pools of one trial."""
        return [f"{leg} {pool}" for leg in self.legs for pool in POOLS]
