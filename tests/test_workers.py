"""--workers N: a command's trials split over worker processes give the folder one process
writes, byte for byte (the manifest apart from timings and the worker count); bad values are
refused naming the option; a 2-worker training interrupted midway resumes to the same files."""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

from astrocpg.studies.runtime.workers import default_workers, split_trials

#: short sessions that end at different steps (a strict alive threshold): the rows interleave
SHORT = ["--set", "L_max=0.3*second", "--set", "L_non_alive=0.01*second",
         "--set", "Thres_z_alive=0.999"]
#: what a manifest may differ in between worker counts (and folders: the command line)
VOLATILE = {"created", "argv", "wall_seconds", "wall_seconds_last_invocation", "workers",
            "mtime_ns", "inventory", "history", "duration_s", "finished", "started"}


def astrocpg(*args: str, cwd: Path, check: bool = True) -> subprocess.CompletedProcess:
    p = subprocess.run([sys.executable, "-m", "astrocpg", *args], cwd=cwd, capture_output=True,
                       text=True, timeout=600)
    if check:
        assert p.returncode == 0, p.stderr
    return p


def _plain(x):
    if isinstance(x, dict):
        return {k: _plain(v) for k, v in x.items() if k not in VOLATILE}
    if isinstance(x, list):
        return [_plain(v) for v in x]
    return x


def same_folders(a: Path, b: Path) -> list[str]:
    """The files of ``a`` and ``b`` (same names, same bytes; manifests compared without
    timings and the worker count); returns the names compared."""
    names = sorted(str(p.relative_to(a)) for p in a.rglob("*") if p.is_file())
    assert names == sorted(str(p.relative_to(b)) for p in b.rglob("*") if p.is_file())
    for name in names:
        if name.endswith("manifest.json"):
            ma, mb = (json.loads((f / name).read_text()) for f in (a, b))
            assert _plain(ma) == _plain(mb), name
        else:
            assert (a / name).read_bytes() == (b / name).read_bytes(), name
    return names


def test_default_and_split():
    assert default_workers() == len(os.sched_getaffinity(0))
    assert split_trials(5, 2) == [(0, 3), (3, 2)]
    assert split_trials(2, 8) == [(0, 1), (1, 1)]
    assert split_trials(20, 3) == [(0, 7), (7, 7), (14, 6)]


def _pair(tmp_path: Path, *args: str) -> tuple[Path, Path]:
    """The same command with --workers 1 and --workers 2, each in its own folder (the same
    relative --out: the manifests name it)."""
    out = []
    for n in ("1", "2"):
        cwd = tmp_path / f"w{n}"
        cwd.mkdir()
        astrocpg(*args, "--workers", n, "--no-progress", cwd=cwd)
        out.append(cwd / "out")
    return out[0], out[1]


def test_run_workers_identical(tmp_path):
    a, b = _pair(tmp_path, "run", "--trials", "3", "--seconds", "0.2", "--out", "out")
    assert {"spikes.npz", "traces.npz", "robot.npz"} <= set(same_folders(a, b))
    assert json.loads((b / "manifest.json").read_text())["results"]["workers"] == 2


def test_unit_workers_identical(tmp_path):
    a, b = _pair(tmp_path, "unit", "--trials", "3", "--seconds", "0.3", "--out", "out")
    assert "unit.png" in same_folders(a, b)


def test_train_workers_identical(tmp_path):
    a, b = _pair(tmp_path, "train", "--trials", "3", "--sessions", "4", "--record-every", "3",
                 *SHORT, "--out", "out")
    trials = [line.split(",")[0] for line in (a / "sessions.csv").read_text().splitlines()[1:]]
    assert trials[:3] != ["0", "1", "2"]  # sessions ending out of trial order: merged by step
    # the packed checkpoint holds one state per batch: the only file that differs
    for f in (a, b):
        (f / "checkpoint.npz").unlink()
    names = same_folders(a, b)
    assert {"sessions.csv", "weights.npz", "session_starts.npz"} <= set(names)
    assert any(n.startswith("recordings/") for n in names)


def test_gait_workers_identical(tmp_path):
    astrocpg("train", "--trials", "2", "--sessions", "1", *SHORT, "--out", "t", "--workers", "1",
             "--no-progress", cwd=tmp_path)
    lines = [astrocpg("gait", "t", "--seconds", "0.3", "--repeats", "2", "--workers", n,
                      "--no-progress", cwd=tmp_path).stdout for n in ("1", "2")]
    assert lines[0] == lines[1] and "table 1 repeat 1" in lines[0]


