"""What a study folder has done and what is left (the status ``astrocpg study`` prints of a
folder, ``ac.study_status``).

A long study (hours on a laptop) is one folder that resumes with the same command after any
stop. This module reads that folder without running or locking anything, so it may be asked
while the study runs in another process: the runs its study file now names (``study.json``),
each run's ``status.json`` and ``sessions.csv`` (sessions done per seed), and the wall time of
every attempt so far (``timeline.csv`` and the running attempts' start).

The estimate of the time left is a projection, and says so: a run's seeds step together in one
network, so its wall time follows the simulated time of its busiest seed. Each run's cost per
simulated second is measured on its own attempts (or, for a run not started, the mean of the
others); the sessions left are taken to last as long as the last ``RECENT`` sessions of each
seed did (sessions grow longer as a gait is learnt, so early in a training it is low). The runs
left are shared over ``workers`` processes.

An attempt that was killed (the machine stopped, the process was ended) leaves no end in the
run's history. Each checkpoint notes the time in the attempt's line (``last_seen``), so such an
attempt counts up to its last checkpoint: the sessions it trained after that are trained again
and their time is lost to the count. An attempt killed before its first checkpoint has no known
time; a run with such an attempt is costed on its current attempt alone: the wall time since
that attempt started against the simulated time trained since (the sessions it found done are
the first ``sessions_at_start`` rows of ``sessions.csv``). A run whose status says "running"
while no process of that pid lives on this host is shown as "stopped".
"""

from __future__ import annotations

import csv
import io
import json
import math
import os
import re
import socket
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from ...errors import InputError, setting
from ...support.reading import open_regular, read_bytes
from ..outputs.study_index import read_current
from .layout import RUNS, STATUS, TIMELINE, as_it_stands

#: the sessions of a seed whose mean length stands for the sessions it has left
RECENT = 20


@dataclass
class RunProgress:
    """One run of a study: its state, sessions done of all, and its cost so far."""

    run_id: str
    state: str
    sessions_done: int
    sessions_total: int
    wall_s: float
    simulated_s: float  # of its busiest seed: what the run's wall time follows
    left_simulated_s: float  # the same, projected for the sessions left
    attempts: int = 0
    unrecorded_attempts: int = 0  # killed attempts: their wall time is not known
    # the wall and simulated seconds the run's cost is measured on (all its attempts, or the
    # current one alone when an earlier attempt's time is not known)
    cost_wall_s: float | None = None
    cost_simulated_s: float | None = None

    def __post_init__(self) -> None:
        if self.cost_wall_s is None:
            self.cost_wall_s, self.cost_simulated_s = self.wall_s, self.simulated_s

    @property
    def fraction(self) -> float:
        return self.sessions_done / self.sessions_total if self.sessions_total else 1.0


