"""benchmarks/speed.py's measurement: the loop's stretches and MuJoCo's timings interleave in
one run, and the timing itself is left out of the loop's figure."""

from __future__ import annotations

import importlib.util
from pathlib import Path

import numpy as np
import pytest

ROOT = Path(__file__).resolve().parents[1]


def benchmark(name: str):
    """The script ``benchmarks/<name>.py`` as a module (its folder on the path while it loads:
    the scripts import one another)."""
    import sys

    sys.path.insert(0, str(ROOT / "benchmarks"))
    try:
        spec = importlib.util.spec_from_file_location(name, ROOT / "benchmarks" / f"{name}.py")
        module = importlib.util.module_from_spec(spec)
        spec.loader.exec_module(module)
    finally:
        sys.path.remove(str(ROOT / "benchmarks"))
    return module


@pytest.fixture(scope="module")
def speed():
    return benchmark("speed")


def test_speed_interleaves_mujoco_timings_with_the_loop(speed):
    from astrocpg.coupling.assembly import build_closed_loop
    from astrocpg.models import DEFAULT_MODELS

    loop = build_closed_loop(DEFAULT_MODELS, n_trials=2, seed=1)
    timer = speed.Interleaved(loop.bridge, every=50, mj_steps=200)
    loop.bridge.add_hook("after_physics", "benchmark", timer, order=1e9)
    loop.run(0.3)
    # marks at steps 50, 100, ..., 300: five stretches of 50 steps between six marks
    assert timer.marks == 6 and timer.loop_steps == 250 and len(timer.loop_chunks) == 5
    # each mark: 200 steps with held controls, and both trials' states stepped 100 times
    assert timer.replays == 100 and timer.mj_total == 6 * (200 + 100 * 2)
    assert len(timer.mj_chunks) == len(timer.held_chunks) == 6
    assert all(c > 0 for c in timer.loop_chunks + timer.mj_chunks + timer.held_chunks)
    assert len(timer.loop_work) == 6 * 2 and len(timer.held_work) == 6
    # MuJoCo timed on a scratch copy: the trials' robots are where the loop left them, and the
    # replayed states are theirs at the last mark (the end of the run)
    assert loop.bridge.data[0].time == pytest.approx(0.3)
    import mujoco

    for row, d in zip(timer.rows, loop.bridge.data):
        here = np.empty_like(row)
        mujoco.mj_getState(loop.bridge.model, d, here, timer.spec)
        assert np.array_equal(row, here)


@pytest.mark.parametrize("runner", ["lean", "brian2"])
def test_measure_gives_the_ratio_of_the_two_medians(speed, runner):
    r = speed.measure(2, 0.3, False, codegen="numpy", mj_seconds=0.05, every=50, runner=runner)
    assert r["trials"] == 2 and r["mj_step_us"] > 0 and r["runner"] == runner
    assert r["x_mj_step"] == pytest.approx(r["trial_step_us"] / r["mj_step_us"])
    assert r["x_mj_step_held"] == pytest.approx(r["trial_step_us"] / r["mj_step_held_us"])
    assert r["iterations_loop"] >= 1 and r["constraints_loop"] >= 0
    assert r["cpu_per_sim_s"] == pytest.approx(r["trial_step_us"] * 2 / 1e3)


def test_the_authors_time_counts_their_loop_only(speed, tmp_path):
    """Two durations: the slope leaves out a start-up that costs the same in both runs (here
    0.3 CPU s of 'imports' before a loop of 0.1 CPU s per simulated second)."""
    import sys

    script = tmp_path / "their_main.py"
    script.write_text(
        "import sys, time\n"
        "def spin(s):\n"
        "    end = time.process_time() + s\n"
        "    while time.process_time() < end:\n"
        "        pass\n"
        "spin(0.3)\n"
        "spin(0.1 * float(sys.argv[1]))\n")
    command = f"{sys.executable} {script} {{seconds}}"
    loop_only = speed.authors_speed(command, [1.0, 4.0])
    with_start = speed.authors_speed(command.replace("{seconds}", "1"), 1.0)
    assert loop_only == pytest.approx(0.1, abs=0.04)
    assert with_start > loop_only + 0.2
    with pytest.raises(SystemExit, match="seconds"):
        speed.authors_speed(f"{sys.executable} {script} 1", [1.0, 2.0])


