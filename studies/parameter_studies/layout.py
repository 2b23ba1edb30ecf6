"""The names of a study folder's files and what each holds (its manifest's inventory).

``OUT/study.toml`` (the study file as run), ``OUT/study.json`` (the index: run ids and their
settings' fingerprints), ``OUT/results.csv``, ``OUT/timeline.csv``, ``OUT/failures.csv`` and
one training folder per run under ``OUT/runs/<run id>/`` with its ``status.json`` and
``gait.csv``.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

from ..commands.train_files import TRAIN_FILES
from ..outputs.writing import read_manifest
from ..outputs.study_index import INDEX

RUNS = "runs"
STATUS = "status.json"
RESULTS = "results.csv"
FAILURES = "failures.csv"
TIMELINE = "timeline.csv"
TIMELINE_COLUMNS = ("run_id", "attempt", "state", "worker", "worker_name", "host", "pid",
                    "started", "ended", "duration_s", "started_utc")
STUDY_COPY = "study.toml"
STUDY_INDEX = INDEX  # "study.json"
GAITS = "gait.csv"

#: The states after which a run is never trained again: a diverged run is a function of its
#: settings and would diverge again.
ENDED = ("finished", "diverged")


def as_it_stands(folder: Path, status: dict[str, Any]) -> dict[str, Any]:
    """``status`` (a run's ``status.json``) as the run really stands. A run ends by writing its
    status, then its manifest (whose inventory lists the status): a run whose status says it
    ended (:data:`ENDED`) while its manifest still says ``running`` was killed between the two writes
    (its study stopped at that moment). Its attempt did not end: it is ``stopped``, continued
    from its checkpoint by the next start of the study, which writes the manifest; never
    skipped as ended, which would leave a folder that does not match its manifest."""
    state = status.get("state")
    if state not in ENDED:
        return status
    # the window: the run's first manifest ("running", written before it trains) is still
    # there; any other (a folder without one, made by hand or by a tool) leaves the status
    manifest = read_manifest(Path(folder))
    results = manifest.get("results") if isinstance(manifest, dict) else None
    if not (isinstance(results, dict) and results.get("status") == "running"):
        return status
    return {**status, "state": "stopped",
            "error": f"stopped after its status said {state}, before its manifest did"}


def run_files() -> dict[str, str]:
    return TRAIN_FILES | {STATUS: "state of the run in its study (running, finished, "
                                     "diverged, failed, stopped), attempts, error",
                          GAITS: "each trial's rhythm (final_rhythm: thigh-extensor "
                                 "bursts) and gait (final_gait: footfalls over the upright "
                                 "part; final_gait_reason when none) with its final tables, "
                                 "learning off, 5 s: labels, speed, periods, leg phases and "
                                 "locking to FR"}


def study_files() -> dict[str, str]:
    return {
        RESULTS: "one row per seed and session of every finished run: run_id, condition, the "
                 "swept parameters, seed, then the columns of a training's sessions.csv",
        FAILURES: "runs that did not finish (state diverged, failed, stopped or not run), with "
                  "their error (absent when none)",
        STUDY_COPY: "the study file as run",
        STUDY_INDEX: "run ids, their settings' fingerprints (of every version of the study "
                     "run here) and the runs the study file now names (current)",
        TIMELINE: "one row per attempt of every run, in the order they started: run_id, attempt, "
                  "state (finished, diverged, failed, stopped; interrupted: its worker or the study "
                  "stopped), worker (address), worker_name, host, pid, started and ended (Unix "
                  "seconds, wall clock), duration_s, started_utc",
        RUNS + "/<run id>/": "one training folder per run (sessions.csv, weights.npz, "
                             "checkpoint.npz, manifest.json, status.json)",
    }
