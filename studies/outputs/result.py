"""Results as Python objects: one :class:`Result` type for a unit, a closed-loop run, a training
and a recorded training session, made in this process or loaded from an output folder.

    >>> import astrocpg as ac
    >>> r = ac.run(seconds=1, seed=3)                 # or ac.load("out/run")
    >>> r.spike_times("motor", trial=0, leg="FR", pool="thigh_flexor")   # seconds, sorted
    >>> ca = r.trace("astrocyte_Ca")                  # ca.t (second), ca.values (umolar)
    >>> ca.column(trial=0, leg="FR", pool="thigh_extensor")
    >>> r.robot["torso_position"]                     # (trial, t, xyz) m
    >>> r.network, r.monitors                         # live objects (this process only)

Indices follow the manifest's ``results.layout`` (:class:`astrocpg.network.Layout`): a motor
neuron is ``trial*motor_per_trial + (leg*4 + pool)*pool_size + k``, an interneuron
``trial*interneurons_per_trial + leg*6 + interneuron``, an astrocyte
``trial*thigh_pools_per_trial + leg*2 + (0 flexor, 1 extensor)``.
"""

from __future__ import annotations

import json
import os
import zipfile
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Mapping

import numpy as np

from ...errors import EnvironmentFault, InputError, did_you_mean
from ...support.reading import open_regular, read_json
from ...network.layout import LEGS, Layout
from ...network.populations import spike_populations, trace_sources
from .folder import MANIFEST, as_path, verify

#: what each ``astrocpg_command`` of a manifest loads as
KINDS = {"unit": "unit", "run": "run", "train": "train", "study-run": "train",
         "train-session": "train-session"}

def _cells(layout: Layout, population: str) -> list[tuple[str, str, int]]:
    """(leg, pool or interneuron, k within the pool) of each cell of one trial, in index order
    (the population table's cells of one limb, limb after limb)."""
    per_leg = layout.row(population).cells(layout.pool_size)
    return [(leg, pool, k) for leg in layout.legs for pool, k in per_leg]


def _pool_names(layout: Layout, population: str) -> tuple[str, ...]:
    """The labels (pools, interneurons ...) of one limb's cells, each once."""
    return tuple(dict.fromkeys(layout.row(population).labels(layout.pool_size)))


def _known_and_recorded(kind: str, name: str, known: Any, recorded: Any, culprit: str) -> None:
    """InputError naming ``culprit`` unless ``name`` is a known ``kind`` (with a suggestion
    otherwise) that this result recorded."""
    if name not in known:
        raise InputError(f"unknown {kind}{did_you_mean(name, list(known))} ({kind}s: "
                         f"{_choices(known)})", culprit=culprit)
    if name not in recorded:
        raise InputError(f"was not recorded in this result (recorded: "
                         f"{_choices(recorded) or 'none'})", culprit=culprit)


def _choices(values: Any) -> str:
    return ", ".join(str(v) for v in values)


def _quantity(values: np.ndarray, unit_text: str) -> Any:
    """``values`` (stored in ``unit_text``: "uM", "a.u.", "s") as a Brian2 Quantity."""
    import brian2

    units = {"uM": brian2.umolar, "s": brian2.second, "mV": brian2.mV, "a.u.": None}
    unit = units.get(unit_text)
    arr = np.asarray(values, dtype=np.float64)
    return brian2.Quantity(arr) if unit is None else arr * unit