def test_profile_step_times_a_steps_python_and_puts_everything_back():
    """profile_step.py --dispatch: the Python of a step, with every compiled block and the
    physics as no-ops, for both runners; the run afterwards is the same as without it."""
    from astrocpg.coupling.assembly import build_closed_loop
    from astrocpg.models import DEFAULT_MODELS

    profile_step = benchmark("profile_step")
    loop = build_closed_loop(DEFAULT_MODELS, n_trials=2, seed=1)
    loop.run(0.02)
    robots = loop.bridge.robots
    physics = robots._compiled
    python = profile_step._python_alone(loop, 0.02, 1)
    assert set(python) == {"brian2", "lean"} and all(v > 0 for v in python.values())
    assert robots._compiled is physics and "before_run" not in vars(loop.cpg.net)
    # the no-ops are gone: the next run moves the network and the robots again
    v, qpos = loop.cpg.array("motor", "v").copy(), loop.bridge.qpos.copy()
    loop.run(0.02)
    assert not np.array_equal(v, loop.cpg.array("motor", "v"))
    assert not np.array_equal(qpos, loop.bridge.qpos)


def test_recording_breakdown_times_each_recorder_and_puts_them_back(tmp_path):
    """recording_breakdown.measure: the recorded run's in-loop parts and phases are timed, the
    unrecorded run has no recorder's time, and the wrapped functions are the originals after."""
    from astrocpg.coupling.bridge import Bridge
    from astrocpg.network import recording

    rb = benchmark("recording_breakdown")
    before = recording.TraceRecorder.sample, Bridge._record
    got = rb.measure(0.2, 2, True, tmp_path / "rec")
    assert {"TraceRecorder.sample", "Bridge._record", "SpikeRecorder.resize", "_run",
            "write_run_folder"} <= set(got) and all(v >= 0 for v in got.values())
    assert got["_run"] > 0
    off = rb.measure(0.2, 2, False, tmp_path / "off")
    assert "TraceRecorder.sample" not in off and "SpikeRecorder.resize" not in off
    assert (recording.TraceRecorder.sample, Bridge._record) == before


def test_between_commits_reads_the_last_table_of_speed():
    """between_commits.py takes the ratio to mj_step from speed.py's closing table, not from
    the per-repeat table above it, and stops when a target's row is missing."""
    spec = importlib.util.spec_from_file_location(
        "between_commits", ROOT / "benchmarks" / "between_commits.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    out = "\n".join([
        "numpy 20 trials                          1.416          0.07         1.450         70.82",
        "point                            trial-step us    mj_step us     x mj_step        goal x",
        "cython 20 trials                          50.4          20.3          2.49           1.5",
        "numpy 20 trials                           70.8          17.2          4.12           2.5",
    ])
    assert module.ratios(out, ["cython", "numpy"]) == {"cython": 2.49, "numpy": 4.12}
    with pytest.raises(SystemExit):
        module.ratios(out.replace("cython", "other"), ["cython"])
    # the closing table says how mj_step was timed: an x held column beside, the loop's states
    assert module.denominator(out) == "held controls"
    assert module.denominator(out.replace("goal x", "goal x        x held")) == "the loop's states"


@pytest.mark.slow
def test_between_commits_runs_as_the_benchmarks_record_shows(tmp_path):
    """The command of benchmarks/README.md ("Did a change slow the loop?"), shortened: HEAD
    against this checkout (a worktree made and removed), one repeat, numpy; its JSON names
    both commits and both figures."""
    import json
    import subprocess
    import sys

    if not (ROOT / ".git").exists():
        pytest.skip("not a git checkout")
    out = tmp_path / "b.json"
    done = subprocess.run([sys.executable, str(ROOT / "benchmarks" / "between_commits.py"),
                           "HEAD", "--repeats", "1", "--seconds", "0.2", "--codegen", "numpy",
                           "--json", str(out)], capture_output=True, text=True, timeout=900)
    assert done.returncode == 0, done.stderr[-2000:]
    result = json.loads(out.read_text())
    numpy_ = result["results"]["numpy"]
    assert len(numpy_["before"]) == len(numpy_["after"]) == 1
    assert numpy_["before"][0] > 1 and numpy_["after"][0] > 1  # a trial-step costs > mj_step
    listed = subprocess.run(["git", "-C", str(ROOT), "worktree", "list"], capture_output=True,
                            text=True).stdout
    assert "between_commits_" not in listed  # its worktree is removed


