"""Parameter studies: a TOML file of conditions, sweep axes and seeds, run on Dask.

A study file::

    [study]
    name = "ablation"
    sessions = 400                    # training sessions per trial
    seeds = { first = 1, count = 20 } # or a list: seeds = [1, 2, 3]
    batch = 20                        # seeds trained together in one network (one run),
                                      # or "auto": chosen for the workers (batching.py)

    [base]                            # parameter overrides for every run, with units
    L_max = "10*second"

    [models]                          # optional: model files (TOML, `astrocpg models dump`)
    astrocyte = "my_astrocyte.toml"   # replacing a model in every run (path beside the study)

    [sweep]                           # optional axes; every combination ("grid") or
    mode = "grid"                     # element by element ("zip")
    [sweep.axes]
    eta_ADO = ["0.5", "1.0"]
    astrocyte = ["li_rinzel.toml", "variant.toml"]  # an axis named by a model: model files

    [conditions.astrocytes]           # at least one condition
    astrocytes = true
    [conditions.no_astrocytes]
    astrocytes = false
    set = { }                         # overrides of this condition only

Every (condition, sweep point) is trained for every seed. Consecutive seeds of one point run as
one *run*: ``batch`` trials in one network. Trial ``b`` of a run that starts at seed ``s`` has
the network (connectivity, neuron positions) of seed ``s + b`` whatever the batch, but its noise
comes from the run's one Brian2 generator, which draws for every trial of the run at each
step: a seed's trajectory depends on the batching, its statistics over seeds do not
(docs/reproducibility.md, "Seeds and batches"). Changing ``batch`` gives other, equally
valid, trajectories.

Each run lives in ``OUT/runs/<run id>/`` as an ordinary training folder (``sessions.csv``,
``weights.npz``, ``checkpoint.npz``, ``manifest.json``) plus ``status.json``. A run whose
status is ``finished`` is never run again; any other run resumes from its checkpoint, so
repeating the command after a crash, a killed worker or Ctrl-C continues where it stopped. A
checkpoint is data, never code (:func:`~astrocpg.studies.files.checkpoint.read_checkpoint`): before any worker
starts, the checkpoints of the runs to resume are checked, and one that is not a checkpoint of
this format (an old pickled ``checkpoint.pkl`` included, which is never loaded) refuses the
study, naming the file.
"""

from __future__ import annotations

import csv
import itertools
import json
import math
import os
import re
import shutil
import socket
import sys
import time
import tomllib
import traceback
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Any, Sequence

import numpy as np

from ...coupling.assembly import check_models
from ...coupling.recorder import RecordPlan
from ...coupling.training import SESSION_COLUMNS, session_steps
from ...errors import EnvironmentFault, InputError, did_you_mean
from ...models import DEFAULT_MODELS
from ...network import exclusive
from ..experiments.cluster import (check_scheduler, check_workers, connect_cluster,
                                   run_on_cluster)
from ..experiments.resources import (available_memory, check_memory, estimate_bytes,
                                     estimate_wall_seconds)
from ...models.compose import model_files_record, model_set, read_model_files
from ..experiments.settings import MAX_SEED
from ..experiments.simulate import STEP, check_duration
from ..experiments.train import (CHECKPOINT, TRAIN_FILES, Trainer, TrainingStopped, TrainSettings,
                                 read_checkpoint)
from ..files.checkpoint import refuse_legacy
from ..files.folder import (FolderLock, check_output_path, check_replaceable,
                            clean_stale_temporaries, clear_folder, holds_results)
from ..files.outputs import atomic_write, prepare_output_dir, save_json, write_manifest
from ..files.weights import WEIGHTS

RUNS = "runs"
STATUS = "status.json"
RESULTS = "results.csv"
FAILURES = "failures.csv"
TIMELINE = "timeline.csv"
TIMELINE_COLUMNS = ("run_id", "attempt", "state", "worker", "worker_name", "host", "pid",
                    "started", "ended", "duration_s", "started_utc")
STUDY_COPY = "study.toml"
STUDY_INDEX = "study.json"

MAX_SEEDS = 100_000
_NAME = re.compile(r"[A-Za-z0-9][A-Za-z0-9._-]{0,99}")
_STUDY_KEYS = {"name", "description", "sessions", "seeds", "batch", "record"}
_CONDITION_KEYS = {"astrocytes", "set"}


@dataclass(frozen=True, kw_only=True)
class RunSpec:
    """One run of a study: ``n_trials`` consecutive seeds of one (condition, sweep point).

    run_id: folder name under ``OUT/runs``; condition: the condition's name; point: the swept
    parameters' values (as written in the study file); seed: the first seed; n_trials: seeds
    seed..seed+n_trials-1; n_sessions: sessions per trial; astrocytes: False for the ablation;
    overrides: every ``NAME=VALUE`` applied (base, sweep point, condition); record: which
    sessions, spikes and traces each run records (``[study] record``), or None.
    """

    run_id: str
    condition: str
    point: dict[str, str]
    seed: int
    n_trials: int
    n_sessions: int
    astrocytes: bool
    overrides: tuple[str, ...]
    record: dict[str, Any] | None = None  # RecordPlan fields (not part of the run's identity)
    # model files of the run: {model: {"sha256": ..., "content": ...}} (the file's whole text)
    models: dict[str, dict[str, str]] = field(default_factory=dict)
    # the longest a session may last (L_max, seconds), for the run's cost estimate only
    session_s: float | None = None

    def estimated_seconds(self) -> float:
        """Wall seconds the run takes at most on one core (every session lasting L_max),
        to start the longest runs first; relative, not a promise."""
        return estimate_wall_seconds(trials=self.n_trials,
                                     seconds=self.n_sessions * (self.session_s or 1.0))

    def record_plan(self):
        if not self.record:
            return None
        return RecordPlan.from_dict(self.record)

    def train_settings(self):
        return TrainSettings(n_sessions=self.n_sessions, seed=self.seed, n_trials=self.n_trials,
                             astrocytes=self.astrocytes, overrides=list(self.overrides),
                             models=dict(self.models))

    def fingerprint(self) -> str:
        return self.train_settings().fingerprint()