@dataclass(frozen=True, eq=False)
class Trace:
    """One recorded trace: ``t`` (Quantity in second, shape (samples,)), ``values`` (Quantity in
    the trace's unit, shape (samples, columns)), ``unit`` (the stored unit's text, e.g. "uM",
    "a.u." for dimensionless) and ``columns``: for each column a dict ``{"trial", "leg",
    "pool", "index"}`` (``index``: the cell's index in its population) and, for motor neurons,
    ``"neuron"`` (its place in the pool, 0..pool_size-1)."""

    name: str
    t: Any
    values: Any
    unit: str
    columns: list[dict[str, Any]] = field(repr=False)

    def indices(self, trial: int = 0, leg: str = "FR", pool: str = "thigh_flexor",
                neuron: int | None = None) -> np.ndarray:
        """The column numbers of ``trial``'s cells in ``leg``'s ``pool`` (one neuron with
        ``neuron``); InputError naming the argument when nothing matches."""
        for arg, value, key in (("trial", trial, "trial"), ("leg", leg, "leg"),
                                ("pool", pool, "pool")):
            valid = list(dict.fromkeys(c[key] for c in self.columns))
            if value not in valid:
                raise InputError(f"not in trace {self.name} (valid: {_choices(valid)})",
                                 culprit=f"{arg}={value!r}")
        cols = [j for j, c in enumerate(self.columns)
                if c["trial"] == trial and c["leg"] == leg and c["pool"] == pool]
        if neuron is not None:
            if not isinstance(neuron, (int, np.integer)) or not 0 <= neuron < len(cols):
                raise InputError(f"must be an integer in 0..{len(cols) - 1} for trace "
                                 f"{self.name}", culprit=f"neuron={neuron!r}")
            cols = [cols[int(neuron)]]
        return np.asarray(cols, dtype=np.intp)

    def column(self, trial: int = 0, leg: str = "FR", pool: str = "thigh_flexor",
               neuron: int | None = None) -> Any:
        """The values of one cell over time, a Quantity of shape (samples,): the astrocyte of
        ``leg``'s ``pool`` (a thigh pool), or with ``neuron`` one motor neuron of the pool.
        For a motor-neuron trace without ``neuron``: the pool's neurons, (samples, pool_size).
        """
        cols = self.indices(trial, leg, pool, neuron)
        return self.values[:, cols[0]] if len(cols) == 1 else self.values[:, cols]

    def __repr__(self) -> str:
        n, m = (self.values.shape + (1,))[:2]
        t = np.asarray(self.t)  # in second
        return (f"Trace({self.name!r}: {n} samples x {m} columns in {self.unit}, "
                f"t {t[0] if n else 0:g}..{t[-1] if n else 0:g} s)")


