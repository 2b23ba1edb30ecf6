"""Studies on Dask: a real scheduler and two workers on 127.0.0.1 with one killed mid-study,
an interrupted study continued by the same command, the results table and the report."""

from __future__ import annotations

import csv
import json
import os
import signal
import socket
import subprocess
import sys
import time
from pathlib import Path

import pytest

from astrocpg.errors import InputError
from astrocpg.studies.parameter_studies.study import load_study

BIN = Path(sys.executable).parent
ENV = {**os.environ, "PYTHONWARNINGS": "ignore", "DASK_DISTRIBUTED__LOGGING__DISTRIBUTED": "error"}

# four runs of one seed each; sessions last at most 1 s, so each run takes seconds
TINY = """
[study]
name = "tiny"
sessions = {sessions}
seeds = {{ first = 1, count = 2 }}
batch = 1
[base]
L_max = "1*second"
[conditions.astrocytes]
astrocytes = true
[conditions.no_astrocytes]
astrocytes = false
"""


def _tiny(tmp_path: Path, sessions: int) -> Path:
    p = tmp_path / "tiny.toml"
    p.write_text(TINY.format(sessions=sessions))
    return p


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def _wait_for(predicate, timeout: float, what: str, poll: float = 0.2):
    t0 = time.time()
    while time.time() - t0 < timeout:
        value = predicate()
        if value:
            return value
        time.sleep(poll)
    raise AssertionError(f"timed out after {timeout:.0f} s waiting for {what}")


def _status(run: Path) -> dict:
    try:
        return json.loads((run / "status.json").read_text())
    except (OSError, ValueError):
        return {}


def _rows(out: Path) -> list[dict]:
    with open(out / "results.csv", newline="") as f:
        return list(csv.DictReader(f))


def _assert_complete(out: Path, study_file: Path) -> list[dict]:
    study = load_study(study_file)
    rows = _rows(out)
    keys = [(r["run_id"], r["seed"], r["session"]) for r in rows]
    assert len(keys) == len(set(keys)), "a run x session appears twice in results.csv"
    expected = {(run.run_id, str(run.seed + b), str(s)) for run in study.runs
                for b in range(run.n_trials) for s in range(1, study.n_sessions + 1)}
    assert set(keys) == expected
    for run in study.runs:
        assert _status(out / "runs" / run.run_id)["state"] == "finished"
    # every seed's final rhythm and gait (gait.csv of its run), on each of its rows
    gaits = {(r["run_id"], r["seed"], r["final_gait"], r["final_rhythm"]) for r in rows}
    assert len(gaits) == len({(r["run_id"], r["seed"]) for r in rows})
    labels = ("trot", "pace", "bound", "walk", "none")
    assert all(r["final_gait"] in labels and r["final_rhythm"] in labels for r in rows)
    # a gait that is none says why; a run's rhythm phases are read whatever its feet do
    assert all(r["final_gait"] != "none" or r["final_gait_reason"] for r in rows)
    assert all(r["final_rhythm_phase_FL"] != "" for r in rows)
    return rows


def _kill_group(proc: subprocess.Popen, sig: int) -> None:
    try:
        os.killpg(proc.pid, sig)
    except ProcessLookupError:
        pass


@pytest.mark.parametrize("section, words", [
    ('[evaluate]\nworlds = "nope.toml"\n', ["[evaluate] worlds", "nope.toml"]),
    ('[evaluate]\nrepeats = 0\n', ["[evaluate] repeats"]),
    ('[evaluate]\nconditions = ["astro"]\n', ["no condition 'astro'"]),
    ('[evaluate]\nworld = "robustness"\n', ["[evaluate] takes"]),
])
def test_evaluate_section_errors_are_named(tmp_path: Path, section: str, words) -> None:
    p = tmp_path / "s.toml"
    p.write_text(TINY.format(sessions=1) + section)
    from astrocpg.errors import EnvironmentFault

    # a worlds file that does not exist is the environment's (exit 1), a bad value bad input
    with pytest.raises(EnvironmentFault if "nope.toml" in section else InputError) as e:
        load_study(p)
    for w in words:
        assert w in str(e.value)