@dataclass(kw_only=True)
class Study:
    """A parsed, validated study file."""

    name: str
    description: str
    path: Path
    text: str
    n_sessions: int
    seeds: list[int]
    batch: int
    sweep: list[str]  # names of the swept parameters (table columns)
    runs: list[RunSpec] = field(default_factory=list)
    # [evaluate]: after the runs, their controllers in other worlds (astrocpg evaluate)
    evaluate: dict[str, Any] | None = None
    # the file's batch: seeds per run, or "auto" (chosen by resolve_batch, then batch_choice
    # says how; runs are split by ``batch`` only once it is chosen)
    batch_setting: int | str = 0
    batch_choice: dict[str, Any] | None = None

    @property
    def batch_pending(self) -> bool:
        """``batch = "auto"`` not yet chosen: :func:`resolve_batch` must come first."""
        return self.batch_setting == "auto" and self.batch_choice is None


def _value_text(key: str, value: Any, where: str) -> str:
    if isinstance(value, bool) or not isinstance(value, (str, int, float)):
        raise InputError(f"'{key}' must be a number or a quantity string like "
                         f"\"9*ms\", got {value!r}", culprit=where)
    return str(value)


def _check_override(models, key: str, value: str, where: str) -> str:
    item = f"{key}={value}"
    try:
        models.parse_assignment(item)
    except InputError as e:
        raise InputError(f"{e}", culprit=where) from None
    return item


def _slug(text: str) -> str:
    return re.sub(r"[^A-Za-z0-9.+-]+", "-", text).strip("-") or "x"


def load_study(path: str | os.PathLike, *, batch: int | None = None) -> Study:
    """Read and validate a study file; every error names the file and the offending key.

    batch: seeds per run, instead of the file's ``batch`` (how a ``batch = "auto"`` study is
    split once its batch is chosen: :func:`resolve_batch`)."""

    p = Path(path)
    built_in = Path(__file__).with_name(f"{p.name}.toml")
    if not p.exists() and p.suffix == "" and built_in.exists():
        p = built_in  # `astrocpg study quick`: a built-in study by name
    try:
        text = p.read_bytes().decode("utf-8")
    except OSError as e:
        raise InputError(f"cannot read ({e.strerror})", culprit=f"study {p}") from None
    except UnicodeDecodeError:
        raise InputError("not a UTF-8 text file (a study file is TOML)",
                         culprit=f"study {p}") from None
    return _parse_study(text, p, batch)


