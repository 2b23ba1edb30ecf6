"""Parameter studies: a TOML file of conditions, sweep axes and seeds, trained on Dask.

A study file (the manual's "Study files" page gives every key with its unit and default)::

    [study]
    name = "my_study"                 # the default folder, out/my_study
    description = "adenosine strength, with and without astrocytes"
    sessions = 20                     # training sessions per trial
    seeds = { first = 1, count = 4 }  # or a list: seeds = [1, 4, 9]
    batch = 2                         # seeds trained together in one network (one run),
                                      # or "auto": chosen for the workers at hand
    paired = true                     # the report compares seed k with seed k
    record = { every = 10, spikes = ["motor"], traces = ["astrocyte_Ca"], stride = 10 }
                                      # sessions 1, 11, ... and the last; stride in 1 ms steps
    populations = ["renshaw.toml"]    # optional: populations added to every run's network

    [base]                            # parameter values of every run, with units
    L_max = "5*second"

    [models]                          # optional: model files replacing a model in every
    astrocyte = "my_astrocyte.toml"   # run (beside the study file, or a shipped name)

    [sweep]
    mode = "grid"                     # every combination; "zip": element by element
    [sweep.axes]
    eta_ADO = ["9*nvolt", "18*nvolt"]
    astrocyte = ["li_rinzel.toml", "variant.toml"]  # an axis named by a model: model files

    [conditions.astrocytes]           # one table per condition
    astrocytes = true
    [conditions.no_astrocytes]
    astrocytes = false                # trained without the astrocytes' adenosine term
    set = { }                         # parameter values of this condition only

    [evaluate]                        # optional: the trained controllers in other worlds
    worlds = "robustness"             # or a worlds file beside the study file
    seconds = 5                       # simulated seconds per evaluation run
    repeats = 2                       # runs per controller and world
    conditions = ["astrocytes"]       # default: every condition

Every (condition, sweep point) is trained for every seed. Consecutive seeds of one point train
together as one *run* of ``batch`` trials. Trial ``b`` of a run that starts at seed ``s`` is
seed ``s + b`` alone: its network and every draw of its noise come from that seed, so a seed's
results do not depend on ``batch``, which changes only the wall time.

Each run is an ordinary training folder under ``OUT/runs/<run id>/`` with a ``status.json``.
A finished run is never run again, nor is one that diverged (the study then ends with exit 3
and its report shows that group as diverged); any other run resumes from its checkpoint, so
the same command after a crash, a killed worker or Ctrl-C continues where the study stopped.
A study file edited to name fewer seeds or points and run again into the same folder keeps the
earlier runs there, but its tables, report and evaluation read only the runs it now names; an
edit that changes a run's settings is refused on that folder.

``load_study`` reads and checks a file, ``prepare_study`` plans its runs and ``run_study``
trains them (:func:`astrocpg.study` does all three).
"""

from __future__ import annotations

import json
import math
import os
import shutil
from dataclasses import asdict
from pathlib import Path
from typing import Any, Sequence

from ...errors import EnvironmentFault, InputError, setting
from ...support.reading import read_bytes, read_json
from ..runtime.cluster import check_scheduler, check_workers, connect_cluster
from ..runtime.workers import default_workers
from ..runtime.resources import available_memory, check_memory, estimate_bytes
from ..commands.train_state import CHECKPOINT, read_checkpoint
from ..outputs.checkpoint import refuse_legacy
from ..outputs.folder import (FolderLock, check_output_path, check_replaceable,
                            clean_stale_temporaries, clear_folder, holds_results,
                            refuse_in_use)
from ..outputs.writing import atomic_write, prepare_output_dir, save_json, write_manifest
from ..runtime.cells import pending
from .execute import dispatch, ended_status, read_status, write_failures
from .layout import FAILURES, RUNS, STUDY_COPY, STUDY_INDEX, study_files
from ..settings.study import StudyOverrides
from .study_file import (RunSpec, Study, consecutive_groups, parse_study,
                         run_group)
