"""A study's run given out again while a worker still trains it.

A worker that stops answering for a while (its machine paused or suspended, ``kill -STOP``) is
taken for dead by the scheduler, which gives its run to another worker; the first worker goes on
training when it wakes. The second attempt finds the run folder locked. It used to give up at
once and mark the run failed, and the study ended (stopping the worker that was training it). It
now waits for the lock, then reads how the run ended (a finished run is not trained again) or
continues it from its checkpoint. It waits only while the study that gave the run out holds its
folder: a run folder held by any other process is left alone at once, as before
(tests/test_study_integrity.py)."""

from __future__ import annotations

import json
import subprocess
import sys
import time
from pathlib import Path
from types import SimpleNamespace

from astrocpg.studies.outputs.folder import FolderLock
from astrocpg.studies.parameter_studies import execute

HOLDER = """
import json, sys, time
from pathlib import Path
from astrocpg.studies.outputs.folder import FolderLock
run, ready, release = Path(sys.argv[1]), Path(sys.argv[2]), Path(sys.argv[3])
lock = FolderLock(run, inside=run.parent.parent).acquire()
(run / "status.json").write_text(json.dumps({"run_id": "r", "state": "finished"}))
ready.write_text("")
deadline = time.monotonic() + 120
while not release.exists() and time.monotonic() < deadline:  # the test says when
    time.sleep(0.01)
lock.release()
"""


def test_a_run_given_out_again_waits_for_the_worker_that_trains_it(tmp_path, monkeypatch):
    import threading

    run = tmp_path / "study" / "runs" / "r"
    run.mkdir(parents=True)
    ready, release = tmp_path / "ready", tmp_path / "release"
    holder = subprocess.Popen([sys.executable, "-c", HOLDER, str(run), str(ready), str(release)])
    try:
        deadline = time.monotonic() + 120
        while not ready.exists():
            assert time.monotonic() < deadline and holder.poll() is None, "the holder never locked"
            time.sleep(0.02)
        assert FolderLock(run).held_elsewhere()
        monkeypatch.setattr(execute, "RUN_LOCK_POLL_S", 0.05)
        # the study that gave the run out holds its folder (here: this process)
        study = FolderLock(tmp_path / "study").acquire()
        # the other worker lets go 1 s from now: until then the attempt must wait
        timer = threading.Timer(1.0, release.write_text, args=("",))
        t0 = time.monotonic()
        timer.start()
        try:
            status = execute.execute_run(SimpleNamespace(run_id="r"), str(run))
        finally:
            timer.cancel()
            release.write_text("")
            study.release()
        waited = time.monotonic() - t0
    finally:
        holder.wait(timeout=120)
    assert status["state"] == "finished", status  # as the first attempt ended it: not failed
    assert waited >= 1.0, waited
    assert json.loads((run / "status.json").read_text())["state"] == "finished"


def test_a_lock_of_a_process_that_died_is_not_waited_for(tmp_path):
    run = tmp_path / "study" / "runs" / "r"
    run.mkdir(parents=True)
    subprocess.run([sys.executable, "-c", "import sys; from pathlib import Path; "
                    "from astrocpg.studies.outputs.folder import FolderLock; "
                    "FolderLock(Path(sys.argv[1])).acquire(); import os; os._exit(0)",
                    str(run)], check=True, timeout=60)
    assert not FolderLock(run).held_elsewhere()  # the kernel dropped the dead process's lock
