"""``astrocpg export DIR`` (``format`` nwb or npz): a simulation folder as one file for analysis
tools.

DIR is the output of ``astrocpg run`` or ``astrocpg unit``, or one recorded session of a
training (``TRAINING/recordings/trialTT_sessionSSSS``, written by ``astrocpg train`` with
``record_every``): ``spikes.npz``, ``traces.npz``, ``robot.npz``, ``manifest.json``. What it
holds was chosen when it was recorded: ``spikes`` and ``traces`` pick populations and traces,
``trace_dt``/``robot_stride`` (``record_stride`` and ``record_every`` in training) the
sampling, so a long run or training does not fill the disk.

NWB (pynwb, core types only, no extension; nwbinspector finds nothing at any importance once
``experimenter`` and ``institution`` are given, which only the person exporting knows. One
exception: ``astrocpg unit`` with one trial has two astrocytes, and nwbinspector's
check_column_binary_capability takes the region indices 0 and 1 of ``astrocyte_trace_columns``
for a yes/no flag; a region's indices are int32 by the schema, so that suggestion stays):

- Units: every neuron of every population with recorded spikes is a row with its spike times
  and the columns ``population``, ``trial``, ``limb``, ``pool`` and ``neuron_index`` (its index
  in the population, the column of its trace in ``traces.npz``); astrocyte "spikes" are
  adenosine releases.
- ``processing/misc/astrocytes`` and ``processing/misc/motor_neurons``: one row per astrocyte
  (trial, limb, the thigh pool it covers, neuron_index) and per motor neuron.
- Traces (motor-neuron Ca2+ per trial and limb; astrocyte Ca2+, IP3, 2-AG and adenosine per
  trial) are TimeSeries in ``acquisition``, time first, one column per cell. A TimeSeries cannot
  hold a table region itself, so ``processing/misc/astrocyte_trace_columns`` and
  ``motor_trace_columns`` have one row per column of such a series: ``timeseries`` (an object
  reference to the series), ``column`` (the column's index) and ``astrocyte`` /
  ``motor_neuron`` (a DynamicTableRegion into the cell table). The cell of a column is found
  through these references, never by reading a description.
- Per trial, joint angles, torques and the torso's position and velocity are TimeSeries.
- Units are SI or "dimensionless": astrocyte Ca2+ and IP3 are stored as recorded, in uM, with
  ``unit="mol/m^3"`` and ``conversion=1e-3`` (data * conversion is in the unit); motor-neuron
  Ca2+, 2-AG and adenosine are dimensionless model variables.
- Time: seconds from ``session_start_time`` (the start of the simulation, t = 0). A sample of a
  TimeSeries at time t holds the state at time t, which is the state at the end of the
  simulation step that ends at t (t = 0: the initial state). The network traces of ``run`` and
  ``unit`` begin with the initial state (t = 0); the robot is sampled after each physics step,
  so its series begin at t = dt; a recorded training session samples both after each step.
  Spike times are Brian2's: the start of the step in which the threshold was crossed (the
  spike shows in the state at t + dt). The rate is exact (1000.0 Hz for samples 1 ms apart):
  it comes from the sampling interval as a fraction, not from a float difference. The same
  text is the file's ``/general/data_collection``.
- Subject: nwbinspector requires one (critical) with a species given as a Latin binomial or an
  NCBI Taxonomy IRI. A simulated agent has no species; the subject is the simulation, its
  species NCBI Taxonomy 32630 "synthetic construct" (the taxonomy's entry for what was made,
  not born), its description says there is no animal.
- The model parameters (value, unit, the paper's symbol, meaning) and equations are tables in
  the ``misc`` processing module; the seed and settings are in the file's ``notes`` and
  ``session_description``.

npz: the same arrays in one compressed file; ``array_units_json`` (a JSON string) maps the name of
every other array to the unit of its values ("s", "uM", "dimensionless", "rad", ...; null for
labels, indices and flags, which have none); ``metadata_json`` (a JSON string) holds the
manifest's metadata and the models.
"""

from __future__ import annotations

