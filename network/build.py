"""Build the CPG (locomotion units, interneurons, astrocytes, torque traces, inter-limb
projection) for ``n_trials`` independent copies from a :class:`~astrocpg.models.ModelSet`.

Nothing here is biophysics: every equation and constant comes from ``models``. This module
decides which element connects to which, and schedules the few objects whose order within a
1 ms step matters (see :func:`build_cpg`).
"""

from __future__ import annotations

import math
import warnings
from dataclasses import dataclass, field
from typing import Any, Iterable

import brian2
import numpy as np
from brian2 import Network, NeuronGroup, Synapses, linked_var, ms, second

from .._quiet_brian import close_debug_files
from ..errors import InputError
from ..models import DEFAULT_MODELS, ModelSet
from ..models.base import NeuronModel, SynapseModel, brian_error_line
from .codegen import DEFAULT as DEFAULT_CODEGEN
from .codegen import initial_target, use_codegen
from .divergence import NonFinite
from .layout import INTERNEURONS, LEGS, THIGH_POOLS, Layout

brian2.prefs.codegen.target = initial_target()  # --codegen / $ASTROCPG_CODEGEN: see codegen.py
brian2.prefs.codegen.loop_invariant_optimisations = True
# Brian2 logs a debug file for every exception it sees; our errors are user-facing.
brian2.prefs.logging.delete_log_on_exit = True


# Brian2 opened its debug log and script copy at import; if it was imported before astrocpg
# (so astrocpg._quiet_brian did not wrap that import), close and delete them now. Our errors
# are one line naming the culprit; no process should leave Brian2's files behind.
close_debug_files()
# A network that failed validation is dropped on purpose; don't warn about its objects.
brian2.BrianLogger.suppress_name("unused_brian_object")
# NaN/inf in the state is reported once, in one line, by the divergence check (CPG.first_nonfinite,
# errors.Diverged); numpy's floating-point warnings from Brian2's generated code (exec'd source,
# module "<string>") would only repeat it on stderr, several lines per step.
warnings.filterwarnings("ignore", category=RuntimeWarning, module=r"<string>$")


