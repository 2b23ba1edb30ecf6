"""Build the CPG (locomotion units, interneurons, astrocytes, torque traces, inter-limb
projection) for ``n_trials`` independent copies from a :class:`~astrocpg.models.ModelSet`.

Nothing here is biophysics: every equation and constant comes from ``models``. This module
decides which element connects to which, and schedules the few objects whose order within a
1 ms step matters (see :func:`build_cpg`).
"""

from __future__ import annotations

import contextlib
import re
from dataclasses import dataclass, field
from typing import Any, Iterable, Iterator, Sequence

import brian2
import numpy as np
from brian2 import Network, NeuronGroup, Synapses, linked_var, ms, second

from .._quiet_brian import close_debug_files, mend_interrupt_handler
from ..errors import InputError, did_you_mean
from ..models import DEFAULT_MODELS, ModelSet
from ..models.base import BrianModel, NeuronModel, SynapseModel, brian_error_line
from ..models.names import why_reserved
from .codegen import DEFAULT as DEFAULT_CODEGEN
from .codegen import use_codegen
from . import populations as populations_
from .divergence import MODEL_OF, InvalidState, StateScan, leave_to_the_scan, model_of
from .delays import limb_stages
from .noise import Rewriter, trial_major
from .layout import INTERNEURONS, LEGS, POOLS, THIGH_POOLS, Layout
from .trial_tables import Part, TrialTable
from .runlock import exclusive

# Brian2's settings (target, warning filters) are applied only while the framework builds and
# runs, by RUN_LOCK (brian_prefs.py), never at import: a user's own Brian2 models are untouched.
# Brian2 opened its debug log and script copy at import; if it was imported before astrocpg
# (so astrocpg._quiet_brian did not wrap that import), close and delete them now. Our errors
# are one line naming the culprit; no process should leave Brian2's files behind. Its Ctrl-C
# handler is mended the same way (a process started with SIGINT ignored).
close_debug_files(switch_off=False)
mend_interrupt_handler()


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
            _require(obj, variable)
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

    def reset_trial(self, trial: int, keep: tuple[str, ...] = ("astrocyte",)) -> None:
        """Reset one trial's state to the start of a session: every state variable of the
        groups not in ``keep`` (astrocytes keep theirs: docs/model.md) and every dynamic variable of the
        inter-limb synapses except the weights. Array writes only (no code generation)."""
        for name in ("motor", *self.groups, "interlimb"):
            if name in keep or (name == "interlimb" and name not in self.synapse_kinds):
                continue
            for part in self.parts(name):
                where = self._trial_slices(part)[trial]
                for var, arr in self._reset_arrays(part.name, part.obj):
                    arr[where] = self._initial(name, var)

    def persistent_state(self, trial: int,
                         keep: tuple[str, ...] = ("astrocyte",)) -> dict[str, np.ndarray]:
        """What a session reset (:meth:`reset_trial`) leaves of ``trial``'s state: every
        dynamic variable of the kept populations and of the inter-limb synapses (their
        weights), as ``{"population.variable": values}`` in the files' order. With the seed,
        the step and the reset values, it is all a session starts from (a replay)."""
        out: dict[str, list[np.ndarray]] = {}
        for name, part in self._persistent_parts(keep):
            where = self._trial_slices(part)[trial]
            for var, arr in self._persistent_arrays(part.name, part.obj):
                out.setdefault(f"{name}.{var}", []).append(np.array(arr[where], dtype=float))
        return {k: np.concatenate(v) for k, v in out.items()}

    def set_persistent_state(self, trial: int, state: dict[str, np.ndarray],
                             shift_s: float = 0.0,
                             keep: tuple[str, ...] = ("astrocyte",)) -> None:
        """Set what :meth:`persistent_state` gave (``shift_s``: subtracted from the spike
        times ``lastspike``, for a network whose clock starts that much later)."""
        taken: dict[str, int] = {}
        for name, part in self._persistent_parts(keep):
            where = self._trial_slices(part)[trial]
            for var, arr in self._persistent_arrays(part.name, part.obj):
                key = f"{name}.{var}"
                if key not in state:
                    raise InputError(f"the recorded state lacks {key}",
                                     culprit="session start")
                n = len(arr[where])
                values = np.asarray(state[key], dtype=float)[taken.get(key, 0):][:n]
                if len(values) != n:
                    raise InputError(f"{key} holds {len(state[key])} values, not those of "
                                     f"this network", culprit="session start")
                taken[key] = taken.get(key, 0) + n
                arr[where] = values - shift_s if var == "lastspike" else values

    def _persistent_parts(self, keep: tuple[str, ...]) -> list[tuple[str, Part]]:
        names = [*keep, *(("interlimb",) if "interlimb" in self.synapse_kinds else ())]
        return [(name, part) for name in names for part in self.parts(name)]

    def _persistent_arrays(self, name: str, obj: Any) -> list[tuple[str, np.ndarray]]:
        out = list(self._reset_arrays(name, obj))
        if "w" in obj.variables and all(v != "w" for v, _ in out):
            out.append(("w", self.array(name, "w")))
        return out

    def _trial_slices(self, part: Part) -> list[Any]:
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

    def _reset_arrays(self, name: str, obj: Any) -> list[tuple[str, np.ndarray]]:
        """(variable, live array) of what a session reset sets back: the model's differential
        equations and non-constant parameters (not linked ones, not the weights ``w``)."""
        key = ("reset", name)
        if key not in self._arrays:
            out = []
            for var, eq in obj.equations.items():
                if eq.type == "subexpression" or var == "w":
                    continue
                if {"constant", "linked", "shared"} & set(eq.flags):
                    continue
                out.append((var, self.array(name, var)))
            for var in ("lastspike", "not_refractory"):
                if var in obj.variables and all(v != var for v, _ in out):
                    out.append((var, self.array(name, var)))
            self._arrays[key] = out  # type: ignore[assignment]
        return self._arrays[key]  # type: ignore[return-value]

    def _initial(self, group: str, var: str) -> Any:
        if var == "lastspike":
            return -1e4  # Brian2's "never spiked"
        if var == "not_refractory":
            return True
        model = (self.models.interlimb_synapse if group == "interlimb"
                 else self.layout.row(group).model_in(self.models))
        value = model.initial_values.get(var, 0.0)
        if isinstance(value, str):
            raise InputError("a session reset needs a number, not an expression",
                             culprit=f"{model.name}.initial_values.{var}")
        return float(np.asarray(value))


