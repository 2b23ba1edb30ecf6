"""One locomotion unit (the FR limb's CPG) open loop: the paper's Fig. 1c rhythm.

``unit(...)`` is what ``astrocpg unit`` runs: it simulates, measures the rhythm per trial and,
given ``out``, writes spikes, traces, a raster figure and the manifest.
"""

from __future__ import annotations

import os
from pathlib import Path
from typing import Any, Mapping, Sequence

import numpy as np

from ...errors import Diverged, setting
from ...network.populations import trace_columns
from ...network.recording import overflowed
from ..analysis.rhythm import rhythm_summary
from ..outputs.folder import OutputFolder
from ..outputs.writing import save_spikes_and_traces, write_manifest
from ..outputs.result import Result
from ...models.compose import Overrides, model_files_record, model_set, override_items
from ..settings.checks import (STEP, check_duration, check_selection, check_trace_dt,
                               check_trace_dtype, number, seed_number)
from ..settings.populations import population_rows, population_table
from ..settings import UnitSettings
from ..runtime.resources import check_memory, estimate_batched
from ..runtime.workers import resolve_workers
from .batched import BatchedCPG, try_batched
from .simulate import SimulationResult, simulate_unit


def unit(*, seconds: float = 30.0, seed: int = 1, trials: int = 1,
         overrides: Overrides | None = None, equations: Mapping[str, str] | None = None,
         models: Mapping[str, Any] | None = None,
         trace_dt: float = 1.0, trace_dtype: str = "float32",
         spikes: tuple[str, ...] | None = None,
         traces: tuple[str, ...] | None = None, out: str | Path | None = None,
         overwrite: bool = False, progress: bool = True,
         inputs: Sequence[str | os.PathLike] = (), populations: Any = None,
         workers: int | None = None) -> Result:
    """Simulate locomotion units: the FR limb's CPG, open loop; what ``astrocpg unit`` runs.

    Parameters
    ----------
    seconds : float
        Simulated time in s, a whole number of 1 ms steps.
    seed : int
        Seed of trial 0; trial k has seed ``seed + k``.
    trials : int
        Independent units simulated together.
    overrides : mapping or sequence of str, optional
        Parameter values with units: ``{"tau_motor": "9*ms"}`` or ``["tau_motor=9*ms"]``.
    equations : mapping of str to str, optional
        ``{model: equation text}`` replacing a model's Brian2 equation string.
    models : mapping, optional
        ``{model: model file text}`` (TOML, as ``astrocpg models dump`` writes) replacing whole
        models.
    trace_dt : float
        Sampling interval of the traces, in ms.
    trace_dtype : {"float32", "float64"}
        How the traces are kept (float64: full resolution).
    spikes, traces : tuple of str, optional
        Which populations' spikes and which traces to record (None: all).
    out : path, optional
        Write the folder ``astrocpg unit`` writes, whole or nothing (its manifest records the
        checked settings); a folder that holds files is refused unless ``overwrite``.
    overwrite : bool
        Replace an existing ``out``: only a folder astrocpg wrote, and none of ``inputs``.
    progress : bool
        A progress bar on stderr.
    inputs : sequence of path
        Other files the caller read (e.g. model files): ``out`` may not be or hold one.
    populations : sequence or mapping, optional
        Model files with a ``[population]`` table (texts, or ``{file: text}``): populations added
        to the network (docs/model-files.md, "A new population").
    workers : int, optional
        Processes the trials are split over (default: the cores this process may use); the
        results are the same whatever the number.

    Returns
    -------
    Result
        A :class:`~astrocpg.studies.outputs.result.Result` of kind "unit"; its
        ``summary["rhythm"]`` holds each trial's period, phases and rates.

    Raises
    ------
    ~astrocpg.errors.InputError
        Bad input, naming the culprit, before anything is simulated or written.
    """
    population_record = population_rows(populations)[1]  # before any other check
    rows = population_table(population_record)  # the table this unit is built from
    settings, models, procs = _plan_unit(dict(locals()), rows)  # nothing touched yet
    return _unit_planned(settings, models, procs, rows, out, overwrite, inputs, progress)


