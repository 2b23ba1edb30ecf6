"""One locomotion unit (the FR limb's CPG) open loop: the paper's Fig. 1c rhythm.

``unit(...)`` is what ``astrocpg unit`` runs: it simulates, measures the rhythm per trial and,
given ``out``, writes spikes, traces, a raster figure and the manifest.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any, Mapping

import numpy as np

from ..analysis.rhythm import rhythm_summary
from ..files.folder import OutputFolder
from ..files.outputs import save_spikes_and_traces, write_manifest
from .settings import Overrides, model_set, number, override_items
from .resources import check_memory, estimate_bytes
from .simulate import STEP, SimulationResult, check_duration, check_selection, simulate_unit


def unit(*, seconds: float = 30.0, seed: int = 1, trials: int = 1,
         overrides: Overrides | None = None, equations: Mapping[str, str] | None = None,
         trace_dt: float = 1.0, spikes: tuple[str, ...] | None = None,
         traces: tuple[str, ...] | None = None, out: str | Path | None = None,
         overwrite: bool = False, progress: bool = True, settings: Mapping[str, Any] | None = None) -> SimulationResult:
    """Simulate ``trials`` independent locomotion units (seeds seed, seed+1, ...) for
    ``seconds``; ``trace_dt`` in ms; ``overrides`` as ``{"tau_motor": "9*ms"}`` or
    ``["tau_motor=9*ms"]``; ``equations`` as ``{model: equation text}``. The result's
    ``extra["rhythm"]`` holds each trial's period, phases and rates. With ``out``, writes the
    folder ``astrocpg unit`` writes (``settings`` goes into its manifest)."""
    from brian2 import ms

    seconds = number(seconds, "--seconds", positive=True)
    trials = number(trials, "--trials", integer=True, minimum=1)
    seed = number(seed, "--seed", integer=True, minimum=0)
    trace_dt = number(trace_dt, "--trace-dt", positive=True)
    check_duration(seconds, STEP)
    if out is not None:
        OutputFolder(out, overwrite=overwrite).check()  # before the simulation, not after
    pops, names = check_selection(spikes, traces)
    check_memory(estimate_bytes(trials=trials, seconds=seconds, dt=STEP, trace_dt=trace_dt * 1e-3,
                                traces=names, spikes=bool(pops)),
                 culprit=f"--seconds {seconds:g} x --trials {trials}")
    models = model_set(overrides, equations)
    result = simulate_unit(models, seconds=seconds, seed=seed, n_trials=trials,
                           trace_dt=trace_dt * ms, spikes=spikes, traces=traces,
                           progress=progress)
    result.extra["rhythm"] = rhythm_per_trial(result, seconds)
    result.extra["models"] = models
    if out is not None:
        settings = dict(settings or {}) or {
            "seconds": seconds, "seed": seed, "trials": trials, "trace_dt": trace_dt,
            "overrides": override_items(overrides), "equations": dict(equations or {}),
            "spikes": spikes, "traces": traces}
        with OutputFolder(out, overwrite=overwrite) as folder:  # whole, or nothing
            write_unit_folder(folder, result, settings)
    return result


def rhythm_per_trial(result: SimulationResult, seconds: float) -> list[dict[str, Any]]:
    """Period, phases vs the thigh flexor, rates per neuron and the interneurons' total rate of
    every trial (empty when motor or interneuron spikes were not recorded)."""
    L = result.cpg.layout
    if not {"motor", "interneuron"} <= set(result.spikes):
        return []
    summaries = []
    for b in range(L.n_trials):
        pools = {name: L.motor_neurons(b, 0, name) for name in ("thigh_flexor", "thigh_extensor",
                                                                 "calf_flexor", "calf_extensor")}
        t, i = result.spikes["motor"]
        s = rhythm_summary(t, i, pools, t_stop=seconds)
        ti, ii = result.spikes["interneuron"]
        mine = (ii // L.interneurons_per_trial == b) & (ti >= 1.0)
        s["interneurons_total_Hz"] = float(mine.sum() / max(seconds - 1.0, 1e-9))
        summaries.append(s)
    return summaries


def write_unit_folder(out: Path, result: SimulationResult, settings: Mapping[str, Any]) -> None:
    """spikes.npz, traces.npz, unit.png (when spikes were recorded) and manifest.json."""
    from ..figures import plots

    L = result.cpg.layout
    files = save_spikes_and_traces(out, result.spikes, result.traces)
    if {"motor", "interneuron"} <= set(result.spikes):
        plots.plot_unit(out / "unit.png", result.spikes, L)
        files["unit.png"] = ("raster of the motor neurons and interneurons, and pool activity "
                             "(trial 0)")
    write_manifest(out, command="unit", seed=int(settings.get("seed", 1)), settings=settings,
                   models_json=result.extra["models"].to_json(), files=files,
                   results={"rhythm": result.extra.get("rhythm", []),
                            "wall_seconds": result.wall_seconds, "dt_s": float(result.cpg.dt),
                            "seconds": result.seconds, "layout": L.to_json()})


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