def _parse_study(text: str, p: Path, batch_given: int | None) -> Study:
    try:
        doc = tomllib.loads(text)
    except tomllib.TOMLDecodeError as e:
        raise InputError(f"not valid TOML ({e})", culprit=f"study {p}") from None
    where = f"study {p.name}"
    unknown = set(doc) - {"study", "base", "models", "sweep", "conditions", "evaluate"}
    if unknown:
        raise InputError(f"unknown section [{sorted(unknown)[0]}] "
                         f"(sections: study, base, models, sweep, conditions, evaluate)",
                         culprit=where)
    head = doc.get("study", {})
    bad = set(head) - _STUDY_KEYS
    if bad:
        raise InputError(f"[study] has unknown key '{sorted(bad)[0]}' "
                         f"(keys: {', '.join(sorted(_STUDY_KEYS))})", culprit=where)
    name = head.get("name", p.stem)
    if not isinstance(name, str) or not _NAME.fullmatch(name):
        # the name becomes a folder (out/<name>): it may never leave the output root
        raise InputError(f"[study] name must be letters, digits, '.', '_' or '-' (a folder "
                         f"name, not a path), got {name!r}", culprit=where)
    n_sessions = head.get("sessions", 400)
    if not isinstance(n_sessions, int) or isinstance(n_sessions, bool) or n_sessions < 1:
        raise InputError(f"[study] sessions must be a positive integer, "
                         f"got {n_sessions!r}", culprit=where)
    seeds_doc = head.get("seeds", {"first": 1, "count": 1})
    if isinstance(seeds_doc, dict):
        first, count = seeds_doc.get("first", 1), seeds_doc.get("count", 1)
        if not all(isinstance(v, int) and not isinstance(v, bool) for v in (first, count)) \
                or count < 1 or set(seeds_doc) - {"first", "count"}:
            raise InputError(f"[study] seeds must be {{ first = K, count = N }} with "
                             f"integers, N >= 1, or a list of integers", culprit=where)
        if count > MAX_SEEDS:
            raise InputError(f"[study] seeds: {count} seeds is more than {MAX_SEEDS} (each seed "
                             f"is a training of {head.get('sessions', 400)} sessions)",
                             culprit=where)
        seeds = list(range(first, first + count))
    elif isinstance(seeds_doc, list) and seeds_doc and all(
            isinstance(s, int) and not isinstance(s, bool) for s in seeds_doc):
        seeds = sorted(set(seeds_doc))
        if len(seeds) != len(seeds_doc):
            raise InputError("[study] seeds lists a seed twice", culprit=where)
    else:
        raise InputError(f"[study] seeds must be {{ first = K, count = N }} or a "
                         f"non-empty list of integers", culprit=where)
    if min(seeds) < 0:
        raise InputError("[study] seeds must be non-negative", culprit=where)
    if max(seeds) > MAX_SEED:
        raise InputError(f"[study] seeds must be at most {MAX_SEED} (2**32 - 1), got "
                         f"{max(seeds)}", culprit=where)
    batch_setting = head.get("batch", len(seeds))
    if batch_setting != "auto" and (not isinstance(batch_setting, int)
                                    or isinstance(batch_setting, bool) or batch_setting < 1):
        raise InputError(f"[study] batch must be a positive integer or \"auto\", "
                         f"got {batch_setting!r}", culprit=where)
    # "auto": until resolve_batch chooses, one run per condition and point (nothing runs so)
    batch = batch_given if batch_given is not None \
        else (len(seeds) if batch_setting == "auto" else batch_setting)
    # one run trains min(batch, seeds) trials in one network: refuse what cannot fit
    if batch_setting != "auto" or batch_given is not None:
        check_memory(estimate_bytes(trials=min(batch, len(seeds)), seconds=0.0, spikes=False,
                                    sessions=n_sessions),
                     culprit=f"{where} [study] batch = {min(batch, len(seeds))} seeds per run "
                             f"of {n_sessions} sessions")

    record = _record_table(head.get("record"), where)
    slots = {name for name, _ in DEFAULT_MODELS.items()}
    models_doc = doc.get("models", {})
    if not isinstance(models_doc, dict):
        raise InputError("[models] must map model names to model files", culprit=where)
    base_files = {}
    for slot, file in models_doc.items():
        if slot not in slots:
            raise InputError(f"[models] unknown model '{slot}'{did_you_mean(slot, slots)} (models: "
                             f"{', '.join(sorted(slots))})", culprit=where)
        base_files[slot] = _model_file(p, slot, file, f"{where} [models]")
    models = model_set(models=base_files, option=f"{where} [models]")
    base = [_check_override(models, k, _value_text(k, v, f"{where} [base]"), f"{where} [base]")
            for k, v in doc.get("base", {}).items()]

    sweep_doc = doc.get("sweep", {})
    bad = set(sweep_doc) - {"mode", "axes"}
    if bad:
        raise InputError(f"[sweep] has unknown key '{sorted(bad)[0]}' "
                         f"(keys: mode, axes)", culprit=where)
    mode = sweep_doc.get("mode", "grid")
    if mode not in ("grid", "zip"):
        raise InputError(f"[sweep] mode must be \"grid\" or \"zip\", got {mode!r}", culprit=where)
    axes: dict[str, list[str]] = {}
    axis_files: dict[tuple[str, str], dict[str, str]] = {}  # (model, file) -> record
    for k, values in sweep_doc.get("axes", {}).items():
        if not isinstance(values, list) or not values:
            raise InputError(f"[sweep.axes] '{k}' must be a non-empty list", culprit=where)
        if k in slots:  # an axis of model files
            axes[k] = []
            for v in values:
                aw = f"{where} [sweep.axes] {k}"
                if not isinstance(v, str):
                    raise InputError(f"lists model files, got {v!r}", culprit=aw)
                axis_files[(k, v)] = _model_file(p, k, v, f"{where} [sweep.axes]")
                model_set(models={**base_files, k: axis_files[(k, v)]},
                          option=f"{where} [sweep.axes]")
                axes[k].append(v)
            continue
        axes[k] = [_value_text(k, v, f"{where} [sweep.axes]") for v in values]
        for v in axes[k]:
            _check_override(models, k, v, f"{where} [sweep.axes]")
    if mode == "zip" and len({len(v) for v in axes.values()}) > 1:
        raise InputError(f"[sweep] mode \"zip\" needs axes of equal length "
                         f"({', '.join(f'{k}: {len(v)}' for k, v in axes.items())})", culprit=where)
    names = list(axes)
    n_points = math.prod(len(v) for v in axes.values()) if mode == "grid" \
        else min((len(v) for v in axes.values()), default=1)
    n_conditions = len(doc["conditions"]) if isinstance(doc.get("conditions"), dict) else 1
    trainings = n_points * max(n_conditions, 1) * len(seeds)
    if trainings > MAX_SEEDS:  # before building (and checking) a million runs
        raise InputError(f"{trainings} trainings ({n_points} sweep point(s) x {n_conditions} "
                         f"condition(s) x {len(seeds)} seed(s)) is more than {MAX_SEEDS}",
                         culprit=where)
    if not names:
        points: list[dict[str, str]] = [{}]
    elif mode == "grid":
        points = [dict(zip(names, combo)) for combo in itertools.product(*axes.values())]
    else:
        points = [dict(zip(names, combo)) for combo in zip(*axes.values())]

    conditions = doc.get("conditions", {"default": {"astrocytes": True}})
    if not isinstance(conditions, dict) or not conditions:
        raise InputError("[conditions] must name at least one condition", culprit=where)
    runs: list[RunSpec] = []
    groups = _consecutive_groups(seeds, batch)
    for cname, cond in conditions.items():
        cw = f"{where} [conditions.{cname}]"
        if not isinstance(cond, dict):
            raise InputError("must be a table", culprit=cw)
        bad = set(cond) - _CONDITION_KEYS
        if bad:
            raise InputError(f"unknown key '{sorted(bad)[0]}' (keys: astrocytes, set)", culprit=cw)
        astro = cond.get("astrocytes", True)
        if not isinstance(astro, bool):
            raise InputError("astrocytes must be true or false", culprit=cw)
        # one parameter, one source per run: a condition's value would win over a sweep axis
        # of the same parameter while the run's id named the axis value
        touched = dict.fromkeys(cond.get("set", {}) if isinstance(cond.get("set"), dict)
                                else (), "its set")
        if not astro:
            touched.setdefault("astrocyte_regulation", "astrocytes = false")
        for k, how in touched.items():
            if k in axes:
                raise InputError(f"{how} changes {k}, which [sweep.axes] {k} also sweeps: "
                                 f"each run would take the "
                                 f"condition's value while its id names the axis value; sweep "
                                 f"it or set it, not both", culprit=f"{cw} and [sweep.axes] {k}")
        cset = [_check_override(models, k, _value_text(k, v, cw), cw)
                for k, v in cond.get("set", {}).items()]
        for point in points:
            files = {**base_files, **{k: axis_files[(k, v)] for k, v in point.items()
                                      if k in slots}}
            overrides = tuple(base + [f"{k}={v}" for k, v in point.items() if k not in slots]
                              + cset)
            # one model set per point: catches e.g. a value out of a parameter's range
            point_models = model_set(models=files, option=cw) if files != base_files \
                else models
            try:
                run_models = point_models.with_values(dict(point_models.parse_assignment(o)
                                                           for o in overrides))
                session_steps(run_models, STEP)  # whole steps, before anything runs
            except InputError as e:
                raise InputError(f"{e}", culprit=cw) from None
            try:  # what a run's build would refuse (delays, world): now, not in every run
                check_models(run_models)
            except InputError as e:
                at = ", ".join(f"{k}={v}" for k, v in point.items())
                raise InputError(f"{'point ' + at + ': ' if at else ''}{e}", culprit=cw) \
                    from None
            session_s = run_models.value("L_max")
            tag = "_".join(f"{k}={_slug(v)}" for k, v in point.items())
            for first, n in groups:
                seeds_tag = f"seed{first}" if n == 1 else f"seeds{first}-{first + n - 1}"
                run_id = "__".join(x for x in (_slug(cname), tag, seeds_tag) if x)
                runs.append(RunSpec(run_id=run_id, condition=cname, point=dict(point),
                                    seed=first, n_trials=n, n_sessions=n_sessions,
                                    astrocytes=astro, overrides=overrides, record=record,
                                    models=files, session_s=session_s))
    ids = [r.run_id for r in runs]
    if len(set(ids)) != len(ids):
        dup = next(i for i in ids if ids.count(i) > 1)
        raise InputError(f"two runs would share the folder '{dup}' (condition names or "
                         f"swept values that differ only in punctuation)", culprit=where)
    evaluate = _evaluate_table(doc.get("evaluate"), p, where)
    if evaluate is not None:
        # one evaluation network holds a run's trials x repeats: refused now, not after the runs
        trials = max(r.n_trials for r in runs) * evaluate["repeats"]
        check_memory(estimate_bytes(trials=trials, seconds=evaluate["seconds"], robot_stride=1),
                     culprit=f"{where} [evaluate] seconds = {evaluate['seconds']:g} x "
                             f"{trials} trials (repeats x seeds per run)")
        for c in evaluate["conditions"]:
            if c not in {r.condition for r in runs}:
                raise InputError(f"[evaluate] conditions: no condition '{c}' in the study",
                                 culprit=where)
    return Study(name=name, description=str(head.get("description", "")), path=p, text=text,
                 n_sessions=n_sessions, seeds=seeds, batch=batch, sweep=names, runs=runs,
                 evaluate=evaluate, batch_setting=batch_setting,
                 batch_choice=None if batch_setting != "auto" or batch_given is None
                 else {"batch": batch_given, "reason": "given by the caller"})