@pytest.mark.slow
def test_dask_overhead_prints_both_settings_with_the_lean_workers_cheaper(tmp_path):
    """The benchmark behind the Dask figures of benchmarks/README.md, shortened: one worker, one
    repeat. Dask's profiler alone costs a worker a few percent of a core, so the lean
    settings must show less of Dask in the worker."""
    import subprocess
    import sys

    out = subprocess.run([sys.executable, str(ROOT / "benchmarks" / "dask_overhead.py"),
                          "--workers", "1", "--seconds", "1", "--repeats", "1",
                          "--codegen", "numpy"],
                         capture_output=True, text=True, timeout=600, cwd=tmp_path)
    assert out.returncode == 0, out.stderr[-2000:]
    rows = {line.split("  ")[0]: line.split() for line in out.stdout.splitlines()
            if line.startswith(("Dask's defaults", "astrocpg's"))}
    assert set(rows) == {"Dask's defaults", "astrocpg's (LEAN_DASK)"}

    def share(row: list[str], k: int) -> float:
        return float([x for x in row if x.endswith("%")][k].rstrip("%"))

    assert share(rows["astrocpg's (LEAN_DASK)"], 0) < share(rows["Dask's defaults"], 0)


def test_command_cost_reads_trained_and_stepped_trial_seconds(tmp_path):
    """benchmarks/command_cost.py: a training's trained trial-seconds are the sum of its
    sessions' lengths; its stepped ones the longest trial's sum times the trials (the batch
    steps until its last trial is done), per run of a study's rows."""
    module = benchmark("command_cost")
    sessions = tmp_path / "sessions.csv"
    sessions.write_text("trial,session,length_s\n0,1,1.5\n1,1,4.0\n0,2,2.0\n1,2,0.5\n")
    assert module.simulated_trial_seconds(sessions) == pytest.approx((8.0, 9.0))
    rows = tmp_path / "results.csv"
    rows.write_text("run_id,trial,session,length_s\na,0,1,1.0\na,1,1,3.0\nb,0,1,2.0\n")
    # run a: 1 + 3 trained, its batch stepped 3 s x 2 trials; run b: 2 and 2 x 1
    assert module.simulated_trial_seconds(rows) == pytest.approx((6.0, 8.0))


def test_command_cost_takes_each_ratio_within_a_pass():
    """A repeat's ratio is the median of its passes' ratios, each taken between the commands
    of one pass: a pass run wholly in a slow spell (every command 10 % dearer) gives the same
    ratio, where keeping each command's least CPU over the passes would mix spells."""
    module = benchmark("command_cost")

    def points(slow: float) -> dict:
        # run: 1 s + 25 ms per trial-second; train: 2 s + 30 ms per stepped trial-second
        return {"run": {3.0: (slow * (1 + 0.025 * 60), 60, 60),
                        24.0: (slow * (1 + 0.025 * 480), 480, 480)},
                "train": {2.0: (slow * (2 + 0.030 * 400), 200, 400),
                          10.0: (slow * (2 + 0.030 * 1600), 1000, 1600)}}

    passes = [module._figures(points(s)) for s in (1.0, 1.1, 1.0)]
    assert [p["stepped_ratio_to_run"]["train"] for p in passes] == pytest.approx([1.2] * 3)
    row = module._repeat(passes)
    assert row["stepped_ratio_to_run"]["train"] == pytest.approx(1.2)
    assert row["ms_per_trial_s"]["run"] == pytest.approx(25.0)
    assert len(row["passes"]) == 3


def test_command_cost_passes_reads_the_committed_tables_as_the_page_says():
    """``command_cost.py --passes`` over the two committed tables of 10:45 and 11:20: 18
    passes, one pass's ratio varying by 4 % (train) and 8 % (study) of its mean, as the
    measurement record (benchmarks/README.md) says; the 3 s and 24 s runs' CPU ranges that
    goals.py's docstring cites."""
    import json

    module = benchmark("command_cost")
    docs = [json.loads((ROOT / "docs" / "benchmarks" / f"goals_{t}.json").read_text())
            for t in ("1045", "1120")]
    both = module.pass_statistics(docs)
    assert both["passes"] == 18
    assert round(100 * both["ratios"]["train"]["relative_sd"]) == 4
    assert round(100 * both["ratios"]["study"]["relative_sd"]) == 8
    ranges = [module.pass_statistics([d])["cpu_s"]["run"] for d in docs]
    assert [round(r["3"][1] - r["3"][0], 2) for r in ranges] == [0.24, 0.60]
    assert [round(r["24"][1] - r["24"][0], 2) for r in ranges] == [0.75, 1.81]
    with pytest.raises(SystemExit, match="no passes"):
        module.pass_statistics([{"repeats": []}])