def _require(obj: Any, *variables: str) -> None:
    """The network (or the coupling) sets or reads ``variables`` of ``obj``: an equation
    string that lacks one is an InputError naming its model and the variable."""
    defined = set(obj.variables) | set(getattr(obj, "equations", {}) or {})  # linked ones too
    for var in variables:
        if var not in defined:
            model = model_of(obj.name) or obj.name
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


@contextlib.contextmanager
def _blame(culprit: str) -> Iterator[None]:
    """Turn any error of Brian2 inside the block into one InputError line naming ``culprit``
    (a model, or "network wiring"); an InputError passes as it is."""
    try:
        yield
    except InputError:
        raise
    except Exception as e:
        raise InputError(f"{brian_error_line(e)}", culprit=culprit) from None


@dataclass
class Wiring:
    """What one :func:`build_cpg` builds, step by step: the layout, the models, the groups by
    population (``groups``; the motor neurons are ``motors``, one group per stage of limbs) and
    the synapse objects (``synapses`` by name, ``kinds`` by kind). An added population's wiring
    step (:class:`~astrocpg.network.populations.Population` ``wire``) receives it and connects
    its group with :meth:`synapses` and :meth:`add`."""

    layout: Layout
    models: ModelSet
    dt: Any
    codeobj_class: Any
    stages: tuple[tuple[int, ...], ...]
    #: the one clock of every object of the step: with one clock Brian2 runs its single-clock
    #: loop (a clock per object made it compare them all at every step, ~150 us at 20 trials)
    clock: Any = None
    objects: list[Any] = field(default_factory=list)
    groups: dict[str, NeuronGroup] = field(default_factory=dict)
    motors: list[NeuronGroup] = field(default_factory=list)
    motor_number: list[np.ndarray] = field(default_factory=list)
    stage_pools: list[Any] = field(default_factory=list)
    syn: dict[str, Synapses] = field(default_factory=dict)
    kinds: dict[str, list[Synapses]] = field(default_factory=dict)
    learning: list[Any] = field(default_factory=list)
    pairs: np.ndarray = field(default_factory=lambda: np.zeros((0, 2), dtype=np.intp))
    pairs_of: dict[str, np.ndarray] = field(default_factory=dict)
    #: the seed of each trial (:func:`trial_seeds`): the key of its noise streams
    seeds: list[int] = field(default_factory=list)
    #: added to Brian2's step in every draw (a replay starts its noise at a recorded step)
    noise_offset: np.ndarray = field(default_factory=lambda: np.zeros(1, dtype=np.int64))
    #: per synapse object: its on_step code with the draws rewritten (:meth:`synapses`)
    on_step: dict[str, str | None] = field(default_factory=dict)

    @property
    def n_stages(self) -> int:
        return len(self.stages)

    def suffix(self, stage: int) -> str:
        """The name suffix of a stage's objects: none with one stage, else its limbs."""
        legs = self.layout.legs
        return "" if self.n_stages == 1 else "_" + "_".join(legs[i] for i in self.stages[stage])

    def stage_start(self, stage: int) -> int:
        """The first pool of the stage's pools in the pool group (0 with one stage)."""
        return self.layout.stage_pool_range(stage)[0] if self.n_stages > 1 else 0

    def group(self, model: NeuronModel, n: int, name: str, *, population: str | None = None,
              numbers: np.ndarray | None = None,
              cells_per_trial: int | None = None) -> NeuronGroup:
        """A NeuronGroup of ``n`` cells of ``model``, added to the network. By default its cells
        are ``n / n_trials`` per trial, trial-major; a group holding a part of a population
        (one stage's motor neurons) gives the ``population``, the trial-major ``numbers`` of
        its cells and the population's ``cells_per_trial``. Each draw of its code comes from
        its cell's own stream (:mod:`astrocpg.network.noise`)."""
        if numbers is None:
            numbers, cells_per_trial = np.arange(n), n // self.layout.n_trials
        draws = Rewriter(population or name)
        code = {role: draws(getattr(model, role)) for role in
                ("equations", "threshold", "reset", "refractory")}
        initial = {var: draws(value) for var, value in model.initial_values.items()}
        namespace = model.parameters.namespace() | self._draws(draws, numbers, cells_per_trial)
        with _blame(model.name):
            # model.method is a scheme's registered name (e.g. "input_then_decay")
            g = NeuronGroup(
                n, code["equations"], threshold=code["threshold"], reset=code["reset"],
                refractory=code["refractory"] if code["refractory"] else False,
                method=model.method, namespace=namespace, name=name,
                clock=self.clock, codeobj_class=self.codeobj_class,
            )
            for var, value in initial.items():
                setattr(g, var, value)
        check_parameters_reach(g, model)
        self.objects.append(g)
        return g

    def _draws(self, draws: Rewriter, numbers: np.ndarray,
               cells_per_trial: int | None) -> dict[str, Any]:
        """The draw functions of an object's rewritten code, by name (none without draws)."""
        if not draws.sites:
            return {}
        B = self.layout.n_trials
        if not cells_per_trial or (len(numbers) and int(numbers.max()) >= cells_per_trial * B):
            raise InputError("its elements do not split evenly into the trials, so its draws "
                             "(rand, randn) have no stream per trial", culprit="network wiring")
        seed, cell = trial_major(numbers, cells_per_trial, self.seeds)
        return draws.bind(seed, cell, cells_per_trial, self.noise_offset).functions

    def synapses(self, model: SynapseModel, source: Any, target: Any, name: str, i: Any,
                 j: Any) -> Synapses:
        """Synapses of ``model`` from cells ``i`` of ``source`` to cells ``j`` of ``target``,
        added to the network (not to a kind: :meth:`add`). The pairs are given trial by trial,
        the same number per trial; the draws of its code are numbered by synapse within its
        trial (:mod:`astrocpg.network.noise`)."""
        draws = Rewriter(name)
        code = {role: draws(getattr(model, role)) for role in ("model", "on_pre", "on_step")}
        initial = {var: draws(value) for var, value in model.initial_values.items()}
        weight = draws(model.weight)
        n, B = len(i), self.layout.n_trials
        namespace = model.parameters.namespace() | self._draws(
            draws, np.arange(n), n // B if n % B == 0 else None)
        self.on_step[name] = code["on_step"]
        with _blame(model.name):
            s = Synapses(source, target, model=code["model"], on_pre=code["on_pre"],
                         method=model.method, namespace=namespace,
                         name=name, clock=self.clock, codeobj_class=self.codeobj_class)
            s.connect(i=np.asarray(i, dtype=np.int32), j=np.asarray(j, dtype=np.int32))
            for var, value in initial.items():
                setattr(s, var, value)
            if weight:
                s.w = weight
        check_parameters_reach(s, model)
        self.objects.append(s)
        return s

    def add(self, kind: str, s: Synapses) -> Synapses:
        """File synapse object ``s`` under its name and its ``kind`` (CPG.parts(kind))."""
        self.syn[s.name] = s
        self.kinds.setdefault(kind, []).append(s)
        return s


def _build_groups(w: Wiring) -> None:
    """One group per population of the table, in its order (the motor neurons: one per stage
    of limbs); then each stage's pools, one contiguous block of the pool group."""
    L, B = w.layout, w.layout.n_trials
    for row in L.rows:
        model = row.model_in(w.models)
        if row.name == "motor":
            # the trial-major motor-neuron number of each neuron of each stage's group
            w.motor_number = [np.arange(B * L.motor_per_trial)] if w.n_stages == 1 else \
                [L.stage_motor_index(s) for s in range(w.n_stages)]
            w.motors = [w.group(model, B * len(m) * len(POOLS) * L.pool_size,
                                "motor" + w.suffix(s), population="motor",
                                numbers=w.motor_number[s], cells_per_trial=L.motor_per_trial)
                        for s, m in enumerate(w.stages)]
        else:
            w.groups[row.name] = w.group(model, B * L.cells_per_trial(row.name), row.name)
    pool = w.groups["pool"]
    w.stage_pools = [pool] if w.n_stages == 1 else \
        [pool[slice(*L.stage_pool_range(s))] for s in range(w.n_stages)]


def _source_cells(w: Wiring, population: str, numbers: np.ndarray) -> list[tuple[Any, np.ndarray,
                                                                             np.ndarray]]:
    """(group, where in ``numbers``, index in the group) of cells of ``population`` given by
    their trial-major numbers: the motor neurons stage by stage, the pools in the pool group's
    order, any other population's group as it is."""
    L = w.layout
    if population == "motor":
        stage, local = L.motor_local(numbers)
        return [(m, stage == s, local[stage == s]) for s, m in enumerate(w.motors)]
    if population == "pool":
        return [(w.groups["pool"], np.ones(len(numbers), dtype=bool),
                 np.argsort(L.pool_number)[numbers])]
    return [(w.groups[population], np.ones(len(numbers), dtype=bool), numbers)]


def _wire_projection(w: Wiring, source: str, target: str, synapse: str, match: str) -> None:
    """The synapses of an input or output declared in an added population's row
    (:class:`~astrocpg.network.populations.Input`, ``Output``): within each trial and limb,
    every target cell from the source cells with its label (``match = "label"``) or from every
    source cell of the limb (``"limb"``); one object per pair of source and target groups
    (the motor neurons' stages), named ``SOURCE_to_TARGET`` (plus the stage's suffix)."""
    L = w.layout
    src_labels = L.row(source).labels(L.pool_size)
    tgt_labels = L.row(target).labels(L.pool_size)
    n_src, n_tgt = L.cells_per_trial(source), L.cells_per_trial(target)
    i, j = [], []
    for b in range(L.n_trials):
        for leg in range(L.n_legs):
            for t, label in enumerate(tgt_labels):
                s = [k for k, x in enumerate(src_labels) if match == "limb" or x == label]
                i += [b * n_src + leg * len(src_labels) + k for k in s]
                j += [b * n_tgt + leg * len(tgt_labels) + t] * len(s)
    added = target if L.row(source).built_in else source
    if not i:
        raise InputError(f"connects no cell: no label of {source} is one of {target}'s",
                         culprit=f"population {added}")
    model = getattr(w.models, synapse)
    kind = f"{source}_to_{target}"
    i_, j_ = np.asarray(i, dtype=np.intp), np.asarray(j, dtype=np.intp)
    for s, (pre, here, pre_local) in enumerate(_source_cells(w, source, i_)):
        for t, (post, there, post_local) in enumerate(_source_cells(w, target, j_[here])):
            stage = s if source == "motor" else t if target == "motor" else None
            name = kind + (w.suffix(stage) if stage is not None else "")
            w.add(kind, w.synapses(model, pre, post, name, pre_local[there], post_local))


def _place_motor_neurons(w: Wiring, seed: int) -> None:
    """Anatomy: neuron positions in the unit cube, drawn per trial from the trial's own seed."""
    L = w.layout
    positions = np.concatenate([
        np.random.default_rng(s).uniform(0.0, 1.0, size=(L.motor_per_trial, 3))
        for s in trial_seeds(seed, L.n_trials)
    ])
    # a motor-neuron model that declares ``leg`` gets each neuron's limb, numbered in LEGS'
    # order whatever limbs the network holds (a per-limb parameter reads it: docs/model-files.md)
    per_leg = len(POOLS) * L.pool_size
    leg_number = np.array([LEGS.index(leg) for leg in L.legs], dtype=np.intp)
    for motor, number in zip(w.motors, w.motor_number):
        _require(motor, "x_position", "y_position", "z_position")
        motor.x_position = positions[number, 0]
        motor.y_position = positions[number, 1]
        motor.z_position = positions[number, 2]
        if "leg" in motor.variables:
            motor.leg = leg_number[(np.asarray(number) % L.motor_per_trial) // per_leg]


def _link_pool_variables(w: Wiring) -> None:
    """Pool-level inputs reach every neuron of the pool; the astrocytes and the torque traces
    read their pools' counts; each torque trace gets its joint's current."""
    L, B = w.layout, w.layout.n_trials
    pool, astrocyte, torque = w.groups["pool"], w.groups["astrocyte"], w.groups["torque"]
    pool_of_motor = L.pool_of_motor_neuron
    with _blame("network wiring"):
        # every linked variable of the motor neuron model is a pool variable of the same name
        for motor, number in zip(w.motors, w.motor_number):
            for var, eq in motor.equations.items():
                if "linked" in eq.flags:
                    if var not in pool.variables:
                        raise InputError(f"linked variable '{var}' is not a variable "
                                         f"of the pool model", culprit="motor_neuron")
                    setattr(motor, var, linked_var(pool, var, index=pool_of_motor[number]))
        _require(pool, "n")
        _require(astrocyte, "n_pool")
        _require(torque, "n_extensor", "n_flexor", "I_joint")
        astrocyte.n_pool = linked_var(pool, "n", index=L.pool_of_astrocyte)
        joints = [(b, leg, jt) for b in range(B) for leg in range(L.n_legs)
                  for jt in ("thigh", "calf")]
        torque.n_extensor = linked_var(
            pool, "n", index=np.array([L.pool(b, leg, f"{jt}_extensor") for b, leg, jt in joints]))
        torque.n_flexor = linked_var(
            pool, "n", index=np.array([L.pool(b, leg, f"{jt}_flexor") for b, leg, jt in joints]))
        # I_thigh or I_calf (SI, newton*meter), joint by joint
        per_joint = {"thigh": w.models.value("I_thigh"), "calf": w.models.value("I_calf")}
        torque.I_joint_ = np.array([per_joint[jt] for _, _, jt in joints])


def _wire_pool_activity(w: Wiring) -> None:
    """Each motor neuron's spikes counted by its pool, stage by stage."""
    pool_of_motor = w.layout.pool_of_motor_neuron
    for s, motor in enumerate(w.motors):
        w.add("pool_activity", w.synapses(
            w.models.pool_activity, motor, w.stage_pools[s], "pool_activity" + w.suffix(s),
            np.arange(len(motor)), pool_of_motor[w.motor_number[s]] - w.stage_start(s)))


def _wire_intra_pool(w: Wiring) -> None:
    """Intra-pool: all ordered pairs of distinct neurons of a pool."""
    n = w.layout.pool_size
    a, b_ = np.meshgrid(np.arange(n), np.arange(n), indexing="ij")
    off = a != b_
    base_i, base_j = a[off], b_[off]
    for s, motor in enumerate(w.motors):
        starts = np.arange(len(motor) // n) * n
        w.add("intra_pool", w.synapses(w.models.intra_pool_synapse, motor, motor,
                                       "intra_pool" + w.suffix(s),
                                       (starts[:, None] + base_i).ravel(),
                                       (starts[:, None] + base_j).ravel()))


def _wire_interneurons(w: Wiring) -> None:
    """Interneurons: each driven by every neuron of one pool, inhibiting every neuron of
    another (:data:`~astrocpg.network.layout.INTERNEURONS`)."""
    L, interneuron = w.layout, w.groups["interneuron"]
    pre_i, pre_j, post_i, post_j = [], [], [], []
    for b in range(L.n_trials):
        for leg in range(L.n_legs):
            for name, _, source, target in INTERNEURONS:
                k = L.interneuron(b, leg, name)
                src = L.motor_neurons(b, leg, source)
                tgt = L.motor_neurons(b, leg, target)
                pre_i.append(src); pre_j.append(np.full(len(src), k))
                post_i.append(np.full(len(tgt), k)); post_j.append(tgt)
    src_stage, src_local = L.motor_local(np.concatenate(pre_i))
    tgt_stage, tgt_local = L.motor_local(np.concatenate(post_j))
    pre_j_, post_i_ = np.concatenate(pre_j), np.concatenate(post_i)
    for s, motor in enumerate(w.motors):
        here, there = src_stage == s, tgt_stage == s
        w.add("pool_to_interneuron", w.synapses(
            w.models.pool_to_interneuron, motor, interneuron,
            "pool_to_interneuron" + w.suffix(s), src_local[here], pre_j_[here]))
        w.add("interneuron_to_pool", w.synapses(
            w.models.interneuron_to_pool, interneuron, motor,
            "interneuron_to_pool" + w.suffix(s), post_i_[there], tgt_local[there]))


def _wire_interlimb(w: Wiring) -> None:
    """Inter-limb: thigh pool x -> thigh pool y of another limb, one weight per pair and trial;
    one object per stage of target limbs, each reading its target pool's astrocyte."""
    L, B = w.layout, w.layout.n_trials
    pool, astrocyte = w.groups["pool"], w.groups["astrocyte"]
    model = w.models.interlimb_synapse
    n_thigh = L.thigh_pools_per_trial
    w.pairs = pairs = np.argwhere(~same_limb_mask(L))  # (row, col) in the per-trial table
    if not len(pairs):
        return

    def thigh_pool(b: int, x: np.ndarray) -> np.ndarray:
        return np.array([L.pool(b, int(t) // 2, THIGH_POOLS[int(t) % 2]) for t in x],
                        dtype=np.intp)

    for s in range(w.n_stages):
        these = pairs[np.isin(pairs[:, 1] // len(THIGH_POOLS), w.stages[s])]
        start = w.stage_start(s)
        name = "interlimb" + w.suffix(s)
        inter = w.add("interlimb", w.synapses(
            model, pool, w.stage_pools[s], name,
            np.concatenate([thigh_pool(b, these[:, 0]) for b in range(B)]),
            np.concatenate([thigh_pool(b, these[:, 1]) - start for b in range(B)])))
        w.pairs_of[name] = these
        with _blame("interlimb_synapse"):
            # the astrocyte of each synapse's target pool (the table's column)
            if "astrocyte_index" in inter.variables:
                inter.astrocyte_index = np.concatenate([b * n_thigh + these[:, 1]
                                                        for b in range(B)])
            for var, eq in inter.equations.items():
                if "linked" in eq.flags:
                    setattr(inter, var, linked_var(astrocyte, var, index="astrocyte_index"))
            if getattr(inter, "state_updater", None) is not None:  # STDP: after the counts
                inter.state_updater.when, inter.state_updater.order = "after_thresholds", 2
            if w.on_step.get(name):  # after the robot moved, reward known
                w.learning.append(inter.run_regularly(
                    w.on_step[name], clock=w.clock, when="end", order=10,
                    name="interlimb_learning" + w.suffix(s)))


#: The built-in wiring steps, in the order they run (the order of the objects, and so of
#: Brian2's random draws for their initial values, is part of the seeded behaviour).
WIRING_STEPS = (_wire_pool_activity, _wire_intra_pool, _wire_interneurons, _wire_interlimb)


@exclusive  # Brian2's global seed and objects: one build or run at a time (runlock.py)
def build_cpg(
    models: ModelSet | None = None,
    *,
    n_trials: int = 1,
    seed: int = 0,
    legs: Iterable[str] = LEGS,
    dt: Any = 1 * ms,
    interlimb_weights: np.ndarray | None = None,
    codegen: str | None = None,
    populations: Sequence[populations_.Population] | None = None,
) -> CPG:
    """Build ``n_trials`` independent copies of the CPG: one group per row of the population
    table (:mod:`astrocpg.network.populations`: the built-in rows and ``populations``, the rows
    added for this build; None: this process's table, rows added with ``register`` included),
    then the wiring steps (:data:`WIRING_STEPS`, then each added row's inputs, outputs and
    ``wire``). An added row's model joins the model set (``CPG.models``) unless the set holds
    it already (composed with ``model_set(..., added=...)``, which may set its values).

    Order within one step (Brian2 schedule): motor neurons, interneurons and astrocytes integrate
    (``groups``), spike (``thresholds``), synapses deliver (``synapses``), neurons reset. Right
    after the thresholds, each pool counts its spikes (``pool_activity``) and the torque traces
    take them in, so the torque of step n holds the spikes of step n (docs/model.md: torque from this
    step's spikes drives this step's physics). The inter-limb input of the pools' spikes reaches
    the target neurons at the next step, like every other synapse.

    ``models``: the model set (None: the built-in models, :data:`~astrocpg.models.DEFAULT_MODELS`).
    ``codegen``: Brian2's target, "numpy" or "cython" (default: $ASTROCPG_CODEGEN, else numpy;
    see :mod:`astrocpg.network.codegen`). It is stored as ``CPG.codegen``.
    """
    models = DEFAULT_MODELS if models is None else models
    legs = tuple(legs)
    for leg in legs:
        if leg not in LEGS:
            raise InputError(f"unknown leg '{leg}'{did_you_mean(leg, LEGS)} (legs are "
                             f"{', '.join(LEGS)})", culprit="build_cpg")
    if int(n_trials) < 1:
        raise InputError(f"n_trials must be at least 1, got {n_trials}", culprit="build_cpg")
    rows = populations_.with_added(populations)  # the rows it is built from, kept
    models = _with_row_models(models, rows)
    pool_size = int(models.value("pool_size"))
    stages = limb_stages(models, legs, dt)  # 0 ms inter-limb delays: limbs one after another
    layout = Layout(n_trials=int(n_trials), pool_size=pool_size, legs=legs,
                    stages=stages if len(stages) > 1 else None, populations=rows)
    # numpy, or cython (opt-in): ``codegen``, else $ASTROCPG_CODEGEN. Every group and synapse
    # is pinned to it, so a later change of Brian2's preference does not move this network.
    codegen = use_codegen(codegen)
    codeobj_class = brian2.CythonCodeObject if codegen == "cython" else brian2.NumpyCodeObject
    # The network's draws do not use Brian2's generator (noise.py); seeded all the same for
    # code that a user's own wiring step adds without going through Wiring.
    brian2.seed(int(seed))

    w = Wiring(layout=layout, models=models, dt=dt, codeobj_class=codeobj_class,
               stages=layout.limb_stages, seeds=trial_seeds(seed, layout.n_trials),
               clock=brian2.Clock(dt=dt, name="cpg_clock*"))
    _build_groups(w)
    _place_motor_neurons(w, seed)
    _link_pool_variables(w)
    for step in WIRING_STEPS:
        step(w)
    for row in layout.rows:
        if not row.built_in:
            with _blame(f"population {row.name}"):
                for given in row.inputs:
                    _wire_projection(w, given.source, row.name, given.synapse, given.match)
                for out in row.outputs:
                    _wire_projection(w, row.name, out.target, out.synapse, out.match)
                if row.wire is not None:
                    row.wire(w)
    w.objects.extend(w.learning)

    g = w.groups
    _schedule(w.motors, w.kinds, g["pool"], g["torque"], g["interneuron"], g["astrocyte"])
    # the divergence scan decides for these, in one line (Brian2's check: a raw warning)
    leave_to_the_scan([*w.objects, *w.stage_pools])
    net = Network(*w.objects)
    cpg = CPG(layout=layout, models=models, seed=int(seed), dt=dt, net=net,
              motor_groups=tuple(w.motors), interneuron=g["interneuron"],
              astrocyte=g["astrocyte"], pool=g["pool"], torque=g["torque"], synapses=w.syn,
              interlimb_pairs=w.pairs, codegen=codegen,
              synapse_kinds={k: tuple(v) for k, v in w.kinds.items()},
              interlimb_pairs_of=w.pairs_of, groups=dict(g), noise_offset=w.noise_offset)
    if interlimb_weights is not None:
        cpg.set_interlimb_weights(interlimb_weights)
    return cpg


def _with_row_models(models: ModelSet, rows: Sequence[populations_.Population]) -> ModelSet:
    """``models`` with the model of every added row that it lacks (``ModelSet.added``)."""
    missing = [r.model for r in rows if not isinstance(r.model, str)
               and r.model.name not in dict(models.items())]
    if not missing:
        return models
    try:
        return models.with_added(*missing)
    except InputError as e:
        raise InputError(e.raw_message, culprit=f"population model {e.raw_culprit}") from None


def _schedule(motors: list[NeuronGroup], kinds: dict[str, list[Synapses]], pool: NeuronGroup,
              torque: NeuronGroup, interneuron: NeuronGroup, astrocyte: NeuronGroup) -> None:
    """Order the objects within a step where the order matters.

    Always: the pools count this step's spikes (``pool_activity``) before the pool traces and
    torque traces take them in, and the STDP signals after those (``after_thresholds``).

    One stage of limbs: every group integrates in ``groups``, spikes in ``thresholds``; the
    inter-limb input is summed at the start of the step from the previous step's counts (1 ms).

    Stages (0 ms delays): astrocytes and interneurons integrate first; then, stage by stage, the
    inter-limb input into the stage's pools is summed from the pools' current counts (this
    step's for the stages before, the previous step's for this and later ones), the stage's motor
    neurons integrate and spike, and their pools count the spikes, all in ``groups``. Synapses,
    resets and everything after are as with one stage.
    """
    for g in (torque, pool):
        if getattr(g, "state_updater", None) is not None:
            g.state_updater.when, g.state_updater.order = "after_thresholds", 1
    if len(motors) == 1:
        for s in kinds.get("pool_activity", ()):
            for updater in s.summed_updaters.values():
                updater.when, updater.order = "after_thresholds", 0
        return
    for g in (astrocyte, interneuron):
        if getattr(g, "state_updater", None) is not None:
            g.state_updater.when, g.state_updater.order = "groups", -10
    for s, motor in enumerate(motors):
        base = 10 * s
        for syn_ in kinds.get("interlimb", ())[s:s + 1]:
            for updater in syn_.summed_updaters.values():
                updater.when, updater.order = "groups", base + 1
        motor.state_updater.when, motor.state_updater.order = "groups", base + 2
        for thresholder in motor.thresholder.values():
            thresholder.when, thresholder.order = "groups", base + 3
        for updater in kinds["pool_activity"][s].summed_updaters.values():
            updater.when, updater.order = "groups", base + 4


def check_parameters_reach(obj: Any, model: BrianModel) -> None:
    """Refuse a network in which a parameter of ``model`` is not what ``obj`` (the Brian2 group
    or projection built from it) reads by that name, so that a value set with ``--set`` and
    recorded in a manifest is the value the network uses.

    Brian2 resolves a name in a group's code from the group's own variables first (for a
    projection, those of its source and target groups too), then from its constants, units and
    functions, and only then from the group's namespace, which holds the model's parameters.
    The model's own name check (:mod:`astrocpg.models.names`) refuses most shadowing names when
    the model is made; what only the built network knows (a synapse parameter named like a
    variable of its target group) is caught here."""
    namespace = getattr(obj, "namespace", None) or {}
    variables = getattr(obj, "variables", {})
    for name, parameter in model.parameters.items():
        if name in variables:
            why = f"'{name}' is also a variable of the Brian2 object {obj.name}"
        else:
            why = why_reserved(name)
        if why is None and namespace.get(name) is not parameter.value:
            why = f"the Brian2 object {obj.name} was not given it"
        if why is not None:
            raise InputError(f"is not the value the network reads: {why}",
                             culprit=f"{model.name}.{name}")


def built_in_models(models: ModelSet) -> bool:
    """Is every Brian2 model of the CPG the built-in one (the same object as in
    ``DEFAULT_MODELS``)? Such a network needs no :func:`check_runs`: the test suite builds and
    runs it, and a check would generate all its code twice (about 0.4 s of every command)."""
    if models.added or any(not r.built_in for r in populations_.table()):  # an added one
        return False
    return all(getattr(models, name) is getattr(DEFAULT_MODELS, name)
               for name in dict.fromkeys(MODEL_OF.values()))


@exclusive
def check_runs(cpg: CPG) -> None:
    """Prepare every object once (units, names, code generation), turning Brian2's errors into
    one line that names the model at fault. Costs about as much as the start of a run, so a
    network of the built-in models (:func:`built_in_models`) is not checked: the run itself
    generates its code once, and the test suite runs those models."""
    if built_in_models(cpg.models) and all(r.built_in for r in cpg.layout.rows):
        return
    try:
        cpg.net.run(0 * second, namespace={})
    except Exception as e:
        culprit = "network"
        err: BaseException | None = e
        while err is not None:
            text = str(err)
            found = re.search(r"object named '([A-Za-z0-9_]+)", text)
            if found and model_of(found.group(1)):
                culprit = model_of(found.group(1)) or culprit
            if culprit != "network":
                break
            err = err.__cause__
        raise InputError(f"{_root_message(e)}", culprit=culprit) from None


def _root_message(e: BaseException) -> str:
    chain = []
    err: BaseException | None = e
    while err is not None:
        chain.append(err)
        err = err.__cause__
    # the innermost error names the expression; its first line is enough
    for err in reversed(chain):
        text = " ".join(str(err).split())
        if text:
            return text[:300]
    return type(e).__name__
