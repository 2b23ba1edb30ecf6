"""``astrocpg study --status DIR``: what a study folder has done and what is left, read without
running or locking anything (so it may be asked while the study runs)."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from astrocpg.errors import InputError
from astrocpg.studies.parameter_studies.status import study_status


def _study(tmp_path: Path, runs: dict[str, dict]) -> Path:
    """A study folder as a study leaves it: study.json naming the runs, a status.json and a
    sessions.csv per run, and timeline.csv with the ended attempts."""
    out = tmp_path / "s"
    (out / "runs").mkdir(parents=True)
    specs = {rid: {"run_id": rid, "n_trials": r["trials"], "n_sessions": r["sessions"]}
             for rid, r in runs.items()}
    (out / "study.json").write_text(json.dumps({"name": "s", "specs": specs,
                                                "current": list(runs)}))
    timeline = ["run_id,attempt,state,worker,worker_name,host,pid,started,ended,duration_s,"
                "started_utc"]
    for rid, r in runs.items():
        folder = out / "runs" / rid
        folder.mkdir()
        if r.get("state"):
            (folder / "status.json").write_text(json.dumps(
                {"state": r["state"], "attempts": 1} | r.get("status", {})))
        if r.get("lengths"):
            rows = ["trial,session,length_s"] + [
                f"{b},{s + 1},{x}" for b, xs in enumerate(r["lengths"]) for s, x in enumerate(xs)]
            (folder / "sessions.csv").write_text("\n".join(rows) + "\n")
        if r.get("ended_s"):
            timeline.append(f"{rid},1,{r['state']},w,0,h,1,0,0,{r['ended_s']},x")
    (out / "timeline.csv").write_text("\n".join(timeline) + "\n")
    return out


def test_sessions_done_and_the_time_left_follow_the_runs(tmp_path):
    out = _study(tmp_path, {
        # finished: 2 seeds x 4 sessions, 80 s of wall for 20 simulated s of its busiest seed
        "a": {"trials": 2, "sessions": 4, "state": "finished", "ended_s": 80,
              "lengths": [[5, 5, 5, 5], [2, 2, 2, 2]]},
        # running since 30 s ago with 2 of 4 sessions (10 simulated s): 3 s of wall per
        # simulated s; 2 sessions of 5 s left -> 30 s
        "b": {"trials": 1, "sessions": 4, "state": "running", "status": {"started": 970.0},
              "lengths": [[5, 5]]},
        # not started: costs the mean run so far (a: 80 s; b: 30 + 30 = 60 s) -> 70 s
        "c": {"trials": 1, "sessions": 4},
    })
    p = study_status(out, workers=1, now=1000.0)
    by = {r.run_id: r for r in p.runs}
    assert (by["a"].state, by["a"].sessions_done, by["a"].sessions_total) == ("finished", 8, 8)
    assert (by["b"].sessions_done, by["b"].wall_s) == (2, 30.0)
    assert by["b"].left_simulated_s == pytest.approx(10.0)
    assert by["c"].state == "not run" and by["c"].sessions_done == 0
    assert p.sessions_done == 10 and p.sessions_total == 16
    assert p.left_s == pytest.approx(30.0 + 70.0)  # one worker: b then c
    assert study_status(out, workers=2, now=1000.0).left_s == pytest.approx(70.0)
    text = p.text()
    assert "10 of 16 seed-sessions done" in text and "time left: about 1 min 40 s" in text
    assert "1 finished" in text and "1 running" in text and "1 not run" in text


def test_a_study_that_has_ended_has_no_time_left_and_one_not_begun_says_unknown(tmp_path):
    out = _study(tmp_path / "1", {"a": {"trials": 1, "sessions": 2, "state": "finished",
                                         "ended_s": 9, "lengths": [[1, 1]]},
                                   "b": {"trials": 1, "sessions": 2, "state": "diverged",
                                         "ended_s": 1, "lengths": [[0.5]]}})
    assert study_status(out).left_s == 0.0
    assert "every run has ended" in study_status(out).text()
    fresh = _study(tmp_path / "2", {"a": {"trials": 3, "sessions": 10}})
    assert study_status(fresh).left_s is None
    assert "unknown until a run has trained a session" in study_status(fresh).text()


def test_only_the_runs_the_study_file_now_names_count(tmp_path):
    out = _study(tmp_path, {"a": {"trials": 1, "sessions": 2, "state": "finished",
                                  "ended_s": 5, "lengths": [[1, 1]]},
                            "old": {"trials": 1, "sessions": 2, "state": "finished",
                                    "ended_s": 5, "lengths": [[1, 1]]}})
    index = json.loads((out / "study.json").read_text())
    index["current"] = ["a"]
    (out / "study.json").write_text(json.dumps(index))
    assert [r.run_id for r in study_status(out).runs] == ["a"]


@pytest.mark.parametrize("make, words", [
    (lambda p: p, "not a study folder"),
    (lambda p: [(p / "study.json").write_text("["), p][1], "not a study folder"),
])
def test_a_folder_that_holds_no_study_is_refused_naming_it(tmp_path, make, words):
    folder = make(tmp_path)
    with pytest.raises(InputError, match=words) as e:
        study_status(folder)
    assert str(folder) in str(e.value)


def test_workers_must_be_a_whole_number(tmp_path):
    out = _study(tmp_path, {"a": {"trials": 1, "sessions": 1}})
    with pytest.raises(InputError, match="at least 1"):
        study_status(out, workers=0)


def test_the_command_and_the_api_say_the_same(tmp_path, capsys):
    import astrocpg as ac
    from astrocpg.studies.cli import main

    out = _study(tmp_path, {"a": {"trials": 1, "sessions": 2, "state": "finished",
                                  "ended_s": 5, "lengths": [[1, 1]]}})
    assert main(["study", "--status", str(out)]) == 0
    printed = capsys.readouterr().out
    assert printed.strip() == ac.study_status(out).text()
    assert "2 of 2 seed-sessions done (100.0%)" in printed
    assert main(["study", "--status", str(tmp_path / "nosuch")]) == 1  # missing: environment
    assert "nosuch: no such file or folder" in capsys.readouterr().err


@pytest.mark.parametrize("extra", [["--out", "x"], ["--seeds", "1-2"], ["--sessions", "3"],
                                   ["--set", "L_max=1*second"], ["--overwrite"],
                                   ["--codegen", "cython"], ["--no-progress"]])
def test_status_refuses_an_option_it_would_ignore(tmp_path, capsys, extra):
    from astrocpg.studies.cli import main

    out = _study(tmp_path, {"a": {"trials": 1, "sessions": 1}})
    assert main(["study", "--status", str(out), *extra]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and extra[0] in err and "does not apply" in err, err


def _killed_then_running(tmp_path: Path, killed: dict) -> Path:
    """One run of 20 sessions of 5 s: a first attempt killed without an end (``killed``: more
    fields of its history line), a second one running in this process since 900 s, having
    found 8 sessions done and trained 2 more."""
    import os
    import socket

    host = socket.gethostname()
    history = [{"attempts": 1, "started": 0.0, "host": host, "pid": 1} | killed,
               {"attempts": 2, "started": 900.0, "host": host, "pid": os.getpid()}]
    return _study(tmp_path, {
        "a": {"trials": 1, "sessions": 20, "state": "running",
              "status": {"started": 900.0, "host": host, "pid": os.getpid(),
                         "history": history, "sessions_at_start": 8},
              "lengths": [[5] * 10]}})


def test_a_killed_attempt_is_not_costed_as_if_it_took_no_time(tmp_path):
    """A machine that stopped leaves attempts without an end: the run is then costed on its
    current attempt alone (wall since it started against the simulated time since), not on all
    its sessions against the current attempt's minutes."""
    # 8 sessions of 5 s done before this attempt (40 s), 2 since (10 s) in 100 s of wall:
    # 10 s of wall per simulated s; 10 sessions of 5 s left -> 500 s
    out = _killed_then_running(tmp_path, {})
    p = study_status(out, workers=1, now=1000.0)
    (run,) = p.runs
    assert run.state == "running" and run.unrecorded_attempts == 1
    assert run.wall_s == pytest.approx(100.0)
    assert p.left_s == pytest.approx(500.0)  # the old reading: 100 s / 50 s -> 100 s
    assert "1 stopped without a record" in p.text()


