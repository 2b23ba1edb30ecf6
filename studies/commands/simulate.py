"""Run the CPG: one locomotion unit open loop (``simulate_unit``), or the full network driving
the robot (``simulate_closed_loop``). Both return plain numpy results; ``save_*`` write them.
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field
from typing import Any, Sequence

import mujoco
import numpy as np
from brian2 import NetworkOperation, ms, second

from ...coupling.assembly import build_closed_loop
from ...coupling.bridge import ORDER_MEASURE
from ...coupling.robot_recording import Recording
from ...coupling.robot import RobotLayout
from ...errors import Diverged
from ...models import ModelSet
from ...network import (CPG, DivergenceCheck, build_cpg, check_runs, exclusive,
                        network_time, run_network)
from ...network.populations import BUILT_IN, spike_populations, trace_sources
from ...network.recording import SpikeRecorder, TraceRecorder
from ..runtime.progress import time_bar
from ..settings.checks import STEP, check_duration, check_selection



@dataclass
class SimulationResult:
    """Spikes per population, sampled traces, and (closed loop) the robot's recording."""

    cpg: CPG
    seconds: float
    spikes: dict[str, tuple[np.ndarray, np.ndarray]]  # population -> (times s, indices)
    traces: dict[str, tuple[np.ndarray, np.ndarray]]  # name -> (t s, values (samples, n))
    robot: Recording | None = None
    wall_seconds: float = 0.0
    extra: dict[str, Any] = field(default_factory=dict)
    monitors: dict[str, Any] = field(default_factory=dict)  # the Brian2 monitors, by name


#: what a built-in network can record (the default of add_monitors)
POPULATIONS: tuple[str, ...] = spike_populations(BUILT_IN)
TRACES: tuple[str, ...] = tuple(trace_sources(BUILT_IN))


def add_monitors(cpg: CPG, trace_dt: Any, record_traces: bool,
                 spikes: tuple[str, ...] = POPULATIONS,
                 traces: tuple[str, ...] = TRACES, *, n_steps: int,
                 trace_dtype: str = "float32", spill: Any = None) -> dict[str, Any]:
    """Spike monitors of ``spikes`` (Brian2's, by population: a monitor, or a tuple of them,
    one per stage, where the limbs integrate in stages: :meth:`CPG.parts`) and, under
    ``"traces"``, a :class:`~astrocpg.network.recording.TraceRecorder` of ``traces`` sampled
    every ``trace_dt`` for the next ``n_steps`` steps (the run's length), kept as
    ``trace_dtype``; all added to the network. ``spill``: where the recorder puts the traces
    too large to hold in memory as the run goes (:class:`~astrocpg.network.recording.TraceRecorder`),
    None to hold every trace."""
    mons: dict[str, Any] = {}
    for p in spikes:
        ms = tuple(SpikeRecorder(part.obj, name=f"spikes_{part.name}") for part in cpg.parts(p))
        mons[p] = ms[0] if len(ms) == 1 else ms
    cpg.net.add(*(m for ms in mons.values() for m in (ms if isinstance(ms, tuple) else (ms,))))
    if record_traces and traces:
        stride = int(round(float(trace_dt) / float(cpg.dt)))
        recorder = TraceRecorder(cpg, tuple(traces), stride=stride, n_steps=int(n_steps),
                                 dtype=trace_dtype, spill=spill)
        cpg.net.add(recorder.operation())
        mons["traces"] = recorder
    return mons


def _with_numbers(cpg: CPG, population: str, monitors: Any) -> list[tuple[Any, Any]]:
    """(monitor, files' number of each element of its object or None) per object."""
    ms = monitors if isinstance(monitors, tuple) else (monitors,)
    return [(m, part.number) for m, part in zip(ms, cpg.parts(population))]