import hashlib
import io
import json
import os
import re
import zipfile
import zlib
from collections.abc import Sequence
from datetime import datetime
from fractions import Fraction
from pathlib import Path
from typing import Any

import numpy as np

from ...errors import InputError, advice, did_you_mean, setting
from ...support.reading import check_regular
from ...network.populations import Population, rows_of, trace_meaning, trace_sources
from ...network.recording import overflow_words, overflowed
from .folder import (check_output_path, check_replaceable, clean_stale_temporaries,
                     refuse_in_use, verify)
from .writing import atomic_path, save_npz

# the unit of each robot.npz array (None: labels or flags, no unit)
ROBOT_UNITS: dict[str, str | None] = {
    "t": "s", "joint_angles": "rad", "torques": "N*m", "torso_position": "m",
    "torso_velocity": "m/s", "torso_quaternion": "dimensionless", "reward": "dimensionless",
    "alive": None, "foot_force": "N", "legs": None, "joints": None,
    "interlimb_weights_mV": "mV",
}
ROBOT_SERIES = (("joint_angles", "joint angles"),
                ("torques", "joint torques as applied (clipped to the motors' range)"),
                ("torso_position", "torso position, world frame"),
                ("torso_velocity", "torso linear velocity, world frame"))
# a stored trace unit -> (NWB unit, conversion): NWB wants SI or "dimensionless", and keeps the
# stored values with a factor to the unit (data * conversion); the traces' "a.u." are
# dimensionless model variables (": 1" in their equations)
NWB_UNITS = {"uM": ("mol/m^3", 1e-3), "mV": ("volts", 1e-3), "a.u.": ("dimensionless", 1.0)}

TIME_CONVENTION = (
    "Times are seconds from session_start_time, the start of the simulation (t = 0). A sample "
    "of a TimeSeries at time t holds the state at time t, i.e. the state at the end of the "
    "simulation step that ends at t (t = 0: the initial state, before the first step). Network "
    "traces of astrocpg run and unit begin with the initial state (t = 0); the robot is sampled "
    "after each physics step, so its series begin at the end of the first step (t = dt); a "
    "recorded training session samples both after each step (from t = dt, times from the "
    "session's start). Spike times (Units) are Brian2's: the start of the step in which the "
    "threshold was crossed; the spike shows in the state at t + dt.")
SAMPLE_COMMENT = ("sample at time t = the state at the end of the simulation step ending at t "
                  "(see /general/data_collection)")

# nwbinspector (check_subject_species_form) takes a Latin binomial or an NCBI Taxonomy IRI; a
# simulated agent has no species: 32630 is NCBI's "synthetic construct" (made, not born)
SYNTHETIC_CONSTRUCT = "http://purl.obolibrary.org/obo/NCBITaxon_32630"
# DANDI's form of a person's name, as nwbinspector's check_experimenter_form checks it
EXPERIMENTER_FORM = r"^([\w\s\-\.']+),\s+([\w\s\-\.']+)$"


def _load(folder: Path) -> dict[str, Any]:
    # the folder's files are exactly what its manifest lists (or it is refused, naming why)
    manifest = verify(folder, culprit="export")
    if manifest.get("astrocpg_command") not in ("run", "unit", "train-session"):
        raise InputError(f"holds a '{manifest.get('astrocpg_command')}' "
                         f"folder; export reads the output of astrocpg run or unit, or a "
                         f"recorded training session (DIR/recordings/trialTT_sessionSSSS, from "
                         f"{advice('record_every', 'N')})", culprit=f"export {folder}")
    data: dict[str, Any] = {"manifest": manifest}
    for name in ("spikes", "traces", "robot"):
        path = folder / f"{name}.npz"
        if path.exists():
            check_regular(path, f"export {folder}")  # a FIFO is refused, never waited on
            try:
                with np.load(path, allow_pickle=False) as z:
                    data[name] = {k: z[k] for k in z.files}
            except (ValueError, EOFError, zipfile.BadZipFile, zlib.error) as e:
                raise InputError(f"{name}.npz is corrupt or truncated ({type(e).__name__}); "
                                 f"record the run again", culprit=f"export {folder}") from None
    data.setdefault("spikes", {})  # recorded with spikes "none": export what exists
    # traces that overflowed float32 (stored as inf): counted from the data itself (a folder
    # recorded before its manifest said so has them too), carried into the export's notes
    # and each such series' description: never passed off as a clean record
    over = overflowed({k: (None, v) for k, v in data.get("traces", {}).items()
                       if not k.endswith("_t")})
    if over:
        data["manifest"] = {**manifest, "results": {**(manifest.get("results") or {}),
                                                    "trace_overflow": over}}
    return data