class Result:
    """What a unit, a closed-loop run, a training or a recorded training session produced.

    Made by ``astrocpg.unit/run/train/resume`` (then ``network`` and ``monitors`` are the live
    Brian2 objects and ``models`` the ModelSet) or by :func:`~astrocpg.load` from an output folder (then
    they are None). Attributes:

    kind        "unit", "run", "train" or "train-session"
    folder      the output folder (a Path), or None when nothing was written
    manifest    the folder's manifest.json as a dict (in memory: the same keys that matter:
                astrocpg_command, seed, settings, models, results)
    seconds     simulated seconds (None for a training)
    seed        the seed (trial b used seed + b)
    layout      the index layout (:class:`astrocpg.network.Layout`)
    spikes      {population: (times in s, indices)}, as recorded
    traces      {name: (t in s, values (samples, columns))}, as recorded (see :meth:`trace`)
    robot       {name: array} as in robot.npz (None for a unit and a training)
    summary     the manifest's ``results``: rhythm (unit); distance_m, mean speed, rates (run);
                status and per-trial figures (training)
    sessions    (training) sessions.csv as a pandas DataFrame
    weights     (training) each trial's inter-limb table after each session,
                (trial, session, 8, 8) in mV (NaN after a trial's last session)
    models      the ModelSet (made in this process, or rebuilt from the manifest)
    network, monitors, simulation, trainer: live objects (this process only)
    """

    def __init__(self, *, kind: str, layout: Layout, manifest: Mapping[str, Any],
                 folder: str | os.PathLike | None = None, seconds: float | None = None,
                 seed: int = 1, spikes: Mapping[str, tuple[np.ndarray, np.ndarray]] | None = None,
                 traces: Mapping[str, tuple[np.ndarray, np.ndarray]] | None = None,
                 robot: Mapping[str, np.ndarray] | None = None,
                 summary: Mapping[str, Any] | None = None, sessions: Any = None,
                 weights: np.ndarray | None = None, network: Any = None,
                 monitors: Mapping[str, Any] | None = None, models: Any = None,
                 simulation: Any = None, trainer: Any = None) -> None:
        self.kind = kind
        self.layout = layout
        self.manifest = dict(manifest)
        self.folder = None if folder is None else Path(folder)
        self.seconds = None if seconds is None else float(seconds)
        self.seed = int(seed)
        self.spikes = dict(spikes or {})
        self.traces = dict(traces or {})
        self.robot = None if robot is None else dict(robot)
        self.summary = dict(summary or {})
        self.sessions = sessions
        self.weights = weights
        self.network = network
        self.monitors = None if monitors is None else dict(monitors)
        self._models = models
        self.simulation = simulation
        self.trainer = trainer

    @property
    def models(self) -> Any:
        """The :class:`~astrocpg.models.ModelSet` it was simulated with: the live one, or
        rebuilt from the manifest's ``models`` (None where that is not possible)."""
        if self._models is None and isinstance(self.manifest.get("models"), dict):
            from ...models import ModelSet

            try:
                self._models = ModelSet.from_json(self.manifest["models"])
            except (InputError, KeyError, TypeError, ValueError, AttributeError):
                return None
        return self._models

    @models.setter
    def models(self, value: Any) -> None:
        self._models = value

    # ------------------------------------------------------------ construction
    @classmethod
    def from_simulation(cls, sim: Any, *, kind: str, seed: int, settings: Mapping[str, Any],
                        summary: Mapping[str, Any], robot: Mapping[str, np.ndarray] | None = None,
                        models: Any = None, folder: str | os.PathLike | None = None) -> "Result":
        """The result of a simulation made in this process (``sim``: the experiments'
        SimulationResult: cpg, seconds, spikes, traces, monitors). ``summary`` is what the
        manifest's ``results`` holds; with ``folder`` (written), its manifest is read back."""
        summary = _plain(summary)
        manifest = _read_manifest(Path(folder)) if folder is not None else None
        if manifest is None:
            manifest = {"astrocpg_command": kind, "seed": seed, "settings": _plain(settings),
                        "models": models.to_json() if models is not None else {},
                        "results": summary}
        return cls(kind=kind, layout=sim.cpg.layout, manifest=manifest, folder=folder,
                   seconds=sim.seconds, seed=seed, spikes=sim.spikes, traces=sim.traces,
                   robot=robot, summary=summary, network=sim.cpg.net,
                   monitors=getattr(sim, "monitors", None) or {}, models=models, simulation=sim)

    @classmethod
    def from_training(cls, trainer: Any, folder: str | os.PathLike) -> "Result":
        """The training in ``folder`` (just written by ``trainer``), with the live network."""
        result = load(folder)
        result.network, result.monitors = trainer.cpg.net, {}
        result.models, result.trainer = trainer.models, trainer
        return result

    # ------------------------------------------------------------ spikes
    @property
    def n_trials(self) -> int:
        """How many independent trials (copies of the network) it holds."""
        return self.layout.n_trials

    def _population(self, population: str) -> None:
        _known_and_recorded("population", population, spike_populations(self.layout.rows),
                            self.spikes,
                            f"population={population!r}")
        return population

    def neurons(self, population: str, trial: int | None = 0, leg: str | None = None,
                pool: str | None = None, neuron: int | None = None) -> np.ndarray:
        """Indices (in the population) of the cells :meth:`spike_times` selects."""
        POPULATIONS = spike_populations(self.layout.rows)
        if population not in POPULATIONS:
            raise InputError(f"unknown population{did_you_mean(population, POPULATIONS)} "
                             f"(populations: {_choices(POPULATIONS)})",
                             culprit=f"population={population!r}")
        L = self.layout
        if trial is not None and (not isinstance(trial, (int, np.integer)) or isinstance(trial, bool)
                                  or not 0 <= trial < L.n_trials):
            raise InputError(f"must be an integer in 0..{L.n_trials - 1} (or None: every trial)",
                             culprit=f"trial={trial!r}")
        if leg is not None and leg not in L.legs:
            raise InputError(f"unknown leg{did_you_mean(leg, L.legs)} (legs: {_choices(L.legs)})",
                             culprit=f"leg={leg!r}")
        names = _pool_names(L, population)
        if pool is not None and pool not in names:
            what = L.row(population).label_meaning or "pools"
            raise InputError(f"not a {population} pool ({what}: {_choices(names)})",
                             culprit=f"pool={pool!r}")
        cells = _cells(L, population)
        local = np.arange(len(cells))
        if neuron is not None:
            if (leg is None) != (pool is None):
                raise InputError("needs both leg= and pool= (the neuron's place in the pool), "
                                 "or neither (its index within the trial)",
                                 culprit=f"neuron={neuron!r}")
            if leg is not None:
                local = np.array([j for j, c in enumerate(cells) if c[0] == leg and c[1] == pool])
            if (not isinstance(neuron, (int, np.integer)) or isinstance(neuron, bool)
                    or not 0 <= neuron < len(local)):
                where = f"{leg} {pool}" if leg is not None else "a trial"
                raise InputError(f"must be an integer in 0..{len(local) - 1} ({len(local)} "
                                 f"{population} cells in {where})", culprit=f"neuron={neuron!r}")
            local = local[[int(neuron)]]
        else:
            local = np.array([j for j in local if (leg is None or cells[j][0] == leg)
                              and (pool is None or cells[j][1] == pool)], dtype=np.intp)
        trials = range(L.n_trials) if trial is None else [int(trial)]
        return np.concatenate([b * len(cells) + local for b in trials]).astype(np.intp)

    def spike_times(self, population: str, trial: int | None = 0, leg: str | None = None,
                    pool: str | None = None, neuron: int | None = None) -> np.ndarray:
        """Spike times in seconds, sorted, of ``population`` ("motor", "interneuron" or
        "astrocyte" = adenosine releases) in ``trial`` (None: every trial), optionally only
        ``leg`` ("FR", "FL", "RR", "RL") and ``pool`` (motor: "thigh_flexor",
        "thigh_extensor", "calf_flexor", "calf_extensor"; astrocyte: a thigh pool;
        interneuron: its name, e.g. "thigh_flexor_to_extensor"). ``neuron``: one cell, its
        place in the pool (with leg and pool) or its index within the trial (without).
        Bad arguments: InputError naming the argument and listing the valid values."""
        self._population(population)
        cells = self.neurons(population, trial, leg, pool, neuron)
        t, i = self.spikes[population]
        return np.sort(np.asarray(t, dtype=np.float64)[np.isin(i, cells)])

    def rate(self, population: str, trial: int | None = 0, leg: str | None = None,
             pool: str | None = None, t_start: float = 0.0) -> float:
        """Mean firing rate per cell (Hz) of the selection, from ``t_start`` (s) to the end."""
        if self.seconds is None:
            raise InputError("a training result holds no spikes; load one of its recordings",
                             culprit="rate")
        n = len(self.neurons(population, trial, leg, pool))
        t = self.spike_times(population, trial, leg, pool)
        span = self.seconds - float(t_start)
        return float(np.sum(t >= t_start) / (n * span)) if n and span > 0 else float("nan")

    # ------------------------------------------------------------ traces
    def trace(self, name: str) -> Trace:
        """A recorded trace as a :class:`Trace` (time in second, values with their unit, the
        columns mapped to trial/leg/pool): "motor_Ca" (a.u.), "astrocyte_Ca" and
        "astrocyte_IP3" (uM), "astrocyte_AG" and "astrocyte_ADO" (a.u.)."""
        TRACE_SOURCES = trace_sources(self.layout.rows)
        _known_and_recorded("trace", name, TRACE_SOURCES, self.traces, f"trace {name!r}")
        group, _, _, unit = TRACE_SOURCES[name]
        t, values = self.traces[name]
        values = np.asarray(values)
        if values.ndim == 1:
            values = values[:, None]
        cells = _cells(self.layout, group)
        # a population with several cells per label (motor neurons: pool_size per pool) numbers
        # each cell within its label
        per_label = max((k + 1 for _, _, k in cells), default=1)
        columns = [{"trial": b, "leg": leg, "pool": pool, "index": b * len(cells) + j}
                   | ({"neuron": k} if per_label > 1 else {})
                   for b in range(self.layout.n_trials) for j, (leg, pool, k) in enumerate(cells)]
        if len(columns) != values.shape[1]:
            raise InputError(f"holds {values.shape[1]} columns; the layout has {len(columns)}",
                             culprit=f"trace {name!r}")
        return Trace(name=name, t=_quantity(t, "s"), values=_quantity(values, unit), unit=unit,
                     columns=columns)

    # ------------------------------------------------------------ training
    @property
    def recordings(self) -> dict[tuple[int, int], Path]:
        """(training) The recorded sessions: {(trial, session): folder}; :meth:`recording`
        loads one."""
        base = None if self.folder is None else self.folder / "recordings"
        if base is None or not base.is_dir():
            return {}
        out = {}
        for p in sorted(base.iterdir()):
            name = p.name
            if p.is_dir() and name.startswith("trial") and "_session" in name:
                try:
                    trial, session = name[5:].split("_session")
                    out[(int(trial), int(session))] = p
                except ValueError:
                    continue
        return out

    def recording(self, trial: int = 0, session: int = 1) -> "Result":
        """(training) One recorded session (a training's ``record_every``) as a Result."""
        found = self.recordings
        if (trial, session) not in found:
            shown = _choices(f"({b}, {s})" for b, s in found) or "none"
            raise InputError(f"no such recorded session (recorded trial, session: {shown})",
                             culprit=f"recording(trial={trial!r}, session={session!r})")
        return load(found[(trial, session)])

    # ------------------------------------------------------------ repr
    def __repr__(self) -> str:
        L = self.layout
        what = f"{L.n_trials} trial{'s' if L.n_trials != 1 else ''}"
        if self.seconds is not None:
            what += f" x {self.seconds:g} s"
        lines = [f"<astrocpg Result: {self.kind}, {what}, seed {self.seed}, "
                 f"folder {self.folder if self.folder is not None else '(not written)'}"]
        if self.spikes:
            lines.append("  spikes: " + ", ".join(f"{p} {len(t)}" for p, (t, _) in
                                                  self.spikes.items())
                         + "  -> spike_times(population, trial, leg, pool, neuron)")
        if self.traces:
            lines.append("  traces: " + ", ".join(
                f"{n} {np.shape(v)[0]}x{np.shape(v)[1] if np.ndim(v) > 1 else 1} "
                f"{trace_sources(L.rows)[n][3] if n in trace_sources(L.rows) else ''}"
                for n, (_, v) in self.traces.items()) + "  -> trace(name)")
        if self.robot:
            lines.append("  robot: " + ", ".join(self.robot))
        if self.sessions is not None:
            lines.append(f"  sessions: {len(self.sessions)} rows; weights: "
                         f"{'x'.join(map(str, np.shape(self.weights)))} mV; "
                         f"recordings: {len(self.recordings)}")
        if self.summary:
            lines.append("  summary: " + ", ".join(self.summary))
        if self.network is not None:
            lines.append("  live: network, monitors" + (", trainer" if self.trainer else ""))
        return "\n".join(lines) + ">"