@pytest.mark.parametrize("command", [["run", "--seconds", "0.1"], ["unit", "--seconds", "0.1"],
                                     ["train", "--sessions", "1"], ["gait", "."]])
@pytest.mark.parametrize("value", ["0", "-2", "1.5"])
def test_bad_workers_refused(tmp_path, command, value):
    # gait reads an existing folder (".", not a training): --workers is refused before it is read
    if command[0] != "train" and value == "-2":
        pytest.skip("one negative case is enough")
    out = [] if command[0] == "gait" else ["--out", "o"]
    p = astrocpg(*command, *out, f"--workers={value}", cwd=tmp_path, check=False)
    assert p.returncode == 2, p.stderr
    assert "--workers" in p.stderr and len(p.stderr.strip().splitlines()) == 1, p.stderr
    assert not (tmp_path / "o").exists()


def _gone(group: int, seconds: float = 20.0) -> bool:
    """Has every process of ``group`` (the command and its workers) ended?"""
    deadline = time.monotonic() + seconds
    while time.monotonic() < deadline:
        try:
            os.killpg(group, 0)
        except ProcessLookupError:
            return True
        time.sleep(0.1)
    return False


@pytest.mark.slow
@pytest.mark.parametrize("to", ["group", "parent"])
def test_train_two_workers_interrupted_resumes_identical(tmp_path, to):
    """Ctrl-C (SIGINT to the process group, or to the command alone) stops every worker after
    its checkpoint, exit 130, no process left; the resume ends with the uninterrupted files."""
    args = ["train", "--trials", "2", "--sessions", "12", *SHORT, "--out", "out",
            "--no-progress", "--workers", "2"]
    whole = tmp_path / "whole"
    whole.mkdir()
    astrocpg(*args, cwd=whole)
    cut = tmp_path / "cut"
    cut.mkdir()
    p = subprocess.Popen([sys.executable, "-m", "astrocpg", *args], cwd=cut,
                         stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                         start_new_session=True)
    deadline = time.monotonic() + 300
    while not (cut / "out" / "checkpoint.npz").exists() and p.poll() is None:
        assert time.monotonic() < deadline
        time.sleep(0.05)
    if to == "group":
        os.killpg(p.pid, signal.SIGINT)  # Ctrl-C: the whole process group
    else:
        os.kill(p.pid, signal.SIGINT)  # the command alone: it stops its workers
    _, err = p.communicate(timeout=300)
    assert p.returncode == 130, err
    assert _gone(p.pid), "a worker outlived the command"
    assert "--resume" in err
    assert not (cut / "out" / ".workers").exists()
    astrocpg("train", "--resume", "out", "--no-progress", cwd=cut)
    for name in ("sessions.csv", "weights.npz", "session_starts.npz"):
        assert (cut / "out" / name).read_bytes() == (whole / "out" / name).read_bytes(), name


def test_benchmark_script_runs(tmp_path):
    """benchmarks/workers.py at a tiny size: it runs the commands with 1 and 2 workers and
    prints the ratio and the projection (timings here mean nothing)."""
    script = Path(__file__).resolve().parents[1] / "benchmarks" / "workers.py"
    p = subprocess.run([sys.executable, str(script), "--only", "run", "--trials", "2",
                        "--seconds", "0.1", "--json", str(tmp_path / "w.json")],
                       capture_output=True, text=True, timeout=600)
    assert p.returncode == 0, p.stderr
    assert "ratio" in p.stdout and "projected on 8 cores" in p.stdout
    rows = json.loads((tmp_path / "w.json").read_text())["rows"]
    assert rows["run"]["workers_1_s"] > 0 and rows["run"]["workers_2_s"] > 0


def test_step_costs_script_runs():
    """benchmarks/step_costs.py (the performance page's bound on splitting) at a tiny size: it
    fits the two parts of a step from runs as typed and prints the bound for 2, 4 and 8
    processes (timings here mean nothing)."""
    script = Path(__file__).resolve().parents[1] / "benchmarks" / "step_costs.py"
    p = subprocess.run([sys.executable, str(script), "--seconds", "0.05", "--trials", "1", "2"],
                       capture_output=True, text=True, timeout=600)
    assert p.returncode == 0, p.stderr
    assert "per step:" in p.stdout and "20 trials over 8 processes" in p.stdout


