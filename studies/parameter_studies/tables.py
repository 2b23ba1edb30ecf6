"""A study's tables, gathered from its run folders: ``results.csv`` (every session of every
finished run with its seed's final gait), ``timeline.csv`` (every attempt of every run: when
and on which worker) and the workers' :func:`utilisation` read from that timeline.
"""

from __future__ import annotations

import csv
import time
from pathlib import Path
from typing import Any, Sequence

from ...coupling.training import SESSION_COLUMNS
from ...errors import InputError
from ..outputs.writing import atomic_write
from .execute import read_status
from .layout import GAITS, RESULTS, RUNS, TIMELINE, TIMELINE_COLUMNS
from .study_file import Study


def write_results(study: Study, out: Path) -> int:
    """Gather the finished runs' ``sessions.csv`` into ``OUT/results.csv``, each row with its
    seed's final gait (``gait.csv`` of the run: label, speed, period, leg phases; empty for a
    run trained before runs wrote it); returns its rows."""
    from ..commands.trained_controller import GAIT_COLUMNS

    head = ["run_id", "condition", *study.sweep, "seed", *SESSION_COLUMNS, *GAIT_COLUMNS]
    lines = [",".join(head)]
    n = 0
    for r in study.runs:
        folder = out / RUNS / r.run_id
        if read_status(folder).get("state") != "finished":
            continue
        gaits: dict[str, dict[str, str]] = {}
        if (folder / GAITS).is_file():
            with open(folder / GAITS, newline="") as f:
                gaits = {row["trial"]: row for row in csv.DictReader(f)}
        with open(folder / "sessions.csv", newline="") as f:
            for row in csv.DictReader(f):
                seed = r.seed + int(row["trial"])
                gait = gaits.get(row["trial"], {})
                cells = [r.run_id, r.condition, *[r.point[k] for k in study.sweep], str(seed),
                         *[row[c] for c in SESSION_COLUMNS],
                         *[gait.get(c, "") for c in GAIT_COLUMNS]]
                lines.append(",".join(_csv_cell(c) for c in cells))
                n += 1
    data = ("\n".join(lines) + "\n").encode()
    atomic_write(out / RESULTS, lambda f: f.write(data))
    return n


def timeline(study: Study, out: Path) -> list[dict[str, Any]]:
    """Every attempt of every run of ``study`` in ``out`` (from the runs' ``status.json``),
    in the order they started. An attempt killed without writing its end has state ``killed``
    and ends at its last checkpoint (``last_seen``: its time is a lower bound), or, killed
    before its first checkpoint, state ``interrupted`` and no end."""
    rows = []
    for r in study.runs:
        for h in read_status(out / RUNS / r.run_id).get("history", []):
            ended, duration, state = h.get("ended"), h.get("duration_s"), h.get("state")
            if not ended:  # killed: known up to its last checkpoint, if it reached one
                seen = h.get("last_seen")
                ended = seen if isinstance(seen, (int, float)) else None
                duration = None if ended is None else ended - h["started"]
                state = "interrupted" if ended is None else "killed"
            rows.append({"run_id": r.run_id, "attempt": h.get("attempts"),
                         "state": state or "interrupted",
                         "worker": h.get("worker", ""), "worker_name": h.get("worker_name", ""),
                         "host": h.get("host", ""), "pid": h.get("pid"),
                         "started": h["started"], "ended": ended,
                         "duration_s": duration,
                         "started_utc": time.strftime("%Y-%m-%dT%H:%M:%SZ",
                                                      time.gmtime(h["started"]))})
    return sorted(rows, key=lambda row: row["started"])