def test_a_run_whose_process_is_gone_is_shown_stopped(tmp_path):
    import socket
    import subprocess
    import sys

    done = subprocess.run([sys.executable, "-c", "import os; print(os.getpid())"],
                          capture_output=True, text=True)
    dead = int(done.stdout)  # a pid that has exited
    host = socket.gethostname()
    out = _study(tmp_path, {
        "a": {"trials": 1, "sessions": 4, "state": "running",
              "status": {"started": 900.0, "host": host, "pid": dead,
                         "history": [{"attempts": 1, "started": 900.0, "host": host,
                                      "pid": dead}], "sessions_at_start": 0},
              "lengths": [[5, 5]]}})
    (run,) = study_status(out, now=1000.0).runs
    assert run.state == "stopped" and run.wall_s == 0.0 and run.unrecorded_attempts == 1
    assert study_status(out, now=1000.0).left_s is None  # no attempt whose cost is known


def test_a_killed_attempt_counts_up_to_its_last_checkpoint(tmp_path):
    """An attempt killed after a checkpoint noted ``last_seen`` counts up to it: the run's wall
    time includes it, it is not 'stopped without a record', and the run is costed on all its
    attempts; the study's timeline shows it as killed, ending there."""
    from astrocpg.studies.parameter_studies.tables import timeline

    # 8 sessions of 5 s by the first attempt's last checkpoint (400 s), 2 since (100 s):
    # 500 s of wall for 50 simulated s; 10 sessions of 5 s left -> 500 s
    out = _killed_then_running(tmp_path, {"last_seen": 400.0})
    p = study_status(out, workers=1, now=1000.0)
    (run,) = p.runs
    assert run.unrecorded_attempts == 0 and run.wall_s == pytest.approx(500.0)
    assert p.left_s == pytest.approx(500.0)
    assert "without a record" not in p.text()

    class Study:
        runs = [type("R", (), {"run_id": "a"})()]
    rows = timeline(Study, out)
    assert [r["state"] for r in rows] == ["killed", "interrupted"]
    assert rows[0]["ended"] == 400.0 and rows[0]["duration_s"] == pytest.approx(400.0)
    assert rows[1]["ended"] is None


