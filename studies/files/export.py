"""``astrocpg export DIR --format nwb|npz``: a simulation folder as one file for analysis tools.

DIR is the output of ``astrocpg run`` or ``astrocpg unit``, or one recorded session of a
training (``TRAINING/recordings/trialTT_sessionSSSS``, written by ``astrocpg train
--record-every N``): ``spikes.npz``, ``traces.npz``, ``robot.npz``, ``manifest.json``. What it
holds was chosen when it was recorded: ``--spikes`` and ``--traces`` pick populations and traces,
``--trace-dt``/``--robot-stride`` (``--record-stride`` and ``--record-every`` in training) the
sampling, so a long run or training does not fill the disk.

NWB (pynwb): every neuron of every recorded population is a row of the Units table with its
spike times and the columns ``population``, ``trial``, ``limb``, ``pool`` and ``neuron_index``
(its index in the population, the column of its trace); astrocyte "spikes" are adenosine
releases. Traces (motor-neuron Ca2+, astrocyte Ca2+, IP3, 2-AG, adenosine) and, per trial, joint
angles, torques and the torso's position and velocity are TimeSeries with their units. The
model parameters (value, unit, the paper's symbol, meaning) and equations are tables in the
``model`` processing module; the seed and settings are in the file's ``notes`` and
``session_description``.

npz: the same arrays in one compressed file, the unit metadata as string arrays and the
metadata as a JSON string (``metadata_json``).
"""

from __future__ import annotations

import hashlib
import io
import json
import os
import zipfile
import zlib
from datetime import datetime
from pathlib import Path
from typing import Any

import numpy as np

from ...errors import InputError
from ...network.recordable import TRACE_SOURCES
from .folder import clean_stale_temporaries, verify
from .outputs import atomic_path, save_npz

TRACE_MEANING = {
    "motor_Ca": "motor-neuron Ca2+ (dimensionless, drives the K+ adaptation current)",
    "astrocyte_Ca": "astrocyte cytosolic Ca2+ (Li-Rinzel)",
    "astrocyte_IP3": "astrocyte IP3",
    "astrocyte_AG": "2-AG (endocannabinoid) at the astrocyte",
    "astrocyte_ADO": "adenosine released by the astrocyte",
}
ROBOT_SERIES = (("joint_angles", "radian", "joint angles"),
                ("torques", "N*m", "joint torques as applied (clipped to the motors' range)"),
                ("torso_position", "meter", "torso position, world frame"),
                ("torso_velocity", "m/s", "torso linear velocity, world frame"))


def _load(folder: Path) -> dict[str, Any]:
    # the folder's files are exactly what its manifest lists (or it is refused, naming why)
    manifest = verify(folder, culprit="export")
    if manifest.get("astrocpg_command") not in ("run", "unit", "train-session"):
        raise InputError(f"holds a '{manifest.get('astrocpg_command')}' "
                         f"folder; export reads the output of astrocpg run or unit, or a "
                         f"recorded training session (DIR/recordings/trialTT_sessionSSSS, from "
                         f"astrocpg train --record-every N)", culprit=f"export {folder}")
    data: dict[str, Any] = {"manifest": manifest}
    for name in ("spikes", "traces", "robot"):
        path = folder / f"{name}.npz"
        if path.exists():
            try:
                with np.load(path, allow_pickle=False) as z:
                    data[name] = {k: z[k] for k in z.files}
            except (ValueError, EOFError, zipfile.BadZipFile, zlib.error) as e:
                raise InputError(f"{name}.npz is corrupt or truncated ({type(e).__name__}); "
                                 f"record the run again", culprit=f"export {folder}") from None
    data.setdefault("spikes", {})  # recorded with --spikes none: export what exists
    return data