def test_command_cost_runs_run_between_the_commands_it_divides():
    """Within a pass ``run`` runs in the middle of the kinds, so that each ratio's two sides
    run next to each other (``train``, ``run``, ``study``); the pass-to-pass spread its
    docstring gives for the old order (``run`` first) is that of the three tables of
    2026-12-05."""
    import json

    module = benchmark("command_cost")
    assert module.pass_order(["run", "train", "study"]) == ["train", "run", "study"]
    assert module.pass_order(["run", "train"]) == ["run", "train"]
    assert module.pass_order(["run", "recorded", "train", "study"]) == [
        "recorded", "run", "train", "study"]
    docs = [json.loads((ROOT / "docs" / "benchmarks" / f"goals_{t}.json").read_text())
            for t in ("1045", "1120", "1200")]
    assert all(d["commands"]["argv"][d["commands"]["argv"].index("--kinds") + 1:][:3]
               == ["run", "train", "study"] for d in docs)  # run first, study two after
    three = module.pass_statistics(docs)
    assert three["passes"] == 27
    assert round(100 * three["ratios"]["train"]["relative_sd"]) == 6
    assert round(100 * three["ratios"]["study"]["relative_sd"]) == 9


@pytest.mark.slow
def test_command_cost_runs_its_passes_as_typed(tmp_path):
    """command_cost.py as typed, shortened (2 trials, run and train, two passes of one
    repeat): the JSON keeps both passes and the repeat's ratio is their median."""
    import json
    import statistics
    import subprocess
    import sys

    out = tmp_path / "cc.json"
    done = subprocess.run([sys.executable, str(ROOT / "benchmarks" / "command_cost.py"),
                           "--trials", "2", "--repeats", "1", "--runs", "2", "--run-seconds",
                           "0.5", "3", "--sessions", "1", "2", "--kinds", "run", "train",
                           "--json", str(out)], capture_output=True, text=True, timeout=900)
    assert done.returncode == 0, done.stderr[-2000:]
    repeat = json.loads(out.read_text())["repeats"][0]
    assert len(repeat["passes"]) == 2
    module = benchmark("command_cost")
    per_pass = [module._figures({k: {float(size): (v["cpu_s"], v["trial_s"],
                                                   v["stepped_trial_s"])
                                     for size, v in sizes.items()}
                                 for k, sizes in p.items()})["stepped_ratio_to_run"]["train"]
                for p in repeat["passes"]]
    # the JSON's CPU seconds are rounded to the millisecond: the ratio up to that
    assert repeat["stepped_ratio_to_run"]["train"] == pytest.approx(
        statistics.median(per_pass), rel=0.02)


def _committed_utilisation(name: str) -> tuple[Path, dict]:
    """``benchmarks/study_utilisation.py --folder docs/ablation/NAME`` prints the committed
    utilisation.txt (a stale file, or a changed reading, fails); the folder and its
    workers' utilisation."""
    import subprocess
    import sys

    from astrocpg.studies.parameter_studies.tables import utilisation

    folder = ROOT / "docs" / "ablation" / name
    done = subprocess.run([sys.executable, "benchmarks/study_utilisation.py", "--folder",
                           f"docs/ablation/{name}"], cwd=ROOT, capture_output=True, text=True,
                          timeout=120)
    assert done.returncode == 0, done.stderr
    assert done.stdout == (folder / "utilisation.txt").read_text()
    return folder, utilisation(benchmark("study_utilisation").read_timeline(folder))


def test_the_ablation_planned_from_its_runs_reads_as_its_page_says() -> None:
    """The ablation planned from the planned one's runs (docs/ablation/fitted): idle 2.2 % and
    0 %, the plan made with the cost fitted to that folder's timeline."""
    import json

    folder, u = _committed_utilisation("fitted")
    assert sorted(round(100 * s, 1) for s in u["worker_idle_share"].values()) == [0.0, 2.2]
    assert max(u["worker_idle_share"].values()) <= 0.05
    choice = json.loads((folder / "study.json").read_text())["batch_choice"]
    assert choice["cost"]["source"] == "timeline" and choice["split"] == {"astrocytes": 18}
    assert "idle for the last 37 s (2.2 % of that wall)" in (folder / "README.md").read_text()


def test_the_committed_ablation_timeline_reads_as_its_page_says() -> None:
    """The committed planned ablation (docs/ablation/planned) reads as its page says: idle
    0 % and 6.5 % of the wall."""
    folder, u = _committed_utilisation("planned")
    assert sorted(round(100 * s, 1) for s in u["worker_idle_share"].values()) == [0.0, 6.5]
    assert u["wall_s"] == pytest.approx(1694.1, abs=0.1)
    assert "idle for the last 111 s (6.5 % of that wall)" in (folder / "README.md").read_text()
