"""The population table: one row per population of the CPG, from which the index layout, the
CPG's groups, the divergence scan, what can be recorded, :class:`~astrocpg.studies.outputs.result.Result`'s
cells and the NWB export read.

A row (:class:`Population`) says which model the population is built from (a slot of the
:class:`~astrocpg.models.ModelSet`, or a model itself), its cells in one limb (so its cells per
trial and its place in the layout), whether its spikes are recordable, which state variables
are recordable traces (with their stored unit), what the export calls its cells, and, for a
population that is not built in, the wiring step that connects it (:data:`Wire`).

Adding a population (docs/model-files.md, "A new population"): write its model file, then
register one row, for the whole process (:func:`register`) or for a block
(:func:`registered`)::

    from astrocpg.models.files import model_from_toml
    from astrocpg.network import populations, build_cpg

    renshaw = populations.Population(
        name="renshaw", model=model_from_toml(text, culprit="renshaw.toml"),
        cells_per_leg=lambda pool_size: populations.POOLS, spikes=True,
        traces={"renshaw_v": populations.TraceSource("v", 1e3, "mV", "Renshaw cell potential")},
        wire=wire_renshaw)
    with populations.registered(renshaw):
        cpg = build_cpg(...)

The projections (synapse objects) have their own, smaller table (:data:`PROJECTIONS`: object
name -> model slot), which the divergence check uses to name the model of a failing object.
This module imports no Brian2 (``describe`` prints cached text without it).
"""

from __future__ import annotations

import contextlib
from collections.abc import Iterator, Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any, Callable

from ..errors import InputError

# The order of the authors' loop over the limbs; the inter-limb synapse model names its delays
# with the same names (models.interlimb_synapse.LIMBS: tests/test_delays.py checks they agree).
LEGS: tuple[str, ...] = ("FR", "FL", "RR", "RL")
POOLS: tuple[str, ...] = ("thigh_flexor", "thigh_extensor", "calf_flexor", "calf_extensor")
THIGH_POOLS: tuple[str, ...] = ("thigh_flexor", "thigh_extensor")
JOINTS_DRIVEN: tuple[str, ...] = ("thigh", "calf")

# The six interneurons of a locomotion unit: (name, kind, source pool, target pool) (docs/model.md,
# "Wiring of one limb").
INTERNEURONS: tuple[tuple[str, str, str, str], ...] = (
    ("thigh_flexor_to_extensor", "V1/V2b", "thigh_flexor", "thigh_extensor"),
    ("thigh_extensor_to_flexor", "V1/V2b", "thigh_extensor", "thigh_flexor"),
    ("calf_flexor_to_extensor", "V1/V2b", "calf_flexor", "calf_extensor"),
    ("calf_extensor_to_flexor", "V1/V2b", "calf_extensor", "calf_flexor"),
    ("thigh_extensor_to_calf_flexor", "IIN", "thigh_extensor", "calf_flexor"),
    ("thigh_flexor_to_calf_extensor", "IIN", "thigh_flexor", "calf_extensor"),
)


@dataclass(frozen=True)
class TraceSource:
    """A recordable trace: the group's ``variable``, the ``factor`` from Brian2's SI value to the
    stored unit, the stored unit's text (``uM``, ``a.u.`` ...) and what it means (NWB)."""

    variable: str
    factor: float
    unit: str
    meaning: str


#: A population's wiring step (populations that are not built in): called by
#: :func:`astrocpg.network.build_cpg` once every built-in population and projection exists, with
#: the build's :class:`~astrocpg.network.build.Wiring` (layout, models, groups by population,
#: ``synapses(model, source, target, name, i, j)`` and ``add(kind, synapses)``).
Wire = Callable[[Any], None]


@dataclass(frozen=True)
class Population:
    """One row of the population table.

    name: the population's name, which is also its Brian2 group's (``motor`` is one group per
        stage of limbs: :mod:`astrocpg.network.delays`), its key in spikes.npz and ``Result``.
    model: the :class:`~astrocpg.models.ModelSet` slot it is built from (``"interneuron"``), or,
        for an added population, the :class:`~astrocpg.models.base.NeuronModel` itself.
    cells_per_leg: given the pool size, the label of each cell of one limb in index order
        (a pool, an interneuron's name); a label repeats for the cells of one pool.
    spikes: are its spikes recordable (``--spikes``)?
    traces: recordable traces, trace name -> :class:`TraceSource`.
    cell_noun: what one cell is called in the export (``motor_neuron``: table ``motor_neurons``).
    label_meaning: what a cell's label (the ``pool`` column of the export) means.
    scan_rank: the divergence scan checks populations upstream first, by this rank (lowest
        first), after the synapses.
    trace_series_per_leg: the export splits its traces in one series per trial and limb (else
        one per trial).
    wire: the wiring step of an added population (None: built in, wired by ``build_cpg``).
    """

    name: str
    model: Any
    cells_per_leg: Callable[[int], Sequence[str]]
    spikes: bool = False
    traces: Mapping[str, TraceSource] = field(default_factory=dict)
    cell_noun: str = ""
    label_meaning: str = ""
    scan_rank: int = 0
    trace_series_per_leg: bool = False
    wire: Wire | None = None

    @property
    def model_name(self) -> str:
        """The name of the model it is built from (a slot's name, or the model's)."""
        return self.model if isinstance(self.model, str) else str(self.model.name)

    def model_in(self, models: Any) -> Any:
        """Its model, taken from ``models`` (a ModelSet) where it names a slot."""
        return getattr(models, self.model) if isinstance(self.model, str) else self.model

    def labels(self, pool_size: int) -> tuple[str, ...]:
        """The label of each cell of one limb (:attr:`cells_per_leg`)."""
        return tuple(self.cells_per_leg(int(pool_size)))

    def cells(self, pool_size: int) -> list[tuple[str, int]]:
        """(label, k: the cell's place among the limb's cells of that label) of one limb."""
        seen: dict[str, int] = {}
        out = []
        for label in self.labels(pool_size):
            out.append((label, seen.get(label, 0)))
            seen[label] = seen.get(label, 0) + 1
        return out