def test_split_phases_script_runs(tmp_path):
    """benchmarks/split_phases.py (the performance page's account of a run's time) at a tiny
    size: its hooks see the run's simulation in both commands and, split, each batch, the
    records coming back and the merge; the phases add up to the whole (timings mean nothing)."""
    script = Path(__file__).resolve().parents[1] / "benchmarks" / "split_phases.py"
    p = subprocess.run([sys.executable, str(script), "--trials", "2", "--seconds", "0.1",
                        "--json", str(tmp_path / "p.json")],
                       capture_output=True, text=True, timeout=600)
    assert p.returncode == 0, p.stderr
    rows = json.loads((tmp_path / "p.json").read_text())
    assert "batches" not in rows["1"] and rows["2"]["batches"] > 0
    for r in rows.values():
        assert abs(r["start"] + r["simulation"] + r["end"] - r["total"]) < 1e-6
        assert r["folder MB"] > 0
    split = rows["2"]
    assert split["batches"] + split["records coming back"] + split["merge"] \
        <= split["simulation"] + 1e-6


@pytest.mark.slow
def test_run_interrupted_stops_every_worker(tmp_path):
    """SIGINT to the command alone while its workers simulate: exit 130, no folder, no
    process left behind."""
    p = subprocess.Popen([sys.executable, "-m", "astrocpg", "run", "--trials", "2", "--seconds",
                          "60", "--out", "out", "--workers", "2"], cwd=tmp_path,
                         stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                         start_new_session=True)
    deadline = time.monotonic() + 120
    while p.poll() is None and time.monotonic() < deadline:  # the bar: the workers started
        time.sleep(0.5)
        if len(subprocess.run(["pgrep", "-g", str(p.pid)], capture_output=True,
                              text=True).stdout.split()) >= 3:  # the command, 2 workers
            break
    time.sleep(3)
    os.kill(p.pid, signal.SIGINT)
    _, err = p.communicate(timeout=120)
    assert p.returncode == 130, err
    assert "interrupted" in err and "Traceback" not in err, err
    assert not (tmp_path / "out").exists()
    assert _gone(p.pid), "a worker outlived the command"


@pytest.mark.slow
def test_a_training_split_over_processes_extends_exactly(tmp_path):
    """Two trials whose sessions end at different steps, one per process: --resume --sessions
    extends each batch as one network extends its trials (no trial ran idle in its batch), and
    ends with the files of a training asked for the longer length from the start."""
    common = ["--trials", "2", *SHORT, "--no-progress"]
    astrocpg("train", *common, "--sessions", "4", "--workers", "1", "--out", "whole",
             cwd=tmp_path)
    astrocpg("train", *common, "--sessions", "2", "--workers", "2", "--out", "grown",
             cwd=tmp_path)
    astrocpg("train", "--resume", "grown", "--sessions", "4", "--workers", "2",
             "--no-progress", cwd=tmp_path)
    for name in ("sessions.csv", "weights.npz", "session_starts.npz"):
        assert (tmp_path / "grown" / name).read_bytes() == \
            (tmp_path / "whole" / name).read_bytes(), name


def test_added_population_workers_identical(tmp_path):
    """A population added with --population is built in every worker (forked from the command
    that added it, or started fresh): the same folders."""
    renshaw = str(Path(__file__).resolve().parent / "data" / "renshaw_population.toml")
    (tmp_path / "run").mkdir()
    a, b = _pair(tmp_path / "run", "run", "--trials", "3", "--seconds", "0.2",
                 "--population", renshaw, "--out", "out")
    assert "spikes.npz" in same_folders(a, b)
    (tmp_path / "train").mkdir()
    a, b = _pair(tmp_path / "train", "train", "--trials", "2", "--sessions", "2", *SHORT,
                 "--population", renshaw, "--out", "out")
    for f in (a, b):
        (f / "checkpoint.npz").unlink()
    assert "sessions.csv" in same_folders(a, b)


def _resolve_in_daemon(queue) -> None:
    from astrocpg.errors import InputError
    from astrocpg.studies.runtime.workers import resolve_workers

    try:
        resolve_workers(2)
        refused = False
    except InputError:
        refused = True
    queue.put((resolve_workers(None), refused))