from .tables import write_results, write_timeline


def load_study(path: str | os.PathLike, *, batch: int | None = None,
               overrides: StudyOverrides | None = None) -> Study:
    """Read and validate a study file; every error names the file and the offending key.

    batch: seeds per run, instead of the file's ``batch`` (how a ``batch = "auto"`` study is
    split once its batch is chosen: :func:`resolve_batch`). overrides: the ``seeds``,
    ``sessions`` and ``overrides`` given with the command (:func:`study_overrides`), applied to
    the study as read."""

    from ...support.shipped import resolve, unreadable
    p = resolve(path, "study")  # `astrocpg study quick`: a shipped study by name
    try:
        text = read_bytes(p, f"study {p}").decode("utf-8")  # a FIFO: refused, not waited on
    except OSError as e:  # a misspelt name: its closest; a missing file: the environment's
        raise unreadable(path, "study", e, culprit="study") from None
    except UnicodeDecodeError:
        raise InputError("not a UTF-8 text file (a study file is TOML)",
                         culprit=f"study {p}") from None
    return parse_study(text, p, batch, overrides)


def resolve_batch(study: Study, out: Path | None, *, workers: int | None = None,
                  scheduler: str | None = None, progress: bool = True,
                  plan_from: Path | None = None) -> Study:
    """``batch = "auto"``: the study split into runs of the batch that finishes it soonest on
    these workers (:func:`~astrocpg.studies.parameter_studies.batching.choose_batch`, with this
    machine's measured cost per trial). ``plan_from``: an earlier study's folder (or results
    table) whose seeds' training lengths cost the runs in place of ``sessions x L_max``
    (:mod:`~astrocpg.studies.parameter_studies.measured`); the batch is then chosen so even in a
    study file that gives a number. A folder that already holds the study keeps the batch and
    split it was started with, whatever the workers and options now, so a rerun resumes the
    same runs. Any other study is returned as it is."""
    if "plan_from" in (study.batch_choice or {}):  # planned already (prepare, then run)
        return study
    recorded, recorded_split, recorded_choice = _recorded_batch(out) if out is not None \
        else (None, {}, {})
    if not (study.batch_pending or plan_from is not None or "plan_from" in recorded_choice):
        return study
    if recorded is not None:  # what it was planned from and the runs' order stay recorded
        chosen = {**recorded_choice, "batch": recorded, "split": recorded_split,
                  "reason": f"recorded in {STUDY_INDEX} when the study began"}
    else:
        chosen = _choose_batch(study, workers=workers, scheduler=scheduler, progress=progress,
                               plan_from=plan_from)
    resolved = parse_study(study.text, study.path, int(chosen["batch"]), study.overrides,
                           split_given=chosen.get("split") or {})
    if isinstance(chosen.get("run_seconds"), list):  # [(group, first seed, s)] -> by run id
        by_start = {(group, first): s for group, first, s in chosen["run_seconds"]}
        chosen["run_seconds"] = {r.run_id: by_start[(run_group(r.run_id), r.seed)]
                                 for r in resolved.runs}
    resolved.batch_choice = chosen
    return resolved