@dataclass
class CPG:
    """The built network: Brian2 groups, synapses and the index layout."""

    layout: Layout
    models: ModelSet
    seed: int
    dt: Any
    net: Network
    motor: NeuronGroup
    interneuron: NeuronGroup
    astrocyte: NeuronGroup
    pool: NeuronGroup
    torque: NeuronGroup
    synapses: dict[str, Synapses]
    interlimb_pairs: np.ndarray  # (n_synapses, 2): (row, col) in the per-trial table
    codegen: str = DEFAULT_CODEGEN  # Brian2 target of its groups and synapses (codegen.py)
    _arrays: dict[tuple[str, str], np.ndarray] = field(default_factory=dict)
    _state: list[tuple[str, str, np.ndarray, int | None, Any, np.ndarray]] | None = None

    @property
    def n_trials(self) -> int:
        return self.layout.n_trials

    def array(self, group: str, variable: str) -> np.ndarray:
        """The raw state array of ``group.variable`` (numpy target: the live array, writes in
        place change the simulation). Cached: use it in hot loops instead of ``G.v[:]``."""
        key = (group, variable)
        if key not in self._arrays:
            obj = self.synapses[group] if group in self.synapses else getattr(self, group)
            _require(obj, variable)
            arr = obj.variables[variable].get_value()
            if not isinstance(arr, np.ndarray):  # pragma: no cover - other devices
                raise RuntimeError("astrocpg needs Brian2's runtime (numpy) target")
            self._arrays[key] = arr
        return self._arrays[key]

    # ---- inter-limb weights, as (n_trials, 8, 8) tables in volt
    def interlimb_weights(self) -> np.ndarray:
        n = self.layout.thigh_pools_per_trial
        table = np.zeros((self.n_trials, n, n))
        if len(self.interlimb_pairs):
            w = self.array("interlimb", "w").reshape(self.n_trials, -1)
            table[:, self.interlimb_pairs[:, 0], self.interlimb_pairs[:, 1]] = w
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
        if not len(self.interlimb_pairs):
            return
        self.array("interlimb", "w")[:] = w[:, self.interlimb_pairs[:, 0],
                                            self.interlimb_pairs[:, 1]].ravel()

    # ---- divergence
    def state_arrays(self) -> list[tuple[str, str, np.ndarray, int | None]]:
        """(population, variable, live array, elements per trial) of every float state variable
        that can change during a run: the per-synapse state of every synapse group (the
        inter-limb weights and STDP signals), and the differential equations and plain
        parameters of the pools, astrocytes, torque traces, interneurons and motor neurons. Not
        constants, linked variables, subexpressions, ``lastspike``, integers or booleans.
        Upstream first (a NaN weight spreads to the pools' input, then to the motor neurons),
        so the first found is the likeliest origin. Groups are trial-major, so element ``k``
        belongs to trial ``k // per_trial``. Built once."""
        return [(p, v, a, n) for p, v, a, n, _, _ in self._state_table()]

    def _state_table(self) -> list[tuple[str, str, np.ndarray, int | None, Any, np.ndarray]]:
        if self._state is None:
            groups = list(self.synapses.items())
            groups += [(name, getattr(self, name)) for name in
                       ("pool", "astrocyte", "torque", "interneuron", "motor")]
            table = []
            for name, obj in groups:
                for var, eq in obj.equations.items():
                    if eq.type == "subexpression":
                        continue
                    if {"constant", "linked", "shared"} & set(eq.flags) or var == "lastspike":
                        continue
                    arr = self.array(name, var)
                    if arr.dtype.kind != "f" or arr.ndim != 1 or not arr.size:
                        continue
                    per_trial = arr.size // self.n_trials if arr.size % self.n_trials == 0 \
                        else None
                    # arr @ zeros is NaN iff arr holds a NaN or an inf, and never overflows
                    table.append((name, var, arr, per_trial, arr.dot, np.zeros(arr.size)))
            self._state = table
        return self._state

    def first_nonfinite(self) -> NonFinite | None:
        """The first NaN or inf in the state (in :meth:`state_arrays` order), or None. One
        reduction per array (about 1 us each); the element is located only when one fails."""
        isfinite = math.isfinite
        with np.errstate(invalid="ignore"):  # inf * 0 in the reduction
            for name, var, arr, per_trial, dot, zeros in self._state_table():
                if isfinite(dot(zeros)):
                    continue
                bad = np.flatnonzero(~np.isfinite(arr))
                if not bad.size:  # pragma: no cover - the array changed under us
                    continue
                k = int(bad[0])
                others = tuple(f"{n}.{v}" for n, v, a, _, d, z in self._state_table()
                               if (n, v) != (name, var) and not isfinite(d(z)))
                return NonFinite(population=name, variable=var,
                                 trial=None if per_trial is None else k // per_trial, index=k,
                                 value=float(arr[k]), others=others)
        return None

    def reset_trial(self, trial: int, keep: tuple[str, ...] = ("astrocyte",)) -> None:
        """Reset one trial's state to the start of a session: every state variable of the
        groups not in ``keep`` (astrocytes keep theirs: SPEC) and every dynamic variable of the
        inter-limb synapses except the weights. Array-slice writes only (no code generation)."""
        L = self.layout
        per_trial = {"motor": L.motor_per_trial, "interneuron": L.interneurons_per_trial,
                     "astrocyte": L.thigh_pools_per_trial, "pool": L.pools_per_trial,
                     "torque": L.joints_per_trial}
        for name, n in per_trial.items():
            if name in keep:
                continue
            for var, arr in self._reset_arrays(name):
                sl = slice(trial * n, (trial + 1) * n)
                arr[sl] = self._initial(name, var)
        if "interlimb" in self.synapses:
            n = len(self.interlimb_pairs)
            for var, arr in self._reset_arrays("interlimb"):
                arr[trial * n:(trial + 1) * n] = self._initial("interlimb", var)

    def _reset_arrays(self, name: str) -> list[tuple[str, np.ndarray]]:
        """(variable, live array) of what a session reset sets back: the model's differential
        equations and non-constant parameters (not linked ones, not the weights ``w``)."""
        key = ("reset", name)
        if key not in self._arrays:
            obj = self.synapses[name] if name in self.synapses else getattr(self, name)
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