def unit_rows(manifest: dict[str, Any]) -> dict[str, list[dict[str, Any]]]:
    """Per population, one dict per neuron: trial, limb, pool (or interneuron name), index.

    The order is the populations' index order (see the manifest's layout): trial, then leg,
    then pool, interneuron or astrocyte, then (motor neurons) neuron within the pool."""
    lay = manifest["results"]["layout"]
    per_leg = {"motor": [p for p in lay["pools"] for _ in range(lay["pool_size"])],
               "interneuron": list(lay["interneurons"]),
               "astrocyte": list(lay["thigh_pools"])}
    rows: dict[str, list[dict[str, Any]]] = {}
    for pop, cells in per_leg.items():
        rows[pop] = [{"trial": b, "limb": leg, "pool": cell}
                     for b in range(lay["n_trials"]) for leg in lay["legs"] for cell in cells]
        for k, row in enumerate(rows[pop]):
            row["neuron_index"] = k
    return rows


def _spike_trains(times: np.ndarray, indices: np.ndarray, n: int) -> list[np.ndarray]:
    order = np.lexsort((times, indices))
    t, i = times[order], indices[order]
    bounds = np.searchsorted(i, np.arange(n + 1))
    return [t[bounds[k]:bounds[k + 1]].astype(np.float64) for k in range(n)]


def _metadata(manifest: dict[str, Any]) -> dict[str, Any]:
    return {k: manifest.get(k) for k in ("astrocpg_command", "seed", "settings", "argv",
                                          "created", "package_versions", "git")}


