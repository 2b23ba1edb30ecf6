"""Interrupted is not finished: SIGINT, SIGTERM and SIGKILL at several points of ``run``,
``unit``, ``train``, ``export`` and ``study``, each a child process
(``python -m astrocpg.studies.cli ...`` in a session of its own, signalled as a group).

Afterwards a result folder is absent (or, when the signal came after the command finished,
complete), never a finished-looking folder with partial data; hidden temporaries a killed
process left are removed by the next start; a training or a study continues with
``--resume`` / the same command to exactly the result of an uninterrupted one (sessions.csv and
weights.npz byte for byte); two trainings on one folder: the second is refused in one line
(exit 2), the first finishes unharmed. No Brian2 debug file is left in the temp folder.
"""

from __future__ import annotations

import hashlib
import itertools
import json
import os
import re
import shutil
import signal
import subprocess
import sys
import time
from pathlib import Path
from typing import Callable

import pytest

from astrocpg.studies.outputs.folder import LOCK_NAME, OWNER_NAME, parse_temp_name, verify

CLI = [sys.executable, "-m", "astrocpg.studies.cli"]
# a short training: sessions of at most 0.3 s, 2 trials
# one process: these are the one-process training's checkpoints (a training split over
# processes, the default on a machine of several cores, is interrupted in tests/test_workers.py)
TRAIN = ["--sessions", "5", "--trials", "2", "--seed", "5", "--set", "L_max=0.3*second",
         "--set", "L_non_alive=0.15*second", "--no-progress", "--workers", "1"]
STUDY = """
[study]
name = "faults"
sessions = 3
seeds = { first = 1, count = 2 }
batch = 1
[base]
L_max = "0.3*second"
L_non_alive = "0.15*second"
[conditions.astro]
astrocytes = true
"""


SIGNALS = {"SIGINT": signal.SIGINT, "SIGTERM": signal.SIGTERM, "SIGKILL": signal.SIGKILL}


def grid(*axes: dict, slow: set[str] = frozenset()) -> list:
    """pytest params of every combination of the axes ({id: value}); the combinations named in
    ``slow`` are marked slow (the default run keeps one or two of each signal per command)."""
    params = []
    for combo in itertools.product(*(list(a.items()) for a in axes)):
        name = "-".join(k for k, _ in combo)
        params.append(pytest.param(*(v for _, v in combo), id=name,
                                   marks=(pytest.mark.slow,) if name in slow else ()))
    return params


# ---------------------------------------------------------------- child processes
class Child:
    """A command in its own session (signals go to its whole process group: a study's Dask
    workers too); stdout and stderr go to files that can be read while it runs."""

    def __init__(self, tmp: Path, argv: list[str], name: str = "child") -> None:
        self.log_out, self.log_err = tmp / f"{name}.out", tmp / f"{name}.err"
        self.tmpdir = tmp / "tmpdir"
        self.tmpdir.mkdir(exist_ok=True)
        env = {**os.environ, "PYTHONWARNINGS": "ignore", "TMPDIR": str(self.tmpdir),
               "DASK_DISTRIBUTED__LOGGING__DISTRIBUTED": "error"}
        with open(self.log_out, "w") as out, open(self.log_err, "w") as err:
            self.proc = subprocess.Popen([*CLI, *argv], stdout=out, stderr=err, cwd=tmp,
                                         env=env, start_new_session=True)

    @property
    def stderr(self) -> str:
        return self.log_err.read_text(errors="replace")

    @property
    def stdout(self) -> str:
        return self.log_out.read_text(errors="replace")

    def signal(self, sig: int) -> None:
        try:
            os.killpg(self.proc.pid, sig)
        except ProcessLookupError:
            pass

    def wait(self, timeout: float = 600) -> int:
        try:
            return self.proc.wait(timeout)
        except subprocess.TimeoutExpired:
            self.signal(signal.SIGKILL)
            self.proc.wait()
            pytest.fail(f"{self.proc.args} did not end within {timeout:.0f} s")

    def finish(self, timeout: float = 600) -> int:
        """Wait for the whole group (a killed study leaves no worker behind)."""
        code = self.wait(timeout)
        deadline = time.time() + 30
        while time.time() < deadline:
            try:
                os.killpg(self.proc.pid, 0)
            except ProcessLookupError:
                break
            time.sleep(0.1)
        else:
            self.signal(signal.SIGKILL)
        return code

    def until(self, predicate: Callable[[], bool], what: str, timeout: float = 300,
              poll: float = 0.002) -> bool:
        """Wait until ``predicate()``; False if the command ended first."""
        deadline = time.time() + timeout
        while time.time() < deadline:
            if predicate():
                return True
            if self.proc.poll() is not None:
                return predicate()
            time.sleep(poll)
        self.signal(signal.SIGKILL)
        pytest.fail(f"timed out waiting for {what}; stderr: {self.stderr[-2000:]}")

    def no_debug_files(self) -> None:
        # Brian2's own files, or the private folder a process killed while importing Brian2
        # keeps them in (astrocpg.support._quiet_brian; the next start removes it)
        left = [n for n in os.listdir(self.tmpdir) if n.startswith(("brian", "astrocpg-brian-"))]
        assert not left, f"Brian2 left {left} in the temp folder"