def _model_file(study: Path, slot: str, file: Any, where: str) -> dict[str, str]:
    """The record ``{"sha256", "content"}`` of the model file for ``slot`` named in a study (a
    path relative to the study file's folder)."""
    if not isinstance(file, str) or not file:
        raise InputError(f"expected the path of a model file, got {file!r}",
                         culprit=f"{where} {slot}")
    path = Path(file) if Path(file).is_absolute() else study.parent / file
    text = read_model_files([f"{slot}={path}"], option=where)[slot]
    return model_files_record({slot: text})[slot]


_EVALUATE_KEYS = {"worlds", "seconds", "repeats", "conditions"}


def _evaluate_table(doc: Any, study: Path, where: str) -> dict[str, Any] | None:
    """``[evaluate]``: worlds (a built-in name or a file beside the study file), seconds,
    repeats, conditions; checked here, worlds included, so a typo stops the study at once."""
    if doc is None:
        return None
    if not isinstance(doc, dict) or set(doc) - _EVALUATE_KEYS:
        raise InputError(f"[evaluate] takes {', '.join(sorted(_EVALUATE_KEYS))}", culprit=where)
    from ..experiments.evaluate import BUILTIN_WORLDS, read_worlds

    worlds = doc.get("worlds", "robustness")
    if not isinstance(worlds, str) or not worlds:
        raise InputError("[evaluate] worlds must be a worlds file or 'robustness'",
                         culprit=where)
    if worlds not in BUILTIN_WORLDS:
        worlds = str((study.parent / worlds).resolve())
    read_worlds(worlds, DEFAULT_MODELS)
    seconds, repeats = doc.get("seconds", 10.0), doc.get("repeats", 2)
    if isinstance(seconds, bool) or not isinstance(seconds, (int, float)) or not seconds > 0:
        raise InputError("[evaluate] seconds must be a positive number", culprit=where)
    check_duration(seconds, STEP, culprit=f"{where} [evaluate] seconds")
    if isinstance(repeats, bool) or not isinstance(repeats, int) or repeats < 1:
        raise InputError("[evaluate] repeats must be a positive integer", culprit=where)
    conditions = doc.get("conditions", [])
    if not isinstance(conditions, list) or not all(isinstance(c, str) for c in conditions):
        raise InputError("[evaluate] conditions must be a list of condition names",
                         culprit=where)
    return {"worlds": worlds, "seconds": float(seconds), "repeats": repeats,
            "conditions": conditions}


def _record_table(doc: Any, where: str) -> dict[str, Any] | None:
    """``[study] record = { every = N, spikes = [...], traces = [...], stride = S }``."""

    if doc is None:
        return None
    if not isinstance(doc, dict) or "every" not in doc:
        raise InputError(f"[study] record must be a table with at least 'every' "
                         f"(e.g. record = {{ every = 50, traces = [\"astrocyte_Ca\"] }})",
                         culprit=where)
    bad = set(doc) - {"every", "spikes", "traces", "stride"}
    if bad:
        raise InputError(f"[study] record has unknown key '{sorted(bad)[0]}' "
                         f"(keys: every, spikes, traces, stride)", culprit=where)
    try:
        plan = RecordPlan.from_dict(doc)
    except (TypeError, ValueError) as e:
        raise InputError(f"[study] record: {e}", culprit=where) from None
    return {"every": plan.every, "spikes": list(plan.spikes), "traces": list(plan.traces),
            "stride": plan.stride}


def _consecutive_groups(seeds: Sequence[int], batch: int) -> list[tuple[int, int]]:
    """Split sorted seeds into runs of consecutive seeds, at most ``batch`` per run."""
    groups: list[tuple[int, int]] = []
    for s in seeds:
        if groups and groups[-1][0] + groups[-1][1] == s and groups[-1][1] < batch:
            groups[-1] = (groups[-1][0], groups[-1][1] + 1)
        else:
            groups.append((s, 1))
    return groups