# ---------------------------------------------------------------- loading
def _plain(obj: Any) -> Any:
    """JSON-like copy (arrays -> lists): what a manifest holds after a round trip."""
    def default(o: Any) -> Any:
        if isinstance(o, np.ndarray):
            return o.tolist()
        if isinstance(o, np.generic):
            return o.item()
        return str(o)
    return json.loads(json.dumps(obj, default=default))


def _read_manifest(folder: Path) -> dict[str, Any] | None:
    try:
        data = read_json(folder / MANIFEST)
    except InputError:  # not a regular file, nested too deeply: refused, naming it
        raise
    except (OSError, ValueError):
        return None
    return data if isinstance(data, dict) else None


def _check_folder(folder: Path) -> dict[str, Any]:
    """The folder's manifest, once its files are checked: against the manifest's inventory
    (sizes and sha256, :func:`~astrocpg.studies.outputs.folder.verify`); a folder written before
    manifests had an inventory: every file its ``files`` names is there."""
    if not os.path.lexists(folder):  # a missing input: the environment's (exit 1)
        raise EnvironmentFault("no such folder", culprit=str(folder))
    if not folder.is_dir():
        raise InputError("is not a folder", culprit=str(folder))
    manifest = _read_manifest(folder)
    if manifest is None:
        state = "no" if not (folder / MANIFEST).exists() else "no readable"
        raise InputError(f"not an astrocpg output folder ({state} {MANIFEST})",
                         culprit=str(folder))
    if "inventory" in manifest:  # every listed file as written (extra files are let be)
        return verify(folder, strict=False)
    files = manifest.get("files")
    if not isinstance(files, dict):
        raise InputError(f"not an astrocpg output folder ({MANIFEST} lists no files)",
                         culprit=str(folder))
    for name in files:
        if not str(name).endswith("/") and not (folder / name).is_file():
            raise InputError(f"{name} is missing ({MANIFEST} lists it)", culprit=str(folder))
    return manifest


