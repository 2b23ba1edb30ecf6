"""A study's integrity and the one line beyond the bad-input
table: the stored cost of a trial (validated, a bad one ignored with a note naming the file),
a report of a partial study (the groups without data named), a study's worker owning its run
folder while it trains it, the probe of ``--scheduler``, and commands whose one line needs a
fresh process (an environment variable a library reads when imported, a broken C compiler,
numpy's warnings without ``PYTHONWARNINGS``)."""

from __future__ import annotations

import json
import logging
import math
import os
import shutil
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from astrocpg.studies.cli import main
from tiny_study import tiny_study

SHORT_STUDY = tiny_study("partial", sessions=1)


def lines_of(err: str) -> list[str]:
    return [x for x in err.splitlines() if x.strip()]


# ---------------------------------------------------------------- the stored cost of a trial
@pytest.fixture
def cache(tmp_path, monkeypatch) -> Path:
    folder = tmp_path / "cache"
    folder.mkdir()
    monkeypatch.setenv("ASTROCPG_CACHE", str(folder))
    return folder


def _store(cache: Path, **entry_changes) -> Path:
    from astrocpg.studies.parameter_studies.trial_cost import COST_FILE, machine_key

    key = machine_key("numpy")
    entry = {"fixed": 0.2, "per_trial": 0.04, "measured": {"1": 0.24, "4": 0.36},
             "codegen": "numpy", "key": key, "when": "2026-01-01T00:00:00+00:00"}
    entry.update(entry_changes)
    path = cache / COST_FILE
    # json.dumps writes NaN and Infinity, as a corrupt cache may hold them
    path.write_text(json.dumps({key: entry}))
    return path


@pytest.mark.parametrize("change", [
    {"fixed": math.nan}, {"per_trial": math.nan}, {"per_trial": 0.0}, {"per_trial": -0.04},
    {"per_trial": math.inf}, {"fixed": -1.0}, {"fixed": math.inf},
    {"measured": {"1": math.nan, "4": 0.3}}, {"measured": [0.2, 0.3]}, {"measured": {"1": 0.2}},
    {"per_trial": "0.04"}, {"per_trial": True}, {"extra": 1}],
    ids=lambda c: json.dumps(c))
def test_a_stored_cost_that_is_not_finite_and_positive_is_ignored_naming_the_file(cache, change):
    from astrocpg.studies.parameter_studies.trial_cost import stored_trial_cost

    path = _store(cache, **change)
    notes: list[str] = []
    assert stored_trial_cost("numpy", note=notes.append) is None
    assert len(notes) == 1 and str(path) in notes[0], notes


def test_a_valid_stored_cost_is_used(cache):
    from astrocpg.studies.parameter_studies.trial_cost import stored_trial_cost

    _store(cache)
    notes: list[str] = []
    cost = stored_trial_cost("numpy", note=notes.append)
    assert cost is not None and cost.per_trial == 0.04 and cost.measured == {1: 0.24, 4: 0.36}
    assert notes == []


@pytest.mark.parametrize("text", ["{not json", "[1, 2]", "null"])
def test_an_unreadable_cost_file_is_ignored_with_a_note(cache, text):
    from astrocpg.studies.parameter_studies.trial_cost import COST_FILE, stored_trial_cost

    (cache / COST_FILE).write_text(text)
    notes: list[str] = []
    assert stored_trial_cost("numpy", note=notes.append) is None
    assert len(notes) == 1 and COST_FILE in notes[0]


def test_batch_auto_with_a_corrupt_cost_measures_again_and_says_so(cache, tmp_path, monkeypatch,
                                                                  capsys):
    """A NaN in trial_cost.json made every batch = "auto" study an internal error: now one note
    naming the file, a new measurement stored over it, and a batch chosen on finite costs."""
    from astrocpg.studies.parameter_studies import trial_cost as tc
    from astrocpg.studies.parameter_studies.study import load_study, prepare_study

    path = _store(cache, per_trial=math.nan)
    measured = []

    def measure(codegen=None, **kw):
        measured.append(codegen)
        return tc.TrialCost.fit({1: 0.27, 4: 0.40, 10: 0.66}, codegen="numpy",
                                key=tc.machine_key("numpy"))

    monkeypatch.setattr(tc, "measure_trial_cost", measure)
    study = tmp_path / "auto.toml"
    study.write_text(SHORT_STUDY.replace("batch = 1", 'batch = "auto"')
                     .replace("count = 1", "count = 4"))
    prepared = prepare_study(load_study(study), tmp_path / "out", workers=1, progress=False)
    err = capsys.readouterr().err
    assert measured == ["numpy"]
    notes = lines_of(err)
    assert len(notes) == 1 and str(path) in notes[0] and "per_trial" in notes[0], err
    assert prepared.batch_choice["projected_s"] > 0 and math.isfinite(
        prepared.batch_choice["projected_s"])
    stored = json.loads(path.read_text())[tc.machine_key("numpy")]
    assert math.isfinite(stored["per_trial"]) and stored["per_trial"] > 0
    assert not (tmp_path / "out").exists()


