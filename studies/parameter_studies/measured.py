"""How long each seed trained in an earlier study: what a study given that study's folder as
``plan_from`` costs its runs with, in place of the bound ``sessions x L_max``.

A run's trials step together until its last trial has done its sessions, so a run lasts as
long as its busiest seed's training, and a training's length is the sum of its sessions'
lengths. Those depend on the condition: in the paper's ablation the robots with astrocytes learn
to walk and their sessions run to L_max (about 3,600 s per seed for 400 sessions), those without
fall sooner (about 2,600 s). Before a study has run nothing says which condition will train
longer; a finished study of the same conditions does. A seed's trajectory does not depend on
the batch it runs in, so on the same settings the lengths read here are the ones the new study
will train.

The same folder's ``timeline.csv`` gives what each of its runs cost in wall seconds on the
workers it had: :func:`fitted_cost` fits the cost per simulated second (a fixed part and a part
per trial) to those runs when they are of two or more sizes, so that the plan is made with
what runs cost in a study (two runs sharing the machine's memory and caches) rather than
with the cost measured on an idle machine, one process at a time.
"""

from __future__ import annotations

import csv
import gzip
import zlib
import io
import os
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from ...errors import EnvironmentFault, Field, InputError, setting, shown_with
from ...support.reading import MAX_PLAN_BYTES, read_bytes, read_json, too_large
from ..outputs.writing import read_manifest
from .trial_cost import TrialCost
from .layout import TIMELINE
from .tables import read_timeline
from .study_file import run_group

#: the results table of a study folder (``results.csv``; also read gzip-compressed)
TABLES = ("results.csv", "results.csv.gz")


def results_table(path: Path, culprit: str) -> Path:
    """The results table ``path`` names: the file itself, or a study folder's."""
    if path.is_dir():
        for name in TABLES:
            if (path / name).is_file():
                return path / name
        raise InputError(f"holds no results table ({' or '.join(TABLES)}): give a finished "
                         f"study's folder", culprit=culprit)
    if path.is_file():
        return path
    if not os.path.lexists(path):  # a missing input: the environment's (exit 1)
        raise EnvironmentFault("no such study folder or results table", culprit=culprit)
    raise InputError("is neither a study folder nor a results table", culprit=culprit)


def _sessions_by_run(path: Path, culprit: str) -> dict[str, dict[int, tuple[float, int]]]:
    """``{run id: {seed: (simulated seconds trained, sessions)}}`` from the results table
    ``path`` names (a study folder or the table), refused naming the file and the row where it
    is not a study's results."""
    table = results_table(Path(path), culprit)
    where = shown_with(culprit, table)
    try:
        # bounded: the file by its size before it is read, its gzip content while it inflates
        # (a 10 MB .gz can hold gigabytes: refused at the bound, never inflated whole)
        raw = read_bytes(table, where, limit=MAX_PLAN_BYTES)
        if table.name.endswith(".gz"):
            with gzip.GzipFile(fileobj=io.BytesIO(raw)) as z:
                raw = z.read(MAX_PLAN_BYTES + 1)
            if len(raw) > MAX_PLAN_BYTES:
                raise too_large(table, where, len(raw), MAX_PLAN_BYTES, "bytes once inflated "
                                "(or more)")
        text = raw.decode("utf-8")
    except (OSError, EOFError, gzip.BadGzipFile, zlib.error) as e:
        raise InputError(f"cannot read the table ({e})", culprit=where) from None
    except UnicodeDecodeError:
        raise InputError("not a UTF-8 text table", culprit=where) from None
    reader = csv.DictReader(io.StringIO(text))
    needed = {"run_id", "seed", "length_s"}
    missing = needed - set(reader.fieldnames or ())
    if missing:
        raise InputError(f"is not a study's results table (no column "
                         f"{', '.join(sorted(missing))})", culprit=where)
    runs: dict[str, dict[int, tuple[float, int]]] = {}
    for line, row in enumerate(reader, start=2):
        try:
            seed, length = int(row["seed"]), float(row["length_s"])
        except (TypeError, ValueError):
            raise InputError(f"line {line}: seed {row['seed']!r} or length_s "
                             f"{row['length_s']!r} is not a number", culprit=where) from None
        if not (length >= 0.0 and length != float("inf")):
            raise InputError(f"line {line}: length_s {row['length_s']!r} is not a finite "
                             f"length", culprit=where)
        seeds = runs.setdefault(row["run_id"], {})
        total, n = seeds.get(seed, (0.0, 0))
        seeds[seed] = (total + length, n + 1)
    if not runs:
        raise InputError("holds no sessions", culprit=where)
    return runs


def measured_lengths(path: str | Path, *, culprit: str | Field = setting("plan_from")
                     ) -> dict[str, dict[int, tuple[float, int]]]:
    """``{group: {seed: (simulated seconds trained, sessions)}}`` from the results table of the
    study folder ``path`` (or the table itself): per condition and sweep point
    (:func:`~astrocpg.studies.parameter_studies.study_file.run_group`), each seed's summed
    session lengths and its number of sessions. A table that is not a study's results (a
    column missing, a value that is not a number) is refused naming the file and the row."""
    lengths: dict[str, dict[int, tuple[float, int]]] = {}
    for run_id, seeds in _sessions_by_run(Path(path), culprit).items():
        group = lengths.setdefault(run_group(run_id), {})
        for seed, (total, n) in seeds.items():
            before, k = group.get(seed, (0.0, 0))
            group[seed] = (before + total, k + n)
    return lengths