def _npz(folder: Path, name: str) -> dict[str, np.ndarray]:
    path = folder / name
    try:
        with open_regular(path, str(folder)) as f, np.load(f, allow_pickle=False) as z:
            return {k: z[k] for k in z.files}
    except (OSError, ValueError, EOFError, KeyError, zipfile.BadZipFile) as e:
        if isinstance(e, InputError):
            raise
        raise InputError(f"{name} cannot be read ({type(e).__name__}: corrupt or truncated?)",
                         culprit=str(folder)) from None


def _layout(manifest: Mapping[str, Any], folder: Path) -> Layout:
    try:
        return Layout.from_json(manifest["results"]["layout"])
    except (KeyError, TypeError, ValueError):
        raise InputError(f"{MANIFEST} has no index layout (results.layout)",
                         culprit=str(folder)) from None


def _training_layout(manifest: Mapping[str, Any], folder: Path) -> Layout:
    try:
        lay = manifest.get("results", {}).get("layout")
        if lay:
            return Layout.from_json(lay)
        # a training written before its manifest held the layout: the pool size its models
        # say (the manifest's model set, read as the models read it)
        from ...models import ModelSet

        size = int(ModelSet.from_json(manifest["models"]).value("pool_size"))
        return Layout(n_trials=int(manifest["settings"]["n_trials"]), pool_size=size, legs=LEGS)
    except (KeyError, TypeError, ValueError, AttributeError, InputError):
        raise InputError(f"{MANIFEST} does not say how many trials the training has, nor "
                         f"its pool size",
                         culprit=str(folder)) from None


