"""Build the CPG (locomotion units, interneurons, astrocytes, torque traces, inter-limb
projection) for ``n_trials`` independent copies from a :class:`~astrocpg.models.ModelSet`.

Nothing here is biophysics: every equation and constant comes from ``models``. This module
decides which element connects to which, and schedules the few objects whose order within a
1 ms step matters (see :func:`build_cpg`).
"""

from __future__ import annotations

import math
import re
import warnings
from dataclasses import dataclass, field
from typing import Any, Iterable

import brian2
import numpy as np
from brian2 import Network, NeuronGroup, Synapses, linked_var, ms, second

from .._quiet_brian import close_debug_files, mend_interrupt_handler
from ..errors import InputError
from ..models import DEFAULT_MODELS, ModelSet
from ..models.base import BrianModel, NeuronModel, SynapseModel, brian_error_line
from ..models.names import why_reserved
from .codegen import DEFAULT as DEFAULT_CODEGEN
from .codegen import initial_target, use_codegen
from .divergence import MODEL_OF, InvalidState, StateScan, leave_to_the_scan, model_of
from .delays import limb_stages
from .layout import INTERNEURONS, LEGS, POOLS, THIGH_POOLS, Layout
from .parts import Part, TrialTable
from .runlock import exclusive

brian2.prefs.codegen.target = initial_target()  # --codegen / $ASTROCPG_CODEGEN: see codegen.py
brian2.prefs.codegen.loop_invariant_optimisations = True
# Brian2 logs a debug file for every exception it sees; our errors are user-facing.
brian2.prefs.logging.delete_log_on_exit = True


