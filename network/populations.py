"""The population table: one row per population of the CPG, from which the index layout, the
CPG's groups, the divergence scan, what can be recorded, :class:`~astrocpg.studies.outputs.result.Result`'s
cells, the figures and the exports read.

A row (:class:`Population`) says which model the population is built from (a slot of the
:class:`~astrocpg.models.ModelSet`, or a model itself), its cells in one limb (so its cells per
trial and its place in the layout), whether its spikes are recordable, which state variables
are recordable traces (a built-in row takes them from its model's interface,
:attr:`astrocpg.models.base.Interface.traces`), what the export calls its cells and its table,
how a raster draws it, and, for a population that is not built in, what connects it (its
``inputs``, or a Python wiring step :data:`Wire`).

Every output folder's manifest holds the rows it was written with (``results.layout.populations``,
:meth:`Population.to_json`), so that a folder describes itself: readers take the rows from the
folder (:func:`rows_of`), never from this process's table.

Adding a population (docs/model-files.md, "A new population"): a model file with a
``[population]`` table (:func:`population_from_toml`: its inputs from and outputs to the other
populations), given to ``astrocpg unit``, ``run`` or ``train`` as an added population file
(``populations``); or, in Python, a row given to the build (``build_cpg(populations=rows)``,
``build_closed_loop(models, populations=rows)``). The table is a value passed down, never a
process's state: a network, a recording and a folder each carry the rows they were made
with::

    from astrocpg.network import populations, build_cpg

    row = populations.population_from_toml(text, culprit="renshaw.toml")
    cpg = build_cpg(..., populations=[row])

An added row's model joins the build's model set (:attr:`astrocpg.models.ModelSet.added`), so
that ``overrides`` reach its parameters.

The projections (synapse objects) have their own, smaller table (:data:`PROJECTIONS`: object
name -> model slot), which the divergence check uses to name the model of a failing object.
"""

from __future__ import annotations

import tomllib
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any, Callable

from ..errors import InputError, did_you_mean, setting
from ..support.reading import loads_toml
from ..models import DEFAULT_MODELS, INTERFACES
from ..models.base import TraceSource

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

#: A population's wiring step written in Python: called by :func:`astrocpg.network.build_cpg`
#: once every built-in population and projection exists, with the build's
#: :class:`~astrocpg.network.wiring.Wiring` (layout, models, groups by population,
#: ``synapses(model, source, target, name, i, j)`` and ``add(kind, synapses)``).
Wire = Callable[[Any], None]

#: How an input connects its source's cells to the population's, within one trial and limb:
#: ``label``: each cell from the source's cells with the same label (a Renshaw cell of a pool
#: from that pool's motor neurons); ``limb``: each cell from every source cell of the limb.
MATCHES: tuple[str, ...] = ("label", "limb")


@dataclass(frozen=True)
class Input:
    """A projection into an added population: from the cells of population ``source`` through
    synapses of the model set's synapse model ``synapse``, paired by ``match`` (:data:`MATCHES`)."""

    source: str
    synapse: str
    match: str = "label"

    def to_json(self) -> dict[str, str]:
        return {"from": self.source, "synapse": self.synapse, "match": self.match}


@dataclass(frozen=True)
class Output:
    """A projection from an added population: to the cells of population ``target`` (a
    built-in one, or one added before it) through synapses of the model set's synapse model
    ``synapse``, paired by ``match`` (:data:`MATCHES`: ``label``, each target cell from the
    added cells with its label; ``limb``, from every added cell of the limb)."""

    target: str
    synapse: str
    match: str = "label"

    def to_json(self) -> dict[str, str]:
        return {"to": self.target, "synapse": self.synapse, "match": self.match}


