"""A study on a real SLURM cluster, as the studies page says ("On a cluster"): its two commands
(``python docs/cluster/slurm_cluster.py ...``, then ``astrocpg study ... --scheduler
tcp://NODE:PORT``) run as the page gives them, with this machine's values (its partition, 2
jobs of 2GB for 30 minutes, the address the script prints) and the study shortened by the
manual's rule (tests/test_doc_commands.py); its rows are the same as a local run's. Then the
same study again with one worker job cancelled (``scancel``) while it trains a run: the run
resumes from its checkpoint, the script submits a new job, and the rows are again the same.

The cluster is Debian's slurm-wlm on this machine (munged, slurmctld, slurmd; no cgroups),
started by tests/slurm/start_slurm.sh (which installs it where it can) and stopped at the end
if this test started it. The test is skipped only where slurm cannot be installed (not root,
no apt-get, apt failed), saying why; a cluster that is installed but does not come up fails.
"""

from __future__ import annotations

import json
import os
import re
import shutil
import signal
import subprocess
import sys
import time
import tomllib
from pathlib import Path

import pytest

from test_doc_commands import (SLURM_CLUSTER, SLURM_STUDY, SLURM_RUN_BY, EXCEPTIONS, _set,
                               _toml, commands, shorten_study)

ROOT = Path(__file__).resolve().parents[1]
START = ROOT / "tests" / "slurm" / "start_slurm.sh"
CANNOT_INSTALL = 77  # start_slurm.sh: slurm cannot be installed here
PARTITION = "debug"  # the partition start_slurm.sh configures
# what the page's cluster script is given here: two one-core jobs
LOCAL_VALUES = {"--partition": PARTITION, "--jobs": "2", "--memory": "2GB",
                "--walltime": "00:30:00"}
# the shortened study: the manual's rule (2 sessions, one seed, 1 s sessions), but 2 seeds of
# 6 sessions, so that a job can be cancelled while it trains a run and 4 runs share 2 workers
SESSIONS, SEEDS = 6, 2


def _page_commands() -> tuple[list[str], list[str]]:
    """The studies page's cluster script and study commands, as words."""
    found = {c.text: c for c in commands() if not c.snippet}
    script = [t for t in found if t.startswith(SLURM_CLUSTER)]
    study = [t for t in found if t == SLURM_STUDY]
    assert len(script) == 1 and len(study) == 1, (script, study)
    return found[script[0]].words, found[study[0]].words


def test_the_pages_slurm_recipe_is_what_this_test_runs():
    """The doc-command test leaves the page's two SLURM commands to this test (and no other
    command); the script's command gives every value this test replaces."""
    by_us = {k for k, why in EXCEPTIONS.items() if why.startswith(SLURM_RUN_BY)}
    assert by_us == {SLURM_CLUSTER, SLURM_STUDY}
    script, study = _page_commands()
    assert script[:2] == ["python", "docs/cluster/slurm_cluster.py"]
    for option in LOCAL_VALUES:
        assert option in script, f"the page's script command has no {option}"
    assert study[:2] == ["astrocpg", "study"] and "--scheduler" in study and "--out" in study


@pytest.mark.parametrize("uid, reason", [("1000", "not root"), ("0", "no apt-get")])
def test_a_machine_that_cannot_install_slurm_says_why(tmp_path, uid, reason):
    """Where slurm is missing and cannot be installed, start_slurm.sh exits 77 (the SLURM test
    is then skipped, naming the reason) and writes nothing but its message."""
    bin_ = tmp_path / "bin"  # a PATH without slurm's programs or apt-get; `id` says ``uid``
    bin_.mkdir()
    (bin_ / "id").write_text(f"#!/bin/sh\necho {uid}\n")
    (bin_ / "id").chmod(0o755)
    done = subprocess.run([shutil.which("bash"), str(START), "start", str(tmp_path / "c")],
                          env={"PATH": str(bin_)}, capture_output=True, text=True, timeout=60)
    assert done.returncode == CANNOT_INSTALL, done.stderr
    assert f"cannot install slurm-wlm and munge: {reason}" in done.stderr.splitlines()[-1]
    assert not (tmp_path / "c").exists()


# ------------------------------------------------------------------------ the cluster