@pytest.fixture
def children(tmp_path):
    started: list[Child] = []

    def start(*argv: str, name: str = "child") -> Child:
        c = Child(tmp_path, [str(a) for a in argv], name=f"{name}{len(started)}")
        started.append(c)
        return c

    yield start
    for c in started:
        if c.proc.poll() is None:
            c.signal(signal.SIGKILL)
            c.proc.wait()


# a progress bar's line, of simulated time or of any other count (tqdm: "plot:  40%|####  |")
BAR = re.compile(r"^(?!astrocpg:)(.*sim s|[^|]*\d+%\|.*\|)")


def one_line(err: str) -> str:
    """The single ``astrocpg:`` line of a failed command (progress bars aside)."""
    assert "Traceback" not in err, err
    lines = [x for x in err.replace("\r", "\n").splitlines()
             if x.strip() and not BAR.search(x)]  # progress bars aside
    assert len(lines) == 1 and lines[0].startswith("astrocpg:"), err
    return lines[0]


def sha_tree(root: Path, locks: bool = True) -> dict[str, str]:
    """relative path -> sha256 of every file below ``root``; ``locks=False``: without the lock
    files a killed process may leave at the top (by design: the kernel drops the lock, the
    files stay; see FolderLock)."""
    return {p.relative_to(root).as_posix(): hashlib.sha256(p.read_bytes()).hexdigest()
            for p in sorted(root.rglob("*")) if p.is_file()
            and (locks or p.relative_to(root).as_posix() not in (LOCK_NAME, OWNER_NAME))}


def temporaries(parent: Path) -> list[str]:
    return sorted(n for n in os.listdir(parent) if parse_temp_name(n))


def partial_exists(parent: Path, name: str) -> Callable[[], bool]:
    prefix = f".{name}.partial-"
    return lambda: any(n.startswith(prefix) for n in os.listdir(parent))


def rows(folder: Path) -> int:
    try:
        return max(0, (folder / "sessions.csv").read_bytes().count(b"\n") - 1)
    except OSError:
        return 0


def manifest_status(folder: Path) -> str | None:
    try:
        return json.loads((folder / "manifest.json").read_text())["results"].get("status")
    except (OSError, ValueError, KeyError):
        return None


# ---------------------------------------------------------------- run and unit
SIM = {"unit": ["--seconds", "4", "--trace-dt", "1"],
       "run": ["--seconds", "4", "--robot-stride", "1"]}


@pytest.mark.parametrize("cmd, sig", grid({"unit": "unit", "run": "run"}, SIGNALS,
                                          slow={"run-SIGTERM", "run-SIGKILL"}))
