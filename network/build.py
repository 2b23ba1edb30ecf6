"""Build the CPG (locomotion units, interneurons, astrocytes, torque traces, inter-limb
projection) for ``n_trials`` independent copies from a :class:`~astrocpg.models.ModelSet`.

Nothing here is biophysics: every equation and constant comes from ``models``. This module
decides which element connects to which, and schedules the few objects whose order within a
1 ms step matters (see :func:`build_cpg`).
"""

from __future__ import annotations

import re
from typing import Any, Iterable, Sequence

import brian2
import numpy as np
from brian2 import Network, NeuronGroup, Synapses, ms, second

from ..support._quiet_brian import close_debug_files, mend_interrupt_handler
from ..errors import InputError, did_you_mean
from ..models import DEFAULT_MODELS, ModelSet
from .codegen import use_codegen
from . import populations as populations_
from .divergence import MODEL_OF, leave_to_the_scan, model_of
from .delays import limb_stages
from .layout import LEGS, Layout
from .runlock import exclusive
from .cpg import CPG, trial_seeds
from .wiring import (WIRING_STEPS, Wiring, blame, build_groups, link_pool_variables,
                     place_motor_neurons, wire_projection)


# Brian2's settings (target, warning filters) are applied only while the framework builds and
# runs, by RUN_LOCK (brian_prefs.py), never at import: a user's own Brian2 models are untouched.
# Brian2 opened its debug log and script copy at import; if it was imported before astrocpg
# (so astrocpg.support._quiet_brian did not wrap that import), close and delete them now. Our errors
# are one line naming the culprit; no process should leave Brian2's files behind. Its Ctrl-C
# handler is mended the same way (a process started with SIGINT ignored).
close_debug_files(switch_off=False)
mend_interrupt_handler()



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
    build_groups(w)
    place_motor_neurons(w, seed)
    link_pool_variables(w)
    for step in WIRING_STEPS:
        step(w)
    for row in layout.rows:
        if not row.built_in:
            with blame(f"population {row.name}"):
                for given in row.inputs:
                    wire_projection(w, given.source, row.name, given.synapse, given.match)
                for out in row.outputs:
                    wire_projection(w, row.name, out.target, out.synapse, out.match)
                if row.wire is not None:
                    row.wire(w)
    w.objects.extend(w.learning)

    g = w.groups
    _schedule(w.motors, w.kinds, g["pool"], g["torque"], g["interneuron"], g["astrocyte"])
    # the divergence scan decides for these, in one line (Brian2's check: a raw warning)
    leave_to_the_scan([*w.objects, *w.stage_pools])
    net = Network(*w.objects)
    # the rows travel with the network: a check that sees only the network (a constant that
    # overflows, a failing object) names the model of an added population too
    net.population_rows = rows
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


def built_in_models(models: ModelSet) -> bool:
    """Is every Brian2 model of the CPG the built-in one (the same object as in
    ``DEFAULT_MODELS``)? Such a network needs no :func:`check_runs`: the test suite builds and
    runs it, and a check would generate all its code twice (about 0.4 s of every command)."""
    if models.added:  # an added population's model (its rows are checked by the caller)
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
            if found and model_of(found.group(1), cpg.layout.rows):
                culprit = model_of(found.group(1), cpg.layout.rows) or culprit
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