def _script(command: str, env: dict, timeout: float = 900) -> subprocess.CompletedProcess:
    return subprocess.run(["bash", str(START), command], env=env, capture_output=True,
                          text=True, timeout=timeout)


@pytest.fixture(scope="session")
def slurm() -> dict:
    """The environment of this machine's SLURM cluster (SLURM_CONF set): started here, or left
    running (and then left alone) by an earlier start."""
    env = {**os.environ}
    env.setdefault("ASTROCPG_SLURM_DIR", "/tmp/astrocpg-slurm")
    env["SLURM_CONF"] = str(Path(env["ASTROCPG_SLURM_DIR"]) / "slurm.conf")
    ours = _script("status", env, 30).returncode != 0
    if ours:
        started = _script("start", env)
        if started.returncode == CANNOT_INSTALL:
            pytest.skip(f"no SLURM cluster: {started.stderr.strip().splitlines()[-1]}")
        assert started.returncode == 0, f"the SLURM cluster did not start:\n{started.stderr}"
    try:
        yield env
    finally:
        if ours:
            _script("stop", env, 120)


def _squeue(env: dict) -> dict[str, str]:
    """{job id: state} of the partition's jobs."""
    done = subprocess.run(["squeue", "-h", "-p", PARTITION, "-o", "%i %T"], env=env,
                          capture_output=True, text=True, timeout=30)
    assert done.returncode == 0, done.stderr
    return dict(line.split() for line in done.stdout.splitlines() if line.strip())


def _wait_for(predicate, timeout: float, what: str, poll: float = 0.5):
    t0 = time.time()
    while time.time() - t0 < timeout:
        value = predicate()
        if value:
            return value
        time.sleep(poll)
    raise AssertionError(f"timed out after {timeout:.0f} s waiting for {what}")


class _ClusterScript:
    """The page's ``python docs/cluster/slurm_cluster.py ...`` with this machine's values,
    running in ``folder`` (the jobs' output files land there): its scheduler's address."""

    def __init__(self, words: list[str], env: dict, folder: Path) -> None:
        argv = list(words[1:])
        argv[0] = str(ROOT / argv[0])  # run in ``folder``: the jobs' output files land there
        for option, value in LOCAL_VALUES.items():
            argv = _set(argv, option, value, add=False)
        self.log = folder / "slurm_cluster.log"
        self.proc = subprocess.Popen([sys.executable, *argv], cwd=folder, env=env,
                                     stdout=subprocess.PIPE, stderr=open(self.log, "w"),
                                     text=True, start_new_session=True)
        line = self.proc.stdout.readline().strip()
        assert re.fullmatch(r"tcp://\S+:\d+", line), \
            f"the script printed {line!r}, not an address:\n{self.log.read_text()[-3000:]}"
        self.address = line

    def stop(self) -> None:
        """Ctrl-C, as the page says: the script cancels its jobs."""
        if self.proc.poll() is None:
            os.killpg(self.proc.pid, signal.SIGINT)
            try:
                self.proc.wait(60)
            except subprocess.TimeoutExpired:
                os.killpg(self.proc.pid, signal.SIGKILL)
                self.proc.wait(10)


# ------------------------------------------------------------------------ the study

def _status(run: Path) -> dict:
    try:
        return json.loads((run / "status.json").read_text())
    except (OSError, ValueError):
        return {}


def _job_of(pid: int) -> str | None:
    """The SLURM job whose process ``pid`` is (its environment's SLURM_JOB_ID)."""
    try:
        environ = Path(f"/proc/{pid}/environ").read_bytes().split(b"\0")
    except OSError:
        return None
    for item in environ:
        if item.startswith(b"SLURM_JOB_ID="):
            return item.split(b"=", 1)[1].decode()
    return None


def _study_argv(words: list[str], study_file: Path, out: Path, address: str) -> list[str]:
    """The page's study command with the shortened study, a folder of the test's and the
    script's address in place of its placeholders."""
    argv = list(words[1:])
    argv[1] = str(study_file)
    argv = _set(argv, "--out", str(out), add=False)
    return _set(argv, "--scheduler", address, add=False) + ["--no-progress"]


