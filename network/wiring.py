"""The CPG's wiring, step by step (:class:`Wiring`): the groups of every population, the
motor neurons placed in their pools, the pool variables linked, and the projections of the
locomotion units, the interneurons and the inter-limb synapses (:data:`WIRING_STEPS`), each
connecting populations by the rules of the population table (:mod:`astrocpg.network.populations`).
Nothing here is biophysics: every equation and constant comes from ``models``.
"""

from __future__ import annotations

import contextlib
from dataclasses import dataclass, field
from typing import Any, Iterator

import numpy as np
from brian2 import NeuronGroup, Synapses, linked_var

from ..errors import InputError
from ..models import ModelSet
from ..models.base import BrianModel, NeuronModel, SynapseModel, brian_error_line
from ..models.names import why_reserved
from .noise import Rewriter, trial_major
from .layout import INTERNEURONS, LEGS, POOLS, THIGH_POOLS, Layout
from .cpg import require_variables, same_limb_mask, trial_seeds


@contextlib.contextmanager
def blame(culprit: str) -> Iterator[None]:
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
        with blame(model.name):
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
        with blame(model.name):
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


def build_groups(w: Wiring) -> None:
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


def wire_projection(w: Wiring, source: str, target: str, synapse: str, match: str) -> None:
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


def place_motor_neurons(w: Wiring, seed: int) -> None:
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
        require_variables(motor, "x_position", "y_position", "z_position")
        motor.x_position = positions[number, 0]
        motor.y_position = positions[number, 1]
        motor.z_position = positions[number, 2]
        if "leg" in motor.variables:
            motor.leg = leg_number[(np.asarray(number) % L.motor_per_trial) // per_leg]


def link_pool_variables(w: Wiring) -> None:
    """Pool-level inputs reach every neuron of the pool; the astrocytes and the torque traces
    read their pools' counts; each torque trace gets its joint's current."""
    L, B = w.layout, w.layout.n_trials
    pool, astrocyte, torque = w.groups["pool"], w.groups["astrocyte"], w.groups["torque"]
    pool_of_motor = L.pool_of_motor_neuron
    with blame("network wiring"):
        # every linked variable of the motor neuron model is a pool variable of the same name
        for motor, number in zip(w.motors, w.motor_number):
            for var, eq in motor.equations.items():
                if "linked" in eq.flags:
                    if var not in pool.variables:
                        raise InputError(f"linked variable '{var}' is not a variable "
                                         f"of the pool model", culprit="motor_neuron")
                    setattr(motor, var, linked_var(pool, var, index=pool_of_motor[number]))
        require_variables(pool, "n")
        require_variables(astrocyte, "n_pool")
        require_variables(torque, "n_extensor", "n_flexor", "I_joint")
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
        with blame("interlimb_synapse"):
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


def check_parameters_reach(obj: Any, model: BrianModel) -> None:
    """Refuse a network in which a parameter of ``model`` is not what ``obj`` (the Brian2 group
    or projection built from it) reads by that name, so that a value set with ``overrides`` and
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