def _choose_batch(study: Study, *, workers: int | None, scheduler: str | None, progress: bool,
                  plan_from: Path | None) -> dict[str, Any]:
    """:func:`resolve_batch`'s choice for a new folder, with what it was made from (the cost,
    the lengths measured) and each run's projected CPU seconds as ``[(group, first seed, s)]``
    (:func:`resolve_batch` keys them by run id once the runs are named)."""
    from .trial_cost import trial_cost
    from .batching import choose_batch
    from ...network.codegen import codegen_target
    from .measured import fitted_cost, measured_lengths, planned_lengths

    measured = measured_lengths(plan_from) if plan_from is not None else {}
    n_workers = _cluster_threads(scheduler) if scheduler else (workers or default_workers())
    groups: dict[str, tuple[list[int], Any]] = {}
    for r in study.runs:  # one group per (condition, point), whatever the runs now
        group = run_group(r.run_id)
        bound = r.n_sessions * (r.session_s or 1.0)
        groups[group] = (study.seeds, planned_lengths(measured[group], study.seeds,
                                                      r.n_sessions, bound)
                         if group in measured else bound)

    def fits(n: int) -> bool:
        runs_at_once = min(n_workers, len(groups) * math.ceil(len(study.seeds) / n))
        return estimate_bytes(trials=n, seconds=0.0, spikes=False,
                              sessions=study.n_sessions) * runs_at_once \
            <= available_memory()

    # with an earlier study of runs of several sizes on the same workers, what its runs cost
    # there (memory shared by the workers' runs included); else the cost measured here
    cost, fitted_to = None, None
    if plan_from is not None:
        cost, fitted_to = fitted_cost(plan_from, codegen=codegen_target(None),
                                      workers=n_workers)
    fitted = cost is not None
    if cost is None:
        cost = trial_cost(progress=progress)
    chosen = choose_batch(list(groups.values()), workers=n_workers, cost=cost,
                          split=consecutive_groups, fits=fits)
    if chosen["batch"] is None:
        raise InputError("batch = \"auto\": not even one seed per run fits in memory "
                         f"on {n_workers} workers", culprit=f"study {study.path.name}")
    names = list(groups)
    chosen["split"] = {names[i]: b for i, b in chosen.get("split", {}).items()}
    # each run's projected CPU seconds, for the dispatcher's order (longest first)
    chosen["run_seconds"] = [(names[g], first, round(s, 1))
                             for g, first, s in chosen["run_seconds"]]
    chosen["cost"] = {"fixed_s_per_sim_s": cost.fixed,
                      "per_trial_s_per_sim_s": cost.per_trial,
                      "measured": cost.measured, "codegen": cost.codegen,
                      "when": cost.when, "source": "timeline" if fitted else "measured here",
                      "note": fitted_to or ""}
    if plan_from is not None:
        chosen["plan_from"] = str(plan_from)
        chosen["measured_groups"] = sorted(g for g in groups if g in measured)
    return chosen


def _recorded_batch(out: Path) -> tuple[int | None, dict[str, int], dict[str, Any]]:
    """The batch a study folder was started with, its groups split otherwise (its index) and
    the choice recorded with them (``plan_from`` in it: planned from an earlier study's
    lengths), or (None, {}, {}) for a new folder."""
    try:
        index = read_json(Path(out) / STUDY_INDEX)
    except (OSError, ValueError):
        return None, {}, {}
    split = index.get("split") if isinstance(index.get("split"), dict) else {}
    split = {str(k): v for k, v in split.items()
             if isinstance(v, int) and not isinstance(v, bool) and v >= 1}
    choice = index.get("batch_choice") if isinstance(index.get("batch_choice"), dict) else {}
    if isinstance(index.get("batch"), int) and index["batch"] >= 1:
        return index["batch"], split, choice
    sizes = [s.get("n_trials") for s in index.get("specs", {}).values()]  # an older index
    sizes = [n for n in sizes if isinstance(n, int) and n >= 1]
    return (max(sizes) if sizes else None), {}, choice


def _cluster_threads(scheduler: str) -> int:
    """Worker threads of a running Dask cluster (what runs at once)."""
    client, _ = connect_cluster(None, scheduler)
    try:
        return max(1, sum(client.nthreads().values()))
    finally:
        client.close()