def load(folder: str | os.PathLike) -> Result:
    """Read an output folder back: what ``astrocpg unit``, ``run`` or ``train`` wrote.

    Parameters
    ----------
    folder : path
        An output folder of ``astrocpg unit``, ``run``, ``train`` (or a study's run), or a
        recorded training session (``TRAINING/recordings/trialTT_sessionSSSS``).

    Returns
    -------
    Result
        Its :class:`~astrocpg.studies.outputs.result.Result`, every file checked against the
        folder's manifest.

    Raises
    ------
    ~astrocpg.errors.EnvironmentFault
        The folder does not exist.
    ~astrocpg.errors.InputError
        It is not an astrocpg output folder, or its files are missing, changed or corrupt (the
        folder named).
    """
    folder = as_path(folder, "folder")
    manifest = _check_folder(folder)
    command = manifest.get("astrocpg_command")
    kind = KINDS.get(command)
    if kind is None:
        raise InputError(f"holds the output of 'astrocpg {command}'; load reads the folders of "
                         f"unit, run and train, and recorded training sessions",
                         culprit=str(folder))
    seed = manifest.get("seed", 1)
    summary = manifest.get("results") or {}
    if kind == "train":
        import pandas as pd

        try:
            sessions = pd.read_csv(folder / "sessions.csv")
        except (OSError, ValueError) as e:
            raise InputError(f"sessions.csv cannot be read ({type(e).__name__})",
                             culprit=str(folder)) from None
        w = _npz(folder, "weights.npz")
        if "weights_mV" not in w:
            raise InputError("weights.npz holds no weights_mV", culprit=str(folder))
        return Result(kind=kind, layout=_training_layout(manifest, folder), manifest=manifest,
                      folder=folder, seconds=None, seed=seed, summary=summary,
                      sessions=sessions, weights=w["weights_mV"])
    layout = _layout(manifest, folder)
    spikes_npz = _npz(folder, "spikes.npz") if (folder / "spikes.npz").exists() else {}
    spikes = {p: (spikes_npz[f"{p}_times"], spikes_npz[f"{p}_indices"])
              for p in spike_populations(layout.rows)
              if f"{p}_times" in spikes_npz and f"{p}_indices" in spikes_npz}
    traces_npz = _npz(folder, "traces.npz") if (folder / "traces.npz").exists() else {}
    traces = {n: (traces_npz[f"{n}_t"], traces_npz[n]) for n in trace_sources(layout.rows)
              if n in traces_npz and f"{n}_t" in traces_npz}
    robot = _npz(folder, "robot.npz") if (folder / "robot.npz").exists() else None
    settings = manifest.get("settings") or {}
    seconds = summary.get("seconds", settings.get("seconds"))
    return Result(kind=kind, layout=layout, manifest=manifest, folder=folder, seconds=seconds,
                  seed=seed, spikes=spikes, traces=traces, robot=robot, summary=summary)


__all__ = ["Result", "Trace", "load", "KINDS"]