def test_study_file_errors_name_the_key(tmp_path: Path) -> None:
    p = tmp_path / "bad.toml"
    for text, message in [
        ('[base]\nno_such_parameter = "1*ms"\n', r"\[base\].*no_such_parameter"),
        ('[base]\nL_max = "3*volt"\n', "L_max"),
        ('sesions = 3\n', "unknown key 'sesions'"),
        ('[sweep]\nmode = "zip"\n[sweep.axes]\nL_max = ["1*second", "2*second"]\n'
         'tau_STDP = ["10*ms"]\n', "equal length"),
        ('record = { every = 5, traces = ["astro_K"] }\n', "record.*astro_K"),
    ]:
        head = "[study]\n" + ("" if text.startswith("sesions") else "sessions = 3\n")
        p.write_text(head + text)
        with pytest.raises(InputError, match=message):
            load_study(p)
    p.write_text('[study]\nsessions = 3\nrecord = { every = 5, traces = ["astrocyte_Ca"], '
                 'stride = 10 }\n')
    (run,) = load_study(p).runs
    assert run.record_plan().traces == ("astrocyte_Ca",) and run.record_plan().stride == 10


def test_sweep_grid_and_seed_batches(tmp_path: Path) -> None:
    p = tmp_path / "s.toml"
    p.write_text('[study]\nsessions = 2\nseeds = [1, 2, 3, 7]\nbatch = 2\n'
                 '[sweep.axes]\nL_max = ["1*second", "2*second"]\n'
                 '[conditions.a]\nastrocytes = true\n[conditions.b]\nastrocytes = false\n'
                 '[conditions.b.set]\nL_non_alive = "0.5*second"\n')
    study = load_study(p)
    # 2 conditions x 2 sweep points x seed runs [1-2], [3], [7]
    assert len(study.runs) == 12
    assert {(r.seed, r.n_trials) for r in study.runs} == {(1, 2), (3, 1), (7, 1)}
    b = [r for r in study.runs if r.condition == "b"][0]
    assert not b.astrocytes and "L_non_alive=0.5*second" in b.overrides
    assert len({r.run_id for r in study.runs}) == 12
    for name in ("quick", "ablation"):
        built_in = load_study(Path(__file__).resolve().parents[1] / "studies" / "parameter_studies"
                              / f"{name}.toml")
        assert {r.condition for r in built_in.runs} == {"astrocytes", "no_astrocytes"}
        # a built-in study by its name (resolved: the package may be imported via a symlink)
        assert load_study(name).path.resolve() == built_in.path
    ablation = load_study(Path(__file__).resolve().parents[1] / "studies" / "parameter_studies" / "ablation.toml")
    assert ablation.n_sessions == 400 and len(ablation.seeds) == 20


@pytest.mark.slow
def test_scheduler_and_two_workers_one_killed(tmp_path: Path) -> None:
    """A real `dask scheduler` and two `dask worker`s; one worker is killed while it trains a
    run; the study completes and every run is present once, the killed one resumed from its
    checkpoint on the other worker."""
    study_file = _tiny(tmp_path, sessions=8)
    out = tmp_path / "out"
    port = _free_port()
    address = f"tcp://127.0.0.1:{port}"
    procs: list[subprocess.Popen] = []

    def start(args: list[str], log: str) -> subprocess.Popen:
        p = subprocess.Popen(args, stdout=open(tmp_path / log, "w"), stderr=subprocess.STDOUT,
                             env=ENV, start_new_session=True, cwd=tmp_path)
        procs.append(p)
        return p

    try:
        start([str(BIN / "dask"), "scheduler", "--host", "127.0.0.1", "--port", str(port),
               "--no-dashboard"], "scheduler.log")
        workers = [start([str(BIN / "dask"), "worker", address, "--nthreads", "1", "--no-nanny",
                          "--no-dashboard", "--name", f"w{k}"], f"worker{k}.log")
                   for k in range(2)]
        study = start([str(BIN / "astrocpg"), "study", str(study_file), "--out", str(out),
                       "--scheduler", address, "--no-progress"], "study.log")
        pids = {w.pid: w for w in workers}

        def in_flight():
            # a run on one of our workers that has checkpointed at least one session
            for run in (out / "runs").glob("*"):
                s = _status(run)
                if s.get("state") == "running" and s.get("pid") in pids \
                        and (run / "checkpoint.npz").exists():
                    return run, s
            return None

        run, s = _wait_for(in_flight, 240, "a run in flight with a checkpoint")
        victim = pids[s["pid"]]
        _kill_group(victim, signal.SIGKILL)
        victim.wait(10)
        assert study.wait(400) == 0, (tmp_path / "study.log").read_text()[-3000:]
    finally:
        for p in procs:
            _kill_group(p, signal.SIGKILL)
            p.wait(10)
    _assert_complete(out, study_file)
    resumed = _status(run)
    assert resumed["attempts"] == 2
    assert resumed["sessions_at_start"] >= 1  # continued from its checkpoint, not from scratch
    survivor = next(p for p in workers if p is not victim)
    assert resumed["pid"] == survivor.pid