def test_a_daemonic_process_runs_its_trials_itself():
    """A Dask worker or a pool's worker may start no processes: there the default is 1 (a
    command called inside one runs its trials there) and more is refused, not crashed."""
    import multiprocessing

    ctx = multiprocessing.get_context("fork")
    queue = ctx.Queue()
    p = ctx.Process(target=_resolve_in_daemon, args=(queue,), daemon=True)
    p.start()
    got = queue.get(timeout=60)
    p.join(timeout=60)
    assert got == (1, True)


def test_the_ablations_projection_on_two_cores_is_what_it_measured():
    """benchmarks/study_cores.py on the committed planned ablation: the projection on 2 cores
    is within 10 % of the 1701 s wall the study measured (docs/ablation/planned/README.md),
    and more cores never project a longer wall."""
    import re

    root = Path(__file__).resolve().parents[1]
    p = subprocess.run([sys.executable, str(root / "benchmarks" / "study_cores.py"),
                        str(root / "docs" / "ablation" / "planned")],
                       capture_output=True, text=True, timeout=300, cwd=root)
    assert p.returncode == 0, p.stderr
    walls = {int(n): int(m) * 60 + int(s) for n, m, s in
             re.findall(r"(\d+) core\(s\): (\d+) min (\d+) s wall projected", p.stdout)}
    assert sorted(walls) == [1, 2, 4, 8, 16], p.stdout
    assert abs(walls[2] - 1701) <= 0.1 * 1701, walls
    assert [walls[n] for n in sorted(walls)] == sorted(walls.values(), reverse=True), walls


@pytest.mark.parametrize("workers", ["1", "2"])
def test_a_training_interrupted_after_its_last_session_is_sealed_by_its_resume(tmp_path,
                                                                               workers):
    """Ctrl-C after the last session, before the manifest said finished (the split training's
    parent gathering its workers' last files): the folder holds every session but says
    interrupted, and its line says --resume. The resume trains nothing and seals it (exit 0,
    status finished, the same files); a sealed training is still refused as finished."""
    args = ["train", "--trials", "2", "--sessions", "2", *SHORT, "--out", "out",
            "--no-progress", "--workers", workers]
    astrocpg(*args, cwd=tmp_path)
    out = tmp_path / "out"
    before = {n: (out / n).read_bytes() for n in ("sessions.csv", "weights.npz")}
    manifest = json.loads((out / "manifest.json").read_text())
    manifest["results"] = {**manifest["results"], "status": "interrupted",
                           "error": "interrupted after 4 of 4 sessions"}
    (out / "manifest.json").write_text(json.dumps(manifest))
    astrocpg("train", "--resume", "out", "--no-progress", "--workers", workers, cwd=tmp_path)
    sealed = json.loads((out / "manifest.json").read_text())
    assert sealed["results"]["status"] == "finished", sealed["results"]
    assert {n: (out / n).read_bytes() for n in before} == before
    again = astrocpg("train", "--resume", "out", "--no-progress", cwd=tmp_path, check=False)
    assert again.returncode == 2 and "already finished" in again.stderr, again.stderr


@pytest.mark.slow
def test_a_command_killed_outright_leaves_no_worker(tmp_path):
    """SIGKILL to the command alone (nothing of it runs again: the out-of-memory killer does
    this): its workers notice their parent is gone, stop as a SIGTERM stops them (a training
    writes its checkpoint) and end; none waits for work forever."""
    p = subprocess.Popen([sys.executable, "-m", "astrocpg", "train", "--trials", "2",
                          "--sessions", "200", *SHORT, "--out", "out", "--no-progress",
                          "--workers", "2"], cwd=tmp_path, stdout=subprocess.DEVNULL,
                         stderr=subprocess.DEVNULL, start_new_session=True)
    deadline = time.monotonic() + 300
    while not list((tmp_path / "out").rglob("checkpoint.npz")) and p.poll() is None:
        assert time.monotonic() < deadline
        time.sleep(0.1)
    workers = [int(x) for x in subprocess.run(["pgrep", "-g", str(p.pid)], capture_output=True,
                                              text=True).stdout.split() if int(x) != p.pid]
    assert workers, "the training did not split over processes"
    os.kill(p.pid, signal.SIGKILL)
    p.wait()
    deadline = time.monotonic() + 60  # a step, its checkpoint, then the worker ends
    while any(Path(f"/proc/{w}").exists() for w in workers) and time.monotonic() < deadline:
        time.sleep(0.5)
    left = [w for w in workers if Path(f"/proc/{w}").exists()]
    for w in left:  # not left to the next test
        os.kill(w, signal.SIGKILL)
    assert not left, "a worker outlived its killed command"
