"""Where every element of the CPG sits in the Brian2 groups, for ``n_trials`` copies.

Per trial (copy) and limb (FR, FL, RR, RL), four pools of motor neurons; the six interneurons of
a limb; one astrocyte per thigh pool; one torque trace per thigh and calf joint. Every group is
trial-major, so the state of trial ``b`` is one contiguous slice of each group.

Inter-limb table: rows and columns are the thigh pools in the order
FR flexor, FR extensor, FL flexor, FL extensor, RR ..., RL ...; ``w[x, y]`` is from pool x to y.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

LEGS: tuple[str, ...] = ("FR", "FL", "RR", "RL")
POOLS: tuple[str, ...] = ("thigh_flexor", "thigh_extensor", "calf_flexor", "calf_extensor")
THIGH_POOLS: tuple[str, ...] = ("thigh_flexor", "thigh_extensor")
JOINTS_DRIVEN: tuple[str, ...] = ("thigh", "calf")

# The six interneurons of a locomotion unit: (name, kind, source pool, target pool) (SPEC 1).
INTERNEURONS: tuple[tuple[str, str, str, str], ...] = (
    ("thigh_flexor_to_extensor", "V1/V2b", "thigh_flexor", "thigh_extensor"),
    ("thigh_extensor_to_flexor", "V1/V2b", "thigh_extensor", "thigh_flexor"),
    ("calf_flexor_to_extensor", "V1/V2b", "calf_flexor", "calf_extensor"),
    ("calf_extensor_to_flexor", "V1/V2b", "calf_extensor", "calf_flexor"),
    ("thigh_extensor_to_calf_flexor", "IIN", "thigh_extensor", "calf_flexor"),
    ("thigh_flexor_to_calf_extensor", "IIN", "thigh_flexor", "calf_extensor"),
)


def interlimb_labels(legs: tuple[str, ...] = LEGS) -> list[str]:
    """Row/column labels of the inter-limb table, e.g. ``FR thigh_flexor``."""
    return [f"{leg} {pool}" for leg in legs for pool in THIGH_POOLS]


@dataclass(frozen=True)
class Layout:
    """Index arithmetic for ``n_trials`` copies of a CPG with ``legs`` and ``pool_size``."""

    n_trials: int
    pool_size: int
    legs: tuple[str, ...] = LEGS

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
        }

    @classmethod
    def from_json(cls, data: dict) -> "Layout":
        """The layout a manifest's ``results.layout`` (:meth:`to_json`) describes."""
        return cls(n_trials=int(data["n_trials"]), pool_size=int(data["pool_size"]),
                   legs=tuple(data.get("legs", LEGS)))

    # ---- sizes per trial
    @property
    def pools_per_trial(self) -> int:
        return self.n_legs * len(POOLS)

    @property
    def motor_per_trial(self) -> int:
        return self.pools_per_trial * self.pool_size

    @property
    def interneurons_per_trial(self) -> int:
        return self.n_legs * len(INTERNEURONS)

    @property
    def thigh_pools_per_trial(self) -> int:
        return self.n_legs * len(THIGH_POOLS)

    @property
    def joints_per_trial(self) -> int:
        return self.n_legs * len(JOINTS_DRIVEN)

    # ---- global indices
    def pool(self, trial: int, leg: int, pool: str) -> int:
        """Index into the pool group."""
        return trial * self.pools_per_trial + leg * len(POOLS) + POOLS.index(pool)

    def motor_neurons(self, trial: int, leg: int, pool: str) -> np.ndarray:
        start = self.pool(trial, leg, pool) * self.pool_size
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
        """For every motor neuron, the index of its pool in the pool group."""
        return np.repeat(np.arange(self.n_trials * self.pools_per_trial), self.pool_size)

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