@dataclass
class StudyProgress:
    """A study folder's progress: its runs and the projected wall time left."""

    folder: Path
    runs: list[RunProgress] = field(default_factory=list)
    workers: int = 1
    left_s: float | None = None
    #: where ``workers`` comes from: "the study" (its manifest) or "workers" (the setting given)
    workers_from: str = "workers"
    #: rows of the folder's files that could not be read (skipped), each naming its line
    skipped: list[str] = field(default_factory=list)

    @property
    def sessions_done(self) -> int:
        return sum(r.sessions_done for r in self.runs)

    @property
    def sessions_total(self) -> int:
        return sum(r.sessions_total for r in self.runs)

    def text(self) -> str:
        """The summary ``astrocpg study`` prints of a study's status."""
        states: dict[str, int] = {}
        for r in self.runs:
            states[r.state] = states.get(r.state, 0) + 1
        done, total = self.sessions_done, self.sessions_total
        lines = [f"study {self.folder}: {len(self.runs)} run(s) ("
                 + ", ".join(f"{n} {s}" for s, n in sorted(states.items())) + f"); "
                 f"{done} of {total} seed-sessions done ({100 * done / max(total, 1):.1f}%)"]
        width = max((len(r.run_id) for r in self.runs), default=0)
        for r in self.runs:
            lines.append(f"  {r.run_id:<{width}}  {r.state:<9} {r.sessions_done:>6}/"
                         f"{r.sessions_total:<6} sessions  {_duration(r.wall_s):>9} spent"
                         + (f", {r.attempts} attempts" if r.attempts > 1 else "")
                         + (f" ({r.unrecorded_attempts} stopped without a record: their "
                            f"time is not counted)" if r.unrecorded_attempts else ""))
        if self.left_s is None:
            lines.append("time left: unknown until a run has trained a session"
                         + (" in an attempt whose time is known"
                            if any(r.unrecorded_attempts for r in self.runs) else ""))
        elif self.left_s == 0:
            lines.append("time left: none (every run has ended)")
        else:
            whose = " (as the study runs)" if self.workers_from == "the study" else ""
            lines.append(f"time left: about {_duration(self.left_s)} with {self.workers} "
                         f"worker(s){whose} (a projection from each run's cost so far; "
                         f"sessions grow longer as a gait is learnt)")
        if self.skipped:
            more = f" and {len(self.skipped) - 3} more" if len(self.skipped) > 3 else ""
            lines.append(f"skipped (unreadable, not counted): {'; '.join(self.skipped[:3])}"
                         f"{more}")
        return "\n".join(lines)

    def to_dict(self) -> dict[str, Any]:
        return {"folder": str(self.folder), "workers": self.workers,
                "workers_from": self.workers_from, "skipped": list(self.skipped),
                "left_s": self.left_s,
                "sessions_done": self.sessions_done, "sessions_total": self.sessions_total,
                "runs": [r.__dict__ | {"fraction": r.fraction} for r in self.runs]}


def _duration(seconds: float) -> str:
    seconds = int(round(seconds))
    h, rest = divmod(seconds, 3600)
    m, s = divmod(rest, 60)
    return f"{h} h {m:02d} min" if h else f"{m} min {s:02d} s"


def _rows(path: Path) -> Any:
    """``csv.DictReader`` rows of ``path`` with their line numbers; nothing when the file is not
    there (a run not started, or between two writes); InputError naming it when it is not a
    regular file (a FIFO would hang the reader)."""
    try:
        f = open_regular(path, culprit=path)
    except OSError:
        return
    with io.TextIOWrapper(f, encoding="utf-8", errors="replace", newline="") as text:
        reader = csv.DictReader(text)
        for row in reader:
            yield reader.line_num, row


def _session_row(row: dict[str, Any], n_trials: int) -> tuple[int, float] | None:
    """(seed index, length in s) of a sessions.csv row, or None when a value is not one."""
    try:
        b, length = int(row["trial"]), float(row["length_s"])
    except (KeyError, TypeError, ValueError):
        return None
    if not (0 <= b < n_trials and math.isfinite(length) and length >= 0):
        return None
    return b, length


def _sessions(folder: Path, n_trials: int,
              skipped: list[str] | None = None) -> tuple[list[int], list[list[float]]]:
    """Sessions done and their lengths (s), per seed of the run, from its sessions.csv; a row
    whose values are not a seed of the run and a length (a negative, non-finite or unreadable
    one) is skipped and named in ``skipped``."""
    done = [0] * n_trials
    lengths: list[list[float]] = [[] for _ in range(n_trials)]
    for line, row in _rows(folder / "sessions.csv"):
        read = _session_row(row, n_trials)
        if read is None:
            if skipped is not None:
                skipped.append(f"{folder / 'sessions.csv'} line {line}")
            continue
        done[read[0]] += 1
        lengths[read[0]].append(read[1])
    return done, lengths


def _attempt_seconds(out: Path, skipped: list[str] | None = None) -> dict[str, float]:
    """Wall seconds of every ended attempt, per run (timeline.csv); a row whose duration is
    not a number of seconds (negative, non-finite, unreadable) is skipped and named."""
    spent: dict[str, float] = {}
    for line, row in _rows(out / TIMELINE):
        try:
            run_id, seconds = str(row["run_id"]), float(row["duration_s"])
        except (KeyError, TypeError, ValueError):
            seconds = math.nan
        if not (math.isfinite(seconds) and seconds >= 0):
            if skipped is not None:
                skipped.append(f"{out / TIMELINE} line {line}")
            continue
        spent[run_id] = spent.get(run_id, 0.0) + seconds
    return spent