# ---------------------------------------------------------------- the study (client side)
def _check_folder(study: Study, out: Path) -> None:
    """A study folder belongs to one study: a rerun may add runs but not change one."""
    index_path = out / STUDY_INDEX
    known: dict[str, str] = {}
    if index_path.exists():
        try:
            known = read_json(index_path)["runs"]
        except (OSError, ValueError, KeyError):
            raise InputError(f"{STUDY_INDEX} is unreadable", culprit=setting("out", out)) from None
    elif any(out.iterdir()):
        raise InputError(f"is not empty and holds no study (no {STUDY_INDEX}); "
                         f"use a new folder", culprit=setting("out", out))
    if index_path.exists():
        try:
            name = read_json(index_path)["name"]
        except (OSError, ValueError, KeyError):
            raise InputError(f"{STUDY_INDEX} is unreadable", culprit=setting("out", out)) from None
        if name != study.name:
            raise InputError(f"belongs to study '{name}', not '{study.name}' "
                             f"(use a new {setting('out')})", culprit=setting("out", out))
        _check_overrides(study, out, json.loads(index_path.read_text()).get("overrides") or {})
    specs = {}
    if index_path.exists():
        try:
            specs = read_json(index_path).get("specs") or {}
        except (OSError, ValueError):
            specs = {}
    for run in study.runs:
        fp = known.get(run.run_id)
        if fp is not None and fp != run.fingerprint():
            changed = _what_changed(specs.get(run.run_id), json.loads(json.dumps(asdict(run))))
            raise InputError(f"run '{run.run_id}' there has other settings than "
                             f"in {study.path.name}{changed} (use a new {setting('out')}, or "
                             f"undo the change to continue it)", culprit=setting("out", out))


def _assignments(items: Any) -> dict[str, str] | None:
    """``["NAME=VALUE", ...]`` as {NAME: VALUE}; None where it is not such a list."""
    if not isinstance(items, list) or not all(isinstance(x, str) and "=" in x for x in items):
        return None
    return {x.split("=", 1)[0].strip(): x.split("=", 1)[1].strip() for x in items}


#: a run's settings as the study file spells them; settings that follow from others
_FILE_KEYS = {"n_sessions": "sessions", "n_trials": "trials (batch)"}
_DERIVED = {"session_s"}


def _what_changed(recorded: Any, now: dict[str, Any]) -> str:
    """``: L_max was 0.02*second, is now 0.03*second``: the settings of a run that differ
    between the study folder's record and the study file as read now (each named with both
    values; a parameter by its name); "" where the folder recorded none."""
    if not isinstance(recorded, dict):
        return ""
    said = []
    keys = sorted(set(recorded) | set(now))
    for key in sorted(keys, key=lambda k: k in _DERIVED):
        was, is_ = recorded.get(key, "(none)"), now.get(key, "(none)")
        if was == is_ or (key in _DERIVED and said):  # follows from a change already named
            continue
        old, new = _assignments(was), _assignments(is_)
        if old is not None and new is not None:  # overrides: by parameter
            for name in sorted(set(old) | set(new)):
                if old.get(name) != new.get(name):
                    said.append(f"{name} was {old.get(name, '(not set)')}, is now "
                                f"{new.get(name, '(not set)')}")
        else:
            said.append(f"{_FILE_KEYS.get(key, key)} was {json.dumps(was)}, is now "
                        f"{json.dumps(is_)}")
    return (": " + "; ".join(said[:3]) + (f"; and {len(said) - 3} more" if len(said) > 3
                                          else "")) if said else ""


def _check_overrides(study: Study, out: Path, recorded: dict[str, Any]) -> None:
    """A study folder keeps the overrides it was started with (``seeds``, ``sessions``,
    ``overrides``, recorded in its study.json): rerunning the same command resumes it, other
    overrides (or none where it had some) are refused naming the setting, as an edited study
    file that changes its runs is."""
    given = study.overrides.record()
    for key, name in (("seeds", "seeds"), ("sessions", "sessions"), ("set", "overrides")):
        was, now = recorded.get(key), given.get(key)
        if was == now:
            continue
        option = setting(name)

        def said(v: Any) -> str:
            if v is None:
                return f"without {option}"
            return "with " + " ".join(str(option.given(x)) for x in (v if isinstance(v, list)
                                                                   else [v]))

        raise InputError(f"{out} holds the study run {said(was)}, not {said(now)}; a study "
                         f"folder keeps its overrides: run the same command again to continue "
                         f"it, or use a new {setting('out')}", culprit=option)


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
                                 f"(use a new {setting('out')})", culprit=folder / CHECKPOINT)


