"""``run`` and ``unit`` with ``workers`` processes: the trials split into contiguous batches
(:func:`~astrocpg.studies.runtime.workers.split_trials`), each simulated in a worker process
(:func:`simulate_batch`), and the batches' recordings put back together in trial order
(:func:`merge_batches`) as the one :class:`~.simulate.SimulationResult` a single process
would have made: the same spikes (each step's spikes in the order the network records them),
traces, robot arrays, inter-limb tables and counts, so that the folder written from it is the
single-process one byte for byte (the manifest's wall time and worker count apart).

A trial's trajectory is a function of its seed alone, so batch ``k`` of trials ``[a, a + n)``
runs a network of ``n`` trials with seed ``seed + a``. A batch that diverges is reported, not
written: the caller runs the whole command again in its own process, which writes the
diverged folder exactly as one process does (the other trials stop where the divergence
stopped the network).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, Mapping

import numpy as np

from ...coupling.robot_recording import Recording
from ...errors import Diverged
from ...network.layout import Layout
from ..outputs.writing import note_worker_environment, simulation_environment
from ..runtime.progress import Bar


class QuietBar(Bar):
    """The command's bar without tqdm's monitor thread: the workers are forked from a process
    of one thread (:mod:`~astrocpg.studies.runtime.workers`)."""

    monitor_interval = 0
from ..runtime.workers import run_batches, split_trials
from .simulate import SimulationResult, merge_parts, spike_parts


@dataclass
class BatchedCPG:
    """What a merged result keeps of the network (the batches' networks stayed in their
    processes): its layout, step, code-generation target and inter-limb tables."""

    layout: Layout
    dt: float
    codegen: str
    weights: np.ndarray  # (n_trials, 8, 8) volt, at the end of the run
    interlimb_pairs: np.ndarray
    net: Any = None
    models: Any = None

    @property
    def n_trials(self) -> int:
        return self.layout.n_trials

    def interlimb_weights(self) -> np.ndarray:
        return self.weights.copy()


class BatchDiverged(Exception):
    """A batch diverged: the command runs again in one process (it writes what diverged)."""


def simulate_batch(kind: str, spec: Mapping[str, Any], first: int, count: int) -> dict[str, Any]:
    """Trials ``[first, first + count)`` of a ``run`` or ``unit`` (``kind``) of ``spec`` (the
    command's checked settings: model changes as texts, the robot file, the weights), in this
    process: what :func:`merge_batches` needs of its result, or ``{"diverged": ...}``."""
    from brian2 import ms

    from ...models.compose import model_set
    from ..settings.populations import population_table
    from .simulate import simulate_closed_loop, simulate_unit

    rows = population_table(spec.get("populations"))  # the command's table, as it built it
    models = (spec["modelset"] if "modelset" in spec else
              model_set(spec["overrides"], spec["equations"], models=spec.get("models")))
    common = {} if kind == "replay" else dict(
        seconds=spec["seconds"], seed=spec["seed"] + first, n_trials=count,
        trace_dt=spec["trace_dt"] * ms, spikes=spec["spikes"], traces=spec["traces"],
        progress=False, trace_dtype=spec["trace_dtype"], populations=rows)
    try:
        if kind == "unit":
            result = simulate_unit(models, **common)
        elif kind == "replay":  # a training's tables (run.replay): the project's A1
            result = simulate_closed_loop(
                models, seconds=spec["seconds"], seed=spec["seed"] + first, n_trials=count,
                weights=spec["weights"][first:first + count], record_traces=False,
                progress=False, populations=rows)
        else:
            from ...coupling.robot import A1Parameters, RobotLayout, load_robot
            from ...coupling.world import world_model

            params = A1Parameters()
            robot = world_model(models, params,
                                load_robot(spec["robot"]) if spec["robot"] else None)
            table = spec["weights"]
            if table is not None and table.ndim == 3:
                table = table[first:first + count]
            result = simulate_closed_loop(models, robot, RobotLayout.from_model(robot, params),
                                          weights=table, robot_stride=spec["robot_stride"],
                                          **common)
    except Diverged as e:
        return {"diverged": e.line}
    cpg = result.cpg
    out = {"first": first, "count": count, "seconds": result.seconds,
           "spikes": spike_parts(cpg, result.monitors),
           "traces": {k: (np.asarray(t), np.asarray(v)) for k, (t, v) in result.traces.items()},
           "dt": float(cpg.dt), "codegen": cpg.codegen,
           "layout": (cpg.layout.pool_size, cpg.layout.legs, cpg.layout.stages),
           "weights": cpg.interlimb_weights(), "pairs": np.asarray(cpg.interlimb_pairs),
           "wall_seconds": result.wall_seconds, "environment": simulation_environment(),
           "populations": spec.get("populations")}
    if result.robot is not None:
        rec = result.robot
        out["robot"] = {f: np.asarray(getattr(rec, f)) for f in rec.__dataclass_fields__}
        out["limit_inhibition"] = result.extra["limit_inhibition"]
    return out


def simulate_batched(kind: str, spec: Mapping[str, Any], trials: int, workers: int,
                     progress: bool = True) -> SimulationResult:
    """The ``trials`` of a ``run``/``unit`` (``kind``) of ``spec`` over ``workers`` processes,
    merged (:func:`merge_batches`); :class:`BatchDiverged` when a batch diverged."""
    import time

    batches = split_trials(trials, workers)
    bar = QuietBar(total=trials, unit="trial", desc=f"{kind} ({len(batches)} processes)",
              disable=not progress, dynamic_ncols=True)
    t0 = time.perf_counter()
    try:
        parts = run_batches(simulate_batch, [(kind, spec, a, n) for a, n in batches], workers,
                            ended=lambda k, r: bar.update(batches[k][1]))
    finally:
        bar.close()
    if any("diverged" in p for p in parts):
        raise BatchDiverged(next(p["diverged"] for p in parts if "diverged" in p))
    return merge_batches(parts, time.perf_counter() - t0)


def try_batched(kind: str, spec: Mapping[str, Any], trials: int, workers: int,
                progress: bool = True) -> SimulationResult | None:
    """:func:`simulate_batched` with ``workers`` of at least 2; None with fewer, or when a
    batch diverged (the caller runs the command in its own process: what diverged is written
    as one process writes it)."""
    note_worker_environment({})  # a command before this one in the process split its trials
    if workers < 2:
        return None
    try:
        return simulate_batched(kind, spec, trials, workers, progress)
    except BatchDiverged:
        return None


def merge_batches(parts: list[dict[str, Any]], wall: float) -> SimulationResult:
    """The batches' results (:func:`simulate_batch`, in trial order) as one result: spikes
    with their trials' file indices, each object's spikes in time order and, within a step,
    in index order (as the object records them), then the objects merged as
    :func:`~.simulate.merge_parts` merges them; traces side by side in trial-major columns;
    the robot's arrays in a recording laid out as one run's (:meth:`Recording.allocate`)."""
    from ..settings.populations import population_table

    note_worker_environment(parts[0]["environment"])
    n = sum(p["count"] for p in parts)
    pool_size, legs, stages = parts[0]["layout"]
    layout = Layout(n_trials=n, pool_size=pool_size, legs=legs, stages=stages,
                    populations=population_table(parts[0].get("populations")))
    spikes = {}
    for name, objects in parts[0]["spikes"].items():
        per_trial = layout.cells_per_trial(name)
        merged_objects = []
        for o in range(len(objects)):
            t = np.concatenate([p["spikes"][name][o][0] for p in parts])
            i = np.concatenate([p["spikes"][name][o][1] + np.int32(p["first"] * per_trial)
                                for p in parts]).astype(np.int32, copy=False)
            order = np.argsort(t, kind="stable")
            merged_objects.append((t[order], i[order]))
        spikes[name] = merge_parts(merged_objects)
    traces = {}
    for name, (t, _) in parts[0]["traces"].items():
        traces[name] = (t, np.concatenate([p["traces"][name][1] for p in parts], axis=1))
    robot, extra = None, {}
    if "robot" in parts[0]:
        first = parts[0]["robot"]
        robot = Recording.allocate(n, len(first["t"]) * int(first["stride"]), int(first["stride"]),
                                   parts[0]["dt"])
        robot.t[...] = first["t"]
        for p in parts:
            for f, v in p["robot"].items():
                if f not in ("t", "stride"):
                    getattr(robot, f)[p["first"]:p["first"] + p["count"]] = v
        counts = [p["limit_inhibition"] for p in parts]
        extra["limit_inhibition"] = {
            "onsets": np.concatenate([c["onsets"] for c in counts]),
            "steps": np.concatenate([c["steps"] for c in counts]),
            "of_steps": counts[0]["of_steps"]}
    cpg = BatchedCPG(layout=layout, dt=parts[0]["dt"], codegen=parts[0]["codegen"],
                     weights=np.concatenate([p["weights"] for p in parts]),
                     interlimb_pairs=parts[0]["pairs"])
    return SimulationResult(cpg=cpg, seconds=parts[0]["seconds"], spikes=spikes, traces=traces,
                            robot=robot, wall_seconds=wall, extra=extra)


__all__ = ["BatchDiverged", "BatchedCPG", "merge_batches", "simulate_batch", "simulate_batched",
           "try_batched"]