def resolve_batch(study: Study, out: Path | None, *, workers: int | None = None,
                  scheduler: str | None = None, progress: bool = True) -> Study:
    """``batch = "auto"``: the study split into runs of the batch that finishes it soonest on
    these workers (:func:`~astrocpg.studies.sweeps.batching.choose_batch`, with this machine's
    measured cost per trial). A folder that already holds the study keeps the batch it was
    started with, whatever the workers now, so a rerun resumes the same runs. Any other study
    is returned as it is."""
    if not study.batch_pending:
        return study
    recorded = _recorded_batch(out) if out is not None else None
    if recorded is not None:
        chosen = {"batch": recorded, "reason": f"recorded in {STUDY_INDEX} when the study began"}
    else:
        from ..experiments.trial_cost import trial_cost
        from .batching import choose_batch

        n_workers = _cluster_threads(scheduler) if scheduler else (workers or os.cpu_count() or 1)
        groups: dict[tuple[str, str], tuple[list[int], float]] = {}
        for r in study.runs:  # one run per (condition, point) until the batch is chosen
            groups[(r.condition, json.dumps(r.point, sort_keys=True))] = (
                study.seeds, r.n_sessions * (r.session_s or 1.0))

        def fits(n: int) -> bool:
            runs_at_once = min(n_workers, len(groups) * math.ceil(len(study.seeds) / n))
            return estimate_bytes(trials=n, seconds=0.0, spikes=False,
                                  sessions=study.n_sessions) * runs_at_once \
                <= available_memory()

        cost = trial_cost(progress=progress)
        chosen = choose_batch(list(groups.values()), workers=n_workers, cost=cost,
                              split=_consecutive_groups, fits=fits)
        if chosen["batch"] is None:
            raise InputError("batch = \"auto\": not even one seed per run fits in memory "
                             f"on {n_workers} workers", culprit=f"study {study.path.name}")
        chosen["cost"] = {"fixed_s_per_sim_s": cost.fixed,
                          "per_trial_s_per_sim_s": cost.per_trial,
                          "measured": cost.measured, "codegen": cost.codegen,
                          "when": cost.when}
    resolved = _parse_study(study.text, study.path, int(chosen["batch"]))
    resolved.batch_choice = chosen
    return resolved


def _recorded_batch(out: Path) -> int | None:
    """The batch a study folder was started with (its index), or None for a new folder."""
    try:
        index = json.loads((Path(out) / STUDY_INDEX).read_text())
    except (OSError, ValueError):
        return None
    if isinstance(index.get("batch"), int) and index["batch"] >= 1:
        return index["batch"]
    sizes = [s.get("n_trials") for s in index.get("specs", {}).values()]  # an older index
    sizes = [n for n in sizes if isinstance(n, int) and n >= 1]
    return max(sizes) if sizes else None


def _cluster_threads(scheduler: str) -> int:
    """Worker threads of a running Dask cluster (what runs at once)."""
    client, _ = connect_cluster(None, scheduler)
    try:
        return max(1, sum(client.nthreads().values()))
    finally:
        client.close()


# ---------------------------------------------------------------- one run (on a worker)

def read_status(folder: Path) -> dict[str, Any]:
    try:
        return json.loads((folder / STATUS).read_text())
    except (OSError, ValueError):
        return {}


def _write_status(folder: Path, status: dict[str, Any]) -> None:
    save_json(folder / STATUS, status)


@exclusive  # a worker's tasks are threads: one Brian2 training at a time (network/runlock.py)
def execute_run(spec: RunSpec, folder: str) -> dict[str, Any]:
    """Train one run in ``folder`` (resuming from its checkpoint if there is one).

    Runs on a Dask worker. Never raises for a failure of the run itself: the error and its
    traceback go into ``status.json`` and the returned dict, so one failed run does not stop
    the study. Returns the final status.
    """
    import warnings

    warnings.filterwarnings("ignore", module="brian2")

    out = prepare_output_dir(folder)
    # the run folder is this worker's while it trains (inside the study's folder, which the
    # study's process holds): `train --resume` or `run --out ... --overwrite` on it is refused
    lock = FolderLock(out, culprit=f"run folder {out}", inside=out.parent.parent)
    try:
        lock.acquire()
    except InputError as e:  # another process holds it: write nothing into it
        return {"run_id": spec.run_id, "state": "failed", "error": f"InputError: {e}",
                "not_written": True}
    try:
        return _execute_run_locked(spec, out)
    finally:
        lock.release()


def _execute_run_locked(spec: RunSpec, out: Path) -> dict[str, Any]:
    status = read_status(out)
    if status.get("state") == "finished":
        return status
    worker, worker_name = _this_worker()
    status.update({
        "run_id": spec.run_id, "state": "running", "attempts": status.get("attempts", 0) + 1,
        "host": socket.gethostname(), "pid": os.getpid(), "worker": worker,
        "worker_name": worker_name, "started": time.time(), "spec": asdict(spec),
    })
    status.pop("error", None)
    status.pop("finished", None)
    # every attempt keeps its own line (the timeline of the study): a killed attempt stays
    # without an end
    status["history"] = status.get("history", []) + [
        {k: status[k] for k in ("attempts", "worker", "worker_name", "host", "pid", "started")}]
    t0 = time.perf_counter()
    try:
        _write_status(out, status)
        settings = spec.train_settings()
        payload = None
        refuse_legacy(out)  # an old pickled checkpoint is never loaded
        if (out / CHECKPOINT).exists():
            payload = read_checkpoint(out / CHECKPOINT, culprit=out)
            if payload["fingerprint"] != settings.fingerprint():
                raise InputError("its checkpoint belongs to other settings", culprit=out)
        models = model_set(settings.overrides, {}, models=settings.models)
        trainer = Trainer(models, settings, out, progress=False, record=spec.record_plan())
        if payload is not None:
            trainer.restore(payload)
        status["sessions_at_start"] = int(trainer.training.sessions_done.sum())
        _write_status(out, status)
        write_manifest(out, command="study-run", seed=spec.seed, settings=asdict(spec),
                       models_json=trainer.models.to_json(), files=_run_files(),
                       results={"status": "running"})
        wall = trainer.run()
        _write_gaits(out, trainer)
        status.update({"state": "finished", "finished": time.time(),
                       "wall_seconds": status.get("wall_seconds", 0.0) + time.perf_counter() - t0})
        _end_attempt(status)
        _write_status(out, status)
        # last: the manifest's inventory lists the run's files as they stay (status included)
        write_manifest(out, command="study-run", seed=spec.seed, settings=asdict(spec),
                       models_json=trainer.models.to_json(), files=_run_files(),
                       results={"status": "finished", "wall_seconds_last_attempt": wall})
        return status
    except TrainingStopped as e:
        status.update({"state": "stopped", "error": str(e), "finished": time.time()})
    except Exception as e:  # recorded, not raised: the other runs go on
        status.update({"state": "failed", "error": f"{type(e).__name__}: {e}",
                       "traceback": traceback.format_exc(), "finished": time.time()})
    _end_attempt(status)
    _write_status(out, status)
    return status