def _rows(manifest: dict[str, Any]) -> tuple[Population, ...]:
    """The population rows the folder was written with (its manifest's; the built-in rows for a
    folder written before manifests held them)."""
    return rows_of(manifest["results"]["layout"])


def unit_rows(manifest: dict[str, Any]) -> dict[str, list[dict[str, Any]]]:
    """Per population that can be recorded (spikes or traces), one dict per cell: trial, limb,
    pool (its label: a pool, an interneuron's name ...), index.

    The order is the populations' index order (see the manifest's layout): trial, then leg,
    then the cells of one limb as the population's row lists them."""
    lay = manifest["results"]["layout"]
    rows: dict[str, list[dict[str, Any]]] = {}
    for row in _rows(manifest):
        if not (row.spikes or row.traces):
            continue
        cells = row.labels(lay["pool_size"])
        rows[row.name] = [{"trial": b, "limb": leg, "pool": cell}
                          for b in range(lay["n_trials"]) for leg in lay["legs"]
                          for cell in cells]
        for k, cell in enumerate(rows[row.name]):
            cell["neuron_index"] = k
    return rows


def _spike_trains(times: np.ndarray, indices: np.ndarray, n: int) -> list[np.ndarray]:
    order = np.lexsort((times, indices))
    t, i = times[order], indices[order]
    bounds = np.searchsorted(i, np.arange(n + 1))
    return [t[bounds[k]:bounds[k + 1]].astype(np.float64) for k in range(n)]


def _overflow_note(manifest: dict[str, Any], name: str) -> str:
    """``; WARNING: ...`` for a trace that overflowed float32 (values stored as inf)."""
    over = ((manifest.get("results") or {}).get("trace_overflow") or {}).get(name)
    if not over:
        return ""
    return (f"; WARNING: {over['values']} of {over['of']} values (in {over['samples']} of "
            f"{over['of_samples']} samples) were beyond float32's range and are stored as inf, "
            f"not as simulated (record again with trace_dtype float64)")


def _metadata(manifest: dict[str, Any]) -> dict[str, Any]:
    """What an export carries of the manifest: the command, its settings, its versions, and
    how the run ended (``status``: finished or diverged, with the ``error`` of a diverged
    run) and the time it actually simulated (``simulated_seconds``), which a diverged run has
    less of than its settings asked for."""
    results = manifest.get("results") or {}
    return {**{k: manifest.get(k) for k in ("astrocpg_command", "seed", "settings", "argv",
                                           "created", "package_versions", "git")},
            "status": results.get("status", "finished"),
            "simulated_seconds": _simulated_seconds(manifest),
            "error": results.get("error"),
            **({"trace_overflow": results["trace_overflow"],
                "warning": overflow_words(results["trace_overflow"])}
               if results.get("trace_overflow") else {})}


def _simulated_seconds(manifest: dict[str, Any]) -> Any:
    """The simulated time the folder holds (the results' ``seconds``; the settings' for a
    folder written before results recorded it)."""
    results = manifest.get("results") or {}
    return results.get("seconds", (manifest.get("settings") or {}).get("seconds"))


def _duration_text(manifest: dict[str, Any]) -> str:
    """``10 s``, or for a diverged run ``DIVERGED: 0.37 s simulated of the 10 s asked (...)``:
    a description never claims the full duration of a run that stopped."""
    results = manifest.get("results") or {}
    simulated = _simulated_seconds(manifest)
    shown = f"{simulated:g} s" if isinstance(simulated, (int, float)) else "? s"
    if results.get("status") != "diverged":
        return shown
    asked = (manifest.get("settings") or {}).get("seconds")
    line = (results.get("error") or {}).get("line", "")
    asked_text = f" of the {asked:g} s asked" if isinstance(asked, (int, float)) else ""
    return f"DIVERGED: {shown} simulated{asked_text}" + (f" ({line})" if line else "")