def _save_index(study: Study, out: Path) -> None:
    index_path = out / STUDY_INDEX
    known: dict[str, str] = {}
    specs: dict[str, Any] = {}
    if index_path.exists():  # a rerun may add runs (more seeds, points): keep the earlier ones
        old = read_json(index_path)
        known, specs = old["runs"], old.get("specs", {})
    known.update({r.run_id: r.fingerprint() for r in study.runs})
    specs.update({r.run_id: asdict(r) for r in study.runs})
    # "current": the runs the study file now names (what its report and evaluation read);
    # "runs" and "specs" keep the runs of earlier versions too, so a later version may not
    # change them
    save_json(index_path, {"name": study.name, "overrides": study.overrides.record(),
                           "sweep": study.sweep, "runs": known,
                           "specs": specs, "current": [r.run_id for r in study.runs],
                           "batch": study.batch, "split": study.split,
                           "paired": study.paired, "margins": study.margins,
                           "batch_setting": study.batch_setting,
                           "batch_choice": study.batch_choice})
    data = study.text.encode()
    atomic_write(out / STUDY_COPY, lambda f: f.write(data))


def prepare_study(study: Study, out: Path, *, workers: int | None = None,
                  scheduler: str | None = None, overwrite: bool = False,
                  progress: bool = True, plan_from: Path | None = None) -> Study:
    """The checks of :func:`run_study` that need no cluster, and ``batch = "auto"`` chosen
    (:func:`resolve_batch`; with ``plan_from``, from an earlier study's lengths): the study as
    it will run. Writes nothing."""
    if scheduler is None:  # a local cluster of that many processes: bounded by the cores
        check_workers(workers)
    elif workers is not None and workers < 1:
        raise InputError(f"must be at least 1, got {workers}", culprit=setting("workers"))
    if scheduler is not None:  # a short probe now, not a long wait (or a strange error) later
        check_scheduler(scheduler)
    out = Path(out)
    if out.exists() and not out.is_dir():
        raise InputError("exists and is not a folder", culprit=setting("out", out))
    # the study file (and a worlds file it names) is never the folder nor inside it; what
    # overwrite replaces is a folder astrocpg wrote, never the user's own files
    worlds = (study.evaluate or {}).get("worlds")
    inputs = [study.path, *([worlds] if isinstance(worlds, str) and os.path.isfile(worlds)
                            else [])]
    check_output_path(out, inputs, culprit=setting("out", out))
    # a study running there (or one started a moment before): "in use", never a reason read
    # from the half-written folder
    refuse_in_use(out, culprit=setting("out", out))
    if overwrite and holds_results(out):
        check_replaceable(out, culprit=setting("out", out), command="study")
    if plan_from is not None:  # named now, also where a resumed folder keeps its plan
        from .measured import results_table

        results_table(Path(plan_from), setting("plan_from"))
    # overwrite starts afresh: the batch the old folder began with does not count
    return resolve_batch(study, None if overwrite else out, workers=workers,
                         scheduler=scheduler, progress=progress,
                         plan_from=None if plan_from is None else Path(plan_from))