# ---------------------------------------------------------------- a study and its runs
@pytest.fixture(scope="module")
def tiny_study(tmp_path_factory) -> Path:
    base = tmp_path_factory.mktemp("study")
    (base / "s.toml").write_text(SHORT_STUDY)
    out = base / "out"
    assert main(["study", str(base / "s.toml"), "--out", str(out), "--workers", "1",
                 "--no-progress"]) == 0
    return out


def test_report_of_a_partial_study_names_the_groups_without_data(tiny_study, tmp_path, capsys):
    """A group none of whose runs has a session was dropped from the report in silence: it is
    named in report.md, in final_figures.csv and in one note on stderr."""
    study = tmp_path / "partial"
    shutil.copytree(tiny_study, study)
    index = json.loads((study / "study.json").read_text())
    spec = dict(next(iter(index["specs"].values())))
    spec.update(run_id="late__seed1", condition="late")
    index["specs"]["late__seed1"] = spec
    index["runs"]["late__seed1"] = "0" * 64
    index["current"].append("late__seed1")  # a run the study file names, not yet started
    (study / "study.json").write_text(json.dumps(index))
    capsys.readouterr()
    assert main(["report", str(study)]) == 0
    captured = capsys.readouterr()
    notes = lines_of(captured.err)
    assert len(notes) == 1 and "no data" in notes[0] and "late" in notes[0], captured.err
    md = (study / "report" / "report.md").read_text()
    assert "No data yet" in md and "late" in md
    table = (study / "report" / "final_figures.csv").read_text()
    assert any(line.startswith("late,") for line in table.splitlines()), table


def test_a_whole_study_reports_without_a_note(tiny_study, tmp_path, capsys):
    study = tmp_path / "whole"
    shutil.copytree(tiny_study, study)
    capsys.readouterr()
    assert main(["report", str(study)]) == 0
    assert lines_of(capsys.readouterr().err) == []


def _hold(folder: Path, inside: Path | None = None) -> subprocess.Popen:
    code = ("import time\nfrom astrocpg.studies.outputs.folder import FolderLock\n"
            f"lock = FolderLock({str(folder)!r}, inside={str(inside) if inside else None!r})"
            ".acquire()\nprint('held', flush=True)\ntime.sleep(120)\n")
    p = subprocess.Popen([sys.executable, "-c", code], stdout=subprocess.PIPE, text=True)
    assert p.stdout is not None and p.stdout.readline().strip() == "held"
    return p


def test_a_worker_writes_nothing_into_a_run_folder_another_process_holds(tiny_study, tmp_path):
    from astrocpg.studies.parameter_studies.execute import execute_run
    from astrocpg.studies.parameter_studies.study_file import RunSpec

    study = tmp_path / "held"
    shutil.copytree(tiny_study, study)
    run = study / "runs" / "astro__seed1"
    (run / "status.json").write_text(json.dumps({"state": "stopped"}))
    before = {p.name: p.read_bytes() for p in run.iterdir() if p.is_file()}
    holder = _hold(run, inside=study)
    try:
        spec = RunSpec(**{k: v for k, v in json.loads(
            (study / "study.json").read_text())["specs"]["astro__seed1"].items()})
        status = execute_run(spec, str(run))
    finally:
        holder.kill()
        holder.wait()
    assert status["state"] == "failed" and status.get("not_written"), status
    assert "in use" in status["error"]
    after = {p.name: p.read_bytes() for p in run.iterdir() if p.is_file()
             if not p.name.startswith(".astrocpg.lock")}
    assert after == {k: v for k, v in before.items() if not k.startswith(".astrocpg.lock")}


def test_a_worker_holds_its_run_folder_while_it_trains(tiny_study, tmp_path, monkeypatch):
    from astrocpg.studies.outputs import folder as folder_module
    from astrocpg.studies.parameter_studies import execute as execute_module
    from astrocpg.studies.parameter_studies.study_file import RunSpec

    study = tmp_path / "mine"
    shutil.copytree(tiny_study, study)
    run = study / "runs" / "astro__seed1"
    seen = {}

    def inside(spec, out):
        seen["held_here"] = bool(folder_module._HELD.get(os.path.realpath(out)))
        # another open file description (another process's view): locked
        seen["locked"] = folder_module._locked_by_another(Path(out) / folder_module.LOCK_NAME)
        return {"state": "finished"}

    monkeypatch.setattr(execute_module, "_execute_run_locked", inside)
    spec = RunSpec(**json.loads((study / "study.json").read_text())["specs"]["astro__seed1"])
    assert execute_module.execute_run(spec, str(run))["state"] == "finished"
    assert seen == {"held_here": True, "locked": True}
    assert not (run / folder_module.LOCK_NAME).exists()  # released, files removed


# ---------------------------------------------------------------- --scheduler
def test_a_running_dask_scheduler_passes_the_probe_quickly():
    import time

    from distributed import LocalCluster

    from astrocpg.studies.runtime.cluster import check_scheduler

    cluster = LocalCluster(n_workers=0, processes=False, protocol="tcp",
                           dashboard_address=":0", silence_logs=logging.ERROR)
    try:
        t0 = time.monotonic()
        check_scheduler(cluster.scheduler_address)
        assert time.monotonic() - t0 < 2.0
    finally:
        cluster.close()