def test_signal_while_simulating_leaves_no_folder(cmd, sig, children, tmp_path):
    out = tmp_path / "res" / "out"
    c = children(cmd, *SIM[cmd], "--out", out)
    # the progress bar appears when the simulation starts
    assert c.until(lambda: "sim s" in c.stderr, "the simulation to start"), c.stderr
    time.sleep(0.5)
    c.signal(sig)
    code = c.finish()
    assert not os.path.lexists(out), "an interrupted run left its folder"
    if sig == signal.SIGKILL:
        assert code == -signal.SIGKILL
    else:
        assert code == 130, c.stderr
        assert one_line(c.stderr) == "astrocpg: interrupted"
        assert not os.path.exists(out.parent) or temporaries(out.parent) == []
    c.no_debug_files()


@pytest.mark.parametrize("cmd, sig", grid({"unit": "unit", "run": "run"}, SIGNALS,
                                          slow={"unit-SIGTERM", "unit-SIGKILL", "run-SIGINT"}))
def test_signal_while_writing_leaves_nothing_or_the_whole_folder(cmd, sig, children, tmp_path):
    parent = tmp_path / "res"
    parent.mkdir()
    out = parent / "out"
    c = children(cmd, "--seconds", "0.3", "--no-progress", "--out", out)
    caught = c.until(partial_exists(parent, "out"), "the temporary folder", poll=0.001)
    c.signal(sig)
    code = c.finish()
    if os.path.lexists(out):  # the signal came after the folder was moved into place
        assert code == 0 or code == -sig or code == 130, (code, c.stderr)
        verify(out)
        assert manifest_status(out) in (None, "finished")
    else:
        assert caught, "the command ended without its folder"
        assert code == (-signal.SIGKILL if sig == signal.SIGKILL else 130), (code, c.stderr)
        if sig != signal.SIGKILL:
            assert one_line(c.stderr) == "astrocpg: interrupted"
            assert temporaries(parent) == [], "an interrupted write left its temporary"
    # the next start removes what a killed process left
    again = children(cmd, "--seconds", "0.01", "--no-progress", "--out", parent / "next")
    assert again.finish() == 0, again.stderr
    assert temporaries(parent) == []
    verify(parent / "next")
    c.no_debug_files()


# ---------------------------------------------------------------- train
@pytest.fixture(scope="module")
def baseline(tmp_path_factory) -> Path:
    """An uninterrupted training: what every interrupted and resumed one must equal."""
    out = tmp_path_factory.mktemp("baseline") / "train"
    proc = subprocess.run([*CLI, "train", *TRAIN, "--out", str(out)], capture_output=True,
                          text=True, timeout=900)
    assert proc.returncode == 0, proc.stderr
    return out


def same_training(a: Path, b: Path) -> None:
    assert (a / "sessions.csv").read_bytes() == (b / "sessions.csv").read_bytes()
    assert (a / "weights.npz").read_bytes() == (b / "weights.npz").read_bytes()


def resume(children, folder: Path) -> None:
    r = children("train", "--resume", folder, "--no-progress", name="resume")
    assert r.finish() == 0, r.stderr
    verify(folder)
    assert manifest_status(folder) == "finished"


@pytest.mark.parametrize("sig", grid(SIGNALS, slow={"SIGTERM"}))
def test_train_interrupted_after_sessions_resumes_to_the_same_result(sig, children, tmp_path,
                                                                     baseline):
    out = tmp_path / "train"
    c = children("train", *TRAIN, "--out", out)
    # the first checkpoint comes at the first session end, after sessions.csv; later ones are
    # spaced (trainer.py), so the signal goes once the first is whole (renamed into place)
    assert c.until(lambda: (out / "checkpoint.npz").exists(), "the first checkpoint",
                   poll=0.01), c.stderr
    c.signal(sig)
    code = c.finish()
    assert rows(out) < 10, "the signal came too late to test anything"
    if sig == signal.SIGKILL:
        assert code == -signal.SIGKILL
    else:
        assert code == 130, c.stderr
        line = one_line(c.stderr)
        assert "interrupted" in line and f"--resume {out}" in line, line
        # what it wrote is whole and listed: the checkpoint's sessions, marked interrupted
        verify(out)
        assert manifest_status(out) == "interrupted"
    assert (out / "checkpoint.npz").exists()
    resume(children, out)
    same_training(out, baseline)
    history = json.loads((out / "manifest.json").read_text())["history"]
    assert len(history) == 2 and history[-1]["status"] == "finished", history
    c.no_debug_files()