@pytest.mark.slow
@pytest.mark.parametrize("sig", [signal.SIGINT, signal.SIGKILL], ids=["ctrl-c", "crash"])
def test_interrupted_study_continues(tmp_path: Path, sig: int) -> None:
    """Interrupt a study (Ctrl-C, or SIGKILL of the whole process group), run the same command
    again: finished runs are not redone, the run in flight resumes, the table is complete."""
    # 30 sessions: a run must outlast the few seconds the cluster takes to close, or the
    # run in flight may end before it is stopped and nothing is left to resume
    study_file = _tiny(tmp_path, sessions=30)
    out = tmp_path / "out"
    cmd = [str(BIN / "astrocpg"), "study", str(study_file), "--out", str(out), "--workers", "1",
           "--no-progress"]
    first = subprocess.Popen(cmd, stdout=open(tmp_path / "first.log", "w"),
                             stderr=subprocess.STDOUT, env=ENV, start_new_session=True)
    try:
        def one_finished_one_running():
            runs = list((out / "runs").glob("*"))
            states = [_status(r).get("state") for r in runs]
            running = [r for r in runs if _status(r).get("state") == "running"
                       and (r / "checkpoint.npz").exists()]
            return states.count("finished") >= 1 and running

        _wait_for(one_finished_one_running, 240, "one run finished and one in flight")
        _kill_group(first, sig)
        rc = first.wait(60)
    finally:
        _kill_group(first, signal.SIGKILL)
        first.wait(10)
    assert rc != 0
    before = {r.name: ((r / "sessions.csv").stat().st_mtime_ns, _status(r))
              for r in (out / "runs").glob("*") if _status(r).get("state") == "finished"}
    assert before
    second = subprocess.run(cmd, capture_output=True, text=True, env=ENV, timeout=400)
    assert second.returncode == 0, second.stdout[-2000:] + second.stderr[-2000:]
    _assert_complete(out, study_file)
    for name, (mtime, status) in before.items():
        run = out / "runs" / name
        assert (run / "sessions.csv").stat().st_mtime_ns == mtime, f"{name} was redone"
        assert _status(run)["attempts"] == status["attempts"] == 1
    assert any(_status(r)["attempts"] == 2 and _status(r)["sessions_at_start"] >= 1
               for r in (out / "runs").glob("*")), "no run resumed from its checkpoint"