#: The model each Brian2 object of the network is built from (object name -> model name).
MODEL_OF = {"motor": "motor_neuron", "interneuron": "interneuron", "astrocyte": "astrocyte",
            "pool": "pool", "torque": "torque", "pool_activity": "pool_activity",
            "intra_pool": "intra_pool_synapse", "pool_to_interneuron": "pool_to_interneuron",
            "interneuron_to_pool": "interneuron_to_pool", "interlimb": "interlimb_synapse"}


def _require(obj: Any, *variables: str) -> None:
    """The network (or the coupling) sets or reads ``variables`` of ``obj``: an equation
    string that lacks one is an InputError naming its model and the variable."""
    defined = set(obj.variables) | set(getattr(obj, "equations", {}) or {})  # linked ones too
    for var in variables:
        if var not in defined:
            model = MODEL_OF.get(obj.name, obj.name)
            raise InputError(f"the equations do not define '{var}', which astrocpg sets or "
                             f"reads (keep its line in the {model} equations)", culprit=model)


def same_limb_mask(layout: Layout) -> np.ndarray:
    """Boolean (8, 8): True on the same-limb blocks, which carry no synapse."""
    limb = np.repeat(np.arange(layout.n_legs), len(THIGH_POOLS))
    return limb[:, None] == limb[None, :]