def test_a_run_notes_its_checkpoints_in_its_attempt(tmp_path):
    """A study's run writes the time of each checkpoint into its attempt's line, which is what
    lets a killed attempt count up to its last checkpoint."""
    import sys

    sys.path.insert(0, str(Path(__file__).resolve().parent))
    from tiny_study import tiny_study

    from astrocpg.studies.parameter_studies.study import load_study, run_study

    sys.path.pop(0)
    f = tmp_path / "tiny.toml"
    f.write_text(tiny_study("tiny", sessions=2))
    out = tmp_path / "out"
    run_study(load_study(f), out, workers=1, progress=False)
    (folder,) = (out / "runs").iterdir()
    status = json.loads((folder / "status.json").read_text())
    (attempt,) = status["history"]
    assert attempt["started"] <= attempt["last_seen"] <= attempt["ended"]


def test_the_progress_bar_counts_a_runs_rows_again_when_its_file_is_replaced(tmp_path):
    import os

    from astrocpg.studies.parameter_studies.execute import _SessionsDone

    count = _SessionsDone()
    assert count(tmp_path) == 0  # no sessions.csv yet
    (tmp_path / "sessions.csv").write_text("trial,session\n0,1\n1,1\n")
    assert count(tmp_path) == 2
    assert count(tmp_path) == 2  # unchanged: the cached count
    new = tmp_path / "new.csv"  # as a checkpoint writes it: a new file moved into place
    new.write_text("trial,session\n0,1\n1,1\n0,2\n1,2\n0,3\n")
    os.replace(new, tmp_path / "sessions.csv")
    assert count(tmp_path) == 5