@pytest.mark.slow
def test_report_and_refusals(tmp_path: Path) -> None:
    study_file = _tiny(tmp_path, sessions=2)
    out = tmp_path / "out"
    from astrocpg.studies.cli import main

    assert main(["study", str(study_file), "--out", str(out), "--workers", "1",
                 "--no-progress"]) == 0
    rows = _assert_complete(out, study_file)
    assert {r["condition"] for r in rows} == {"astrocytes", "no_astrocytes"}
    assert main(["report", str(out)]) == 0
    for name in ("fig3c.png", "final_figures.csv", "report.md"):
        assert (out / "report" / name).stat().st_size > 0
    text = (out / "report" / "report.md").read_text()
    assert "| astrocytes | 2 | 2/2 | 2 |" in text and "| no_astrocytes | 2 | 2/2 | 2 |" in text
    # a rerun does nothing and keeps the table
    mtime = (out / "runs" / "astrocytes__seed1" / "sessions.csv").stat().st_mtime_ns
    assert main(["study", str(study_file), "--out", str(out), "--no-progress"]) == 0
    assert (out / "runs" / "astrocytes__seed1" / "sessions.csv").stat().st_mtime_ns == mtime
    assert len(_rows(out)) == len(rows)
    # an [evaluate] step: the study's controllers in two worlds once the runs are done
    worlds = tmp_path / "w.toml"
    worlds.write_text('[worlds.flat]\n[worlds.uphill]\nslope = "0.1"\n')
    study_file.write_text(TINY.format(sessions=2) + '[evaluate]\nworlds = "w.toml"\n'
                          'seconds = 0.3\nrepeats = 1\nconditions = ["astrocytes"]\n')
    assert main(["study", str(study_file), "--out", str(out), "--no-progress"]) == 0
    evaluated = list(csv.DictReader(open(out / "evaluation" / "evaluation.csv")))
    assert {(r["condition"], r["seed"], r["world"]) for r in evaluated} == {
        ("astrocytes", s, w) for s in ("1", "2") for w in ("flat", "uphill")}
    # the same folder with other settings for an existing run is refused
    study_file.write_text(TINY.format(sessions=3))
    assert main(["study", str(study_file), "--out", str(out), "--no-progress"]) == 2
    assert main(["report", str(tmp_path)]) == 2


@pytest.mark.slow
def test_power_counts_come_from_the_network(tmp_path: Path) -> None:
    """Events per spike are counted on the built network; the estimate follows the paper's
    formula with the measured rates; the RL figure is the paper's."""
    from astrocpg.network import INTERNEURONS, LEGS, build_cpg
    from astrocpg.studies.cli import main
    from astrocpg.studies.commands.power import synaptic_events_per_spike

    cpg = build_cpg(n_trials=2, seed=3)
    ops = synaptic_events_per_spike(cpg)
    n = cpg.layout.pool_size
    drives = {}  # interneurons driven by each pool
    for _, _, source, _ in INTERNEURONS:
        drives[source] = drives.get(source, 0) + 1
    other_thigh_pools = (len(LEGS) - 1) * 2
    assert ops["thigh"] == (n - 1) + drives["thigh_flexor"] + other_thigh_pools * n == 141
    assert ops["calf"] == (n - 1) + drives["calf_flexor"] == 20
    assert ops["inhibitory"] == n and ops["limit"] == n

    out = tmp_path / "train"
    assert main(["train", "--sessions", "1", "--set", "L_max=0.5*second", "--out", str(out),
                 "--no-progress"]) == 0
    assert main(["power", str(out), "--sessions", "2", "--no-progress"]) == 0
    res = json.loads((out / "power_trial0.json").read_text())
    assert len(res["sessions"]) == 2
    f, o = res["total_rate_Hz"], res["ops_per_spike"]
    assert res["snn_W"] == pytest.approx(0.9e-12 * sum(o[k] * f[k] for k in o))
    assert res["rl_W"] == pytest.approx(100 * (42 * 128 + 128 * 128 + 128 * 12) * 4.6e-12)
    assert res["ratio"] == pytest.approx(res["rl_W"] / res["snn_W"])
    # the rhythm makes every population fire
    assert all(v > 0 for v in f.values())
    assert main(["power", str(out), "--trial", "3", "--no-progress"]) == 2


def _snapshot(folder: Path) -> dict[str, bytes]:
    return {str(p.relative_to(folder)): p.read_bytes() for p in sorted(folder.rglob("*"))
            if p.is_file()} if folder.exists() else {}


