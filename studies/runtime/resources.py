"""Memory an experiment will need, estimated before anything is allocated, so that
``seconds`` 1e7 or ``trials`` 100000 is refused in one line instead of exhausting the
machine part-way through."""

from __future__ import annotations

import os
from typing import Any, Mapping, Sequence

from ...errors import InputError, setting

# Measured (build_cpg + a short run, RSS difference between 1 and 33 trials): 0.33 MB of Brian2
# state per trial; with its MjData, bridge arrays and code-object buffers we count 1 MB.
BYTES_PER_TRIAL = 1_000_000
# What the recorders keep per trial and simulated second at their densest (1 ms sampling):
# spikes ~9,000/s x 12 B; motor Ca2+ 320 columns and astrocyte traces 4 x 8 columns, each value
# float32 (4 B) or float64 (network/recording.py: arrays of the run's size, allocated once);
# the robot's ~40 float64 per step.
SPIKE_BYTES_PER_TRIAL_S = 9_000 * 12
ROBOT_FLOATS_PER_STEP = 40
# What a training (or a power measurement) keeps per trial and session: the row of
# sessions.csv as a dict (~25 values) and the inter-limb table after the session (8x8 floats).
SESSION_BYTES_PER_TRIAL = 2_000

# Wall seconds per simulated second of the closed loop on one core for a network of n trials:
# about WALL_PER_SIM_S + WALL_PER_SIM_S_PER_TRIAL * n (benchmarks/speed.py,
# docs/performance.md: 0.27 s for
# 1 trial, 0.40 for 4, 0.91 for 16). The ablation simulates its astrocytes too (regulation 0),
# so it costs the same per simulated second.
WALL_PER_SIM_S = 0.23
WALL_PER_SIM_S_PER_TRIAL = 0.043


def available_memory() -> int:
    """Bytes this process may still allocate: MemAvailable (Linux), else physical memory."""
    try:
        with open("/proc/meminfo") as f:
            for line in f:
                if line.startswith("MemAvailable:"):
                    return int(line.split()[1]) * 1024
    except OSError:
        pass
    try:
        return os.sysconf("SC_PAGE_SIZE") * os.sysconf("SC_PHYS_PAGES")
    except (ValueError, OSError, AttributeError):
        return 1 << 62  # unknown: do not refuse


def estimate_bytes(*, trials: int, seconds: float, dt: float = 1e-3, trace_dt: float = 1e-3,
                   robot_stride: int | None = None, traces: Mapping[str, int] | None = None,
                   spikes: bool = True, sessions: int = 0, trace_bytes: int = 4,
                   spill_bytes: int | None = None) -> int:
    """Bytes a simulation of ``trials`` for ``seconds`` holds at its end (state + records),
    or a training of ``sessions`` sessions per trial (its rows and tables). ``traces``: the
    recorded traces, each with its columns per trial
    (:func:`astrocpg.network.populations.trace_columns`). ``trace_bytes``:
    per trace value (4: float32, the default; 8: float64). ``spill_bytes``: a run that writes
    its folder puts each trace of at least this many bytes on disk as it goes
    (:data:`~astrocpg.network.recording.SPILL_BYTES`): such a trace is not held."""
    steps = seconds / dt
    per_trial = float(BYTES_PER_TRIAL) + float(SESSION_BYTES_PER_TRIAL) * sessions
    if spikes:
        per_trial += SPIKE_BYTES_PER_TRIAL_S * seconds
    for columns in (traces or {}).values():
        held = columns * trace_bytes * seconds / trace_dt
        if spill_bytes is None or held * trials < spill_bytes:
            per_trial += held
    if robot_stride:
        per_trial += ROBOT_FLOATS_PER_STEP * 8 * steps / robot_stride
    return int(per_trial * trials)


#: What one worker process holds besides its batch (Python, NumPy, Brian2, MuJoCo and astrocpg
#: imported: 0.15 GB resident, measured; with its network's code and buffers we count 0.25 GB):
#: counted once per worker of a command.
WORKER_PROCESS_BYTES = 250_000_000


def estimate_batched(workers: int, *, trials: int, **sizes: Any) -> int:
    """Bytes a command of ``trials`` split over ``workers`` processes holds at its end
    (:func:`estimate_bytes` for each batch, in its process, with the process itself), and the
    parent's share: every batch's records as they come back and the merged copy (a trace
    too large to hold is not spilled then). One process: :func:`estimate_bytes`."""
    workers = max(1, min(int(workers), int(trials)))
    if workers == 1:
        return estimate_bytes(trials=trials, **sizes)
    size, extra = divmod(int(trials), workers)
    batches = [size + (1 if b < extra else 0) for b in range(workers)]
    held = dict(sizes, spill_bytes=None)
    per_batch = sum(estimate_bytes(trials=n, **held) + WORKER_PROCESS_BYTES for n in batches)
    return per_batch + 2 * estimate_bytes(trials=trials, **held)


#: the settings that record less, as a remedy names them (spikes and traces: set to none)
RECORD_LESS = ("spikes", "traces", "trace_dt", "robot_stride")


def check_memory(needed: int, culprit: Any, record_less: Sequence[str] = ()) -> None:
    """Refuse (InputError) a plan that needs more memory than the machine has available.
    ``record_less``: the settings of the caller (of :data:`RECORD_LESS`) that would record less,
    named as a remedy; a command that has none of them is not told to use them."""
    have = available_memory()
    if needed > have:
        raise InputError(f"needs about {_gib(needed)} of memory; this machine has "
                         f"{_gib(have)} available (fewer trials, a shorter run"
                         f"{_record_less_words(record_less)})", culprit=culprit)


def _record_less_words(names: Sequence[str]) -> str:
    """``, or record less: spikes/traces none, trace_dt`` (as fields), or "" for none."""
    none = [str(setting(n)) for n in names if n in ("spikes", "traces")]
    said = ["/".join(none) + " none"] if none else []
    said += [str(setting(n)) for n in names if n not in ("spikes", "traces")]
    return f", or record less: {', '.join(said)}" if said else ""


def _gib(n: float) -> str:
    return f"{n / 2**30:.3g} GiB" if n >= 2**28 else f"{n / 2**20:.3g} MiB"


def estimate_wall_seconds(*, trials: int, seconds: float) -> float:
    """Wall seconds (one core) to simulate ``seconds`` of ``trials`` batched in one network:
    an estimate to order work by (longest first), not a promise."""
    return seconds * (WALL_PER_SIM_S + WALL_PER_SIM_S_PER_TRIAL * trials)