GAITS = "gait.csv"


def _write_gaits(out: Path, trainer: Trainer) -> None:
    """``gait.csv``: each trial's gait with its final tables, learning off (a short run)."""
    from ..experiments.trained import GAIT_COLUMNS, final_gaits

    with np.load(out / WEIGHTS, allow_pickle=False) as z:  # written by this process a moment ago
        tables = np.asarray(z["final_weights_mV"], dtype=float) * 1e-3
    rows = final_gaits(trainer.models, tables)
    lines = ["trial," + ",".join(GAIT_COLUMNS)]
    for b, row in enumerate(rows):
        lines.append(f"{b}," + ",".join(str(row[c]) for c in GAIT_COLUMNS))
    data = ("\n".join(lines) + "\n").encode()
    atomic_write(out / GAITS, lambda f: f.write(data))


def _this_worker() -> tuple[str, str]:
    """(address, name) of the Dask worker running this task; empty outside a worker."""
    try:
        from distributed import get_worker

        w = get_worker()
        return str(w.address), str(w.name)
    except (ImportError, ValueError):
        return "", ""


def _end_attempt(status: dict[str, Any]) -> None:
    last = status["history"][-1]
    last.update({"state": status["state"], "ended": status["finished"],
                 "duration_s": status["finished"] - last["started"]})


def _run_files() -> dict[str, str]:
    return TRAIN_FILES | {STATUS: "state of the run in its study (running, finished, failed), "
                                     "attempts, error",
                          GAITS: "each trial's gait with its final tables, learning off, "
                                 "5 s: label, speed, period, leg phases and locking to FR"}


# ---------------------------------------------------------------- the study (client side)
def _check_folder(study: Study, out: Path) -> None:
    """A study folder belongs to one study: a rerun may add runs but not change one."""
    index_path = out / STUDY_INDEX
    known: dict[str, str] = {}
    if index_path.exists():
        try:
            known = json.loads(index_path.read_text())["runs"]
        except (OSError, ValueError, KeyError):
            raise InputError(f"{STUDY_INDEX} is unreadable", culprit=f"--out {out}") from None
    elif any(out.iterdir()):
        raise InputError(f"is not empty and holds no study (no {STUDY_INDEX}); "
                         f"use a new folder", culprit=f"--out {out}")
    if index_path.exists():
        try:
            name = json.loads(index_path.read_text())["name"]
        except (OSError, ValueError, KeyError):
            raise InputError(f"{STUDY_INDEX} is unreadable", culprit=f"--out {out}") from None
        if name != study.name:
            raise InputError(f"belongs to study '{name}', not '{study.name}' "
                             f"(use a new --out)", culprit=f"--out {out}")
    for run in study.runs:
        fp = known.get(run.run_id)
        if fp is not None and fp != run.fingerprint():
            raise InputError(f"run '{run.run_id}' there has other settings than "
                             f"in {study.path.name} (use a new --out)", culprit=f"--out {out}")


def _check_checkpoints(pending: Sequence[RunSpec], folders: dict[str, Path]) -> None:
    """Before any worker starts: each run to resume holds no checkpoint or a whole one of this
    format and of its settings (read and checked as a worker will); else the study is refused
    naming the file (an InputError: exit 2), rather than each worker failing its run. The
    workers read checkpoints as data only all the same (a file changed after this check fails
    its run, recorded in failures.csv, and runs no code)."""
    for r in pending:
        folder = folders[r.run_id]
        refuse_legacy(folder)
        if (folder / CHECKPOINT).exists() or (folder / CHECKPOINT).is_symlink():
            payload = read_checkpoint(folder / CHECKPOINT)
            if payload["fingerprint"] != r.train_settings().fingerprint():
                raise InputError("belongs to other settings than its run in the study file "
                                 "(use a new --out)", culprit=folder / CHECKPOINT)


def _save_index(study: Study, out: Path) -> None:
    index_path = out / STUDY_INDEX
    known: dict[str, str] = {}
    specs: dict[str, Any] = {}
    if index_path.exists():  # a rerun may add runs (more seeds, points): keep the earlier ones
        old = json.loads(index_path.read_text())
        known, specs = old["runs"], old.get("specs", {})
    known.update({r.run_id: r.fingerprint() for r in study.runs})
    specs.update({r.run_id: asdict(r) for r in study.runs})
    save_json(index_path, {"name": study.name, "sweep": study.sweep, "runs": known,
                           "specs": specs, "batch": study.batch,
                           "batch_setting": study.batch_setting,
                           "batch_choice": study.batch_choice})
    data = study.text.encode()
    atomic_write(out / STUDY_COPY, lambda f: f.write(data))


def _sessions_done(folder: Path) -> int:
    try:
        with open(folder / "sessions.csv", "rb") as f:
            return max(0, sum(1 for _ in f) - 1)
    except OSError:
        return 0


