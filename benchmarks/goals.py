"""The three speed goals side by side, in one run, each from its own benchmark run as a user
would type it, every figure with its repeats and their spread:

    python benchmarks/goals.py [--repeats 3] [--recorded-seconds 3 24] [--runs 3] [--passes 5]
                               [--seconds 12]
                               [--command-seconds 3 48] [--command-sessions 2 10]
                               [--json docs/benchmarks/goals.json]
                               [--markdown docs/benchmarks/goals.md]

- **Recorded run** (``recorded_run_cost.py``): ``astrocpg run --trials 20 --codegen cython``
  with its default recording against the same command recording nothing, CPU of the command as
  typed (writes included), slope between ``--recorded-seconds`` runs (3 s and 24 s). Goal: at most 1.25 x.
- **Training step** (``training_cost.py``): a training step against a fixed-weight step of the
  same 20-trial batch, in one process, interleaved. Goal: at most 1.15 x.
- **Trial-step** (``speed.py --trials 20``): a trial-step of the closed loop against MuJoCo's
  own step of the same states (every trial's state as the loop left it, stepped alone), Cython
  and numpy. Goals: at most 2.0 x on Cython, 3.5 x on numpy. Beside each, described, the ratio
  to ``mj_step`` with held controls (hundreds of steps in a row from one trial's state: the
  robot settles, and MuJoCo's solver needs fewer iterations than on the loop's states), the
  denominator of the tables before 2026-12-05 11:00.
- **Commands end to end** (``command_cost.py``): ``astrocpg train`` and ``astrocpg study`` as
  typed against ``astrocpg run`` recording nothing (the fixed-weight loop as typed), CPU per
  stepped trial-second (the batch's steps, trials that finished their sessions idling
  included), slopes between 2 and 10 sessions and 3 and 48 s, ``--passes`` passes per repeat
  (the median of the passes' ratios, each taken within its pass, ``run`` between ``train``
  and ``study``). Goal: the training step's,
  at most 1.15 x. Per trained trial-second (what the user gets: the idle trials' steps not
  counted) beside it, described.

Each benchmark runs ``--repeats`` times inside its own script (interleaved where the script
interleaves); ``spread`` is max/min - 1 over the repeats, and a figure counts as measured when
its spread is within ``--within`` (default 10 %). Other programs on the machine slow a run and
widen the spread: run it on a quiet machine (the load average is recorded). A command's CPU
varies by a few percent from run to run on a VM (fresh memory costs more some runs than
others), and a slope is the difference of two commands: the longer sizes (24 s, 48 s, 10 sessions)
keep that variation small against the slope, the least of three runs the recorded run's, and
ratios taken within a pass the commands' (a slow spell of minutes slows both sides). Part of a
command's variation does not grow with its length (from pass to pass in the two tables of
2026-12-05 10:45 and 11:20 the 3 s run's CPU moved by 0.24 s and 0.60 s, the 24 s run's by
0.75 s and 1.8 s: ``python benchmarks/command_cost.py --passes docs/benchmarks/goals_1045.json``,
then ``goals_1120.json``), so ``run``'s slope goes to 48 s, where that part weighs half as much against it. The
training-step and trial-step measurements run 12 simulated seconds each (with 6 s the training
step's repeats spread by 13 % on 2026-12-05). About 40 minutes for the whole table with five
passes (28 minutes with three: 1664 s on the 2-core machine, 2026-12-05 14:40).
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

HERE = Path(__file__).resolve().parent


def _run(script: str, *args: str, json_out: Path) -> dict:
    cmd = [sys.executable, str(HERE / script), *args, "--json", str(json_out)]
    print("$ " + " ".join(cmd[1:]), flush=True)
    subprocess.run(cmd, check=True)
    return json.loads(json_out.read_text())


def _row(goal: str, measure: str, values: list[float], target: float | None,
         within: float) -> dict:
    """One goal's figures; ``target`` None: described beside a goal, no target of its own."""
    median = statistics.median(values)
    spread = max(values) / min(values) - 1
    return {"goal": goal, "measure": measure, "values": [round(v, 3) for v in values],
            "median": round(median, 3), "spread": round(spread, 3), "target": target,
            "steady": spread <= within,
            "met": None if target is None else median <= target and spread <= within}


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--within", type=float, default=0.10, help="largest spread that counts")
    ap.add_argument("--recorded-seconds", type=float, nargs=2, default=[3.0, 24.0],
                    metavar=("S1", "S2"), help="the two durations of the recorded-run slope")
    ap.add_argument("--command-seconds", type=float, nargs=2, default=[3.0, 48.0],
                    metavar=("S1", "S2"), help="the two durations of `astrocpg run`'s slope in "
                    "the commands end to end")
    ap.add_argument("--command-sessions", type=int, nargs=2, default=[2, 10],
                    metavar=("K1", "K2"), help="the two session counts of `train`'s and "
                    "`study`'s slopes")
    ap.add_argument("--runs", type=int, default=3,
                    help="runs per repeat of each command of the recorded run (the least CPU "
                         "counts)")
    ap.add_argument("--passes", type=int, default=5,
                    help="passes per repeat of the commands end to end (the median ratio; "
                         "with 3, one pass varying by about 5 %%, the train and study rows' "
                         "repeats spread by more than 10 %% in three of five tables)")
    ap.add_argument("--seconds", type=float, default=12.0,
                    help="simulated s of each training-step and trial-step measurement")
    ap.add_argument("--json", default=None, metavar="FILE")
    ap.add_argument("--markdown", default=None, metavar="FILE")
    args = ap.parse_args()
    started, load_before = time.time(), os.getloadavg()
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        t = Path(tmp)
        rec = _run("recorded_run_cost.py", "--repeats", str(args.repeats), "--runs",
                   str(args.runs), "--seconds", *map(str, args.recorded_seconds),
                   json_out=t / "recorded.json")
        rows.append(_row("recorded run", "recorded / unrecorded CPU per trial-second",
                         [r["ratio"] for r in rec["repeats"]], 1.25, args.within))
        tr = _run("training_cost.py", "--seconds", str(args.seconds), "--repeats", str(args.repeats),
                  "--no-breakdown", json_out=t / "training.json")
        rows.append(_row("training step", "training / fixed-weight step",
                         [r["ratio"] for r in tr["repeats"]], 1.15, args.within))
        sp = _run("speed.py", "--trials", "20", "--codegen", "cython", "numpy", "--seconds",
                  str(args.seconds), "--repeats", str(args.repeats), json_out=t / "speed.json")
        for point in sp["points"]:
            target = {"cython": 2.0, "numpy": 3.5}[point["codegen"]]
            rows.append(_row(f"trial-step ({point['codegen']})", "trial-step / mj_step on the "
                             "loop's states", [r["x_mj_step"] for r in point["repeats"]], target,
                             args.within))
            rows.append(_row(f"trial-step ({point['codegen']}, held)", "trial-step / mj_step "
                             "with held controls", [r["x_mj_step_held"] for r in point["repeats"]],
                             None, args.within))
        cc = _run("command_cost.py", "--repeats", str(args.repeats), "--runs", str(args.passes),
                  "--kinds", "run", "train", "study", "--run-seconds",
                  *map(str, args.command_seconds), "--sessions", *map(str, args.command_sessions),
                  json_out=t / "commands.json")
        for kind, what in (("train", "`astrocpg train`"), ("study", "`astrocpg study`")):
            rows.append(_row(f"{kind} command", f"{what} / `astrocpg run` per stepped "
                             "trial-second, end to end",
                             [r["stepped_ratio_to_run"][kind] for r in cc["repeats"]], 1.15,
                             args.within))
            rows.append(_row(f"{kind} command (trained)", f"{what} / `astrocpg run` per "
                             "trained trial-second, end to end",
                             [r["ratio_to_run"][kind] for r in cc["repeats"]], None,
                             args.within))
    result = {"benchmark": "goals", "argv": sys.argv, "date": time.strftime("%Y-%m-%d %H:%M"),
              "wall_s": round(time.time() - started, 1),
              "machine": {"platform": platform.platform(), "cpu_count": os.cpu_count(),
                          "load_average_before": list(load_before),
                          "load_average_after": list(os.getloadavg())},
              "goals": rows, "recorded_run": rec, "training": tr, "speed": sp,
              "commands": cc}
    lines = [f"Speed goals, `python {' '.join(sys.argv)}`, {result['date']}, "
             f"{os.cpu_count()} cores, load average {load_before[0]:.1f} before and "
             f"{os.getloadavg()[0]:.1f} after, {result['wall_s']:.0f} s.", "",
             "| goal | measure | repeats | median | spread | target | met |",
             "|---|---|---|---|---|---|---|"]
    for r in rows:
        met = ("described" if r["met"] is None else "yes" if r["met"] else
               "no" if r["steady"] else "not shown (spread)")
        target = "" if r["target"] is None else f"≤ {r['target']:.2f}"
        lines.append(f"| {r['goal']} | {r['measure']} | "
                     + ", ".join(f"{v:.2f}" for v in r["values"])
                     + f" | {r['median']:.2f} | {100 * r['spread']:.0f} % | "
                       f"{target} | {met} |")
    text = "\n".join(lines) + "\n"
    print()
    print(text)
    if args.json:
        Path(args.json).write_text(json.dumps(result, indent=1))
    if args.markdown:
        Path(args.markdown).write_text(text)
    return 0


if __name__ == "__main__":
    sys.exit(main())