def utilisation(rows: Sequence[dict[str, Any]], n_workers: int = 0) -> dict[str, Any]:
    """How busy the workers were, from a :func:`timeline`: ``wall_s`` (first start to last
    end), ``utilisation`` (run seconds / (workers x wall)), ``idle_pending_s`` (seconds workers
    were free while a run had not started yet, summed over workers), ``longest_idle_pending_s``
    (the longest such stretch of one worker), ``worker_gaps`` (per worker, those stretches
    as (from, to) seconds after the first start), ``worker_busy_s`` (per worker, the seconds
    it ran runs) and ``worker_idle_share`` (per worker, the share of the wall it ran none:
    waiting for a run, or done before the last run ended). With ``n_workers`` more than the workers in
    ``rows``, the others ran nothing: they count as free throughout. A worker is its address
    (or host:pid)."""
    def who(row):
        return row["worker"] or f"{row['host']}:{row['pid']}"

    names = list(dict.fromkeys(map(who, rows)))
    n = max(n_workers, len(names))
    if not rows:
        return {"runs": 0, "workers": n, "wall_s": 0.0, "utilisation": 0.0,
                "idle_pending_s": 0.0, "longest_idle_pending_s": 0.0, "worker_gaps": {},
                "worker_busy_s": {}, "worker_idle_share": {}}
    t0 = min(r["started"] for r in rows)
    last_start = max(r["started"] for r in rows)  # after it, no run waits
    t1 = max([r["ended"] for r in rows if r["ended"] is not None] + [last_start])
    busy = sum((r["ended"] if r["ended"] is not None else t1) - r["started"] for r in rows)
    gaps: dict[str, list[tuple[float, float]]] = {}
    for w in names:
        spans = sorted((r["started"], r["ended"] if r["ended"] is not None else t1)
                       for r in rows if who(r) == w)
        free_from, mine = t0, []
        for a, b in spans:
            if a > free_from and free_from < last_start:
                mine.append((free_from - t0, min(a, last_start) - t0))
            free_from = max(free_from, b)
        if free_from < last_start:
            mine.append((free_from - t0, last_start - t0))
        gaps[w] = mine
    for k in range(n - len(names)):
        gaps[f"(no run {k + 1})"] = [(0.0, last_start - t0)]
    every = [b - a for g in gaps.values() for a, b in g]
    wall = t1 - t0
    worker_busy = {w: sum((r["ended"] if r["ended"] is not None else t1) - r["started"]
                          for r in rows if who(r) == w) for w in gaps}
    return {"runs": len(rows), "workers": n, "wall_s": wall,
            "utilisation": busy / (n * wall) if wall > 0 else 1.0,
            "idle_pending_s": sum(every), "longest_idle_pending_s": max(every, default=0.0),
            "worker_gaps": gaps, "worker_busy_s": worker_busy,
            "worker_idle_share": {w: (1.0 - b / wall if wall > 0 else 0.0)
                                  for w, b in worker_busy.items()}}


def read_timeline(folder: Path, *, culprit: str = "timeline") -> list[dict[str, Any]]:
    """The rows of the ``timeline.csv`` in ``folder`` (what :func:`write_timeline` wrote), its
    times as numbers: ``started``, and ``ended`` and ``duration_s`` (None where the attempt did
    not end). A value that is not a number is refused naming the file and the line."""
    path = Path(folder) / TIMELINE
    where = f"{culprit} {path}"
    try:
        rows = list(csv.DictReader(path.read_text(encoding="utf-8").splitlines()))
    except (OSError, UnicodeDecodeError, csv.Error) as e:
        raise InputError(f"cannot read the timeline ({e})", culprit=where) from None
    for line, row in enumerate(rows, start=2):
        for key in ("started", "ended", "duration_s"):
            value = row.get(key)
            if key != "started" and not value:
                row[key] = None
                continue
            try:
                row[key] = float(value)  # type: ignore[arg-type]
            except (TypeError, ValueError):
                raise InputError(f"line {line}: {key} {value!r} is not a number",
                                 culprit=where) from None
    return rows


def write_timeline(study: Study, out: Path) -> int:
    """``OUT/timeline.csv``: when and where each attempt of each run ran; returns its rows."""
    rows = timeline(study, out)
    lines = [",".join(TIMELINE_COLUMNS)]
    for row in rows:
        cells = []
        for c in TIMELINE_COLUMNS:
            v = row[c]
            cells.append("" if v is None else f"{v:.3f}" if isinstance(v, float) else str(v))
        lines.append(",".join(_csv_cell(c) for c in cells))
    data = ("\n".join(lines) + "\n").encode()
    atomic_write(out / TIMELINE, lambda f: f.write(data))
    return len(rows)


def _csv_cell(text: str) -> str:
    return f'"{text}"' if ("," in text or '"' in text) else text