def spike_parts(cpg: CPG, mons: dict[str, Any]) -> dict[str, list[tuple[np.ndarray, np.ndarray]]]:
    """Each recorded population's spikes per Brian2 object (a stage's group, :meth:`CPG.parts`):
    (t, files' index), in the order the object recorded them."""
    parts = {}
    for p in spike_populations(cpg.layout.rows):
        if p not in mons:
            continue
        parts[p] = []
        for m, number in _with_numbers(cpg, p, mons[p]):
            i = np.asarray(m.i_[:], dtype=np.int32)
            parts[p].append((np.asarray(m.t_[:]),
                             i if number is None else number[i].astype(np.int32)))
    return parts


def merge_parts(parts: list[tuple[np.ndarray, np.ndarray]]) -> tuple[np.ndarray, np.ndarray]:
    """One population's spikes from its objects' (:func:`spike_parts`): the stages' spikes
    merged in time order (stably: within a step, stage by stage)."""
    if len(parts) == 1:
        return parts[0]
    t, i = np.concatenate([x[0] for x in parts]), np.concatenate([x[1] for x in parts])
    order = np.argsort(t, kind="stable")
    return t[order], i[order]


def _collect(cpg: CPG, mons: dict[str, Any]) -> tuple[dict, dict]:
    """Spikes (t, files' index) and traces (t, values in the files' column order)."""
    spikes = {p: merge_parts(parts) for p, parts in spike_parts(cpg, mons).items()}
    traces = mons["traces"].collected() if "traces" in mons else {}
    return spikes, traces


class _Progress:
    """A bar over a run's ``seconds`` of simulated time, counted in whole steps of ``dt``
    (:func:`~.progress.time_bar`: a float total reached by adding 0.1 s overshoots it) and
    moved every ``every`` steps from inside the run; shown from :meth:`open` (at the start of
    the run) to :meth:`close`, so that an error or an interrupt before the run leaves no bar
    behind its one-line message. :meth:`finish` takes a whole run to its total."""

    def __init__(self, seconds: float, desc: str, enabled: bool, every: int = 100,
                 dt: float | None = None):
        self.every, self.seconds, self.desc, self.enabled = every, seconds, desc, enabled
        self.dt = STEP if dt is None else float(dt)
        self.steps = max(1, int(round(seconds / self.dt)))
        self.bar: Any = None

    def open(self) -> None:
        self.bar = time_bar(self.steps, self.dt, self.desc, self.enabled)

    def position(self, step: int) -> int | None:
        """Where the bar stands after ``step`` steps: None between strides, never past the
        total."""
        if step % self.every and step < self.steps:
            return None
        return min(int(step), self.steps)

    def __call__(self, step: int) -> None:
        at = self.position(step) if self.bar is not None else None
        if at is not None and at > self.bar.n:
            self.bar.update(at - self.bar.n)

    def finish(self) -> None:
        if self.bar is not None:
            self.bar.finish()

    def close(self) -> None:
        if self.bar is not None:
            self.bar.close()


@exclusive  # build to last read: no other thread's Brian2 in between (network/runlock.py)
def simulate_unit(models: ModelSet, *, seconds: float, seed: int, n_trials: int = 1,
                  trace_dt: Any = 1 * ms, record_traces: bool = True,
                  spikes: tuple[str, ...] | None = None, traces: tuple[str, ...] | None = None,
                  progress: bool = True, trace_dtype: str = "float32",
                  populations: Sequence[Any] | None = None) -> SimulationResult:
    """One locomotion unit (the FR limb's CPG) open loop: no robot, torso speed 0, no
    limit-position inhibition (the paper's Fig. 1c). ``n_trials`` units with seeds seed...
    ``populations``: the population table (None: the built-in rows)."""
    check_duration(seconds)
    cpg = build_cpg(models, n_trials=n_trials, seed=seed, legs=("FR",), populations=populations)
    check_runs(cpg)
    mons = add_monitors(cpg, trace_dt, record_traces,
                        *check_selection(spikes, traces, cpg.layout.rows),
                        n_steps=check_duration(seconds), trace_dtype=trace_dtype)
    bar = _Progress(seconds, "unit", progress and seconds > 3)
    steps = [0]

    def tick() -> None:
        steps[0] += 100
        bar(steps[0])

    cpg.net.add(NetworkOperation(tick, dt=100 * ms, when="end", name="progress"))
    divergence = DivergenceCheck(cpg)  # every 10 steps, and once after the run
    cpg.net.add(divergence.operation())
    t0 = time.perf_counter()
    try:
        wall = _run(cpg, seconds, bar)
        divergence.check()
    except Diverged as e:  # keep what was recorded up to the divergence, for its folder
        e.result = _partial(cpg, mons, None, t0)
        raise
    spikes, traces = _collect(cpg, mons)
    return SimulationResult(cpg=cpg, seconds=seconds, spikes=spikes, traces=traces,
                            wall_seconds=wall, monitors=mons)