@pytest.mark.parametrize("case", ["malformed_toml", "unknown_parameter", "unknown_axis",
                                  "unit_mismatch", "unreachable_scheduler", "other_study",
                                  "training_folder"])
def test_bad_input_one_line_exit_2_nothing_written(tmp_path: Path, case: str, capsys) -> None:
    """Each mistake: one line on stderr naming it, exit code 2, the folder untouched."""
    from astrocpg.studies.cli import main

    study = tmp_path / "s.toml"
    good = TINY.format(sessions=1)
    out = tmp_path / "out"
    extra: list[str] = ["--workers", "1"]
    expect = ""
    if case == "malformed_toml":
        study.write_text(good.replace("[study]", "[study"))
        expect = "not valid TOML"
    elif case == "unknown_parameter":
        study.write_text(good.replace('L_max = "1*second"', 'L_maximum = "1*second"'))
        expect = "L_maximum"
    elif case == "unknown_axis":
        study.write_text(good + '[sweep.axes]\ntau_nothing = ["1*ms", "2*ms"]\n')
        expect = "tau_nothing"
    elif case == "unit_mismatch":
        study.write_text(good + '[sweep.axes]\ntau_STDP = ["10*ms", "3*mV"]\n')
        expect = "tau_STDP"
    elif case == "unreachable_scheduler":
        study.write_text(good)
        extra = ["--scheduler", f"tcp://127.0.0.1:{_free_port()}"]
        expect = "cannot connect"
    elif case == "other_study":
        study.write_text(good)
        other = tmp_path / "other.toml"
        other.write_text(good.replace('name = "tiny"', 'name = "other"'))
        out.mkdir()
        (out / "study.json").write_text(json.dumps({"name": "other", "runs": {}}))
        (out / "results.csv").write_text("run_id\n")
        expect = "belongs to study 'other'"
    elif case == "training_folder":
        study.write_text(good)
        out.mkdir()
        (out / "sessions.csv").write_text("trial,session\n0,1\n")
        expect = "holds no study"
    before = _snapshot(out)
    capsys.readouterr()
    rc = main(["study", str(study), "--out", str(out), "--no-progress", *extra])
    err = capsys.readouterr().err
    assert rc == 2
    lines = [line for line in err.splitlines() if line.strip()]
    assert len(lines) == 1 and lines[0].startswith("astrocpg: error:") and expect in lines[0], err
    assert _snapshot(out) == before


def test_trailing_mean_of_the_report() -> None:
    import numpy as np

    from astrocpg.studies.analysis.final_figures import moving_mean
    t = np.array([[1.0, 2.0, 3.0, 4.0, np.nan], [2.0, 2.0, 2.0, 2.0, 2.0]])
    out = moving_mean(t, 2)
    np.testing.assert_allclose(out[0, :4], [1.0, 1.5, 2.5, 3.5])
    assert np.isnan(out[0, 4])  # a seed without that session stays missing
    np.testing.assert_allclose(out[1], 2.0)


# six runs of unequal length: 3, 1 and 2 seeds per run, sessions of at most 1 s or 0.5 s
UNEQUAL = """
[study]
name = "unequal"
sessions = 2
seeds = [1, 2, 3, 10, 20, 21]
batch = 3
[base]
L_max = "1*second"
[conditions.long]
astrocytes = true
[conditions.short]
astrocytes = false
set = { L_max = "0.5*second" }
"""