@pytest.mark.parametrize("sig, then", grid({"SIGKILL": signal.SIGKILL, "SIGINT": signal.SIGINT},
                                          {"resume": "resume", "overwrite": "overwrite"},
                                          slow={"SIGKILL-overwrite", "SIGINT-overwrite"}))
def test_train_stopped_before_its_first_checkpoint_resumes_or_is_replaced(sig, then, children,
                                                                          tmp_path, baseline):
    out = tmp_path / "train"
    c = children("train", *TRAIN, "--out", out)
    # the folder holds its manifest (status running) before the first session ends
    c.until(lambda: (out / "manifest.json").exists(), "the training's manifest", poll=0.001)
    c.signal(sig)
    code = c.finish()
    if sig == signal.SIGINT and not (out / "checkpoint.npz").exists():
        assert code == 130, c.stderr
        assert f"--resume {out}" in one_line(c.stderr)
        assert manifest_status(out) == "interrupted"
    if (out / "checkpoint.npz").exists():
        pytest.skip("the first checkpoint came before the kill")
    if then == "resume":
        resume(children, out)
    else:
        r = children("train", *TRAIN, "--out", out, "--overwrite", name="again")
        assert r.finish() == 0, r.stderr
        verify(out)
    same_training(out, baseline)


def test_train_resume_of_a_finished_run_changes_nothing(children, tmp_path, baseline):
    out = tmp_path / "train"
    shutil.copytree(baseline, out)
    before = sha_tree(out)
    r = children("train", "--resume", out)
    assert r.finish() == 2
    assert "already finished" in one_line(r.stderr)
    assert sha_tree(out) == before


def test_second_training_on_one_folder_is_refused_and_the_first_finishes(children, tmp_path):
    out = tmp_path / "train"
    long = [*TRAIN, "--sessions", "40"]  # long enough to be running while the others start
    first = children("train", *long, "--out", out, name="first")
    assert first.until(lambda: rows(out) >= 1, "the first session", poll=0.01), first.stderr
    seconds = [children(*argv, name="second") for argv in
               (["train", "--resume", out], ["train", *long, "--out", out, "--overwrite"],
                ["run", "--seconds", "0.01", "--no-progress", "--out", out, "--overwrite"])]
    for second in seconds:
        assert second.finish() == 2, second.stderr
        line = one_line(second.stderr)
        assert "in use by another astrocpg process" in line and str(out) in line, line
    assert first.proc.poll() is None, "the first training ended before the others started"
    assert first.finish() == 0, first.stderr
    verify(out)
    assert manifest_status(out) == "finished" and rows(out) == 2 * 40


# ---------------------------------------------------------------- export
@pytest.fixture(scope="module")
def run_folder(tmp_path_factory) -> Path:
    out = tmp_path_factory.mktemp("export") / "run"
    proc = subprocess.run([*CLI, "run", "--seconds", "2", "--trials", "2", "--no-progress",
                           "--out", str(out)], capture_output=True, text=True, timeout=600)
    assert proc.returncode == 0, proc.stderr
    return out


@pytest.mark.parametrize("sig, delay", grid(
    {"SIGINT": signal.SIGINT, "SIGKILL": signal.SIGKILL},
    {"0.5": 0.5, "2.0": 2.0, "3.5": 3.5, "5.0": 5.0},
    slow={"SIGINT-0.5", "SIGINT-2.0", "SIGINT-5.0", "SIGKILL-0.5", "SIGKILL-3.5", "SIGKILL-5.0"}))