def test_runs_are_listed_by_the_value_of_their_numbers(tmp_path):
    out = _study(tmp_path, {f"astro__L_max={v}": {"trials": 1, "sessions": 1}
                            for v in ("18", "9", "100", "9.5")})
    ids = [r.run_id for r in study_status(out).runs]
    assert ids == ["astro__L_max=9", "astro__L_max=9.5", "astro__L_max=18",
                   "astro__L_max=100"]


def test_the_time_left_uses_the_workers_the_study_runs_on(tmp_path):
    out = _study(tmp_path, {
        "a": {"trials": 1, "sessions": 2, "state": "finished", "ended_s": 10,
              "lengths": [[1, 1]]},
        "b": {"trials": 1, "sessions": 2}, "c": {"trials": 1, "sessions": 2}})
    assert study_status(out).workers == 1  # no manifest: one, as before
    (out / "manifest.json").write_text(json.dumps({"settings": {"worker_count": 2}}))
    p = study_status(out)
    assert p.workers == 2 and p.left_s == pytest.approx(10.0)  # b and c side by side
    assert "with 2 worker(s) (as the study runs)" in p.text()
    asked = study_status(out, workers=1)
    assert asked.workers == 1 and asked.left_s == pytest.approx(20.0)
    (out / "manifest.json").write_text(json.dumps({"settings": {"workers": 3}}))
    assert study_status(out).workers == 3  # a folder from before worker_count


@pytest.mark.parametrize("which", ["runs/a/sessions.csv", "runs/a/status.json",
                                   "timeline.csv", "manifest.json"])
def test_a_fifo_in_the_folder_is_refused_not_waited_on(tmp_path, which):
    import os
    import signal

    out = _study(tmp_path, {"a": {"trials": 1, "sessions": 2, "state": "running",
                                  "lengths": [[1]]}})
    path = out / which
    path.unlink(missing_ok=True)
    os.mkfifo(path)

    def hung(*_):
        raise TimeoutError(f"study_status waited on the FIFO {which}")

    previous = signal.signal(signal.SIGALRM, hung)
    signal.alarm(10)
    try:
        with pytest.raises(InputError) as e:
            study_status(out)
    finally:
        signal.alarm(0)
        signal.signal(signal.SIGALRM, previous)
    assert which in str(e.value) and "FIFO" in str(e.value)


def test_corrupt_values_are_refused_or_skipped_naming_the_line(tmp_path):
    out = _study(tmp_path / "1", {"a": {"trials": 1, "sessions": 4, "state": "running",
                                         "lengths": [[1, 1]]}})
    with open(out / "runs" / "a" / "sessions.csv", "a") as f:
        f.write("0,3,-5\n0,4,nan\n7,5,1\n")  # a negative, a non-finite length, no such seed
    p = study_status(out)
    assert p.runs[0].sessions_done == 2 and p.runs[0].simulated_s == 2.0
    assert "sessions.csv line 4" in p.text() and "line 6" in " ".join(p.skipped)
    index = json.loads((out / "study.json").read_text())
    index["specs"]["a"]["n_sessions"] = -10  # was "-1000.0%"
    (out / "study.json").write_text(json.dumps(index))
    with pytest.raises(InputError) as e:
        study_status(out)
    assert "study.json" in str(e.value) and "n_sessions" in str(e.value)