@exclusive
def simulate_closed_loop(models: ModelSet, robot: mujoco.MjModel | None = None,
                         robot_layout: RobotLayout | None = None, *,
                         seconds: float, seed: int, n_trials: int = 1,
                         weights: np.ndarray | None = None, trace_dt: Any = 1 * ms,
                         robot_stride: int = 1, record_traces: bool = True,
                         record_spikes: bool = True, spikes: tuple[str, ...] | None = None,
                         traces: tuple[str, ...] | None = None,
                         progress: bool = True, trace_dtype: str = "float32",
                         spill: Any = None,
                         populations: Sequence[Any] | None = None) -> SimulationResult:
    """The whole CPG driving ``n_trials`` robots (default: the project's A1) for ``seconds``,
    inter-limb weights fixed (``weights``: (8, 8) or (n_trials, 8, 8) in volt; default zero).
    ``spill``: see :func:`add_monitors` (a run that writes its folder). ``populations``: the
    population table (None: the built-in rows)."""
    check_duration(seconds)
    bar = _Progress(seconds, f"run ({n_trials} trial{'s' if n_trials > 1 else ''})",
                    progress and seconds * n_trials > 3)
    loop = build_closed_loop(models, n_trials=n_trials, seed=seed, weights=weights, robot=robot,
                             robot_layout=robot_layout, on_step=bar, populations=populations)
    cpg, bridge = loop.cpg, loop.bridge
    n_steps = int(round(seconds / loop.robot.opt.timestep))
    rec = bridge.start_recording(n_steps, robot_stride)
    limit = LimitCount(cpg)
    bridge.add_hook("after_physics", "limit_count", limit, order=ORDER_MEASURE)
    selection = check_selection(spikes, traces, cpg.layout.rows)
    mons = add_monitors(cpg, trace_dt, record_traces, *selection, n_steps=n_steps,
                        trace_dtype=trace_dtype, spill=spill) if record_spikes else {}
    t0 = time.perf_counter()
    try:
        wall = _run(cpg, seconds, bar)
        bridge.check_cpg(network_time(cpg.net), full=True)  # the steps since its last check
    except Diverged as e:  # keep what was recorded up to the divergence, for its folder
        e.result = _partial(cpg, mons, rec.truncated(bridge.step_count), t0,
                            extra={"bridge": bridge, "limit_inhibition": limit.counts()})
        raise
    except BaseException:  # interrupted, or a bug: nothing will be written
        if "traces" in mons:
            mons["traces"].abandon()
        raise
    spikes, traces = _collect(cpg, mons) if mons else ({}, {})
    return SimulationResult(cpg=cpg, seconds=seconds, spikes=spikes, traces=traces, robot=rec,
                            wall_seconds=wall, monitors=mons,
                            extra={"bridge": bridge, "limit_inhibition": limit.counts()})