def test_export_interrupted_leaves_no_file_and_the_next_start_cleans(sig, delay, children,
                                                                     tmp_path, run_folder):
    folder = tmp_path / "run"
    shutil.copytree(run_folder, folder)
    before = sha_tree(folder)
    target = tmp_path / "run.nwb"
    c = children("export", folder)
    time.sleep(delay)
    c.signal(sig)
    code = c.finish()
    if target.exists():  # finished before the signal
        assert code in (0, -sig, 130), (code, c.stderr)
    else:
        if sig == signal.SIGINT:
            assert code == 130, (code, c.stderr)
            assert one_line(c.stderr) == "astrocpg: interrupted"
            assert temporaries(tmp_path) == []
        else:
            assert code == -signal.SIGKILL
    assert sha_tree(folder) == before, "export changed the folder it read"
    again = children("export", folder, "--overwrite", name="again")
    assert again.finish() == 0, again.stderr
    assert temporaries(tmp_path) == [], "the next export left a killed one's temporary"
    from pynwb import NWBHDF5IO
    with NWBHDF5IO(str(target), "r") as io:
        assert len(io.read().units) > 0
    c.no_debug_files()


@pytest.mark.parametrize("sig", grid(SIGNALS, slow={"SIGINT"}))
def test_export_signalled_while_its_temporary_exists(sig, children, tmp_path, run_folder):
    folder = tmp_path / "run"
    shutil.copytree(run_folder, folder)
    before = sha_tree(folder)
    target = tmp_path / "run.npz"
    c = children("export", folder, "--format", "npz")
    caught = c.until(lambda: any(n.startswith(".run.tmp-") for n in os.listdir(tmp_path)),
                     "the export's temporary file", poll=0.0005)
    c.signal(sig)
    code = c.finish()
    if not target.exists():
        assert caught
        if sig == signal.SIGKILL:
            assert code == -signal.SIGKILL
            assert temporaries(tmp_path), "expected the killed export's temporary"
        else:
            assert code == 130, (code, c.stderr)
            assert one_line(c.stderr) == "astrocpg: interrupted"
            assert temporaries(tmp_path) == []
    assert sha_tree(folder) == before
    again = children("export", folder, "--format", "npz", "--overwrite", name="again")
    assert again.finish() == 0, again.stderr
    assert temporaries(tmp_path) == []
    import numpy as np
    with np.load(target) as z:
        assert "spikes_motor_times" in z.files


# ---------------------------------------------------------------- plot and report
@pytest.fixture(scope="module")
def unit_folder(tmp_path_factory) -> Path:
    out = tmp_path_factory.mktemp("plot") / "unit"
    proc = subprocess.run([*CLI, "unit", "--seconds", "1", "--no-progress", "--out", str(out)],
                          capture_output=True, text=True, timeout=600)
    assert proc.returncode == 0, proc.stderr
    return out


@pytest.mark.parametrize("cmd, sig", [("plot", signal.SIGINT), ("report", signal.SIGKILL)],
                         ids=["plot-SIGINT", "report-SIGKILL"])
def test_interrupted_figures_leave_the_previous_ones_whole(cmd, sig, children, tmp_path,
                                                           unit_folder, study_baseline):
    """plot and report replace their figure folder whole on every call: interrupted, the
    previous figures stay byte for byte; the next start removes the temporaries."""
    source = study_baseline[2] if cmd == "report" else unit_folder
    folder = tmp_path / "src"
    shutil.copytree(source, folder)
    name = "report" if cmd == "report" else "figures"
    first = children(cmd, folder, name="first")
    assert first.finish() == 0, first.stderr
    before = sha_tree(folder / name)
    c = children(cmd, folder, name="second")
    caught = c.until(partial_exists(folder, name), "the temporary folder", poll=0.001)
    c.signal(sig)
    code = c.finish()
    if code != 0:
        assert caught
        assert sha_tree(folder / name, locks=sig != signal.SIGKILL) == before, \
            "an interrupted plot changed the old figures"
        if sig != signal.SIGKILL:
            assert code == 130 and one_line(c.stderr) == "astrocpg: interrupted"
            assert temporaries(folder) == []
    verify(folder / name)
    again = children(cmd, folder, name="again")
    assert again.finish() == 0, again.stderr
    assert temporaries(folder) == []
    verify(folder / name)


# ---------------------------------------------------------------- study
def results(out: Path) -> bytes:
    return (out / "results.csv").read_bytes()