def _plan_unit(a: dict[str, Any], rows: Sequence[Any]) -> tuple[dict[str, Any], Any, int]:
    """:func:`unit`'s arguments ``a`` checked and its memory estimated, with the population
    table ``rows``: the manifest's settings (the checked values, whichever door called), the
    model set and the processes; refused (InputError) before anything is simulated or
    written."""
    seconds = number(a["seconds"], setting("seconds"), positive=True)
    trials = number(a["trials"], setting("trials"), integer=True, minimum=1)
    seed = seed_number(a["seed"], trials=trials)
    trace_dt = number(a["trace_dt"], setting("trace_dt"), positive=True)
    check_trace_dt(trace_dt)  # samples are taken at steps: a whole number of them
    trace_dtype = check_trace_dtype(a["trace_dtype"])
    check_duration(seconds, STEP)
    if a["out"] is not None:  # before the simulation, not after
        OutputFolder(a["out"], overwrite=a["overwrite"], inputs=a["inputs"]).check()
    pops, names = check_selection(a["spikes"], a["traces"], rows)
    procs = min(resolve_workers(a["workers"]), trials)
    check_memory(estimate_batched(procs, trials=trials, seconds=seconds, dt=STEP,
                                  trace_dt=trace_dt * 1e-3, traces=trace_columns(names, rows),
                                  spikes=bool(pops),
                                  trace_bytes=np.dtype(trace_dtype).itemsize),
                 culprit=f"{setting('seconds', f'{seconds:g}')} x {setting('trials', trials)}"
                         + (f" x {setting('workers', procs)}" if procs > 1 else ""),
                 record_less=("spikes", "traces", "trace_dt"))
    files = model_files_record(a["models"])
    models = model_set(a["overrides"], a["equations"], models=a["models"],
                       added=[r.model for r in rows if not r.built_in])
    values = UnitSettings(seconds=seconds, seed=seed, trials=trials, trace_dt=trace_dt,
                          trace_dtype=trace_dtype, overrides=override_items(a["overrides"]),
                          equations=a["equations"], spikes=a["spikes"], traces=a["traces"],
                          models=files, populations=a["population_record"])
    return values.record(), models, procs


def _unit_planned(settings: dict[str, Any], models: Any, procs: int, rows: Sequence[Any],
                  out: str | Path | None, overwrite: bool,
                  inputs: Sequence[str | os.PathLike], progress: bool) -> Result:
    """Simulate the checked ``settings`` (over ``procs`` processes, or here) with the
    population table ``rows``, then write the folder (whole, or nothing; what ran, where it
    diverged) where ``out`` is given."""
    from brian2 import ms

    seconds, seed, trials = settings["seconds"], settings["seed"], settings["trials"]
    try:
        result = try_batched("unit", settings, trials, procs, progress)
        if result is None:  # one process (or a batch diverged: its folder written here)
            result = simulate_unit(models, seconds=seconds, seed=seed, n_trials=trials,
                                   trace_dt=settings["trace_dt"] * ms,
                                   spikes=settings["spikes"], traces=settings["traces"],
                                   progress=progress, trace_dtype=settings["trace_dtype"],
                                   populations=rows)
    except Diverged as e:  # the folder keeps what ran, and says it diverged
        partial = getattr(e, "result", None)
        if out is not None and partial is not None:
            partial.extra.update({"models": models, "rhythm": [], "status": "diverged",
                                  "error": {"line": e.line, "t_s": e.t, "trial": e.trial}})
            with OutputFolder(out, overwrite=overwrite, inputs=inputs) as folder:
                write_unit_folder(folder, partial, settings)
        raise
    result.extra["rhythm"] = rhythm_per_trial(result, seconds)
    result.extra["models"] = models
    result.extra["workers"] = procs if isinstance(result.cpg, BatchedCPG) else 1
    if out is not None:
        with OutputFolder(out, overwrite=overwrite, inputs=inputs) as folder:  # whole, or nothing
            write_unit_folder(folder, result, settings)
    return Result.from_simulation(result, kind="unit", seed=seed, settings=settings,
                                  summary=unit_results(result), models=models, folder=out)