@dataclass(frozen=True)
class Population:
    """One row of the population table.

    name: the population's name, which is also its Brian2 group's (``motor`` is one group per
        stage of limbs: ``astrocpg.network.delays``), its key in spikes.npz and ``Result``.
    model: the :class:`~astrocpg.models.ModelSet` slot it is built from (``"interneuron"``), or,
        for an added population, the ``NeuronModel`` itself.
    cells_per_leg: given the pool size, the label of each cell of one limb in index order
        (a pool, an interneuron's name); a label repeats for the cells of one pool.
    spikes: are its spikes recordable (the ``spikes`` setting)?
    traces: recordable traces, trace name -> :class:`~astrocpg.models.base.TraceSource`.
    cell_noun: what one cell is called in the export (``motor_neuron``: table ``motor_neurons``).
    label_meaning: what a cell's label (the ``pool`` column of the export) means.
    spike_meaning: what one of its spikes is (the export's ``population`` column).
    table_description: the export's description of its cell table.
    scan_rank: the divergence scan checks populations upstream first, by this rank (lowest
        first), after the synapses.
    trace_series_per_leg: the export splits its traces in one series per trial and limb (else
        one per trial).
    raster: how a raster draws it: ``height`` (relative), ``label`` (the axis),
        ``marker``, ``colour`` (``"by label"``: one colour per label), ``ticks`` (``"leg"``: one
        tick per limb; ``"cell"``: one per cell).
    trace_plot: how ``astrocpg plot`` draws its traces: ``style`` ``"label mean"`` (default: per
        limb, each label's mean with a min..max band; ``figures`` names the figure of a trace,
        default the trace's name) or ``"per cell"`` (one figure per cell with all its traces,
        ``labels`` by trace, its spikes marked as ``events``, and the activity of the pool its
        label names).
    activity: its spikes per label and step are the pools' activity (the figures' activity
        panels).
    inputs: what connects an added population (``Input``: source population, synapse model, match), declared in its file.
    outputs: what an added population drives (``Output``: target population, synapse model,
        match), declared in its file.
    wire: a wiring step in Python for an added population (``Wire``: a function given the build's ``Wiring``).
    """

    name: str
    model: Any
    cells_per_leg: Callable[[int], Sequence[str]]
    spikes: bool = False
    traces: Mapping[str, TraceSource] = field(default_factory=dict)
    cell_noun: str = ""
    label_meaning: str = ""
    spike_meaning: str = ""
    table_description: str = ""
    scan_rank: int = 0
    trace_series_per_leg: bool = False
    raster: Mapping[str, Any] = field(default_factory=dict)
    trace_plot: Mapping[str, Any] = field(default_factory=dict)
    activity: bool = False
    inputs: tuple[Input, ...] = ()
    wire: Wire | None = None
    outputs: tuple[Output, ...] = ()

    @property
    def model_name(self) -> str:
        """The name of the model it is built from (a slot's name, or the model's)."""
        return self.model if isinstance(self.model, str) else str(self.model.name)

    @property
    def built_in(self) -> bool:
        """Is it wired by ``build_cpg`` itself (no ``inputs``, ``outputs`` nor ``wire``)?"""
        return not self.inputs and not self.outputs and self.wire is None

    def model_in(self, models: Any) -> Any:
        """Its model, taken from ``models`` (a ModelSet): the slot it names, or, for an added
        population, the set's model of its model's name (which carries the values ``overrides``
        gave), else its own."""
        if isinstance(self.model, str):
            return getattr(models, self.model)
        try:
            return models.model(self.model.name)
        except (KeyError, AttributeError):
            return self.model

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

    @property
    def noun(self) -> str:
        return self.cell_noun or self.name

    @property
    def table_name(self) -> str:
        """The export's table of its cells (``motor_neurons``)."""
        return f"{self.noun}s"

    def to_json(self, pool_size: int) -> dict[str, Any]:
        """What a folder's manifest holds of the row (its cells at ``pool_size``): all a reader
        needs, so that a folder describes itself (:func:`from_json`)."""
        return {"name": self.name, "model": self.model_name,
                "cells_per_leg": list(self.labels(pool_size)), "spikes": self.spikes,
                "traces": {t: s.to_json() for t, s in self.traces.items()},
                "cell_noun": self.noun, "label_meaning": self.label_meaning,
                "spike_meaning": self.spike_meaning,
                "table_description": self.table_description
                or f"one row per {self.noun.replace('_', ' ')}",
                "scan_rank": self.scan_rank, "trace_series_per_leg": self.trace_series_per_leg,
                "raster": dict(self.raster), "trace_plot": dict(self.trace_plot),
                "activity": self.activity, "inputs": [i.to_json() for i in self.inputs],
                "outputs": [o.to_json() for o in self.outputs], "built_in": self.built_in}