# Brian2 opened its debug log and script copy at import; if it was imported before astrocpg
# (so astrocpg._quiet_brian did not wrap that import), close and delete them now. Our errors
# are one line naming the culprit; no process should leave Brian2's files behind. Its Ctrl-C
# handler is mended the same way (a process started with SIGINT ignored).
close_debug_files()
mend_interrupt_handler()
# A network that failed validation is dropped on purpose; don't warn about its objects.
brian2.BrianLogger.suppress_name("unused_brian_object")
# An invalid state (NaN, inf, beyond 1e50) is reported once, in one line, by the divergence check
# (CPG.first_invalid, errors.Diverged); numpy's floating-point warnings from Brian2's generated code (exec'd source,
# module "<string>") would only repeat it on stderr, several lines per step.
warnings.filterwarnings("ignore", category=RuntimeWarning, module=r"<string>$")


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
    _arrays: dict[tuple[str, str], np.ndarray] = field(default_factory=dict)
    _scan: StateScan | None = None

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
        if name in ("interneuron", "astrocyte", "pool", "torque"):
            return getattr(self, name)
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
        ``pool``, ``torque`` or a synapse kind such as ``interlimb``), with the files' number of
        each element."""
        L = self.layout
        if population == "motor":
            if len(self.motor_groups) == 1:
                return [Part(self.motor_groups[0], None, L.motor_per_trial)]
            return [Part(g, L.stage_motor_index(s), L.motor_per_trial)
                    for s, g in enumerate(self.motor_groups)]
        if population == "pool":
            return [Part(self.pool, L.pool_number if L.staged else None, L.pools_per_trial)]
        per_trial = {"interneuron": L.interneurons_per_trial,
                     "astrocyte": L.thigh_pools_per_trial, "torque": L.joints_per_trial}
        if population in per_trial:
            return [Part(getattr(self, population), None, per_trial[population])]
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
        parts += [p for name in ("pool", "astrocyte", "torque", "interneuron", "motor")
                  for p in self.parts(name)]
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

    #: The former name of :meth:`first_invalid` (NaN and inf only were invalid then).
    first_nonfinite = first_invalid

    def reset_trial(self, trial: int, keep: tuple[str, ...] = ("astrocyte",)) -> None:
        """Reset one trial's state to the start of a session: every state variable of the
        groups not in ``keep`` (astrocytes keep theirs: docs/model.md) and every dynamic variable of the
        inter-limb synapses except the weights. Array writes only (no code generation)."""
        for name in ("motor", "interneuron", "astrocyte", "pool", "torque", "interlimb"):
            if name in keep or (name == "interlimb" and name not in self.synapse_kinds):
                continue
            for part in self.parts(name):
                where = self._trial_slices(part)[trial]
                for var, arr in self._reset_arrays(part.name, part.obj):
                    arr[where] = self._initial(name, var)

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
        model = {"motor": self.models.motor_neuron, "interneuron": self.models.interneuron,
                 "astrocyte": self.models.astrocyte, "pool": self.models.pool,
                 "torque": self.models.torque,
                 "interlimb": self.models.interlimb_synapse}[group]
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
    """Trial ``b`` of a batch started with ``seed`` draws its connectivity from ``seed + b``, so
    a trial's network does not depend on the batch it runs in. Its noise does: Brian2 draws it
    for all trials from one generator seeded with ``seed``
    (docs/reproducibility.md, "Seeds and batches")."""
    return [int(seed) + b for b in range(n_trials)]


@exclusive  # Brian2's global seed and objects: one build or run at a time (runlock.py)
def build_cpg(
    models: ModelSet = DEFAULT_MODELS,
    *,
    n_trials: int = 1,
    seed: int = 0,
    legs: Iterable[str] = LEGS,
    dt: Any = 1 * ms,
    interlimb_weights: np.ndarray | None = None,
    codegen: str | None = None,
) -> CPG:
    """Build ``n_trials`` independent copies of the CPG.

    Order within one step (Brian2 schedule): motor neurons, interneurons and astrocytes integrate
    (``groups``), spike (``thresholds``), synapses deliver (``synapses``), neurons reset. Right
    after the thresholds, each pool counts its spikes (``pool_activity``) and the torque traces
    take them in, so the torque of step n holds the spikes of step n (docs/model.md: torque from this
    step's spikes drives this step's physics). The inter-limb input of the pools' spikes reaches
    the target neurons at the next step, like every other synapse.

    ``codegen``: Brian2's target, "numpy" or "cython" (default: $ASTROCPG_CODEGEN, else numpy;
    see :mod:`astrocpg.network.codegen`). It is stored as ``CPG.codegen``.
    """
    legs = tuple(legs)
    for leg in legs:
        if leg not in LEGS:
            raise InputError(f"unknown leg '{leg}' (legs are {', '.join(LEGS)})",
                             culprit="build_cpg")
    if int(n_trials) < 1:
        raise InputError(f"n_trials must be at least 1, got {n_trials}", culprit="build_cpg")
    pool_size = int(models.value("pool_size"))
    stages = limb_stages(models, legs, dt)  # 0 ms inter-limb delays: limbs one after another
    layout = Layout(n_trials=int(n_trials), pool_size=pool_size, legs=legs,
                    stages=stages if len(stages) > 1 else None)
    # numpy, or cython (opt-in): ``codegen``, else $ASTROCPG_CODEGEN. Every group and synapse
    # is pinned to it, so a later change of Brian2's preference does not move this network.
    codegen = use_codegen(codegen)
    codeobj_class = brian2.CythonCodeObject if codegen == "cython" else brian2.NumpyCodeObject
    brian2.seed(int(seed))

    objects: list[Any] = []

    def group(model: NeuronModel, n: int, name: str) -> NeuronGroup:
        try:
            # model.method is a scheme's registered name (e.g. "input_then_decay")
            g = NeuronGroup(
                n, model.equations, threshold=model.threshold, reset=model.reset,
                refractory=model.refractory if model.refractory else False,
                method=model.method, namespace=model.parameters.namespace(), name=name, dt=dt,
                codeobj_class=codeobj_class,
            )
            for var, value in model.initial_values.items():
                setattr(g, var, value)
        except InputError:
            raise
        except Exception as e:
            raise InputError(f"{brian_error_line(e)}", culprit=model.name) from None
        check_parameters_reach(g, model)
        objects.append(g)
        return g

    def synapses(model: SynapseModel, source, target, name: str, i, j) -> Synapses:
        try:
            s = Synapses(source, target, model=model.model, on_pre=model.on_pre,
                         method=model.method, namespace=model.parameters.namespace(), name=name,
                         dt=dt, codeobj_class=codeobj_class)
            s.connect(i=np.asarray(i, dtype=np.int32), j=np.asarray(j, dtype=np.int32))
            for var, value in model.initial_values.items():
                setattr(s, var, value)
            if model.weight:
                s.w = model.weight
        except InputError:
            raise
        except Exception as e:
            raise InputError(f"{brian_error_line(e)}", culprit=model.name) from None
        check_parameters_reach(s, model)
        objects.append(s)
        return s

    B, L = layout.n_trials, layout
    S = len(stages)

    def suffix(stage: int) -> str:
        """The name suffix of a stage's objects: none with one stage, else its limbs."""
        return "" if S == 1 else "_" + "_".join(legs[i] for i in stages[stage])

    per_stage_motor = [B * len(m) * len(POOLS) * L.pool_size for m in stages]
    motors = [group(models.motor_neuron, per_stage_motor[s], "motor" + suffix(s))
              for s in range(S)]
    # the trial-major motor-neuron number of each neuron of each stage's group
    motor_number = [np.arange(B * L.motor_per_trial)] if S == 1 else \
        [L.stage_motor_index(s) for s in range(S)]
    interneuron = group(models.interneuron, B * L.interneurons_per_trial, "interneuron")
    astrocyte = group(models.astrocyte, B * L.thigh_pools_per_trial, "astrocyte")
    pool = group(models.pool, B * L.pools_per_trial, "pool")
    torque = group(models.torque, B * L.joints_per_trial, "torque")
    # each stage's pools, one contiguous block of the pool group (the whole group with one stage)
    stage_pools = [pool] if S == 1 else [pool[slice(*L.stage_pool_range(s))] for s in range(S)]

    # Anatomy: neuron positions in the unit cube, drawn per trial from the trial's own seed.
    positions = np.concatenate([
        np.random.default_rng(s).uniform(0.0, 1.0, size=(L.motor_per_trial, 3))
        for s in trial_seeds(seed, B)
    ])
    for motor, number in zip(motors, motor_number):
        _require(motor, "x_position", "y_position", "z_position")
        motor.x_position = positions[number, 0]
        motor.y_position = positions[number, 1]
        motor.z_position = positions[number, 2]

    # Pool-level inputs reach every neuron of the pool.
    pool_of_motor = L.pool_of_motor_neuron
    try:
        # every linked variable of the motor neuron model is a pool variable of the same name
        for motor, number in zip(motors, motor_number):
            for var, eq in motor.equations.items():
                if "linked" in eq.flags:
                    if var not in pool.variables:
                        raise InputError(f"linked variable '{var}' is not a variable "
                                         f"of the pool model", culprit=f"motor_neuron")
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
        per_joint = {"thigh": models.value("I_thigh"), "calf": models.value("I_calf")}
        torque.I_joint_ = np.array([per_joint[jt] for _, _, jt in joints])
    except InputError:
        raise
    except Exception as e:
        raise InputError(f"{brian_error_line(e)}", culprit=f"network wiring") from None

    syn: dict[str, Synapses] = {}
    kinds: dict[str, list[Synapses]] = {}

    def add(kind: str, s: Synapses) -> Synapses:
        syn[s.name] = s
        kinds.setdefault(kind, []).append(s)
        return s

    for s, motor in enumerate(motors):
        start = L.stage_pool_range(s)[0] if S > 1 else 0
        add("pool_activity", synapses(
            models.pool_activity, motor, stage_pools[s], "pool_activity" + suffix(s),
            np.arange(len(motor)), pool_of_motor[motor_number[s]] - start))

    # Intra-pool: all ordered pairs of distinct neurons of a pool.
    a, b_ = np.meshgrid(np.arange(L.pool_size), np.arange(L.pool_size), indexing="ij")
    off = a != b_
    base_i, base_j = a[off], b_[off]
    for s, motor in enumerate(motors):
        starts = np.arange(len(motor) // L.pool_size) * L.pool_size
        add("intra_pool", synapses(models.intra_pool_synapse, motor, motor,
                                      "intra_pool" + suffix(s),
                                      (starts[:, None] + base_i).ravel(),
                                      (starts[:, None] + base_j).ravel()))

    # Interneurons: each driven by every neuron of one pool, inhibiting every neuron of another.
    pre_i, pre_j, post_i, post_j = [], [], [], []
    for b in range(B):
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
    for s, motor in enumerate(motors):
        here, there = src_stage == s, tgt_stage == s
        add("pool_to_interneuron", synapses(
            models.pool_to_interneuron, motor, interneuron, "pool_to_interneuron" + suffix(s),
            src_local[here], pre_j_[here]))
        add("interneuron_to_pool", synapses(
            models.interneuron_to_pool, interneuron, motor, "interneuron_to_pool" + suffix(s),
            post_i_[there], tgt_local[there]))

    # Inter-limb: thigh pool x -> thigh pool y of another limb, one weight per pair and trial;
    # one object per stage of target limbs.
    n_thigh = L.thigh_pools_per_trial
    mask = same_limb_mask(L)
    pairs = np.argwhere(~mask)  # (row, col) in the per-trial table
    pairs_of: dict[str, np.ndarray] = {}
    learning = []
    if len(pairs):
        def thigh_pool(b: int, x: np.ndarray) -> np.ndarray:
            return np.array([L.pool(b, int(t) // 2, THIGH_POOLS[int(t) % 2]) for t in x],
                            dtype=np.intp)
        for s in range(S):
            these = pairs[np.isin(pairs[:, 1] // len(THIGH_POOLS), stages[s])]
            start = L.stage_pool_range(s)[0] if S > 1 else 0
            name = "interlimb" + suffix(s)
            inter = add("interlimb", synapses(
                models.interlimb_synapse, pool, stage_pools[s], name,
                np.concatenate([thigh_pool(b, these[:, 0]) for b in range(B)]),
                np.concatenate([thigh_pool(b, these[:, 1]) - start for b in range(B)])))
            pairs_of[name] = these
            try:
                # the astrocyte of each synapse's target pool (the table's column)
                if "astrocyte_index" in inter.variables:
                    inter.astrocyte_index = np.concatenate([b * n_thigh + these[:, 1]
                                                            for b in range(B)])
                for var, eq in inter.equations.items():
                    if "linked" in eq.flags:
                        setattr(inter, var, linked_var(astrocyte, var, index="astrocyte_index"))
                if getattr(inter, "state_updater", None) is not None:  # STDP: after the counts
                    inter.state_updater.when, inter.state_updater.order = "after_thresholds", 2
                if models.interlimb_synapse.on_step:  # after the robot moved, reward known
                    learning.append(inter.run_regularly(
                        models.interlimb_synapse.on_step, dt=dt, when="end", order=10,
                        name="interlimb_learning" + suffix(s)))
            except InputError:
                raise
            except Exception as e:
                raise InputError(f"{brian_error_line(e)}", culprit=f"interlimb_synapse") from None
    objects.extend(learning)

    _schedule(motors, kinds, pool, torque, interneuron, astrocyte)
    # the divergence scan decides for these, in one line (Brian2's check: a raw warning)
    leave_to_the_scan([*objects, *stage_pools])
    net = Network(*objects)
    cpg = CPG(layout=layout, models=models, seed=int(seed), dt=dt, net=net,
              motor_groups=tuple(motors), interneuron=interneuron, astrocyte=astrocyte,
              pool=pool, torque=torque, synapses=syn, interlimb_pairs=pairs, codegen=codegen,
              synapse_kinds={k: tuple(v) for k, v in kinds.items()}, interlimb_pairs_of=pairs_of)
    if interlimb_weights is not None:
        cpg.set_interlimb_weights(interlimb_weights)
    return cpg


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
    return all(getattr(models, name) is getattr(DEFAULT_MODELS, name)
               for name in dict.fromkeys(MODEL_OF.values()))


@exclusive
def check_runs(cpg: CPG) -> None:
    """Prepare every object once (units, names, code generation), turning Brian2's errors into
    one line that names the model at fault. Costs about as much as the start of a run, so a
    network of the built-in models (:func:`built_in_models`) is not checked: the run itself
    generates its code once, and the test suite runs those models."""
    if built_in_models(cpg.models):
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
