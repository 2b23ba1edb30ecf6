"""The names of a study folder's files and what each holds (its manifest's inventory).

``OUT/study.toml`` (the study file as run), ``OUT/study.json`` (the index: run ids and their
settings' fingerprints), ``OUT/results.csv``, ``OUT/timeline.csv``, ``OUT/failures.csv`` and
one training folder per run under ``OUT/runs/<run id>/`` with its ``status.json`` and
``gait.csv``.
"""

from __future__ import annotations

from ..commands.train import TRAIN_FILES
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