class LimitCount:
    """A bridge hook counting, per trial, the limit-position inhibition the bridge applied:
    ``onsets`` (a pool's inhibition switching on) and ``steps`` (steps with any pool of the
    trial inhibited), read each step before a session loop may reset the trial."""

    def __init__(self, cpg: CPG):
        self._table = cpg.table("pool", "limit_inhibition")  # (trial, pool)
        self.limit = self._table.values
        self.before = np.zeros(self.limit.shape, dtype=bool)
        self.onsets = np.zeros(cpg.n_trials, dtype=np.int64)
        self.steps = np.zeros(cpg.n_trials, dtype=np.int64)
        self.n_steps = 0

    def __call__(self) -> None:
        now = self._table.read() > 0
        self.onsets += (now & ~self.before).sum(axis=1)
        self.steps += now.any(axis=1)
        self.before[:] = now
        self.n_steps += 1

    def counts(self) -> dict[str, Any]:
        return {"onsets": self.onsets.copy(), "steps": self.steps.copy(),
                "of_steps": self.n_steps}


def _partial(cpg: CPG, mons: dict[str, Any], rec: Recording | None, t0: float,
             extra: dict[str, Any] | None = None) -> SimulationResult:
    """What a run that diverged recorded, up to the step it stopped at."""
    spikes, traces = _collect(cpg, mons) if mons else ({}, {})
    return SimulationResult(cpg=cpg, seconds=network_time(cpg.net), spikes=spikes, traces=traces,
                            robot=rec, wall_seconds=time.perf_counter() - t0,
                            extra=dict(extra or {}), monitors=mons)


def _run(cpg: CPG, seconds: float, bar: _Progress) -> float:
    """One long ``Network.run`` (each call costs ~0.3 s of set-up); returns wall seconds."""
    t0 = time.perf_counter()
    t_end = network_time(cpg.net) + seconds
    try:
        bar.open()
        run_network(cpg.net, seconds * second, namespace={})  # Diverged comes out as itself
        if network_time(cpg.net) >= t_end - 0.5 * float(cpg.dt):
            bar.finish()  # the whole run: the bar at its total whatever its stride
    finally:
        bar.close()
    # Brian2 turns Ctrl-C (and our SIGTERM) into a clean stop at the end of a step: a run that
    # stopped early was interrupted, and its partial data must not pass for a finished run
    if network_time(cpg.net) < t_end - 0.5 * float(cpg.dt):
        raise KeyboardInterrupt
    return time.perf_counter() - t0



# The CPG steps with the physics (the A1 model's timestep, 1 ms)


def firing_rates(result: SimulationResult) -> dict[str, Any]:
    """Mean rate per neuron (Hz) of each population and of each pool type, per trial."""
    cpg, T = result.cpg, result.seconds
    L = cpg.layout
    out: dict[str, Any] = {}
    # the pools' activity (the motor neurons): one rate per pool type, the others one each
    active = next((r for r in L.rows if r.activity and r.name in result.spikes), None)
    if active is None:
        return {}
    for row in L.rows:
        if not row.spikes or row.name not in result.spikes:
            continue
        _, idx = result.spikes[row.name]
        idx = np.asarray(idx)
        n = L.cells_per_trial(row.name)
        if row is not active:
            out[row.name] = np.bincount(idx // n, minlength=L.n_trials) / (n * T)
            continue
        labels = row.labels(L.pool_size)
        kinds = list(dict.fromkeys(labels))
        # each cell's pool type as a number, and one count of (type, trial) pairs: a pass over
        # the spikes in integers (a run of 12 s x 20 trials has millions of motor spikes)
        kind_of = np.array([kinds.index(label) for label in labels] * L.n_legs, dtype=np.intp)
        counts = np.bincount(kind_of[idx % n] * L.n_trials + idx // n,
                             minlength=len(kinds) * L.n_trials).reshape(len(kinds), L.n_trials)
        for k, label in enumerate(kinds):
            out[label] = counts[k] / (L.n_legs * labels.count(label) * T)
    return {k: np.asarray(v) for k, v in out.items()}