def _astrocpg(argv: list[str], env: dict, log: Path, **kw) -> subprocess.Popen:
    return subprocess.Popen([sys.executable, "-m", "astrocpg", *argv], cwd=log.parent, env=env,
                            stdout=open(log, "w"), stderr=subprocess.STDOUT,
                            start_new_session=True, **kw)


def _finish(proc: subprocess.Popen, log: Path, timeout: float) -> None:
    try:
        rc = proc.wait(timeout)
    except subprocess.TimeoutExpired:
        os.killpg(proc.pid, signal.SIGKILL)
        proc.wait(10)
        raise AssertionError(f"the study did not end in {timeout:.0f} s:\n"
                             f"{log.read_text()[-3000:]}") from None
    assert rc == 0, f"the study ended with exit {rc}:\n{log.read_text()[-3000:]}"


@pytest.mark.slow
def test_study_on_slurm_with_a_job_cancelled(slurm: dict, tmp_path: Path) -> None:
    script_words, study_words = _page_commands()
    study_file = tmp_path / "ablation.toml"
    shutil.copy(ROOT / study_words[2], study_file)
    shorten_study(study_file)
    data = tomllib.loads(study_file.read_text())
    data["study"]["sessions"], data["study"]["seeds"]["count"] = SESSIONS, SEEDS
    study_file.write_text(_toml(data))
    env = {**slurm, "PYTHONWARNINGS": "ignore", "MPLBACKEND": "Agg",
           "DASK_DISTRIBUTED__LOGGING__DISTRIBUTED": "error"}

    # the local run, on two worker processes of this machine
    local = tmp_path / "local"
    proc = _astrocpg(["study", str(study_file), "--out", str(local), "--workers", "2",
                      "--no-progress"], env, tmp_path / "local.log")
    _finish(proc, tmp_path / "local.log", 600)
    rows = (local / "results.csv").read_bytes()
    assert rows.count(b"\n") == 1 + 2 * SEEDS * SESSIONS  # 2 conditions

    cluster = _ClusterScript(script_words, env, tmp_path)
    try:
        # the page's study command on the cluster's workers
        on_slurm = tmp_path / "slurm"
        proc = _astrocpg(_study_argv(study_words, study_file, on_slurm, cluster.address), env,
                         tmp_path / "slurm.log")
        _finish(proc, tmp_path / "slurm.log", 600)
        assert (on_slurm / "results.csv").read_bytes() == rows
        hosts = {_status(r).get("worker_name") for r in (on_slurm / "runs").glob("*")}
        assert all(h and h.startswith("SLURMCluster") for h in hosts), hosts

        # again, one job cancelled while its worker trains a run that has checkpointed
        cancelled = tmp_path / "cancelled"
        proc = _astrocpg(_study_argv(study_words, study_file, cancelled, cluster.address), env,
                         tmp_path / "cancelled.log")
        try:
            def in_flight():
                for run in (cancelled / "runs").glob("*"):
                    s = _status(run)
                    job = _job_of(s.get("pid", 0)) if s.get("state") == "running" else None
                    if job and (run / "checkpoint.npz").exists() \
                            and _squeue(slurm).get(job) == "RUNNING":
                        return run, job
                return None

            run, job = _wait_for(in_flight, 300, "a run in flight on a SLURM job, checkpointed")
            jobs_before = set(_squeue(slurm))
            subprocess.run(["scancel", job], env=slurm, check=True, timeout=30)
            _wait_for(lambda: job not in _squeue(slurm), 60, f"job {job} to leave the queue")
            _finish(proc, tmp_path / "cancelled.log", 600)
        finally:
            if proc.poll() is None:
                os.killpg(proc.pid, signal.SIGKILL)
                proc.wait(10)
        assert (cancelled / "results.csv").read_bytes() == rows
        resumed = _status(run)
        assert resumed["attempts"] == 2 and resumed["state"] == "finished"
        assert resumed["sessions_at_start"] >= 1  # from its checkpoint, not from the start
        assert len({h["pid"] for h in resumed["history"]}) == 2  # on another worker
        # the script replaced the cancelled job
        _wait_for(lambda: set(_squeue(slurm)) - jobs_before, 90, "a job replacing the cancelled")
    finally:
        cluster.stop()
    _wait_for(lambda: not _squeue(slurm), 60, "the script's jobs to be cancelled")