def from_json(data: Mapping[str, Any]) -> Population:
    """The row a manifest holds (:meth:`Population.to_json`), for reading a folder: its cells
    are the ones recorded (at the folder's pool size); it builds nothing."""
    try:
        labels = tuple(str(x) for x in data["cells_per_leg"])
        traces = {str(t): TraceSource(str(s["variable"]), float(s["factor"]), str(s["unit"]),
                                      str(s.get("meaning", t)))
                  for t, s in (data.get("traces") or {}).items()}
        return Population(
            name=str(data["name"]), model=str(data.get("model", data["name"])),
            cells_per_leg=lambda pool_size: labels, spikes=bool(data.get("spikes", False)),
            traces=traces, cell_noun=str(data.get("cell_noun", "")),
            label_meaning=str(data.get("label_meaning", "")),
            spike_meaning=str(data.get("spike_meaning", "")),
            table_description=str(data.get("table_description", "")),
            scan_rank=int(data.get("scan_rank", 0)),
            trace_series_per_leg=bool(data.get("trace_series_per_leg", False)),
            raster=dict(data.get("raster") or {}),
            trace_plot=dict(data.get("trace_plot") or {}),
            activity=bool(data.get("activity", False)),
            inputs=tuple(Input(str(i["from"]), str(i["synapse"]), str(i.get("match", "label")))
                         for i in data.get("inputs") or ()),
            outputs=tuple(Output(str(o["to"]), str(o["synapse"]), str(o.get("match", "label")))
                          for o in data.get("outputs") or ()))
    except (KeyError, TypeError, ValueError, AttributeError) as e:
        raise InputError(f"a population row of the manifest cannot be read ({type(e).__name__}: "
                         f"{e})", culprit=str(data.get("name", "population")
                                              if isinstance(data, Mapping) else "population"))


def rows_of(layout: Mapping[str, Any] | None) -> tuple[Population, ...]:
    """The rows a folder was written with: its manifest's ``results.layout.populations``; a
    folder written before manifests held them has the built-in rows."""
    rows = (layout or {}).get("populations") if isinstance(layout, Mapping) else None
    if not rows:
        return BUILT_IN
    return tuple(from_json(r) for r in rows)