@pytest.fixture(scope="module")
def study_baseline(tmp_path_factory) -> tuple[Path, bytes, Path]:
    base = tmp_path_factory.mktemp("study")
    spec = base / "faults.toml"
    spec.write_text(STUDY)
    out = base / "out"
    proc = subprocess.run([*CLI, "study", str(spec), "--out", str(out), "--workers", "2",
                           "--no-progress"], capture_output=True, text=True, timeout=900,
                          env={**os.environ, "PYTHONWARNINGS": "ignore"})
    assert proc.returncode == 0, proc.stderr
    return spec, results(out), out


@pytest.mark.parametrize("sig", grid({"SIGINT": signal.SIGINT, "SIGKILL": signal.SIGKILL}))
def test_study_interrupted_continues_to_the_same_result(sig, children, tmp_path,
                                                        study_baseline):
    spec, expected, _ = study_baseline
    out = tmp_path / "out"
    argv = ["study", spec, "--out", out, "--workers", "2", "--no-progress"]
    c = children(*argv)
    assert c.until(lambda: any(rows(r) >= 1 for r in (out / "runs").glob("*")),
                   "a run's first session", poll=0.01), c.stderr
    c.signal(sig)
    code = c.finish()
    if sig == signal.SIGINT:
        assert code == 130, (code, c.stderr)
        assert "interrupted" in c.stderr and "Traceback" not in c.stderr
    again = children(*argv, name="again")
    assert again.finish() == 0, again.stderr
    assert results(out) == expected
    manifest = verify(out)
    assert manifest["results"]["status"] == "finished"
    for run in (out / "runs").iterdir():
        verify(run)
    c.no_debug_files()


def test_a_run_killed_between_its_status_and_its_manifest_is_continued(children, tmp_path,
                                                                       study_baseline):
    """A run ends by writing status.json (finished), then its manifest: a study stopped between
    the two (its worker killed) left a run whose status says finished and whose manifest still
    says running, listing the files of its start. The next start of the study must not take it
    as ended (the folder would not match its manifest): it continues the run from its
    checkpoint and seals it, to the same results."""
    from astrocpg.studies.parameter_studies.status import study_status

    spec, expected, baseline = study_baseline
    out = tmp_path / "out"
    shutil.copytree(baseline, out)
    run = out / "runs" / "astro__seed1"
    manifest = json.loads((run / "manifest.json").read_text())
    assert manifest["results"]["status"] == "finished"
    manifest["results"] = {"status": "running"}
    manifest["inventory"] = {"status.json": manifest["inventory"]["status.json"]}
    (run / "manifest.json").write_text(json.dumps(manifest))
    (run / LOCK_NAME).write_bytes(b"")  # what the killed worker left: its lock does not block
    with pytest.raises(Exception, match="checkpoint.npz is not listed"):
        verify(run)
    states = {r.run_id: r.state for r in study_status(out).runs}
    assert states == {"astro__seed1": "stopped", "astro__seed2": "finished"}, states
    again = children("study", spec, "--out", out, "--workers", "1", "--no-progress")
    assert again.finish() == 0, again.stderr
    assert results(out) == expected
    for r in (out / "runs").iterdir():
        verify(r)
    status = json.loads((run / "status.json").read_text())
    assert status["state"] == "finished" and status["attempts"] == 2, status
    assert json.loads((out / "runs" / "astro__seed2" / "status.json").read_text())["attempts"] == 1


@pytest.mark.slow
def test_second_study_on_one_folder_is_refused(children, tmp_path, study_baseline):
    spec, _, _ = study_baseline
    out = tmp_path / "out"
    argv = ["study", spec, "--out", out, "--workers", "1", "--no-progress"]
    first = children(*argv, name="first")
    assert first.until(lambda: (out / ".astrocpg.lock.owner").exists(), "the study's lock",
                       poll=0.01), first.stderr
    second = children(*argv, name="second")
    assert second.finish() == 2, second.stderr
    assert "in use by another astrocpg process" in one_line(second.stderr)
    first.signal(signal.SIGINT)
    assert first.finish() in (0, 130)


