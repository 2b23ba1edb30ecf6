"""A study file read and checked: the TOML text parsed into a :class:`Study` of
:class:`RunSpec` (one per run), every mistake an InputError naming the file and the key.

What a study file holds is described in :mod:`astrocpg.studies.parameter_studies.study`. Everything a run
would refuse (a parameter out of range, a model file that does not fit, whole steps per session,
memory for a batch) is checked here, before anything runs.
"""

from __future__ import annotations

import itertools
import math
import re
import tomllib
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Sequence

from ...coupling.assembly import check_models
from ...coupling.recorder import RecordPlan
from ...coupling.training import session_steps
from ...errors import Field, InputError, did_you_mean, setting
from ...support.reading import loads_toml
from ...models import DEFAULT_MODELS
from ..runtime.resources import check_memory, estimate_bytes, estimate_wall_seconds
from ...models.compose import model_files_record, model_set, read_model_files
from ..analysis.margins import read_margins
from ..settings.study import MAX_SEEDS, StudyOverrides
from ..settings.checks import MAX_SEED, STEP, check_duration, check_grid
from ..settings.populations import population_models, population_rows, population_table
from ..settings import TrainSettings

_NAME = re.compile(r"[A-Za-z0-9][A-Za-z0-9._-]{0,99}")
_STUDY_KEYS = {"name", "description", "sessions", "seeds", "batch", "record", "paired",
               "populations"}
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
    # populations added to the run's network ([study] populations): {name: {"sha256",
    # "content"}} of the model file that declares each
    populations: dict[str, dict[str, str]] = field(default_factory=dict)

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
                             models=dict(self.models), populations=dict(self.populations))

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
    # "auto" only: the groups (run ids without their seeds, :func:`run_group`) split into
    # smaller runs than ``batch`` so that no worker idles at the end ({group: seeds per run})
    split: dict[str, int] = field(default_factory=dict)
    # what the command line changed in the file's study (recorded in the study folder)
    overrides: StudyOverrides = field(default_factory=StudyOverrides)
    # paired = true: the report compares seed k of one condition with seed k of another
    # (paired tests), a design declared in the file before any run, never chosen after
    paired: bool = False
    # [margins]: equivalence margins per measure (SI units or plain numbers), declared in the
    # file before any run; the report tests equivalence against them
    margins: dict[str, float] = field(default_factory=dict)

    @property
    def batch_pending(self) -> bool:
        """``batch = "auto"`` not yet chosen: :func:`resolve_batch` must come first."""
        return self.batch_setting == "auto" and self.batch_choice is None


def _value_text(key: str, value: Any, where: str) -> str:
    if isinstance(value, bool) or not isinstance(value, (str, int, float)):
        raise InputError(f"'{key}' must be a number or a quantity string like "
                         f"\"9*ms\", got {value!r}", culprit=where)
    return str(value)


def _check_override(models, key: str, value: str, where: Any) -> str:
    item = f"{key}={value}"
    try:
        models.parse_assignment(item)
    except InputError as e:
        # an override given as a setting already names the parameter: said once, not twice
        said = e.raw_message if isinstance(where, Field) else e.raw_line
        raise InputError(said, culprit=where) from None
    return item


def _slug(text: str) -> str:
    return re.sub(r"[^A-Za-z0-9.+-]+", "-", text).strip("-") or "x"