def test_a_local_clusters_workers_run_without_dasks_profiler_and_fast_ticks():
    """The settings reach the worker processes (set when the nannies start them) and the
    scheduler; outside the cluster Dask's own defaults are left as they were."""
    import dask
    import distributed  # noqa: F401  (its settings join dask.config on import)

    from astrocpg.studies.runtime.cluster import LEAN_DASK, connect_cluster

    before = dask.config.get("distributed.worker.profile.enabled")
    client, cluster = connect_cluster(1, None)
    try:
        seen = client.run(lambda: (dask.config.get("distributed.worker.profile.enabled"),
                                   dask.config.get("distributed.admin.tick.interval")))
        assert list(seen.values()) == [(False, LEAN_DASK["distributed.admin.tick.interval"])]
        # the scheduler's event-loop check runs once a second, not every 20 ms
        assert cluster.scheduler._tick_interval == pytest.approx(1.0)
    finally:
        client.close()
        cluster.close()
    assert dask.config.get("distributed.worker.profile.enabled") == before


def test_frame_count_is_the_number_of_frames_made():
    from astrocpg.coupling.render import frame_count, frame_samples

    for t in (np.arange(0, 0.05, 0.001), np.arange(0, 3.0, 0.004), np.array([0.0])):
        for fps, speed in ((30, 1), (10, 0.5), (60, 2.0), (1000, 0.05)):
            assert frame_count(t, fps, speed) == len(frame_samples(t, fps, speed))


# ---------------------------------------------------------------- one line, in a fresh process
def _child(argv: list[str], cwd: Path, **env: str) -> tuple[int, str, str]:
    environ = {**os.environ, **env}
    environ.pop("PYTHONWARNINGS", None)  # what a user's shell has: warnings on
    proc = subprocess.run([sys.executable, "-m", "astrocpg.studies.cli", *argv],
                          capture_output=True, text=True, env=environ, cwd=cwd, timeout=600)
    return proc.returncode, proc.stdout, proc.stderr


def test_a_library_refusing_mujoco_gl_is_an_environment_fault_naming_it(tmp_path):
    code, out, err = _child(["run", "--seconds", "0.01", "--no-progress", "--out",
                             str(tmp_path / "o")], tmp_path, MUJOCO_GL="bogus")
    lines = lines_of(err)
    assert code == 1 and len(lines) == 1, err
    assert lines[0].startswith("astrocpg: environment: MUJOCO_GL=bogus"), lines
    assert "internal error" not in err and "bug" not in err
    assert not (tmp_path / "o").exists()


def test_numpys_warning_on_an_empty_table_does_not_reach_stderr(tmp_path):
    (tmp_path / "empty.csv").write_text("")
    code, out, err = _child(["run", "--seconds", "0.01", "--no-progress", "--weights",
                             str(tmp_path / "empty.csv"), "--out", str(tmp_path / "o")],
                            tmp_path)
    lines = lines_of(err)
    assert code == 2 and len(lines) == 1 and "empty.csv" in lines[0], err


def test_a_broken_c_compiler_gives_one_line(tmp_path):
    cc = tmp_path / "cc"
    cc.write_text("#!/bin/sh\necho 'cc: fatal error: this compiler is broken' >&2\nexit 1\n")
    cc.chmod(0o755)
    code, out, err = _child(["run", "--seconds", "0.01", "--no-progress", "--codegen", "cython",
                             "--out", str(tmp_path / "o")], tmp_path, CC=str(cc), CXX=str(cc))
    lines = lines_of(err)
    assert code == 1 and len(lines) == 1, err
    assert "codegen cython" in lines[0] and "broken" not in err, err


def test_an_edited_study_file_is_refused_naming_the_setting_and_both_values(tmp_path) -> None:
    """A study folder keeps its runs' settings: the study file edited under it is refused,
    naming each setting that changed with the value recorded and the value now."""
    import pytest

    from astrocpg.errors import InputError
    from astrocpg.studies.parameter_studies.study import _check_folder, _save_index, load_study

    text = ('[study]\nname = "edited"\nsessions = 1\nseeds = [1]\n'
            '[base]\nL_max = "0.02*second"\nA_random = "0.25"\n')
    f = tmp_path / "edited.toml"
    f.write_text(text)
    out = tmp_path / "out"
    out.mkdir()
    _save_index(load_study(str(f)), out)
    _check_folder(load_study(str(f)), out)  # unchanged: accepted
    f.write_text(text.replace("0.02*second", "0.03*second").replace("sessions = 1",
                                                                     "sessions = 2"))
    with pytest.raises(InputError) as err:
        _check_folder(load_study(str(f)), out)
    line = str(err.value)
    assert "L_max was 0.02*second, is now 0.03*second" in line, line
    assert "sessions was 1, is now 2" in line and "A_random" not in line, line
    assert "session_s" not in line  # follows from L_max: not named twice