BUILT_IN: tuple[Population, ...] = (
    Population("motor", "motor_neuron",
               lambda n: [p for p in POOLS for _ in range(n)], spikes=True,
               traces=INTERFACES["motor_neuron"].traces,
               cell_noun="motor_neuron", label_meaning="motor pool", spike_meaning="motor neuron",
               table_description="one row per motor neuron", scan_rank=4,
               trace_series_per_leg=True, activity=True,
               trace_plot={"style": "label mean", "figures": {"motor_Ca": "motor_calcium"},
                           "title": "Motor-neuron Ca²⁺", "ylabel": "Ca²⁺"},
               raster={"height": 4, "label": "motor neuron (leg)", "colour": "by label",
                       "marker": "|", "size": 2, "ticks": "leg", "title": True}),
    Population("interneuron", "interneuron", lambda n: [name for name, *_ in INTERNEURONS],
               spikes=True, cell_noun="interneuron",
               label_meaning="interneuron (source_to_target)", spike_meaning="V1/V2b or IIN",
               scan_rank=3,
               raster={"height": 2, "label": "interneuron (leg)", "colour": "k", "marker": "|",
                       "size": 3, "ticks": "leg"}),
    # astrocyte "spikes": adenosine releases
    Population("astrocyte", "astrocyte", lambda n: THIGH_POOLS, spikes=True,
               traces=INTERFACES["astrocyte"].traces,
               cell_noun="astrocyte", label_meaning="the thigh pool whose spikes the astrocyte "
                                                    "takes in",
               spike_meaning="spike = adenosine release",
               table_description="one row per astrocyte: the trial, limb and thigh pool it "
                                 "covers", scan_rank=1,
               trace_plot={"style": "per cell", "title": "Astrocyte", "colour": "tab:olive",
                           "events": "adenosine release",
                           "labels": {"astrocyte_Ca": "Ca²⁺", "astrocyte_IP3": "IP3",
                                      "astrocyte_AG": "2-AG", "astrocyte_ADO": "adenosine"}},
               raster={"height": 1.2, "label": "astrocyte\n(adenosine release)",
                       "colour": "tab:olive", "marker": "v", "size": 4, "ticks": "cell"}),
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

def row(name: str, rows: Sequence[Population] | None = None) -> Population:
    """The row of population ``name`` in ``rows`` (None: the built-in rows); KeyError if
    there is none."""
    for p in BUILT_IN if rows is None else rows:
        if p.name == name:
            return p
    raise KeyError(f"no population {name!r}")


def names(rows: Sequence[Population] | None = None) -> tuple[str, ...]:
    return tuple(p.name for p in (BUILT_IN if rows is None else rows))


def with_added(rows: Sequence[Population] | None) -> tuple[Population, ...]:
    """The table a build reads: the built-in rows and ``rows`` (populations added for this
    build), each added row checked (its name and its traces' names new, its connections
    given); None or none: the built-in rows. The built-in rows among ``rows`` (a whole table
    given again: a built network's) are the built-in rows already."""
    if not rows:
        return BUILT_IN
    built_in = {p.name for p in BUILT_IN}
    rows = tuple(r for r in rows
                 if not (isinstance(r, Population) and r.built_in and r.name in built_in))
    out = BUILT_IN
    for r in rows:
        if not isinstance(r, Population):
            raise InputError(f"expected a population row, got {type(r).__name__}",
                             culprit=setting("populations"))
        _check_added(r, out)
        out += (r,)
    return out


def _check_added(population: Population, rows: Sequence[Population]) -> None:
    if population.built_in:
        raise InputError("an added population needs its inputs, outputs or its wiring step "
                         "(wire=)", culprit=f"population {population.name}")
    taken = {r.name for r in rows} | set(PROJECTIONS) | set(trace_sources(rows))
    for name in (population.name, *population.traces):
        if name in taken:
            raise InputError("is already in the population table", culprit=f"population {name}")


# ---- the views the rest of the package reads (rows: a network's or a folder's; None: the
# built-in rows)
def spike_populations(rows: Sequence[Population] | None = None) -> tuple[str, ...]:
    """The populations whose spikes can be recorded, in table order."""
    return tuple(p.name for p in (BUILT_IN if rows is None else rows) if p.spikes)


def trace_sources(rows: Sequence[Population] | None = None
                  ) -> dict[str, tuple[str, str, float, str]]:
    """trace -> (population, variable, factor to the stored unit, stored unit)."""
    return {t: (p.name, s.variable, s.factor, s.unit)
            for p in (BUILT_IN if rows is None else rows) for t, s in p.traces.items()}


def trace_columns(traces: Sequence[str], rows: Sequence[Population] | None = None
                  ) -> dict[str, int]:
    """Each trace's columns in one trial (its population's cells at the built-in pool size;
    8 for a trace the table does not know): what a memory estimate counts per trial."""
    from ..models import DEFAULT_MODELS
    from .layout import Layout

    sources = trace_sources(rows)
    layout = Layout(n_trials=1, pool_size=int(DEFAULT_MODELS.value("pool_size")),
                    populations=with_added(rows))
    return {t: layout.cells_per_trial(sources[t][0]) if t in sources else 8 for t in traces}


def trace_meaning(trace: str, rows: Sequence[Population] | None = None) -> str:
    for p in BUILT_IN if rows is None else rows:
        if trace in p.traces:
            return p.traces[trace].meaning
    return trace


def model_of_object(rows: Sequence[Population] | None = None) -> dict[str, str]:
    """Brian2 object name (or stage prefix) -> the name of the model it is built from, for a
    network of ``rows`` (None: the built-in rows)."""
    return {**{p.name: p.model_name for p in (BUILT_IN if rows is None else rows)},
            **PROJECTIONS}


# ---- a population declared in a model file
#: the stored unit's factor from Brian2's SI value, for the units a trace may name without one
UNIT_FACTORS = {"a.u.": 1.0, "mV": 1e3, "uM": 1e3, "ms": 1e3, "s": 1.0, "V": 1.0}
_ROW_KEYS = {"name", "cells_per_leg", "spikes", "traces", "inputs", "outputs", "cell_noun",
             "label_meaning", "spike_meaning", "table_description", "trace_series_per_leg",
             "raster", "trace_plot"}


def population_from_toml(text: str, *, culprit: str) -> Population:
    """The row a model file declares in its ``[population]`` table (docs/model-files.md, "A new
    population"), with the model the same file defines. InputError naming ``culprit`` (and the
    key) for anything that does not fit: a name the table holds, a label source it does not,
    a trace variable the equations lack, an input from no population or through no synapse
    model."""
    from ..models.files import model_from_toml

    try:
        doc = loads_toml(text, culprit)
    except tomllib.TOMLDecodeError as e:
        raise InputError(f"not valid TOML ({e})", culprit=culprit) from None
    spec = doc.pop("population", None)
    if not isinstance(spec, dict):
        raise InputError("declares no population (a [population] table)", culprit=culprit)
    unknown = sorted(set(spec) - _ROW_KEYS)
    if unknown:
        raise InputError(f"unknown key {unknown[0]}{did_you_mean(unknown[0], _ROW_KEYS)} (keys: "
                         f"{', '.join(sorted(_ROW_KEYS))})", culprit=f"{culprit} [population]")
    model = model_from_toml(_without_population(text), culprit=culprit)
    if model.kind != "neuron":
        raise InputError(f"a population is built from a neuron model, not a {model.kind} model",
                         culprit=culprit)
    where = f"{culprit} [population]"
    name = spec.get("name", model.name)
    if not isinstance(name, str) or not name.isidentifier():
        raise InputError(f"name must be a Python identifier, got {name!r}", culprit=where)
    cells = _labels(spec.get("cells_per_leg"), f"{where} cells_per_leg")
    variables = set(model.brian_equations().names)
    traces = {}
    for trace, t in (spec.get("traces") or {}).items():
        tw = f"{where} traces.{trace}"
        if not isinstance(t, dict) or not isinstance(t.get("variable"), str):
            raise InputError("needs { variable = \"...\", unit = \"...\" }", culprit=tw)
        if t["variable"] not in variables:
            raise InputError(f"the equations do not define {t['variable']!r}", culprit=tw)
        unit = str(t.get("unit", "a.u."))
        factor = t.get("factor", UNIT_FACTORS.get(unit))
        if isinstance(factor, bool) or not isinstance(factor, (int, float)):
            raise InputError(f"needs a factor from the SI value to {unit!r} (factor = ...)",
                             culprit=tw)
        traces[trace] = TraceSource(t["variable"], float(factor), unit,
                                    str(t.get("meaning", trace)))
    inputs = tuple(_input(i, f"{where} inputs[{k}]")
                   for k, i in enumerate(_tables(spec, "inputs", where)))
    outputs = tuple(_output(o, f"{where} outputs[{k}]")
                    for k, o in enumerate(_tables(spec, "outputs", where)))
    if not inputs and not outputs:
        raise InputError("needs at least one input ([[population.inputs]] from = ..., "
                         "synapse = ...) or output ([[population.outputs]] to = ..., "
                         "synapse = ...)", culprit=where)
    _check_parameter_names(model, culprit)
    text_fields = {k: str(spec.get(k, "")) for k in ("cell_noun", "label_meaning",
                                                      "spike_meaning", "table_description")}
    return Population(name=name, model=model, cells_per_leg=lambda pool_size: cells(pool_size),
                      spikes=bool(spec.get("spikes", True)), traces=traces,
                      trace_series_per_leg=bool(spec.get("trace_series_per_leg", False)),
                      raster=dict(spec.get("raster") or {}),
                      trace_plot=dict(spec.get("trace_plot") or {}), inputs=inputs,
                      outputs=outputs, **text_fields)


def _without_population(text: str) -> str:
    """The model file's text without its ``[population]`` tables (the model's own part)."""
    out, skipping = [], False
    for line in text.splitlines():
        head = line.strip()
        if head.startswith("["):
            skipping = head.strip("[] ").split(".")[0].strip() == "population"
        if not skipping:
            out.append(line)
    return "\n".join(out) + "\n"


def _labels(given: Any, culprit: str) -> Callable[[int], tuple[str, ...]]:
    """cells_per_leg: a list of labels, or the name of a population whose labels it takes."""
    if isinstance(given, list) and given and all(isinstance(x, str) for x in given):
        fixed = tuple(given)
        return lambda pool_size: fixed
    if isinstance(given, str):
        try:
            source = row(given)
        except KeyError:
            raise InputError(f"names no population (populations: {', '.join(names())}), nor "
                             f"is it a list of labels", culprit=culprit) from None
        return source.labels
    raise InputError("must be a list of labels or the name of a population", culprit=culprit)


def _tables(spec: Mapping[str, Any], key: str, where: str) -> list[Any]:
    """The ``[[population.inputs]]`` or ``[[population.outputs]]`` tables (none: [])."""
    given = spec.get(key) or []
    if not isinstance(given, list):
        raise InputError(f"must be tables ([[population.{key}]])", culprit=f"{where} {key}")
    return given


def _projection(given: Any, end: str, culprit: str) -> tuple[str, str, str]:
    """(population, synapse model, match) of an input (``end`` "from") or output ("to")."""
    if not isinstance(given, dict) or set(given) - {end, "synapse", "match"}:
        raise InputError(f"needs {end} = POPULATION, synapse = MODEL (and match)",
                         culprit=culprit)
    other, synapse = given.get(end), given.get("synapse")
    match = given.get("match", "label")
    if other not in names():
        raise InputError(f"{end} {other!r}: no such population (populations: "
                         f"{', '.join(names())})", culprit=culprit)
    slots = {n: m for n, m in DEFAULT_MODELS.items() if m.kind == "synapse"}
    if synapse not in slots:
        raise InputError(f"synapse {synapse!r}: no such synapse model (synapse models: "
                         f"{', '.join(slots)})", culprit=culprit)
    if match not in MATCHES:
        raise InputError(f"match {match!r}: one of {', '.join(MATCHES)}", culprit=culprit)
    return str(other), str(synapse), str(match)


def _input(given: Any, culprit: str) -> Input:
    return Input(*_projection(given, "from", culprit))


def _output(given: Any, culprit: str) -> Output:
    return Output(*_projection(given, "to", culprit))


def _check_parameter_names(model: Any, culprit: str) -> None:
    """The population's model joins the model set (``overrides`` reach its parameters), so a
    parameter named like one of the built-in models' is refused, naming both."""
    owners = {p: name for name, m in DEFAULT_MODELS.items() for p in m.parameters}
    if model.name in dict(DEFAULT_MODELS.items()):
        raise InputError(f"its model is named {model.name}, like a built-in model: rename it",
                         culprit=culprit)
    for pname in model.parameters:
        if pname in owners:
            raise InputError(f"parameter {pname} of {model.name} is also a parameter of the "
                             f"{owners[pname]} model ({setting('overrides')} must name one: "
                             f"rename it)",
                             culprit=culprit)


__all__ = ["Population", "TraceSource", "Input", "Output", "Wire", "MATCHES", "BUILT_IN", "PROJECTIONS",
           "with_added", "row", "names",
           "spike_populations", "trace_sources", "trace_meaning", "model_of_object",
           "from_json", "rows_of", "population_from_toml", "LEGS", "POOLS", "THIGH_POOLS",
           "JOINTS_DRIVEN", "INTERNEURONS"]