def parse_study(text: str, p: Path, batch_given: int | None,
                overrides: StudyOverrides | None = None,
                split_given: dict[str, int] | None = None) -> Study:
    """The :class:`Study` of the TOML ``text`` read from ``p``, every key checked in the order
    the file is read (the first mistake is the one reported); ``batch_given``: seeds per run,
    instead of the file's ``batch``; ``overrides``: the command line's changes, applied to the
    study as read (a mistake names the option); ``split_given``: with ``batch_given``, the
    groups (:func:`run_group`) split into runs of other sizes (``batch = "auto"``'s choice)."""
    given = overrides or StudyOverrides()
    try:
        doc = loads_toml(text, f"study {p}")  # nesting bounded before tomllib recurses
    except tomllib.TOMLDecodeError as e:
        raise InputError(f"not valid TOML ({e})", culprit=f"study {p}") from None
    where = f"study {p.name}"
    if not doc:  # no key at all: a study of every default (400 sessions) is never guessed
        raise InputError("is empty (no [study] or other section); a study file names at least "
                         "its [study] (see 'astrocpg study quick' and the manual's studies "
                         "page)", culprit=f"study {p}")
    unknown = set(doc) - {"study", "base", "models", "sweep", "conditions", "evaluate",
                          "margins"}
    if unknown:
        sections = ("study", "base", "models", "sweep", "conditions", "evaluate", "margins")
        raise InputError(f"unknown section [{sorted(unknown)[0]}]"
                         f"{did_you_mean(sorted(unknown)[0], sections)} "
                         f"(sections: {', '.join(sections)})",
                         culprit=where)
    # equivalence margins, declared before any run (what "no difference" means per measure)
    margins = read_margins(doc.get("margins"), where)
    head = doc.get("study", {})
    bad = set(head) - _STUDY_KEYS
    if bad:
        raise InputError(f"[study] has unknown key '{sorted(bad)[0]}'"
                         f"{did_you_mean(sorted(bad)[0], _STUDY_KEYS)} "
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
    if given.sessions is not None:
        n_sessions = given.sessions
    seeds = _seeds(head, where)
    if given.seeds is not None:
        seeds = list(given.seeds)
    elif given.count is not None:
        if seeds[0] + given.count - 1 > MAX_SEED:
            raise InputError(f"{given.count} seeds from {seeds[0]} go past {MAX_SEED}",
                             culprit=setting("seeds"))
        seeds = list(range(seeds[0], seeds[0] + given.count))
    batch_setting, batch = _batch(head, seeds, n_sessions, batch_given, where)
    populations = _population_files(p, head.get("populations"), where)
    # what the runs may record: theirs too
    record = _record_table(head.get("record"), where, population_table(populations))
    slots = {name for name, _ in DEFAULT_MODELS.items()}
    base_files, models, base = _base(doc, p, slots, where, population_models(populations))
    names, axes, axis_files, points = _sweep(doc, p, slots, base_files, models, len(seeds),
                                             where)
    base = _apply_sets(doc, models, base, axes, given.sets, where)
    runs = _runs(doc, slots, base_files, models, base, axes, axis_files, points,
                 _Runs(seeds=seeds, batch=batch, split=dict(split_given or {}),
                       n_sessions=n_sessions, record=record,
                       populations=populations), where)
    evaluate = _evaluate_table(doc.get("evaluate"), p, where)
    if evaluate is not None:
        # its cells (runs x worlds) bounded now, not refused after the runs have trained
        check_grid(len(runs) * evaluate["n_worlds"],
                   f"cells of [evaluate] ({len(runs)} run(s) x {evaluate['n_worlds']} "
                   f"world(s))", culprit=f"{where} [evaluate]")
        # one evaluation network holds a run's trials x repeats: refused now, not after the runs
        trials = max(r.n_trials for r in runs) * evaluate["repeats"]
        check_memory(estimate_bytes(trials=trials, seconds=evaluate["seconds"], robot_stride=1),
                     culprit=f"{where} [evaluate] seconds = {evaluate['seconds']:g} x "
                             f"{trials} trials (repeats x seeds per run)")
        for c in evaluate["conditions"]:
            if c not in {r.condition for r in runs}:
                raise InputError(f"[evaluate] conditions: no condition '{c}' in the study",
                                 culprit=where)
    paired = head.get("paired", False)
    if not isinstance(paired, bool):
        raise InputError("[study] paired must be true or false", culprit=where)
    return Study(name=name, description=str(head.get("description", "")), path=p, text=text,
                 n_sessions=n_sessions, seeds=seeds, batch=batch, sweep=names, runs=runs,
                 paired=paired, margins=margins,
                 evaluate=evaluate, batch_setting=batch_setting,
                 batch_choice=None if batch_setting != "auto" or batch_given is None
                 else {"batch": batch_given, "reason": "given by the caller"},
                 overrides=given, split=dict(split_given or {}))


def _apply_sets(doc: dict[str, Any], models, base: list[str], axes: dict[str, list[str]],
                sets: Sequence[str], where: str) -> list[str]:
    """``base`` with each override ``NAME=VALUE`` checked against the study's models and put in
    place of the file's ``[base]`` NAME (or added). A name the study sweeps, or a condition
    sets, is refused: its runs would take the axis's or the condition's value, not this one."""
    out = list(base)
    conditions = doc.get("conditions", {})
    for item in sets:
        name, _, value = item.partition("=")
        name, value = name.strip(), value.strip()
        culprit = setting("overrides", name)
        if name in axes:
            raise InputError(f"the study sweeps {name} ([sweep.axes] of {where[6:]}): every "
                             f"run takes its axis value; drop {setting('overrides')} or the axis",
                             culprit=culprit)
        if isinstance(conditions, dict):
            for cname, cond in conditions.items():
                if isinstance(cond, dict) and (
                        name in (cond.get("set") or {})
                        or (name == "astrocyte_regulation" and cond.get("astrocytes") is False)):
                    raise InputError(f"condition '{cname}' of {where[6:]} sets {name}: its "
                                     f"runs take the condition's value; drop "
                                     f"{setting('overrides')} or edit "
                                     f"the condition", culprit=culprit)
        checked = _check_override(models, name, value, culprit)
        out = [b for b in out if b.partition("=")[0] != name] + [checked]
    return out


def _seeds(head: dict[str, Any], where: str) -> list[int]:
    """``[study] seeds``: ``{ first = K, count = N }`` or a list of integers, sorted."""
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
    return seeds


def _batch(head: dict[str, Any], seeds: list[int], n_sessions: int, batch_given: int | None,
           where: str) -> tuple[int | str, int]:
    """``[study] batch`` as written (a positive integer or "auto") and the seeds per run it
    gives now (``batch_given`` instead, when given); a run that cannot fit in memory is
    refused."""
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
    return batch_setting, batch


def _base(doc: dict[str, Any], p: Path, slots: set[str], where: str, added: Any = ()):
    """``[models]`` and ``[base]``: the model files of every run, their model set and the
    overrides of every run (``NAME=VALUE`` texts, each checked)."""
    models_doc = doc.get("models", {})
    if not isinstance(models_doc, dict):
        raise InputError("[models] must map model names to model files", culprit=where)
    base_files = {}
    for slot, file in models_doc.items():
        if slot not in slots:
            raise InputError(f"[models] unknown model '{slot}'{did_you_mean(slot, slots)} (models: "
                             f"{', '.join(sorted(slots))})", culprit=where)
        base_files[slot] = _model_file(p, slot, file, f"{where} [models]")
    # the added populations' models join the set: [base], the sweep and overrides reach them
    models = model_set(models=base_files, option=f"{where} [models]", added=added)
    base = [_check_override(models, k, _value_text(k, v, f"{where} [base]"), f"{where} [base]")
            for k, v in doc.get("base", {}).items()]
    return base_files, models, base


def _sweep(doc: dict[str, Any], p: Path, slots: set[str], base_files: dict[str, Any], models,
           n_seeds: int, where: str):
    """``[sweep]``: the swept names, their values (an axis named by a model lists model files,
    each read and checked), the files of those axes and the points (every combination, or
    element by element), refused beyond :data:`MAX_SEEDS` trainings before any is built."""
    sweep_doc = doc.get("sweep", {})
    bad = set(sweep_doc) - {"mode", "axes"}
    if bad:
        raise InputError(f"[sweep] has unknown key '{sorted(bad)[0]}'"
                         f"{did_you_mean(sorted(bad)[0], ('mode', 'axes'))} "
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
    trainings = n_points * max(n_conditions, 1) * n_seeds
    # before building (and checking) a million runs
    check_grid(trainings, f"trainings ({n_points} sweep point(s) x {n_conditions} "
                          f"condition(s) x {n_seeds} seed(s))", culprit=where)
    if not names:
        points: list[dict[str, str]] = [{}]
    elif mode == "grid":
        points = [dict(zip(names, combo)) for combo in itertools.product(*axes.values())]
    else:
        points = [dict(zip(names, combo)) for combo in zip(*axes.values())]
    return names, axes, axis_files, points


@dataclass(frozen=True)
class _Runs:
    """What every run of a study shares: its seeds, the seeds per run, sessions, recording."""

    seeds: list[int]
    batch: int
    n_sessions: int
    record: dict[str, Any] | None
    populations: dict[str, dict[str, str]] = field(default_factory=dict)
    split: dict[str, int] = field(default_factory=dict)  # {group: seeds per run}, else batch


def _runs(doc: dict[str, Any], slots: set[str], base_files: dict[str, Any], models,
          base: list[str], axes: dict[str, list[str]],
          axis_files: dict[tuple[str, str], dict[str, str]], points: list[dict[str, str]],
          shared: _Runs, where: str) -> list[RunSpec]:
    """``[conditions]``: one run per condition, sweep point and group of consecutive seeds,
    each point's models and overrides checked as its run's build would check them; two runs
    sharing a folder are refused."""
    conditions = doc.get("conditions", {"default": {"astrocytes": True}})
    if not isinstance(conditions, dict) or not conditions:
        raise InputError("[conditions] must name at least one condition", culprit=where)
    runs: list[RunSpec] = []
    for cname, cond in conditions.items():
        cw = f"{where} [conditions.{cname}]"
        if not isinstance(cond, dict):
            raise InputError("must be a table", culprit=cw)
        bad = set(cond) - _CONDITION_KEYS
        if bad:
            raise InputError(f"unknown key '{sorted(bad)[0]}'"
                             f"{did_you_mean(sorted(bad)[0], _CONDITION_KEYS)} "
                             f"(keys: astrocytes, set)", culprit=cw)
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
            point_models = model_set(models=files, option=cw, added=models.added) \
                if files != base_files else models
            try:
                run_models = point_models.with_values(dict(point_models.parse_assignment(o)
                                                           for o in overrides))
                session_steps(run_models, STEP)  # whole steps, before anything runs
            except InputError as e:
                raise InputError(e.raw_line, culprit=cw) from None
            try:  # what a run's build would refuse (delays, world): now, not in every run
                check_models(run_models)
            except InputError as e:
                at = ", ".join(f"{k}={v}" for k, v in point.items())
                raise InputError(f"{'point ' + at + ': ' if at else ''}{e.raw_line}", culprit=cw) \
                    from None
            session_s = run_models.value("L_max")
            tag = "_".join(f"{k}={_slug(v)}" for k, v in point.items())
            group = "__".join(x for x in (_slug(cname), tag) if x)
            for first, n in consecutive_groups(shared.seeds,
                                               shared.split.get(group, shared.batch)):
                seeds_tag = f"seed{first}" if n == 1 else f"seeds{first}-{first + n - 1}"
                run_id = f"{group}__{seeds_tag}"
                runs.append(RunSpec(run_id=run_id, condition=cname, point=dict(point),
                                    seed=first, n_trials=n, n_sessions=shared.n_sessions,
                                    astrocytes=astro, overrides=overrides, record=shared.record,
                                    models=files, session_s=session_s,
                                    populations=dict(shared.populations)))
    ids = [r.run_id for r in runs]
    if len(set(ids)) != len(ids):
        dup = next(i for i in ids if ids.count(i) > 1)
        raise InputError(f"two runs would share the folder '{dup}' (condition names or "
                         f"swept values that differ only in punctuation)", culprit=where)
    return runs


def _model_file(study: Path, slot: str, file: Any, where: str) -> dict[str, str]:
    """The record ``{"sha256", "content"}`` of the model file for ``slot`` named in a study (a
    path relative to the study file's folder, or a shipped model file's name when no such path
    exists, e.g. ``homeostatic_interlimb_synapse``)."""
    if not isinstance(file, str) or not file:
        raise InputError(f"expected the path of a model file, got {file!r}",
                         culprit=f"{where} {slot}")
    from ...support.shipped import resolve

    path = Path(file) if Path(file).is_absolute() else study.parent / file
    if not path.exists() and not path.is_symlink():  # a shipped model file by its name
        path = resolve(file, "model") if resolve(file, "model").exists() else path
    text = read_model_files([f"{slot}={path}"], option=where)[slot]
    return model_files_record({slot: text})[slot]


def _population_files(study: Path, files: Any, where: str) -> dict[str, dict[str, str]]:
    """``[study] populations``: model files with a ``[population]`` table (paths relative to
    the study file's folder, or a shipped model file's name when no such path exists, as
    :func:`_model_file` reads them), each read and checked as a run's ``populations`` are; the
    record ``{name: {"sha256", "content"}}`` every run of the study adds."""
    if files is None:
        return {}
    culprit = f"{where} [study] populations"
    if not isinstance(files, list) or not all(isinstance(f, str) and f for f in files):
        raise InputError(f"must be a list of model files (paths relative to the study file), "
                         f"got {files!r}", culprit=culprit)
    from ...support.reading import read_text
    from ...support.shipped import resolve

    texts = {}
    for file in files:
        path = Path(file) if Path(file).is_absolute() else study.parent / file
        if not path.exists() and not path.is_symlink():  # a shipped model file by its name
            path = resolve(file, "model") if resolve(file, "model").exists() else path
        try:
            texts[file] = read_text(path, culprit=f"{culprit} {file}")
        except InputError:
            raise
        except (OSError, ValueError) as e:
            raise InputError(f"cannot be read ({type(e).__name__}: {e})",
                             culprit=f"{culprit} {file}") from None
    record = population_rows(texts, option=culprit)[1]
    population_table(record)  # a name the table holds already is refused now
    return record


_EVALUATE_KEYS = {"worlds", "seconds", "repeats", "conditions"}


def _evaluate_table(doc: Any, study: Path, where: str) -> dict[str, Any] | None:
    """``[evaluate]``: worlds (a built-in name or a file beside the study file), seconds,
    repeats, conditions; checked here, worlds included, so a typo stops the study at once."""
    if doc is None:
        return None
    if not isinstance(doc, dict) or set(doc) - _EVALUATE_KEYS:
        raise InputError(f"[evaluate] takes {', '.join(sorted(_EVALUATE_KEYS))}", culprit=where)
    from ..commands.evaluate import BUILTIN_WORLDS, read_worlds

    worlds = doc.get("worlds", "robustness")
    if not isinstance(worlds, str) or not worlds:
        raise InputError("[evaluate] worlds must be a worlds file or 'robustness'",
                         culprit=where)
    if worlds not in BUILTIN_WORLDS:
        worlds = str((study.parent / worlds).resolve())
    # named by its place in the study file: a study has no worlds setting of its own
    n_worlds = len(read_worlds(worlds, DEFAULT_MODELS,
                               culprit=f"{where} [evaluate] worlds {doc.get('worlds', worlds)}").worlds)
    seconds, repeats = doc.get("seconds", 10.0), doc.get("repeats", 5)
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
            "conditions": conditions, "n_worlds": n_worlds}


def _record_table(doc: Any, where: str, rows: Any) -> dict[str, Any] | None:
    """``[study] record = { every = N, spikes = [...], traces = [...], stride = S }``."""

    if doc is None:
        return None
    if not isinstance(doc, dict) or "every" not in doc:
        raise InputError(f"[study] record must be a table with at least 'every' "
                         f"(e.g. record = {{ every = 50, traces = [\"astrocyte_Ca\"] }})",
                         culprit=where)
    bad = set(doc) - {"every", "spikes", "traces", "stride"}
    if bad:
        keys = ("every", "spikes", "traces", "stride")
        raise InputError(f"[study] record has unknown key '{sorted(bad)[0]}'"
                         f"{did_you_mean(sorted(bad)[0], keys)} "
                         f"(keys: {', '.join(keys)})", culprit=where)
    from ...network.populations import spike_populations, trace_sources

    # by default every population and trace of the table, the study's added ones included
    # (as a training's record_every records them)
    fields = {"spikes": spike_populations(rows), "traces": tuple(trace_sources(rows))} | dict(doc)
    try:
        plan = RecordPlan.from_dict(fields)
        plan.check_names(rows)
    except (TypeError, ValueError) as e:
        raise InputError(f"[study] record: {e}", culprit=where) from None
    return {"every": plan.every, "spikes": list(plan.spikes), "traces": list(plan.traces),
            "stride": plan.stride}


_SEEDS_TAG = re.compile(r"__seeds?\d+(?:-\d+)?$")


def run_group(run_id: str) -> str:
    """The condition and sweep point a run belongs to: its id without the seeds
    (``astrocytes__eta_ADO=9-nvolt__seeds1-20`` -> ``astrocytes__eta_ADO=9-nvolt``)."""
    return _SEEDS_TAG.sub("", run_id)


def consecutive_groups(seeds: Sequence[int], batch: int) -> list[tuple[int, int]]:
    """Split sorted seeds into runs of consecutive seeds, at most ``batch`` per run."""
    groups: list[tuple[int, int]] = []
    for s in seeds:
        if groups and groups[-1][0] + groups[-1][1] == s and groups[-1][1] < batch:
            groups[-1] = (groups[-1][0], groups[-1][1] + 1)
        else:
            groups.append((s, 1))
    return groups