def _index_dtype(largest: int) -> np.dtype:
    """The smallest unsigned integer type holding 0..largest: compact, and a trial column of a
    2-trial run (values 0 and 1) is then not mistaken for a yes/no flag by nwbinspector."""
    return np.min_scalar_type(max(int(largest), 0))


def _sampling(t: np.ndarray, dt: float) -> dict[str, Any]:
    """``starting_time`` and ``rate`` of sample times ``t`` (s) on a regular grid, or
    ``timestamps`` if they are not.

    The interval and the start are taken as the nearest fractions with a denominator of at
    most 10**6 (1/1000 s for 1 ms; recorded intervals are multiples or simple fractions of the
    step), so 1 ms sampling gives exactly 1000.0 Hz rather than the inverse of a float
    difference (999.9999999999991); a grid that does not match every time gives timestamps.
    ``dt``: the interval of a single sample."""
    t = np.asarray(t, dtype=np.float64)
    step = (Fraction(float(np.median(np.diff(t)))) if len(t) > 1
            else Fraction(dt)).limit_denominator(10**6)
    start = Fraction(float(t[0])).limit_denominator(10**6)
    grid = float(start) + np.arange(len(t)) * float(step)
    if step <= 0 or not np.allclose(grid, t, rtol=0, atol=1e-6 * float(step)):
        return {"timestamps": t}
    return {"starting_time": float(start), "rate": float(1 / step)}


def _cell_table(name: str, description: str, rows: list[dict[str, Any]],
                pool_meaning: str) -> Any:
    """A DynamicTable of cells (one row per neuron or astrocyte, in neuron_index order)."""
    from hdmf.common import DynamicTable, VectorData

    return DynamicTable(name=name, description=description, columns=[
        VectorData(name="trial", description="independent trial of the batch (seed = file seed "
                                             "+ trial)",
                   data=np.array([r["trial"] for r in rows],
                                 dtype=_index_dtype(max(r["trial"] for r in rows)))),
        VectorData(name="limb", description="leg: FR, FL, RR, RL",
                   data=[r["limb"] for r in rows]),
        VectorData(name="pool", description=pool_meaning, data=[r["pool"] for r in rows]),
        VectorData(name="neuron_index", description="index within the population (column of "
                                                    "its trace in traces.npz)",
                   data=np.arange(len(rows), dtype=_index_dtype(len(rows) - 1)))])


def _column_table(name: str, description: str, cell: str, cells: Any,
                  columns: list[tuple[Any, int, int]]) -> Any:
    """One row per column of the trace TimeSeries: (series, column, row of ``cells``)."""
    from hdmf.common import DynamicTable, DynamicTableRegion, VectorData

    return DynamicTable(name=name, description=description, columns=[
        VectorData(name="timeseries", description="the TimeSeries (object reference)",
                   data=[series for series, _, _ in columns]),
        VectorData(name="column", description="index of the column in the TimeSeries' data "
                                              "(second dimension)",
                   data=np.array([k for _, k, _ in columns],
                                 dtype=_index_dtype(max(k for _, k, _ in columns)))),
        DynamicTableRegion(name=cell, description=f"the {cell.replace('_', ' ')} whose state "
                                                  f"the column holds (row of {cells.name})",
                           # int32: the schema's type of a region's indices (not smaller)
                           data=np.array([row for _, _, row in columns], dtype=np.int32),
                           table=cells)])


