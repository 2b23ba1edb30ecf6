"""The built CPG (:class:`CPG`): its Brian2 groups and synapses, their index layout, and the
views the coupling and the recordings read (arrays, trial tables, inter-limb weights, the
divergence scan). :func:`~astrocpg.network.build.build_cpg` makes one; nothing here is
biophysics or wiring.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np
from brian2 import Network, NeuronGroup, Synapses

from ..errors import InputError
from ..models import ModelSet
from .codegen import DEFAULT as DEFAULT_CODEGEN
from .divergence import InvalidState, StateScan, model_of
from .layout import THIGH_POOLS, Layout
from .trial_tables import Part, TrialTable

@dataclass
class CPG:
    """The built network: Brian2 groups, synapses and the index layout.

    ``motor_groups`` holds one motor-neuron group per stage of limbs (one, named ``motor``,
    unless 0 ms inter-limb delays make the limbs integrate one after another: see
    :mod:`astrocpg.network.delays`); ``synapses`` maps each synapse object's name to it (per
    stage: ``interlimb_FR``, ...). :meth:`parts` and :meth:`table` give any population in the
    files' trial-major order either way."""

    layout: Layout
    models: ModelSet
    seed: int
    dt: Any
    net: Network
    motor_groups: tuple[NeuronGroup, ...]
    interneuron: NeuronGroup
    astrocyte: NeuronGroup
    pool: NeuronGroup
    torque: NeuronGroup
    synapses: dict[str, Synapses]
    interlimb_pairs: np.ndarray  # (n_synapses, 2): (row, col) in the per-trial table
    codegen: str = DEFAULT_CODEGEN  # Brian2 target of its groups and synapses (codegen.py)
    #: per synapse kind (``interlimb``, ``intra_pool``, ...): its objects, stage by stage
    synapse_kinds: dict[str, tuple[Synapses, ...]] = field(default_factory=dict)
    #: per inter-limb object: its (row, col) pairs of the per-trial table
    interlimb_pairs_of: dict[str, np.ndarray] = field(default_factory=dict)
    #: every population's group but the motor neurons', by name (rows added to the table too)
    groups: dict[str, NeuronGroup] = field(default_factory=dict)
    #: added to Brian2's step in every draw of the network (:meth:`start_noise_at`)
    noise_offset: np.ndarray = field(default_factory=lambda: np.zeros(1, dtype=np.int64))
    _arrays: dict[tuple[str, str], np.ndarray] = field(default_factory=dict)
    _scan: StateScan | None = None

    def start_noise_at(self, step: int) -> None:
        """Draw the noise of Brian2's step ``k`` from step ``step + k`` of each trial's streams
        (:mod:`astrocpg.network.noise`): a replay of a session that started at ``step`` of a
        training gets that session's noise. Set before the run; 0 by default."""
        self.noise_offset[0] = int(step)

    @property
    def n_trials(self) -> int:
        return self.layout.n_trials

    @property
    def motor(self) -> NeuronGroup:
        """The motor-neuron group, where there is one (one stage of limbs)."""
        if len(self.motor_groups) != 1:
            raise AttributeError("the motor neurons are split into one group per stage of "
                                 "limbs (0 ms inter-limb delays): use CPG.parts('motor')")
        return self.motor_groups[0]

    @property
    def clock(self) -> Any:
        """The clock of the network's step (every object runs on the same ``dt``)."""
        return self.pool.clock

    def _object(self, name: str) -> Any:
        if name in self.synapses:
            return self.synapses[name]
        for g in self.motor_groups:
            if g.name == name:
                return g
        if name in self.groups:
            return self.groups[name]
        raise KeyError(f"no Brian2 object named {name!r} in this network")

    def array(self, group: str, variable: str) -> np.ndarray:
        """The raw state array of ``group.variable`` (``group``: a Brian2 object's name; numpy
        target: the live array, writes in place change the simulation). Cached: use it in hot
        loops instead of ``G.v[:]``. Its order is the object's own: :meth:`table` gives a
        population in the files' order whatever its objects."""
        key = (group, variable)
        if key not in self._arrays:
            obj = self._object(group)
            require_variables(obj, variable, rows=self.layout.rows)
            arr = obj.variables[variable].get_value()
            if not isinstance(arr, np.ndarray):  # pragma: no cover - other devices
                raise RuntimeError("astrocpg needs Brian2's runtime (numpy) target")
            self._arrays[key] = arr
        return self._arrays[key]

    def parts(self, population: str) -> list[Part]:
        """The Brian2 objects holding ``population`` (``motor``, ``interneuron``, ``astrocyte``,
        ``pool``, ``torque``, a population added to the table, or a synapse kind such as
        ``interlimb``), with the files' number of each element."""
        L = self.layout
        if population == "motor":
            if len(self.motor_groups) == 1:
                return [Part(self.motor_groups[0], None, L.motor_per_trial)]
            return [Part(g, L.stage_motor_index(s), L.motor_per_trial)
                    for s, g in enumerate(self.motor_groups)]
        if population == "pool":
            return [Part(self.pool, L.pool_number if L.staged else None, L.pools_per_trial)]
        if population in self.groups:
            return [Part(self.groups[population], None, L.cells_per_trial(population))]
        if population in self.synapse_kinds:
            return [Part(s, None, max(1, len(s) // self.n_trials))
                    for s in self.synapse_kinds[population]]
        raise KeyError(f"no population {population!r} in this network")

    def table(self, population: str, variable: str) -> TrialTable:
        """``population.variable`` as an ``(n_trials, per_trial)`` table in the files' order
        (a live view of Brian2's array where there is one object in that order)."""
        key = ("table", population, variable)
        if key not in self._arrays:
            arrays = [(self.array(p.name, variable), p.number) for p in self.parts(population)]
            self._arrays[key] = TrialTable(arrays, self.n_trials)  # type: ignore[assignment]
        return self._arrays[key]  # type: ignore[return-value]

    # ---- inter-limb weights, as (n_trials, 8, 8) tables in volt
    def interlimb_weights(self) -> np.ndarray:
        n = self.layout.thigh_pools_per_trial
        table = np.zeros((self.n_trials, n, n))
        for name, pairs in self.interlimb_pairs_of.items():
            if len(pairs):
                w = self.array(name, "w").reshape(self.n_trials, -1)
                table[:, pairs[:, 0], pairs[:, 1]] = w
        return table

    def set_interlimb_weights(self, weights: np.ndarray) -> None:
        """Set the inter-limb tables: shape (8, 8) for every trial or (n_trials, 8, 8), in volt."""
        n = self.layout.thigh_pools_per_trial
        w = np.asarray(weights, dtype=float)
        if w.shape == (n, n):
            w = np.broadcast_to(w, (self.n_trials, n, n))
        if w.shape != (self.n_trials, n, n):
            raise InputError(
                f"expected shape ({n}, {n}) or ({self.n_trials}, {n}, {n}), "
                f"got {w.shape}", culprit="inter-limb weights")
        mask = same_limb_mask(self.layout)
        if np.any(w[:, mask] != 0):
            raise InputError("the same-limb 2x2 blocks must be zero", culprit="inter-limb weights")
        for name, pairs in self.interlimb_pairs_of.items():
            if len(pairs):
                self.array(name, "w")[:] = w[:, pairs[:, 0], pairs[:, 1]].ravel()

    # ---- divergence (the rule and the scan: divergence.py)
    def state_arrays(self) -> list[tuple[str, str, np.ndarray, np.ndarray]]:
        """(object, variable, live array, trial of each element) of every float state variable
        that the divergence check scans: the per-synapse state of every synapse object (the
        inter-limb weights and STDP signals), and the differential equations, parameters and
        constants of the pools, astrocytes, torque traces, interneurons and motor neurons. Not
        linked variables (their source is scanned), subexpressions, ``lastspike``, integers or
        booleans. Upstream first (a NaN weight spreads to the pools' input, then to the motor
        neurons), so the first found is the likeliest origin."""
        return [(n, v, a, t) for n, v, a, t, _ in self._state_entries()]

    def _state_entries(self) -> list[tuple[str, str, np.ndarray, np.ndarray, bool]]:
        parts = [p for kind in self.synapse_kinds for p in self.parts(kind)]
        parts += [p for name in self._scan_order() for p in self.parts(name)]
        entries = []
        for part in parts:
            obj = part.obj
            for var, eq in obj.equations.items():
                if eq.type == "subexpression" or "linked" in eq.flags or var == "lastspike":
                    continue
                arr = self.array(part.name, var)
                if arr.dtype.kind != "f" or arr.ndim != 1 or not arr.size:
                    continue
                shared = "shared" in eq.flags
                entries.append((part.name, var, arr, None if shared else part.trials(),
                                "constant" not in eq.flags))
        return entries

    def _scan_order(self) -> list[str]:
        """The populations of this network, upstream first (the table's ``scan_rank``)."""
        built = [r for r in self.layout.rows if r.name in self.groups or r.name == "motor"]
        return [r.name for r in sorted(built, key=lambda r: r.scan_rank)]

    @property
    def scan(self) -> StateScan:
        """The divergence scan of :meth:`state_arrays` (built once)."""
        if self._scan is None:
            self._scan = StateScan(self._state_entries())
        return self._scan

    def first_invalid(self, full: bool = False) -> InvalidState | None:
        """The first invalid state value (NaN, inf or beyond 1e50 in SI units:
        :func:`astrocpg.network.divergence.invalid`), in :meth:`state_arrays` order, or None.
        One reduction per array (about 1 us each), constants on the first call and with
        ``full`` only; the element is located only when one fails."""
        return self.scan.first(full)

    def memo(self, key: tuple[str, str], make: Any) -> Any:
        """``make()`` computed once per network and kept under ``key`` (live arrays and the
        views built from them: what the coupling's per-step and per-session code reads)."""
        if key not in self._arrays:
            self._arrays[key] = make()
        return self._arrays[key]

    def trial_slices(self, part: Part) -> list[Any]:
        """Per trial, the elements of ``part`` in it: a slice where they are contiguous."""
        key = ("trials", part.name)
        if key not in self._arrays:
            trials = part.trials()
            out: list[Any] = []
            for b in range(self.n_trials):
                idx = np.flatnonzero(trials == b)
                contiguous = idx.size and idx[-1] - idx[0] + 1 == idx.size
                out.append(slice(int(idx[0]), int(idx[-1]) + 1) if contiguous else idx)
            self._arrays[key] = out  # type: ignore[assignment]
        return self._arrays[key]  # type: ignore[return-value]



def require_variables(obj: Any, *variables: str, rows: Any = None) -> None:
    """The network (or the coupling) sets or reads ``variables`` of ``obj``: an equation
    string that lacks one is an InputError naming its model (found among the network's
    population ``rows``; None: the built-in rows) and the variable."""
    defined = set(obj.variables) | set(getattr(obj, "equations", {}) or {})  # linked ones too
    for var in variables:
        if var not in defined:
            model = model_of(obj.name, rows) or obj.name
            raise InputError(f"the equations do not define '{var}', which astrocpg sets or "
                             f"reads (keep its line in the {model} equations)", culprit=model)


def same_limb_mask(layout: Layout) -> np.ndarray:
    """Boolean (8, 8): True on the same-limb blocks, which carry no synapse."""
    limb = np.repeat(np.arange(layout.n_legs), len(THIGH_POOLS))
    return limb[:, None] == limb[None, :]


def trial_seeds(seed: int, n_trials: int) -> list[int]:
    """Trial ``b`` of a batch started with ``seed`` has the seed ``seed + b``: its connectivity
    and every draw of its noise (:mod:`astrocpg.network.noise`) come from it, so a trial is the
    same whatever batch it runs in (docs/reproducibility.md, "Seeds and batches")."""
    return [int(seed) + b for b in range(n_trials)]