def test_a_diverging_run_of_a_study_is_recorded_as_diverged_with_its_reason(children, tmp_path):
    spec = tmp_path / "dv.toml"
    spec.write_text(STUDY.replace('name = "faults"', 'name = "dv"').replace("count = 2", "count = 1")
                    + '[conditions.blows_up]\nastrocytes = true\n'
                      'set = { r_IP3 = "1e306*umolar/second" }\n')
    out = tmp_path / "out"
    c = children("study", spec, "--out", out, "--workers", "1", "--no-progress")
    # a diverged run is not retried: with nothing else left the study ends diverged (exit 3)
    assert c.finish() == 3, c.stderr
    assert "Traceback" not in c.stderr + c.stdout
    assert "diverged (blows-up__seed1)" in c.stderr, c.stderr
    failures = (out / "failures.csv").read_text()
    assert "blows-up__seed1" in failures and "astrocyte." in failures and "t = " in failures
    status = json.loads((out / "runs" / "blows-up__seed1" / "status.json").read_text())
    assert status["state"] == "diverged" and "Diverged" in status["error"], status
    assert json.loads((out / "runs" / "astro__seed1" / "status.json").read_text())["state"] == \
        "finished"
    c.no_debug_files()


# ---- leftovers: what a killed plot or video leaves does not lock the run out of export; a
# resumed training keeps nothing derived from its earlier weights
@pytest.mark.parametrize("cmd, hidden", [("plot", ".figures.partial-"),
                                         ("video", ".video_trial00.tmp-")])
def test_a_killed_plot_or_video_leaves_a_run_that_export_reads(cmd, hidden, children, tmp_path,
                                                               run_folder):
    folder = tmp_path / "run"
    shutil.copytree(run_folder, folder)
    argv = [cmd, folder] + (["--no-progress", "--size", "64", "48", "--fps", "30"]
                            if cmd == "video" else [])
    c = children(*argv)

    def written() -> bool:  # a temporary file, or a temporary folder holding a figure already
        return any(n.startswith(hidden) and (not (folder / n).is_dir() or os.listdir(folder / n))
                   for n in os.listdir(folder))
    caught = c.until(written, f"the {cmd}'s temporary", poll=0.0005)
    c.signal(signal.SIGKILL)
    c.finish()
    if not caught or not written():
        pytest.skip(f"the {cmd} finished before the kill")
    before = sha_tree(folder)
    e = children("export", folder, "--format", "npz", name="export")
    assert e.finish() == 0, e.stderr  # no later plot needed
    assert sha_tree(folder) == before, "export changed the folder it read"
    again = children(*argv, name="again")  # and the next plot/video cleans the leftover
    assert again.finish() == 0, again.stderr
    assert not any(n.startswith(hidden) for n in os.listdir(folder))


def test_a_resumed_training_removes_what_was_derived_from_its_earlier_weights(children,
                                                                              tmp_path):
    out = tmp_path / "train"
    c = children("train", *TRAIN, "--out", out)
    c.until(lambda: (out / "checkpoint.npz").exists(), "the first checkpoint", poll=0.005)
    c.signal(signal.SIGINT)
    if c.finish() == 0:
        pytest.skip("the training finished before the signal")
    # what evaluate, plot, video and power wrote from the interrupted training's weights
    for sub in ("evaluation", "evaluation.parts", "figures"):
        (out / sub).mkdir()
        (out / sub / "manifest.json").write_text(json.dumps({"astrocpg_command": "evaluate"}))
    (out / "video_trial00.mp4").write_bytes(b"old video")
    (out / "power_trial0.json").write_text("{}")
    (out / "notes.txt").write_text("the user's own notes")  # not derived: kept
    r = children("train", "--resume", out, name="resume")
    assert r.finish() == 0, r.stderr
    left = sorted(os.listdir(out))
    for name in ("evaluation", "evaluation.parts", "figures", "video_trial00.mp4",
                 "power_trial0.json"):
        assert name not in left, f"stale {name} kept after --resume: {left}"
    assert (out / "notes.txt").read_text() == "the user's own notes"
    verify(out, strict=False)
    assert manifest_status(out) == "finished"


# The whole table (and every signal case) is long: CI runs it (CI=true); `pytest -m slow` here.
pytestmark = pytest.mark.slow