@dataclass(frozen=True)
class RunCost:
    """One run of an earlier study as it cost: its trials, its busiest seed's simulated
    seconds (the run steps until that seed is done) and the wall seconds it ran."""

    run_id: str
    n_trials: int
    busiest_s: float
    wall_s: float

    @property
    def per_simulated_s(self) -> float:
        return self.wall_s / self.busiest_s


def measured_run_costs(path: str | Path, *,
                       culprit: str | Field = setting("plan_from")) -> list[RunCost]:
    """The runs of the study folder ``path`` that finished in one attempt, with what each
    cost (its ``timeline.csv``; its trials and busiest seed from the results table). A run
    resumed after a stop is left out (its wall time includes starting again); a folder
    without a timeline (or a bare table) gives none."""
    path = Path(path)
    if not (path.is_dir() and (path / TIMELINE).is_file()):
        return []
    runs = _sessions_by_run(path, culprit)
    attempts: dict[str, list[tuple[int, dict[str, Any]]]] = {}
    for line, row in enumerate(read_timeline(path, culprit=culprit), start=2):
        attempts.setdefault(str(row.get("run_id")), []).append((line, row))
    out = []
    for run_id, tried in attempts.items():
        seeds = runs.get(run_id)
        if len(tried) != 1 or tried[0][1].get("state") != "finished" or not seeds:
            continue
        line, row = tried[0]
        wall = row["duration_s"]
        if not (wall is not None and 0.0 < wall < float("inf")):  # a finished run took time
            raise InputError(f"line {line}: duration_s {wall!r} of a finished run is not a "
                             f"positive number of seconds",
                             culprit=shown_with(culprit, path / TIMELINE))
        busiest = max(total for total, _ in seeds.values())
        if busiest > 0.0:
            out.append(RunCost(run_id, len(seeds), busiest, wall))
    return out


def _study_manifest(path: Path) -> dict[str, Any] | None:
    """The study folder's manifest (``manifest.json``; ``study_manifest.json`` where the
    folder is a copy beside a report's), or None."""
    manifest = read_manifest(path)
    if not (isinstance(manifest, dict) and manifest.get("astrocpg_command") == "study"):
        try:
            manifest = read_json(path / "study_manifest.json")
        except (OSError, ValueError):
            return None
    return manifest if isinstance(manifest, dict) and \
        manifest.get("astrocpg_command") == "study" else None


def fitted_cost(path: str | Path, *, codegen: str, workers: int,
                culprit: str | Field = setting("plan_from")) -> tuple[TrialCost | None, str]:
    """The cost per simulated second fitted to the runs of the study in ``path``
    (:func:`measured_run_costs`; the mean per size where several runs have one: runs of
    different conditions with as many trials are pooled), and what it was fitted to; or
    ``(None, why not)``: the folder's runs ran with another Brian2 target, number of workers
    or of cores, or its manifest does not say (their costs would not hold here), or they are
    all of one size (a fixed part cannot be told from a per-trial part). The costs are a
    worker's wall seconds, one worker per core, as the plan's projections are."""
    path = Path(path)
    runs = measured_run_costs(path, culprit=culprit)
    if not runs:
        return None, "it has no timeline of finished runs"
    manifest = _study_manifest(path)
    if manifest is None:
        return None, "it has no study manifest to say where its runs ran"
    settings = manifest.get("settings") if isinstance(manifest.get("settings"), dict) else {}
    machine = manifest.get("machine") if isinstance(manifest.get("machine"), dict) else {}
    ran = (manifest.get("codegen"), settings.get("workers"), machine.get("cpu_count"))
    here = (codegen, workers, os.cpu_count())
    if ran != here:
        return None, (f"its runs ran with codegen, workers, cores = {ran[0]}, {ran[1]}, "
                      f"{ran[2]}, not {here[0]}, {here[1]}, {here[2]}")
    by_size: dict[int, list[float]] = {}
    for r in runs:
        by_size.setdefault(r.n_trials, []).append(r.per_simulated_s)
    if len(by_size) < 2:
        return None, f"its runs are all of {runs[0].n_trials} trials"
    measured = {n: sum(v) / len(v) for n, v in by_size.items()}
    key = (f"fitted to {len(runs)} runs of {path} (codegen={codegen}, workers={workers}, "
           f"cpus={os.cpu_count()})")
    return TrialCost.fit(measured, codegen=codegen, key=key), f"{len(runs)} runs of {path}"


def planned_lengths(measured: dict[int, tuple[float, int]] | None, seeds: list[int],
                    n_sessions: int, bound_s: float) -> dict[int, float]:
    """Each seed's projected training length for ``n_sessions`` sessions of at most
    ``bound_s / n_sessions`` s: its measured mean session length times ``n_sessions`` (the
    measured total when the sessions are as many), at most ``bound_s``; a seed not measured gets
    ``bound_s``."""
    measured = measured or {}
    out = {}
    for s in seeds:
        total, n = measured.get(s, (0.0, 0))
        out[s] = min(bound_s, total / n * n_sessions) if n else bound_s
    return out