def run_study(study: Study, out: Path, *, workers: int | None = None,
              scheduler: str | None = None, progress: bool = True,
              overwrite: bool = False, plan_from: Path | None = None) -> dict[str, Any]:
    """Run every unfinished run of ``study`` on Dask; write the results table. Returns counts
    of runs by state and the paths written. Nothing is written before the folder is known to
    belong to this study and the cluster is reachable; while it runs, the study owns its folder
    (a second process on it is refused). ``overwrite`` replaces the folder whole.
    ``plan_from``: an earlier study whose seeds' training lengths plan the runs
    (:func:`resolve_batch`)."""
    out = Path(out)
    study = prepare_study(study, out, workers=workers, scheduler=scheduler,
                          overwrite=overwrite, progress=progress, plan_from=plan_from)
    if out.exists() and not overwrite:
        try:
            _check_folder(study, out)
        except InputError:  # a study that took the folder since: that is the reason
            refuse_in_use(out, culprit=setting("out", out))
            raise
    created = not out.exists()
    try:
        out.mkdir(parents=True, exist_ok=True)
    except OSError as e:
        raise EnvironmentFault.from_os_error(e, out, "cannot create the folder") from None
    try:
        with FolderLock(out, culprit=setting("out")):
            if overwrite:
                clear_folder(out, culprit=setting("out", out))
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
    from ..runtime.progress import Bar as tqdm

    largest = max(r.n_trials for r in study.runs)
    check_memory(estimate_bytes(trials=largest, seconds=0.0, spikes=False,
                                sessions=study.n_sessions)
                 * min(len(study.runs), workers or default_workers()),
                 culprit=f"study {study.name} (runs of {largest} trials)")
    folders = {r.run_id: out / RUNS / r.run_id for r in study.runs}
    # the runs that ended are never run again (their status.json says so): the rest run
    _, todo = pending({r.run_id: r for r in study.runs},
                      lambda run_id: ended_status(folders[run_id]))
    waiting = list(todo.values())
    _check_checkpoints(waiting, folders)
    total_sessions = sum(r.n_trials * r.n_sessions for r in study.runs)
    n_done_before = len(study.runs) - len(waiting)
    settings = {"study": str(study.path), "study_text": study.text,
                "overrides": study.overrides.record(), "workers": workers,
                "scheduler": scheduler, "batch": study.batch, "batch_choice": study.batch_choice}
    cluster = connect_cluster(workers, scheduler) if waiting else None
    # the worker processes (threads of a scheduler's cluster) the runs share: what a study's
    # status projects the time left with
    settings["worker_count"] = (sum(cluster[0].nthreads().values()) or None
                                if cluster is not None and scheduler else
                                workers or os.cpu_count() or 1)
    unwritten: dict[str, str] = {}
    try:
        prepare_output_dir(out)
        _save_index(study, out)
        write_manifest(out, command="study", seed=min(study.seeds),
                       settings=settings,
                       models_json={}, files=study_files(), results={"status": "running"})
        if waiting:
            unwritten = dispatch(study, waiting, folders, cluster[0], progress,
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
    diverged = [r.run_id for r in failed if states[r.run_id] == "diverged"]
    errors = write_failures(out, failed, folders, unwritten)
    counts = {s: list(states.values()).count(s) for s in sorted(set(states.values()))}
    evaluated = None
    # the finished runs' controllers, once nothing is left to retry (a diverged run has none)
    if study.evaluate is not None and len(failed) == len(diverged) \
            and len(diverged) < len(study.runs):
        # a step of the study: its trained controllers in other worlds (out/evaluation)
        from ..commands.evaluate import evaluate

        e = study.evaluate
        # on the study's cluster settings, resumable like its runs (out/evaluation.parts)
        evaluated = str(evaluate(out, worlds=e["worlds"], seconds=e["seconds"],
                                 repeats=e["repeats"], conditions=e["conditions"] or None,
                                 progress=progress, workers=workers or default_workers(),
                                 scheduler=scheduler)["out"])
    write_manifest(out, command="study", seed=min(study.seeds),
                   settings=settings,
                   models_json={}, files=study_files(),
                   results={"status": "finished" if not failed
                            else "diverged" if len(failed) == len(diverged) else "incomplete",
                            "runs": counts, "diverged": diverged, "rows": table,
                            "evaluation": evaluated})
    return {"counts": counts, "failed": [r.run_id for r in failed], "diverged": diverged,
            "rows": table,
            "evaluation": evaluated, "errors": errors,
            "failures": str(out / FAILURES) if (out / FAILURES).is_file() else None}