def prepare_study(study: Study, out: Path, *, workers: int | None = None,
                  scheduler: str | None = None, overwrite: bool = False,
                  progress: bool = True) -> Study:
    """The checks of :func:`run_study` that need no cluster, and ``batch = "auto"`` chosen
    (:func:`resolve_batch`): the study as it will run. Writes nothing."""
    if scheduler is None:  # a local cluster of that many processes: bounded by the cores
        check_workers(workers)
    elif workers is not None and workers < 1:
        raise InputError(f"must be at least 1, got {workers}", culprit="--workers")
    if scheduler is not None:  # a short probe now, not a long wait (or a strange error) later
        check_scheduler(scheduler)
    out = Path(out)
    if out.exists() and not out.is_dir():
        raise InputError("exists and is not a folder", culprit=f"--out {out}")
    # the study file (and a worlds file it names) is never the folder nor inside it; what
    # --overwrite replaces is a folder astrocpg wrote, never the user's own files
    worlds = (study.evaluate or {}).get("worlds")
    inputs = [study.path, *([worlds] if isinstance(worlds, str) and os.path.isfile(worlds)
                            else [])]
    check_output_path(out, inputs, culprit=f"--out {out}")
    if overwrite and holds_results(out):
        check_replaceable(out, culprit=f"--out {out}")
    # --overwrite starts afresh: the batch the old folder began with does not count
    return resolve_batch(study, None if overwrite else out, workers=workers,
                         scheduler=scheduler, progress=progress)


def run_study(study: Study, out: Path, *, workers: int | None = None,
              scheduler: str | None = None, progress: bool = True,
              overwrite: bool = False) -> dict[str, Any]:
    """Run every unfinished run of ``study`` on Dask; write the results table. Returns counts
    of runs by state and the paths written. Nothing is written before the folder is known to
    belong to this study and the cluster is reachable; while it runs, the study owns its folder
    (a second process on it is refused). ``overwrite`` replaces the folder whole."""
    out = Path(out)
    study = prepare_study(study, out, workers=workers, scheduler=scheduler,
                          overwrite=overwrite, progress=progress)
    if out.exists() and not overwrite:
        _check_folder(study, out)
    created = not out.exists()
    try:
        out.mkdir(parents=True, exist_ok=True)
    except OSError as e:
        raise EnvironmentFault.from_os_error(e, out, "cannot create the folder") from None
    try:
        with FolderLock(out, culprit="--out"):
            if overwrite:
                clear_folder(out)
            clean_stale_temporaries(out)
            return _run_study_locked(study, out, workers=workers, scheduler=scheduler,
                                     progress=progress)
    except BaseException:
        if created and not holds_results(out):  # refused before writing: leave no folder
            shutil.rmtree(out, ignore_errors=True)
        raise


def _run_study_locked(study: Study, out: Path, *, workers: int | None, scheduler: str | None,
                      progress: bool) -> dict[str, Any]:
    # the progress bar of a study (tqdm.auto: notebook or tty; warnings wait until it closes)
    from ..experiments.progress import Bar as tqdm

    largest = max(r.n_trials for r in study.runs)
    check_memory(estimate_bytes(trials=largest, seconds=0.0, spikes=False,
                                sessions=study.n_sessions)
                 * min(len(study.runs), workers or os.cpu_count() or 1),
                 culprit=f"study {study.name} (runs of {largest} trials)")
    folders = {r.run_id: out / RUNS / r.run_id for r in study.runs}
    pending = [r for r in study.runs if read_status(folders[r.run_id]).get("state") != "finished"]
    _check_checkpoints(pending, folders)
    total_sessions = sum(r.n_trials * r.n_sessions for r in study.runs)
    n_done_before = len(study.runs) - len(pending)
    settings = {"study": str(study.path), "study_text": study.text, "workers": workers,
                "scheduler": scheduler, "batch": study.batch, "batch_choice": study.batch_choice}
    cluster = connect_cluster(workers, scheduler) if pending else None
    unwritten: dict[str, str] = {}
    try:
        prepare_output_dir(out)
        _save_index(study, out)
        write_manifest(out, command="study", seed=min(study.seeds),
                       settings=settings,
                       models_json={}, files=_study_files(), results={"status": "running"})
        if pending:
            unwritten = _dispatch(study, pending, folders, cluster[0], progress,
                                  total_sessions, n_done_before, tqdm)
    finally:
        if cluster is not None:
            cluster[0].close()
            if cluster[1] is not None:
                cluster[1].close()
    states = {r.run_id: "failed" if r.run_id in unwritten
              else read_status(folders[r.run_id]).get("state", "not run")
              for r in study.runs}
    table = write_results(study, out)
    write_timeline(study, out)
    failed = [r for r in study.runs if states[r.run_id] != "finished"]
    errors = _write_failures(out, failed, folders, unwritten)
    counts = {s: list(states.values()).count(s) for s in sorted(set(states.values()))}
    evaluated = None
    if study.evaluate is not None and not failed:
        # a step of the study: its trained controllers in other worlds (out/evaluation)
        from ..experiments.evaluate import evaluate

        e = study.evaluate
        # on the study's cluster settings, resumable like its runs (out/evaluation.parts)
        evaluated = str(evaluate(out, worlds=e["worlds"], seconds=e["seconds"],
                                 repeats=e["repeats"], conditions=e["conditions"] or None,
                                 progress=progress, workers=workers or os.cpu_count() or 1,
                                 scheduler=scheduler)["out"])
    write_manifest(out, command="study", seed=min(study.seeds),
                   settings=settings,
                   models_json={}, files=_study_files(),
                   results={"status": "finished" if not failed else "incomplete",
                            "runs": counts, "rows": table, "evaluation": evaluated})
    return {"counts": counts, "failed": [r.run_id for r in failed], "rows": table,
            "evaluation": evaluated, "errors": errors,
            "failures": str(out / FAILURES) if (out / FAILURES).is_file() else None}


def _dispatch(study, pending, folders, client, progress, total_sessions, n_done_before,
              tqdm) -> dict[str, str]:
    """Run ``pending`` on the cluster, longest first, one run per free worker thread
    (:func:`run_on_cluster`), with the study's progress bar. Returns the errors of runs that
    could not write their status (their folder was held by another process): {run_id:
    error}."""
    unwritten: dict[str, str] = {}
    waiting = sorted(pending, key=lambda r: r.estimated_seconds(), reverse=True)
    by_id = {r.run_id: r for r in waiting}
    counts = {"failed": 0, "finished": 0}
    done_sessions = sum(_sessions_done(f) for f in folders.values())
    bar = tqdm(total=total_sessions, initial=done_sessions, unit="session",
               desc=f"study {study.name}", disable=not progress, dynamic_ncols=True,
               smoothing=0.05,
               # a log file (not a terminal) gets a line every 30 s, not every second
               mininterval=0.5 if sys.stderr.isatty() else 30.0)

    def ended(run_id: str, future: Any) -> None:
        counts["finished"] += 1
        if not _collect(future, by_id[run_id], folders[run_id], unwritten):
            counts["failed"] += 1

    def tick(running: int) -> None:
        now = sum(_sessions_done(f) for f in folders.values())
        bar.update(max(0, now - bar.n))
        bar.set_postfix_str(f"runs done {n_done_before + counts['finished'] - counts['failed']}/"
                            f"{len(study.runs)}, running {running}, failed {counts['failed']}")

    try:
        run_on_cluster(client, execute_run,
                       [(r.run_id, (r, str(folders[r.run_id]))) for r in waiting], ended, tick)
    finally:
        bar.close()
    return unwritten