def export_nwb(folder: Path, path: Path, *, experimenter: Sequence[str] = (),
               institution: str | None = None) -> Path:
    """Write ``folder`` as the NWB file ``path`` (see the module's docstring)."""
    from pynwb import NWBHDF5IO, ProcessingModule

    data = _load(folder)
    m = data["manifest"]
    dt = _resolution(m, data)
    nwb = _nwb_file(m, experimenter=experimenter, institution=institution)
    populations = unit_rows(m)
    _add_units(nwb, m, populations, data["spikes"], dt)
    traced = [r for r in _rows(m) if r.traces]
    module = ProcessingModule(name="misc", description=(
        f"the simulated network: its cells ({', '.join(r.table_name for r in traced)}), the cell "
        f"of each column of the trace TimeSeries "
        f"({', '.join(f'{r.name}_trace_columns' for r in traced)}), and the model as simulated "
        f"(parameters and equations of every model)"))
    _add_traces(nwb, module, m, data, populations, dt)
    _add_robot(nwb, data.get("robot"), dt)
    _add_models(module, m)
    nwb.add_processing_module(module)
    atomic_path(path, lambda p: _nwb_write(NWBHDF5IO, nwb, p))
    return path


def _nwb_file(m: dict[str, Any], *, experimenter: Sequence[str],
              institution: str | None) -> Any:
    """The NWBFile of the folder whose manifest is ``m``: its session, who and where, and the
    simulation as its subject."""
    from pynwb import NWBFile
    from pynwb.file import Subject

    created = datetime.strptime(m["created"], "%Y-%m-%dT%H:%M:%S%z")
    lay = m["results"]["layout"]
    digest = hashlib.sha256(json.dumps(_metadata(m), sort_keys=True, default=str)
                            .encode()).hexdigest()
    nwb = NWBFile(
        session_description=(f"astrocpg {m['astrocpg_command']}: simulated astrocyte-regulated "
                             f"spiking CPG, {lay['n_trials']} trial(s), seed {m['seed']} "
                             f"(trial b uses seed {m['seed']}+b), "
                             f"{_duration_text(m)}"),
        identifier=f"astrocpg-{digest[:32]}",
        session_start_time=created,
        experiment_description=("Simulation of the astrocyte-regulated spiking CPG of a "
                                "quadruped (Brian2), coupled to a Unitree A1 in MuJoCo"),
        experimenter=list(experimenter) or None,
        institution=institution,
        data_collection=TIME_CONVENTION,
        notes=json.dumps(_metadata(m), default=str),
        source_script=" ".join(m.get("argv") or []),
        source_script_file_name="astrocpg",
        keywords=["spiking neural network", "central pattern generator", "astrocyte",
                  "simulation"] + (["diverged"] if m["results"].get("status") == "diverged"
                                   else []),
    )
    # the subject is the simulation: it comes into being when the simulation starts, so its
    # date of birth is the session start; no animal, no sex (U = unknown)
    nwb.subject = Subject(subject_id="astrocpg-simulation", sex="U", date_of_birth=created,
                          species=SYNTHETIC_CONSTRUCT,
                          description=("a simulated spiking CPG with astrocytes driving a "
                                       "simulated Unitree A1 quadruped robot; no animal (species: "
                                       "NCBI Taxonomy 32630, synthetic construct)"))
    return nwb


def _add_units(nwb: Any, m: dict[str, Any], populations: dict[str, list[dict[str, Any]]],
               spikes: dict[str, np.ndarray], dt: float) -> None:
    """The Units table: every recorded neuron's spike train and its trial, limb and pool."""
    from pynwb.misc import Units

    recorded = [pop for pop in populations if f"{pop}_times" in spikes]
    spiking = [r for r in _rows(m) if r.spikes]
    if recorded:  # recorded with spikes "none": no Units table
        nwb.units = Units(name="units", resolution=dt, description=(
            "spikes of the simulated cells" + "".join(
                f"; {r.name}: {r.spike_meaning}" for r in spiking
                if r.spike_meaning.startswith("spike"))))
        rows = []
        for pop in recorded:
            trains = _spike_trains(spikes[f"{pop}_times"], spikes[f"{pop}_indices"],
                                   len(populations[pop]))
            for row, train in zip(populations[pop], trains):
                nwb.add_unit(spike_times=train)
                rows.append(row | {"population": pop})
        # typed columns (pynwb would store Python ints as int64)
        for col, desc, values in (
                ("population", ", ".join(f"{r.name} ({r.spike_meaning})" if r.spike_meaning
                                         else r.name for r in spiking),
                 [r["population"] for r in rows]),
                ("trial", "independent trial of the batch (seed = file seed + trial)",
                 np.array([r["trial"] for r in rows],
                          dtype=_index_dtype(max(r["trial"] for r in rows)))),
                ("limb", "leg: FR, FL, RR, RL", [r["limb"] for r in rows]),
                ("pool", "; ".join(f"{r.name}: {r.label_meaning or 'its label'}"
                                   for r in spiking), [r["pool"] for r in rows]),
                ("neuron_index", "index within the population (column of its trace)",
                 np.array([r["neuron_index"] for r in rows],
                          dtype=_index_dtype(max(r["neuron_index"] for r in rows))))):
            nwb.units.add_column(name=col, description=desc, data=values)