BUILT_IN: tuple[Population, ...] = (
    Population("motor", "motor_neuron",
               lambda n: [p for p in POOLS for _ in range(n)], spikes=True,
               traces={"motor_Ca": TraceSource(
                   "Ca", 1.0, "a.u.",
                   "motor-neuron Ca2+ (dimensionless, drives the K+ adaptation current)")},
               cell_noun="motor_neuron", label_meaning="motor pool", scan_rank=4,
               trace_series_per_leg=True),
    Population("interneuron", "interneuron", lambda n: [name for name, *_ in INTERNEURONS],
               spikes=True, cell_noun="interneuron",
               label_meaning="interneuron (source_to_target)", scan_rank=3),
    # astrocyte "spikes": adenosine releases; concentrations in uM (Brian2 keeps mol/m^3 = mM)
    Population("astrocyte", "astrocyte", lambda n: THIGH_POOLS, spikes=True,
               traces={
                   "astrocyte_Ca": TraceSource("Ca", 1e3, "uM",
                                               "astrocyte cytosolic Ca2+ (Li-Rinzel)"),
                   "astrocyte_IP3": TraceSource("IP3", 1e3, "uM", "astrocyte IP3"),
                   "astrocyte_AG": TraceSource(
                       "AG", 1.0, "a.u.",
                       "2-AG (endocannabinoid) at the astrocyte (dimensionless)"),
                   "astrocyte_ADO": TraceSource(
                       "ADO", 1.0, "a.u.", "adenosine released by the astrocyte (dimensionless)"),
               },
               cell_noun="astrocyte", label_meaning="the thigh pool whose spikes the astrocyte "
                                                    "takes in", scan_rank=1),
    Population("pool", "pool", lambda n: POOLS, cell_noun="pool", label_meaning="motor pool",
               scan_rank=0),
    Population("torque", "torque", lambda n: JOINTS_DRIVEN, cell_noun="joint",
               label_meaning="joint", scan_rank=2),
)

#: The projections: Brian2 object (or stage object prefix) -> the model slot it is built from.
PROJECTIONS: dict[str, str] = {
    "pool_activity": "pool_activity", "intra_pool": "intra_pool_synapse",
    "pool_to_interneuron": "pool_to_interneuron", "interneuron_to_pool": "interneuron_to_pool",
    "interlimb": "interlimb_synapse"}

_ADDED: list[Population] = []


def table() -> tuple[Population, ...]:
    """Every population, built-in rows first, then those added by :func:`register`."""
    return BUILT_IN + tuple(_ADDED)


def added() -> tuple[Population, ...]:
    """The rows added by :func:`register` (populations with their own wiring step)."""
    return tuple(_ADDED)


def row(name: str) -> Population:
    """The row of population ``name`` (KeyError if there is none)."""
    for p in table():
        if p.name == name:
            return p
    raise KeyError(f"no population {name!r}")


def names() -> tuple[str, ...]:
    return tuple(p.name for p in table())


def register(population: Population) -> Population:
    """Add a row to the table for this process (its ``wire`` step connects it). A name or a
    trace name the table already holds is an InputError naming it."""
    if population.wire is None:
        raise InputError("an added population needs its wiring step (wire=)",
                         culprit=f"population {population.name}")
    taken = set(names()) | set(PROJECTIONS) | set(trace_sources())
    for name in (population.name, *population.traces):
        if name in taken:
            raise InputError("is already in the population table", culprit=f"population {name}")
    _ADDED.append(population)
    return population


def unregister(name: str) -> None:
    """Remove an added row (built-in rows stay)."""
    _ADDED[:] = [p for p in _ADDED if p.name != name]


@contextlib.contextmanager
def registered(*populations: Population) -> Iterator[tuple[Population, ...]]:
    """Add rows for the ``with`` block only (tests, a notebook's experiment)."""
    done = []
    try:
        for p in populations:
            done.append(register(p))
        yield tuple(done)
    finally:
        for p in done:
            unregister(p.name)


# ---- the views the rest of the package reads
def spike_populations() -> tuple[str, ...]:
    """The populations whose spikes can be recorded, in table order."""
    return tuple(p.name for p in table() if p.spikes)


def trace_sources() -> dict[str, tuple[str, str, float, str]]:
    """trace -> (population, variable, factor to the stored unit, stored unit)."""
    return {t: (p.name, s.variable, s.factor, s.unit) for p in table() for t, s in p.traces.items()}


def trace_meaning(trace: str) -> str:
    for p in table():
        if trace in p.traces:
            return p.traces[trace].meaning
    return trace


def model_of_object() -> dict[str, str]:
    """Brian2 object name (or stage prefix) -> the name of the model it is built from."""
    return {**{p.name: p.model_name for p in table()}, **PROJECTIONS}


__all__ = ["Population", "TraceSource", "Wire", "BUILT_IN", "PROJECTIONS", "table", "added",
           "row", "names", "register", "unregister", "registered", "spike_populations",
           "trace_sources", "trace_meaning", "model_of_object", "LEGS", "POOLS", "THIGH_POOLS",
           "JOINTS_DRIVEN", "INTERNEURONS"]