def _collect(future: Any, spec: RunSpec, folder: Path, unwritten: dict[str, str]) -> bool:
    """True when the run of ``future`` finished; a run that failed on its worker has said so in
    its status.json; one that could not run (e.g. KilledWorker after repeated worker deaths, or
    a cancelled task) is recorded as failed here; one whose folder another process held wrote
    nothing there: its error goes into ``unwritten``."""
    if future.status == "finished":
        status = future.result()
        if status.get("not_written"):
            unwritten[spec.run_id] = str(status.get("error", ""))
        return status.get("state") == "finished"
    if future.status == "error":
        exc = future.exception()
        error = f"{type(exc).__name__}: {exc}"
    else:
        error = f"the task was {future.status}"
    prepare_output_dir(folder)
    status = read_status(folder)
    status.update({"run_id": spec.run_id, "state": "failed", "error": error})
    _write_status(folder, status)
    return False


def _write_failures(out: Path, failed: list[RunSpec], folders: dict[str, Path],
                    unwritten: dict[str, str] | None = None) -> dict[str, str]:
    """``failures.csv``: the runs that did not finish and their errors (removed when none);
    returns {run_id: error}. ``unwritten``: errors of runs whose folder another process held
    (their status.json is not theirs to tell)."""
    path = out / FAILURES
    unwritten = unwritten or {}
    if not failed:
        if path.exists():
            path.unlink()
        return {}
    lines = ["run_id,state,attempts,error"]
    errors: dict[str, str] = {}
    for r in failed:
        s = read_status(folders[r.run_id])
        if r.run_id in unwritten:
            s = {"state": "failed", "attempts": s.get("attempts", 0),
                 "error": unwritten[r.run_id]}
        state = s.get("state", "not run")
        err = str(s.get("error", "") or ("not run" if state == "not run" else state))
        errors[r.run_id] = " ".join(err.split())
        err = err.replace('"', "'").replace("\n", " ")
        lines.append(f'{r.run_id},{state},{s.get("attempts", 0)},"{err}"')
    data = ("\n".join(lines) + "\n").encode()
    atomic_write(path, lambda f: f.write(data))
    return errors


def _study_files() -> dict[str, str]:
    return {
        RESULTS: "one row per seed and session of every finished run: run_id, condition, the "
                 "swept parameters, seed, then the columns of a training's sessions.csv",
        FAILURES: "runs that did not finish, with their error (absent when none)",
        STUDY_COPY: "the study file as run", STUDY_INDEX: "run ids, their settings' fingerprints",
        TIMELINE: "one row per attempt of every run, in the order they started: run_id, attempt, "
                  "state (finished, failed, stopped; interrupted: its worker or the study "
                  "stopped), worker (address), worker_name, host, pid, started and ended (Unix "
                  "seconds, wall clock), duration_s, started_utc",
        RUNS + "/<run id>/": "one training folder per run (sessions.csv, weights.npz, "
                             "checkpoint.npz, manifest.json, status.json)",
    }


def write_results(study: Study, out: Path) -> int:
    """Gather the finished runs' ``sessions.csv`` into ``OUT/results.csv``, each row with its
    seed's final gait (``gait.csv`` of the run: label, speed, period, leg phases; empty for a
    run trained before runs wrote it); returns its rows."""
    from ..experiments.trained import GAIT_COLUMNS

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
    in the order they started; an attempt without an end has state ``interrupted``."""
    rows = []
    for r in study.runs:
        for h in read_status(out / RUNS / r.run_id).get("history", []):
            ended = h.get("ended")
            rows.append({"run_id": r.run_id, "attempt": h.get("attempts"),
                         "state": h.get("state", "interrupted") if ended else "interrupted",
                         "worker": h.get("worker", ""), "worker_name": h.get("worker_name", ""),
                         "host": h.get("host", ""), "pid": h.get("pid"),
                         "started": h["started"], "ended": ended,
                         "duration_s": h.get("duration_s"),
                         "started_utc": time.strftime("%Y-%m-%dT%H:%M:%SZ",
                                                      time.gmtime(h["started"]))})
    return sorted(rows, key=lambda row: row["started"])


def utilisation(rows: Sequence[dict[str, Any]], n_workers: int = 0) -> dict[str, Any]:
    """How busy the workers were, from a :func:`timeline`: ``wall_s`` (first start to last
    end), ``utilisation`` (run seconds / (workers x wall)), ``idle_pending_s`` (seconds workers
    were free while a run had not started yet, summed over workers), ``longest_idle_pending_s``
    (the longest such stretch of one worker) and ``worker_gaps`` (per worker, those stretches
    as (from, to) seconds after the first start). With ``n_workers`` more than the workers in
    ``rows``, the others ran nothing: they count as free throughout. A worker is its address
    (or host:pid)."""
    def who(row):
        return row["worker"] or f"{row['host']}:{row['pid']}"

    names = list(dict.fromkeys(map(who, rows)))
    n = max(n_workers, len(names))
    if not rows:
        return {"runs": 0, "workers": n, "wall_s": 0.0, "utilisation": 0.0,
                "idle_pending_s": 0.0, "longest_idle_pending_s": 0.0, "worker_gaps": {}}
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
    return {"runs": len(rows), "workers": n, "wall_s": wall,
            "utilisation": busy / (n * wall) if wall > 0 else 1.0,
            "idle_pending_s": sum(every), "longest_idle_pending_s": max(every, default=0.0),
            "worker_gaps": gaps}


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