def _attempt_wall(h: dict[str, Any]) -> float | None:
    """Wall seconds of an attempt that is over: its recorded duration, or for one killed
    without writing its end, the time up to its last checkpoint (its sessions after that are
    trained again); None when it was killed before its first checkpoint."""
    if isinstance(h.get("duration_s"), (int, float)):
        return float(h["duration_s"])
    seen, started = h.get("last_seen"), h.get("started")
    if isinstance(seen, (int, float)) and isinstance(started, (int, float)):
        return max(0.0, float(seen) - float(started))
    return None


def _alive(status: dict[str, Any]) -> bool:
    """Whether the attempt a status names still runs: its pid lives, where that can be known
    (the same host); an attempt on another host is taken at its word."""
    pid = status.get("pid")
    if status.get("host") != socket.gethostname() or not isinstance(pid, int) or pid <= 0:
        return True
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except OSError:  # it exists but is not ours to signal
        return True
    return True


def _simulated_before(folder: Path, n_trials: int, rows: Any) -> float | None:
    """The busiest seed's simulated seconds over the first ``rows`` rows of sessions.csv (the
    sessions an attempt found done); None when that count is not known."""
    if not isinstance(rows, int) or rows < 0:
        return None
    per_seed = [0.0] * n_trials
    for k, (_, row) in enumerate(_rows(folder / "sessions.csv")):
        if k >= rows:
            break
        read = _session_row(row, n_trials)
        if read is not None:
            per_seed[read[0]] += read[1]
    return max(per_seed, default=0.0)


def _read_status(folder: Path) -> dict[str, Any]:
    try:  # a FIFO is refused (naming it), never waited on
        status = json.loads(read_bytes(folder / STATUS, culprit=folder / STATUS))
    except InputError:
        raise
    except (OSError, ValueError, RecursionError):
        return {}
    return as_it_stands(folder, status) if isinstance(status, dict) else {}


def _natural(text: str) -> tuple:
    """A sort key that orders the numbers in a run id by value: ``L_max=9`` before
    ``L_max=18``, ``seed2`` before ``seed10``."""
    parts = re.split(r"(\d+(?:\.\d+)?(?:[eE][-+]?\d+)?)", text)
    return tuple((0, float(p), "") if k % 2 else (1, 0.0, p) for k, p in enumerate(parts))


def _study_workers(out: Path) -> int | None:
    """The worker processes the study in ``out`` runs on (its manifest, written as it
    starts), or None when the manifest does not say."""
    try:
        settings = json.loads(read_bytes(out / "manifest.json",
                                         culprit=out / "manifest.json")).get("settings")
    except InputError:
        raise
    except (OSError, ValueError, RecursionError, AttributeError):
        return None
    if not isinstance(settings, dict):
        return None
    for key in ("worker_count", "workers"):
        n = settings.get(key)
        if isinstance(n, int) and not isinstance(n, bool) and n >= 1:
            return n
    return None


def _run_size(out: Path, run_id: str, spec: Any) -> tuple[int, int]:
    """(seeds, sessions) of a run as study.json gives them; InputError naming the file and
    the run for a value that is not a whole number (a corrupt or hand-edited file)."""
    values = []
    for key, default, least in (("n_trials", 1, 1), ("n_sessions", 0, 1)):
        v = spec.get(key, default) if isinstance(spec, dict) else None
        if isinstance(v, bool) or not isinstance(v, int) or v < least:
            raise InputError(f"run {run_id}: {key} is {v!r}, not a whole number of at least "
                             f"{least} (a damaged or hand-edited file)",
                             culprit=out / "study.json")
        values.append(v)
    return values[0], values[1]