def trial_seeds(seed: int, n_trials: int) -> list[int]:
    """Trial ``b`` of a batch started with ``seed`` draws its connectivity from ``seed + b``, so
    a trial's network does not depend on the batch it runs in. Its noise does: Brian2 draws it
    for all trials from one generator seeded with ``seed`` (README, "Seeds and batches")."""
    return [int(seed) + b for b in range(n_trials)]


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
    take them in, so the torque of step n holds the spikes of step n (SPEC: torque from this
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
    pool_size = int(np.asarray(models.pool.parameters["pool_size"].value))
    layout = Layout(n_trials=int(n_trials), pool_size=pool_size, legs=legs)
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
        objects.append(s)
        return s

    B, L = layout.n_trials, layout
    motor = group(models.motor_neuron, B * L.motor_per_trial, "motor")
    interneuron = group(models.interneuron, B * L.interneurons_per_trial, "interneuron")
    astrocyte = group(models.astrocyte, B * L.thigh_pools_per_trial, "astrocyte")
    pool = group(models.pool, B * L.pools_per_trial, "pool")
    torque = group(models.torque, B * L.joints_per_trial, "torque")

    # Anatomy: neuron positions in the unit cube, drawn per trial from the trial's own seed.
    positions = np.concatenate([
        np.random.default_rng(s).uniform(0.0, 1.0, size=(L.motor_per_trial, 3))
        for s in trial_seeds(seed, B)
    ])
    _require(motor, "x_position", "y_position", "z_position")
    motor.x_position = positions[:, 0]
    motor.y_position = positions[:, 1]
    motor.z_position = positions[:, 2]

    # Pool-level inputs reach every neuron of the pool.
    pool_index = L.pool_of_motor_neuron
    try:
        # every linked variable of the motor neuron model is a pool variable of the same name
        for var, eq in motor.equations.items():
            if "linked" in eq.flags:
                if var not in pool.variables:
                    raise InputError(f"linked variable '{var}' is not a variable "
                                     f"of the pool model", culprit=f"motor_neuron")
                setattr(motor, var, linked_var(pool, var, index=pool_index))
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
        tp = models.torque.parameters
        # the value (with its unit) of I_thigh or I_calf, joint by joint
        torque.I_joint = brian2.Quantity([
            tp["I_thigh"].value if jt == "thigh" else tp["I_calf"].value
            for _, _, jt in joints])
    except InputError:
        raise
    except Exception as e:
        raise InputError(f"{brian_error_line(e)}", culprit=f"network wiring") from None

    syn: dict[str, Synapses] = {}
    syn["pool_activity"] = synapses(models.pool_activity, motor, pool, "pool_activity",
                                    np.arange(len(pool_index)), pool_index)
    for updater in syn["pool_activity"].summed_updaters.values():
        updater.when, updater.order = "after_thresholds", 0
    # pool traces and torque traces take this step's spike counts in
    for g in (torque, pool):
        if getattr(g, "state_updater", None) is not None:
            g.state_updater.when, g.state_updater.order = "after_thresholds", 1

    # Intra-pool: all ordered pairs of distinct neurons of a pool.
    a, b_ = np.meshgrid(np.arange(L.pool_size), np.arange(L.pool_size), indexing="ij")
    off = a != b_
    base_i, base_j = a[off], b_[off]
    starts = np.arange(B * L.pools_per_trial) * L.pool_size
    syn["intra_pool"] = synapses(models.intra_pool_synapse, motor, motor, "intra_pool",
                                 (starts[:, None] + base_i).ravel(),
                                 (starts[:, None] + base_j).ravel())

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
    syn["pool_to_interneuron"] = synapses(models.pool_to_interneuron, motor, interneuron,
                                          "pool_to_interneuron", np.concatenate(pre_i),
                                          np.concatenate(pre_j))
    syn["interneuron_to_pool"] = synapses(models.interneuron_to_pool, interneuron, motor,
                                          "interneuron_to_pool", np.concatenate(post_i),
                                          np.concatenate(post_j))

    # Inter-limb: thigh pool x -> thigh pool y of another limb, one weight per pair and trial.
    n_thigh = L.thigh_pools_per_trial
    mask = same_limb_mask(L)
    pairs = np.argwhere(~mask)  # (row, col) in the per-trial table
    if len(pairs):
        thigh_pool_index = np.array([L.pool(0, leg, p) for leg in range(L.n_legs)
                                     for p in THIGH_POOLS])
        inter_i = np.concatenate([b * L.pools_per_trial + thigh_pool_index[pairs[:, 0]]
                                  for b in range(B)])
        inter_j = np.concatenate([b * L.pools_per_trial + thigh_pool_index[pairs[:, 1]]
                                  for b in range(B)])
        inter = syn["interlimb"] = synapses(models.interlimb_synapse, pool, pool, "interlimb",
                                            inter_i, inter_j)
        try:
            # the astrocyte of each synapse's target pool (the table's column)
            if "astrocyte_index" in inter.variables:
                inter.astrocyte_index = np.concatenate([b * n_thigh + pairs[:, 1]
                                                        for b in range(B)])
            for var, eq in inter.equations.items():
                if "linked" in eq.flags:
                    setattr(inter, var, linked_var(astrocyte, var, index="astrocyte_index"))
            if getattr(inter, "state_updater", None) is not None:  # STDP: after the counts
                inter.state_updater.when, inter.state_updater.order = "after_thresholds", 2
            if models.interlimb_synapse.on_step:  # after the robot moved and the reward is known
                objects.append(inter.run_regularly(models.interlimb_synapse.on_step, dt=dt,
                                                   when="end", order=10, name="interlimb_learning"))
        except InputError:
            raise
        except Exception as e:
            raise InputError(f"{brian_error_line(e)}", culprit=f"interlimb_synapse") from None

    net = Network(*objects)
    cpg = CPG(layout=layout, models=models, seed=int(seed), dt=dt, net=net, motor=motor,
              interneuron=interneuron, astrocyte=astrocyte, pool=pool, torque=torque,
              synapses=syn, interlimb_pairs=pairs, codegen=codegen)
    if interlimb_weights is not None:
        cpg.set_interlimb_weights(interlimb_weights)
    return cpg


def built_in_models(models: ModelSet) -> bool:
    """Is every Brian2 model of the CPG the built-in one (the same object as in
    ``DEFAULT_MODELS``)? Such a network needs no :func:`check_runs`: the test suite builds and
    runs it, and a check would generate all its code twice (about 0.4 s of every command)."""
    return all(getattr(models, name) is getattr(DEFAULT_MODELS, name)
               for name in dict.fromkeys(MODEL_OF.values()))


def check_runs(cpg: CPG) -> None:
    """Prepare every object once (units, names, code generation), turning Brian2's errors into
    one line that names the model at fault. Costs about as much as the start of a run, so a
    network of the built-in models (:func:`built_in_models`) is not checked: the run itself
    generates its code once, and the test suite runs those models."""
    if built_in_models(cpg.models):
        return
    names = MODEL_OF
    try:
        cpg.net.run(0 * second, namespace={})
    except Exception as e:
        culprit = "network"
        err: BaseException | None = e
        while err is not None:
            text = str(err)
            for obj, model in names.items():
                if f"object named '{obj}" in text:
                    culprit = model
                    break
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