def rhythm_per_trial(result: SimulationResult, seconds: float) -> list[dict[str, Any]]:
    """Period, phases vs the thigh flexor, rates per neuron and the interneurons' total rate of
    every trial (empty when motor or interneuron spikes were not recorded)."""
    L = result.cpg.layout
    if not {"motor", "interneuron"} <= set(result.spikes):
        return []
    # the first second is a transient; a unit shorter than 2 s skips its first half instead
    t_start = min(1.0, seconds / 2)
    summaries = []
    for b in range(L.n_trials):
        pools = {name: L.motor_neurons(b, 0, name) for name in ("thigh_flexor", "thigh_extensor",
                                                                 "calf_flexor", "calf_extensor")}
        t, i = result.spikes["motor"]
        s = rhythm_summary(t, i, pools, t_stop=seconds, t_start=t_start)
        ti, ii = result.spikes["interneuron"]
        mine = (ii // L.interneurons_per_trial == b) & (ti >= t_start)
        s["interneurons_total_Hz"] = float(mine.sum() / max(seconds - t_start, 1e-9))
        summaries.append(s)
    return summaries


def write_unit_folder(out: Path, result: SimulationResult, settings: Mapping[str, Any]) -> None:
    """spikes.npz, traces.npz, unit.png (when spikes were recorded) and manifest.json."""
    from ..figures import plots
    from ..figures.save import save_figure

    L = result.cpg.layout
    files = save_spikes_and_traces(out, result.spikes, result.traces)
    if {"motor", "interneuron"} <= set(result.spikes):
        save_figure(plots.plot_unit(result.spikes, L), out / "unit.png")
        files["unit.png"] = ("raster of the motor neurons and interneurons, and pool activity "
                             "(trial 0)")
    write_manifest(out, command="unit", seed=int(settings.get("seed", 1)), settings=settings,
                   models_json=result.extra["models"].to_json(), files=files,
                   results=unit_results(result))


def unit_results(result: SimulationResult) -> dict[str, Any]:
    """What the manifest's ``results`` (and the Result's ``summary``) hold for a unit."""
    return {"status": result.extra.get("status", "finished"), "error": result.extra.get("error"),
            "rhythm": result.extra.get("rhythm", []), "wall_seconds": result.wall_seconds,
            "workers": result.extra.get("workers", 1),
            "dt_s": float(result.cpg.dt), "seconds": result.seconds,
            "layout": result.cpg.layout.to_json(),
            # never silent: which traces lost values to float32 (stored as inf), how many
            "trace_overflow": overflowed(result.traces)}


def format_rhythm(b: int, seed: int, s: Mapping[str, Any]) -> str:
    """One line per trial: period, phases, rates."""
    def f(key: str, fmt: str = ".3f") -> str:
        v = s.get(key)
        return "n/a" if v is None or (isinstance(v, float) and not np.isfinite(v)) else format(v, fmt)
    ph = s.get("phases", {})
    rates = s.get("rates", {})
    phases = ", ".join(f"{k} {v:.2f}" for k, v in ph.items()) if ph else "n/a"
    rate_text = ", ".join(f"{k} {v:.1f} Hz" for k, v in rates.items()) if rates else "n/a"
    return (f"unit {b} (seed {seed}): period {f('period')} s; phases vs thigh flexor: "
            f"{phases}; rate per neuron: {rate_text}; interneurons "
            f"{s.get('interneurons_total_Hz', float('nan')):.0f} Hz in total")