def study_status(folder: str | Path, *, workers: int | None = None,
                 now: float | None = None) -> StudyProgress:
    """The progress of the study in ``folder`` (read only; safe while the study runs).
    ``workers``: the processes the runs left will share, for the time left; by default
    those the study runs on (its manifest), else one."""
    out = Path(folder)
    if workers is not None and (not isinstance(workers, int) or isinstance(workers, bool)
                                or workers < 1):
        raise InputError(f"must be a whole number of at least 1, got {workers!r}",
                         culprit=setting("workers"))
    specs = read_current(out, culprit=setting("status", out))
    now = time.time() if now is None else now
    skipped: list[str] = []
    ended_attempts = _attempt_seconds(out, skipped)
    recorded = _study_workers(out) if workers is None else None
    progress = StudyProgress(folder=out, workers=workers or recorded or 1,
                             workers_from="the study" if recorded else "workers",
                             skipped=skipped)
    for run_id, spec in sorted(specs.items(), key=lambda item: _natural(str(item[0]))):
        n_trials, n_sessions = _run_size(out, run_id, spec)
        run_folder = out / RUNS / run_id
        status = _read_status(run_folder)
        state = str(status.get("state", "not run"))
        done, lengths = _sessions(run_folder, n_trials, skipped)
        history = status.get("history") if isinstance(status.get("history"), list) else None
        running = state == "running" and isinstance(status.get("started"), (int, float))
        if running and not _alive(status):
            state, running = "stopped", False
        ended_history = [h for h in (history or [])[:-1 if running else None]
                         if isinstance(h, dict)]
        if history is not None:  # the run's own record of its attempts, ended or not
            wall = sum(_attempt_wall(h) or 0.0 for h in ended_history)
        else:  # older folders: the study's timeline, written when it ended
            wall = ended_attempts.get(run_id, 0.0)
        unrecorded = sum(1 for h in ended_history if _attempt_wall(h) is None)
        current_wall = max(0.0, now - float(status["started"])) if running else 0.0
        wall += current_wall
        simulated = max((sum(x) for x in lengths), default=0.0)
        cost_wall, cost_simulated = wall, simulated
        if unrecorded:  # cost the run on its current attempt alone, or not at all
            before = _simulated_before(run_folder, n_trials, status.get("sessions_at_start"))
            cost_wall, cost_simulated = (current_wall, simulated - before) \
                if running and before is not None and simulated > before else (0.0, 0.0)
        left = 0.0
        if state not in ("finished", "diverged"):
            for b in range(n_trials):
                recent = lengths[b][-RECENT:]
                if recent:
                    left = max(left, sum(lengths[b]) + (n_sessions - done[b])
                               * sum(recent) / len(recent))
            left = max(0.0, left - simulated) if left else 0.0
        progress.runs.append(RunProgress(
            run_id=run_id, state=state, sessions_done=sum(min(d, n_sessions) for d in done),
            sessions_total=n_trials * n_sessions, wall_s=wall, simulated_s=simulated,
            left_simulated_s=left, attempts=_count(status.get("attempts")),
            unrecorded_attempts=unrecorded, cost_wall_s=cost_wall,
            cost_simulated_s=cost_simulated))
    progress.left_s = _time_left(progress.runs, progress.workers)
    return progress


def _count(value: Any) -> int:
    """A count a status.json gives, or 0 when it is not one."""
    return value if isinstance(value, int) and not isinstance(value, bool) and value > 0 else 0


def _time_left(runs: list[RunProgress], workers: int) -> float | None:
    """Projected wall seconds left: each unfinished run's simulated time left at its own cost
    per simulated second; a run with nothing trained yet costs what the mean run has so far
    cost in all. None when no run has trained a session."""
    measured = [r for r in runs if r.cost_simulated_s > 0 and r.cost_wall_s > 0]
    if all(r.state in ("finished", "diverged") for r in runs):
        return 0.0
    if not measured:
        return None

    def cost(r: RunProgress) -> float:  # wall seconds per simulated second of the busiest seed
        return r.cost_wall_s / r.cost_simulated_s

    whole = [(r.simulated_s + r.left_simulated_s) * cost(r) for r in measured]
    mean_run = sum(whole) / len(whole)
    left = []
    for r in runs:
        if r.state in ("finished", "diverged"):
            continue
        if r in measured:
            left.append(r.left_simulated_s * cost(r))
        else:
            left.append(mean_run)
    # the runs left over the workers: no shorter than the longest run, nor than their sum shared
    return max(max(left), sum(left) / workers) if left else 0.0