def export_nwb(folder: Path, path: Path) -> Path:
    from hdmf.common import DynamicTable, VectorData
    from pynwb import NWBHDF5IO, NWBFile, ProcessingModule, TimeSeries
    from pynwb.file import Subject
    from pynwb.misc import Units

    data = _load(folder)
    m = data["manifest"]
    created = datetime.strptime(m["created"], "%Y-%m-%dT%H:%M:%S%z")
    settings = m.get("settings", {})
    lay = m["results"]["layout"]
    digest = hashlib.sha256(json.dumps(_metadata(m), sort_keys=True, default=str)
                            .encode()).hexdigest()
    nwb = NWBFile(
        session_description=(f"astrocpg {m['astrocpg_command']}: simulated astrocyte-regulated "
                             f"spiking CPG, {lay['n_trials']} trial(s), seed {m['seed']} "
                             f"(trial b uses seed {m['seed']}+b), "
                             f"{settings.get('seconds', '?')} s"),
        identifier=f"astrocpg-{digest[:32]}",
        session_start_time=created,
        experiment_description=("Simulation of the astrocyte-regulated spiking CPG of a "
                                "quadruped (Brian2), coupled to a Unitree A1 in MuJoCo"),
        notes=json.dumps(_metadata(m), default=str),
        source_script=" ".join(m.get("argv") or []),
        source_script_file_name="astrocpg",
        keywords=["spiking neural network", "central pattern generator", "astrocyte",
                  "simulation"],
    )
    # a simulated subject: no animal, no sex (U = unknown); it comes into being when the
    # simulation starts, so its date of birth is the session start
    nwb.subject = Subject(subject_id="astrocpg-simulation", sex="U", date_of_birth=created,
                          description=("a simulated spiking CPG with astrocytes driving a "
                                       "simulated Unitree A1 quadruped robot; no animal"))
    populations = unit_rows(m)
    spikes = data["spikes"]
    recorded = [pop for pop in populations if f"{pop}_times" in spikes]
    if recorded:  # recorded with --spikes none: no Units table
        nwb.units = Units(name="units", resolution=_resolution(m, data),
                          description="spikes of the simulated neurons (astrocytes: adenosine "
                                      "releases)")
    for col, desc in (("population", "motor (motor neuron), interneuron (V1/V2b or IIN), "
                                     "astrocyte (spike = adenosine release)"),
                      ("trial", "independent trial of the batch (seed = file seed + trial)"),
                      ("limb", "leg: FR, FL, RR, RL"),
                      ("pool", "motor pool, interneuron (source_to_target) or astrocyte's pool"),
                      ("neuron_index", "index within the population (column of its trace)")):
        if recorded:
            nwb.add_unit_column(name=col, description=desc)
    for pop, rows in populations.items():
        if pop not in recorded:
            continue
        trains = _spike_trains(spikes[f"{pop}_times"], spikes[f"{pop}_indices"], len(rows))
        for row, train in zip(rows, trains):
            nwb.add_unit(spike_times=train, population=pop, **row)
    dims = {"motor": (len(lay["legs"]), len(lay["pools"]) * lay["pool_size"]),
            "astrocyte": (1, len(lay["legs"]) * len(lay["thigh_pools"]))}
    for name, values in sorted(data.get("traces", {}).items()):
        if name.endswith("_t"):
            continue
        t = data["traces"][f"{name}_t"]
        dt = float(np.median(np.diff(t))) if len(t) > 1 else 1e-3
        population = name.split("_")[0]
        # one series per trial and limb (motor) or per trial (astrocytes): time stays the
        # longest dimension, and a series is one limb's or one trial's cells
        n_parts, width = dims[population]
        for part in range(values.shape[1] // width):
            b, limb = divmod(part, n_parts)
            cols = slice(part * width, (part + 1) * width)
            suffix = f"trial{b}_{lay['legs'][limb]}" if population == "motor" else f"trial{b}"
            nwb.add_acquisition(TimeSeries(
                name=f"{name}_{suffix}", data=values[:, cols], unit=TRACE_SOURCES[name][3],
                rate=1.0 / dt, starting_time=float(t[0]) if len(t) else 0.0,
                description=(f"{TRACE_MEANING.get(name, name)}; column k = neuron_index "
                             f"{cols.start}+k of the {population} population in the Units "
                             f"table")))
    robot = data.get("robot")
    if robot is not None:
        t = robot["t"]
        dt = float(np.median(np.diff(t))) if len(t) > 1 else 1e-3
        legs, joints = [str(x) for x in robot["legs"]], [str(x) for x in robot["joints"]]
        for key, unit, meaning in ROBOT_SERIES:
            arr = robot[key]
            for b in range(arr.shape[0]):
                values = arr[b].reshape(arr.shape[1], -1)
                columns = ([f"{leg}_{j}" for leg in legs for j in joints]
                           if values.shape[1] == len(legs) * len(joints) else ["x", "y", "z"])
                nwb.add_acquisition(TimeSeries(
                    name=f"{key}_trial{b}", data=values, unit=unit, rate=1.0 / dt,
                    starting_time=float(t[0]), description=f"{meaning}; columns: "
                                                           f"{', '.join(columns)}"))
    module = ProcessingModule(name="misc", description="the model as simulated: parameters and "
                                                        "equations of every model (astrocpg)")
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
    nwb.add_processing_module(module)
    atomic_path(path, lambda p: _nwb_write(NWBHDF5IO, nwb, p))
    return path


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


def export_npz(folder: Path, path: Path) -> Path:
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
    arrays["metadata_json"] = np.array(json.dumps(
        _metadata(m) | {"models": m.get("models"),
                        "units": {n: src[3] for n, src in TRACE_SOURCES.items()}
                        | {"robot_joint_angles": "rad", "robot_torques": "N m",
                           "spike times": "s"}}, default=str))
    save_npz(path, arrays)
    return path


def default_path(folder: Path, fmt: str) -> Path:
    """``<folder>.<fmt>`` beside the folder: an export never changes the folder it reads."""
    folder = Path(os.path.abspath(folder))
    return folder.with_name(f"{folder.name}.{fmt}")


def export(folder: Path, fmt: str, out: Path | None = None, *, overwrite: bool = False) -> Path:
    """Export the run, unit or recorded-session ``folder`` to ``out`` (default
    :func:`default_path`) as NWB or npz, atomically; returns the path written."""
    if fmt not in ("nwb", "npz"):
        raise InputError(f"must be nwb or npz, got '{fmt}'", culprit="--format")
    folder = Path(folder)
    path = Path(out) if out is not None else default_path(folder, fmt)
    shown = f"--out {out}" if out is not None else f"export {path}"
    if path.is_dir():
        raise InputError("is a folder; name the file to write", culprit=shown)
    if path.exists() and not overwrite:
        raise InputError("exists; --overwrite replaces it", culprit=shown)
    if not path.parent.is_dir():
        raise InputError(f"folder '{path.parent}' does not exist", culprit=shown)
    clean_stale_temporaries(path.parent)  # what a killed export left
    return export_nwb(folder, path) if fmt == "nwb" else export_npz(folder, path)