def _add_traces(nwb: Any, module: Any, m: dict[str, Any], data: dict[str, Any],
                populations: dict[str, list[dict[str, Any]]], dt: float) -> None:
    """The traces as TimeSeries (one per trial and limb, or per trial), the cell tables and
    the cell of each trace column (in ``module``)."""
    from pynwb import TimeSeries

    lay = m["results"]["layout"]
    rows = _rows(m)
    cells, column_rows, dims = {}, {}, {}
    for row in rows:  # every population with recordable traces: a table of its cells
        if not row.traces or row.name not in populations:
            continue
        d = row.to_json(lay["pool_size"])
        cells[row.name] = _cell_table(row.table_name, d["table_description"],
                                      populations[row.name], row.label_meaning or "pool")
        column_rows[row.name] = []
        per_leg = len(row.labels(lay["pool_size"]))
        dims[row.name] = ((len(lay["legs"]), per_leg) if row.trace_series_per_leg
                          else (1, len(lay["legs"]) * per_leg))
    sources = trace_sources(rows)
    for name, values in sorted(data.get("traces", {}).items()):
        if name.endswith("_t"):
            continue
        t = data["traces"][f"{name}_t"]
        if len(t) == 0 or name not in sources:  # nothing sampled (diverged at once), or the
            continue  # trace of a population added to the table in another process only
        population = sources[name][0]
        unit, conversion = NWB_UNITS.get(sources[name][3], (sources[name][3], 1.0))
        # one series per trial and limb (motor) or per trial (astrocytes): time stays the
        # longest dimension, and a series is one limb's or one trial's cells
        n_parts, width = dims[population]
        by_leg = next(r for r in rows if r.name == population).trace_series_per_leg
        for part in range(values.shape[1] // width):
            b, limb = divmod(part, n_parts)
            cols = slice(part * width, (part + 1) * width)
            suffix = f"trial{b}_{lay['legs'][limb]}" if by_leg else f"trial{b}"
            series = TimeSeries(
                name=f"{name}_{suffix}", data=values[:, cols], unit=unit,
                conversion=conversion, comments=SAMPLE_COMMENT, **_sampling(t, dt),
                description=(f"{trace_meaning(name, rows)}; one column per cell, the cell "
                             f"of each column in processing/misc/{population}_trace_columns"
                             + _overflow_note(m, name)))
            nwb.add_acquisition(series)
            column_rows[population] += [(series, k, cols.start + k) for k in range(width)]
    for pop, table in cells.items():
        module.add(table)
    for pop in cells:
        cell = next(r for r in rows if r.name == pop).noun
        if column_rows[pop]:
            module.add(_column_table(f"{pop}_trace_columns",
                                     f"the {cell.replace('_', ' ')} of each column of the "
                                     f"{pop} trace TimeSeries", cell, cells[pop],
                                     column_rows[pop]))


def _add_robot(nwb: Any, robot: Any, dt: float) -> None:
    """The robot's recorded arrays, one TimeSeries per array and trial."""
    from pynwb import TimeSeries

    if robot is not None and len(robot["t"]):
        legs, joints = [str(x) for x in robot["legs"]], [str(x) for x in robot["joints"]]
        for key, meaning in ROBOT_SERIES:
            arr = robot[key]
            for b in range(arr.shape[0]):
                values = arr[b].reshape(arr.shape[1], -1)
                columns = ([f"{leg}_{j}" for leg in legs for j in joints]
                           if values.shape[1] == len(legs) * len(joints) else ["x", "y", "z"])
                nwb.add_acquisition(TimeSeries(
                    name=f"{key}_trial{b}", data=values, unit=ROBOT_UNITS[key],
                    comments=SAMPLE_COMMENT, **_sampling(robot["t"], dt),
                    description=f"{meaning}; columns: {', '.join(columns)}"))


def _add_models(module: Any, m: dict[str, Any]) -> None:
    """The model as simulated: every model's parameters and equation strings, two tables."""
    from hdmf.common import DynamicTable, VectorData

    names, params, values, symbols, meanings = [], [], [], [], []
    eq_models, eq_kinds, eq_texts = [], [], []
    for model, entry in m.get("models", {}).items():
        for pname, p in entry.get("parameters", {}).items():
            names.append(model)
            params.append(pname)
            values.append(str(p.get("value")))
            symbols.append(str(p.get("symbol", "")))
            meanings.append(str(p.get("meaning", "")))
        for kind in ("equations", "model", "expression", "threshold", "reset", "on_pre",
                     "on_step", "refractory"):
            if entry.get(kind):
                eq_models.append(model)
                eq_kinds.append(kind)
                eq_texts.append(str(entry[kind]))
    module.add(DynamicTable(name="parameters", description="model parameters (value with unit)",
                            columns=[VectorData(name="model", description="model", data=names),
                                     VectorData(name="parameter", description="name in "
                                                "the equations", data=params),
                                     VectorData(name="value", description="value with unit",
                                                data=values),
                                     VectorData(name="symbol", description="the paper's symbol "
                                                "(LaTeX)", data=symbols),
                                     VectorData(name="meaning", description="meaning and "
                                                "source", data=meanings)]))
    module.add(DynamicTable(name="equations", description="Brian2 equation strings",
                            columns=[VectorData(name="model", description="model",
                                                data=eq_models),
                                     VectorData(name="kind", description="equations, model, "
                                                "threshold, reset, ...", data=eq_kinds),
                                     VectorData(name="text", description="Brian2 code",
                                                data=eq_texts)]))


def _resolution(manifest: dict[str, Any], data: dict[str, Any]) -> float:
    """The simulation time step (spike times lie on its grid)."""
    dt = manifest.get("results", {}).get("dt_s")
    if dt:
        return float(dt)
    times = np.unique(np.concatenate([v for k, v in data["spikes"].items()
                                      if k.endswith("_times")] + [np.zeros(1)]))
    steps = np.diff(times)
    return float(steps[steps > 0].min()) if (steps > 0).any() else 1e-3


def _nwb_write(io_cls, nwb, path: Path) -> None:
    """Build the HDF5 file in memory, then write its bytes: HDF5 meets a full disk or a file
    size limit with errors from its destructors (and can crash), Python's own writes with one
    OSError naming the file."""
    import h5py

    buf = io.BytesIO()
    with h5py.File(buf, "w") as f:
        with io_cls(mode="w", file=f) as nwb_io:
            nwb_io.write(nwb)
    data = buf.getbuffer()
    with open(path, "wb") as out:
        out.write(data)
        out.flush()
        os.fsync(out.fileno())


def _npz_unit(name: str, sources: dict[str, tuple[str, str, float, str]]) -> str | None:
    """The unit of the npz array ``name`` (None: labels, indices or flags)."""
    if name.startswith("spikes_"):
        return "s" if name.endswith("_times") else None  # _indices: neuron indices
    if name.startswith("units_"):
        return None  # trial, limb, pool of each neuron
    if name.startswith("trace_"):
        trace = name[len("trace_"):]
        if trace.endswith("_t"):
            return "s"
        if trace not in sources:
            return None
        unit = sources[trace][3]
        return "dimensionless" if unit == "a.u." else unit
    return ROBOT_UNITS[name[len("robot_"):]]


def export_npz(folder: Path, path: Path, *, experimenter: Sequence[str] = (),
               institution: str | None = None) -> Path:
    """Write ``folder`` as the npz file ``path`` (see the module's docstring)."""
    data = _load(folder)
    m = data["manifest"]
    arrays: dict[str, np.ndarray] = {}
    for pop, rows in unit_rows(m).items():
        if f"{pop}_times" not in data["spikes"]:
            continue
        arrays[f"spikes_{pop}_times"] = data["spikes"][f"{pop}_times"]
        arrays[f"spikes_{pop}_indices"] = data["spikes"][f"{pop}_indices"]
        for col in ("trial", "limb", "pool"):
            arrays[f"units_{pop}_{col}"] = np.array([r[col] for r in rows])
    for name, v in data.get("traces", {}).items():
        arrays[f"trace_{name}"] = v
    for name, v in data.get("robot", {}).items():
        arrays[f"robot_{name}"] = v
    sources = trace_sources(_rows(m))  # the folder's traces, as its manifest's rows say
    units = {name: _npz_unit(name, sources) for name in arrays}
    arrays["array_units_json"] = np.array(json.dumps(units))
    arrays["metadata_json"] = np.array(json.dumps(
        _metadata(m) | {"models": m.get("models"), "experimenter": list(experimenter),
                        "institution": institution}, default=str))
    save_npz(path, arrays, compressed=True)
    return path

def default_path(folder: Path, fmt: str) -> Path:
    """``<folder>.<fmt>`` beside the folder: an export never changes the folder it reads."""
    folder = Path(os.path.abspath(folder))
    return folder.with_name(f"{folder.name}.{fmt}")


def export(folder: Path, fmt: str, out: Path | None = None, *, overwrite: bool = False,
           experimenter: Sequence[str] = (), institution: str | None = None) -> Path:
    """Export the run, unit or recorded-session ``folder`` to ``out`` (default
    :func:`default_path`) as NWB or npz, atomically; returns the path written.

    experimenter: who ran the simulation, each as "Last, First" (DANDI's form); institution:
    where. Only the person exporting knows them: given neither, they are read from the
    environment, ``ASTROCPG_EXPERIMENTER`` (names separated by ";") and
    ``ASTROCPG_INSTITUTION``, so a lab sets them once; without any, nwbinspector suggests adding
    them (its only messages on the file)."""
    if fmt not in ("nwb", "npz"):
        raise InputError(f"must be nwb or npz, got '{fmt}'{did_you_mean(fmt, ('nwb', 'npz'))}",
                         culprit=setting("format"))
    experimenter = tuple(experimenter)
    if not experimenter and os.environ.get("ASTROCPG_EXPERIMENTER", "").strip():
        experimenter = tuple(n.strip() for n in os.environ["ASTROCPG_EXPERIMENTER"].split(";")
                             if n.strip())
    if institution is None and os.environ.get("ASTROCPG_INSTITUTION", "").strip():
        institution = os.environ["ASTROCPG_INSTITUTION"].strip()
    for name in experimenter:
        if not re.match(EXPERIMENTER_FORM, name):
            raise InputError(f"'{name}' is not of the form 'Last, First' (e.g. 'Doe, Jane')",
                             culprit=setting("experimenter"))
    if institution is not None and not institution.strip():
        raise InputError("is empty", culprit=setting("institution"))
    folder = Path(folder)
    path = Path(out) if out is not None else default_path(folder, fmt)
    shown = setting("out", out) if out is not None else f"export {path}"
    if path.is_dir():
        raise InputError("is a folder; name the file to write", culprit=shown)
    # an export never writes into the folder it reads, nor replaces a file an output lists
    check_output_path(path, [folder], culprit=shown, file=True)
    if path.exists() and not overwrite:
        raise InputError(f"exists; {setting('overwrite')} replaces it", culprit=shown)
    check_replaceable(path, culprit=shown)
    if not path.parent.is_dir():
        raise InputError(f"folder '{path.parent}' does not exist", culprit=shown)
    refuse_in_use(path, culprit=shown)  # never into a folder a running train or study holds
    clean_stale_temporaries(path.parent)  # what a killed export left
    write = export_nwb if fmt == "nwb" else export_npz
    return write(folder, path, experimenter=experimenter, institution=institution)