def test_runs_are_ordered_longest_first_and_idle_is_measured(tmp_path: Path) -> None:
    """The cost estimate ranks runs by trials, sessions and session length; `utilisation`
    finds a worker left free while a run waited (synthetic timeline, no cluster)."""
    from astrocpg.studies.parameter_studies.tables import utilisation

    p = tmp_path / "unequal.toml"
    p.write_text(UNEQUAL)
    study = load_study(p)
    cost = {(r.condition, r.n_trials): r.estimated_seconds() for r in study.runs}
    assert len(study.runs) == 6 and {r.session_s for r in study.runs} == {1.0, 0.5}
    assert cost[("long", 3)] > cost[("long", 2)] > cost[("long", 1)]
    assert cost[("long", 3)] > cost[("short", 3)]  # same trials, shorter sessions

    def row(worker, a, b):
        return {"worker": worker, "host": "h", "pid": 1, "started": 100.0 + a,
                "ended": None if b is None else 100.0 + b}

    # back to back on two workers: nobody idle while runs wait
    busy = [row("A", 0, 10), row("B", 0.5, 4), row("B", 4.2, 12), row("A", 10.3, 15)]
    u = utilisation(busy, 2)
    assert u["longest_idle_pending_s"] == pytest.approx(0.5)
    assert u["idle_pending_s"] == pytest.approx(0.5 + 0.2 + 0.3)
    assert u["wall_s"] == pytest.approx(15)
    assert u["utilisation"] == pytest.approx((10 + 3.5 + 7.8 + 4.7) / 30)
    # each worker's share of the wall it ran nothing (waiting, or done before the end)
    assert u["worker_busy_s"] == pytest.approx({"A": 14.7, "B": 11.3})
    assert u["worker_idle_share"] == pytest.approx({"A": 0.3 / 15, "B": 3.7 / 15})
    # B free from 4 to 9 while the last run waited; a third worker that ran nothing counts
    # as free from the first start to the last
    idle = [row("A", 0, 10), row("B", 0, 4), row("B", 9, 12), row("A", 10, None)]
    u = utilisation(idle, 3)
    assert u["longest_idle_pending_s"] == pytest.approx(10)
    assert u["idle_pending_s"] == pytest.approx(5 + 10)
    assert u["worker_gaps"][next(w for w in u["worker_gaps"] if w != "A" and w != "B")] \
        == [(0.0, 10.0)]


@pytest.mark.slow
def test_no_worker_idles_while_runs_wait(tmp_path: Path) -> None:
    """Six runs of unequal length on two workers: from the recorded timeline, every worker
    ran its runs back to back and was never free while a run waited (beyond the hand-over
    from one run to the next), and runs started longest first."""
    from astrocpg.studies.parameter_studies.study import run_study
    from astrocpg.studies.parameter_studies.tables import utilisation

    p = tmp_path / "unequal.toml"
    # twelve sessions: every run lasts well beyond the hand-over slack below, also on a fast
    # machine (with six, the shortest run took 2.9 s on the CI machine, below the slack)
    p.write_text(UNEQUAL.replace("sessions = 2\n", "sessions = 12\n"))
    study = load_study(p)
    assert {r.n_sessions for r in study.runs} == {12}
    out = tmp_path / "out"
    res = run_study(study, out, workers=2, progress=False)
    assert res["failed"] == []
    with open(out / "timeline.csv", newline="") as f:
        rows = list(csv.DictReader(f))
    assert len(rows) == 6 and {r["run_id"] for r in rows} == {r.run_id for r in study.runs}
    manifest = json.loads((out / "manifest.json").read_text())
    assert "timeline.csv" in manifest["files"] and "timeline.csv" in manifest["inventory"]
    runs = []
    for r in rows:
        assert r["state"] == "finished" and r["attempt"] == "1" and r["worker"] and r["pid"]
        started, ended = float(r["started"]), float(r["ended"])
        assert float(r["duration_s"]) == pytest.approx(ended - started, abs=2e-3)
        runs.append({**r, "started": started, "ended": ended})
    assert len({r["worker"] for r in runs}) == 2
    # the hand-over: the run's manifest, its result to the scheduler and the client, the next
    # run to the worker; generous for a loaded two-core machine, far below any run's length
    slack = 3.0
    assert min(r["ended"] - r["started"] for r in runs) > slack
    u = utilisation(runs, 2)
    assert u["longest_idle_pending_s"] <= slack, u["worker_gaps"]
    # longest first: a run estimated longer than another did not start after it
    cost = {r.run_id: r.estimated_seconds() for r in study.runs}
    for a in runs:
        for b in runs:
            if cost[a["run_id"]] > cost[b["run_id"]]:
                assert a["started"] <= b["started"] + slack, (a["run_id"], b["run_id"])
