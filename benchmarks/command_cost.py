"""What ``run``, ``train`` and ``study`` cost end to end, as a user types them, per simulated
trial-second.

    python benchmarks/command_cost.py [--trials 20] [--codegen cython] [--repeats 3]
        [--run-seconds 3 12] [--sessions 2 6] [--runs 1] [--json FILE]
    python benchmarks/command_cost.py --passes FILE [FILE ...]

Each command runs in a fresh process, exactly as typed (start-up, network build, the loop, every
file written and hashed, the process's end), and its CPU time is taken (user + system of the
process and the processes it waited for, ``getrusage(RUSAGE_CHILDREN)``; a study's worker
processes are its children). Each command runs at two sizes and the figure is the slope
between them, CPU seconds per simulated trial-second: what each further simulated second costs,
the start-up cancelled.

- ``run``: ``astrocpg run --trials 20 --codegen cython --seconds S --out DIR`` recording
  nothing (``--spikes none --traces none --robot-stride S*1000``): the fixed-weight closed loop
  as typed; and the same with its default recording (every spike, every trace, the robot every
  step, written and hashed);
- ``train``: ``astrocpg train --trials 20 --sessions K --codegen cython --seed 1 --out DIR``,
  the simulated time read from its ``sessions.csv`` (the sum of every session's length): every
  trial trains its own sessions, and the batch steps until its last trial has trained its K;
- ``study``: ``astrocpg study FILE --out DIR --workers 1 --codegen cython`` of a study file of
  one condition (astrocytes), 20 seeds in one run of K sessions, the simulated time read from
  its ``results.csv``: the study's scheduling, its worker process and its files included.

``train / run`` and ``study / run`` compare each with the fixed loop as typed, per trained
trial-second (what the user gets) and per stepped trial-second (``stepped``: what the batch
stepped, the trials that had finished their sessions idling until the last one had: the
training's own cost, the goal of at most 1.15 x); ``recorded / run`` is the recorded run (goal:
at most 1.25 x). A pass runs every kind at its small size, then every kind at its large size
(a burst of other work on the machine falls on one of them, not on one kind), ``run`` in the
middle of the kinds at each size (:func:`pass_order`: ``train``, ``run``, ``study``), and its
ratios are taken within it: the commands of a ratio run minutes apart, so that a slow spell of the
machine (on a VM, whole minutes at a few percent slower) slows both sides of it. A repeat is
``--runs`` passes, its figure the median of their ratios; the median of the ``--repeats``
repeats is the figure and their spread (max / min - 1) says how steady it is. (Before, each
command's least CPU over the passes was kept and the ratio taken between those: on
2026-12-05 a repeat whose three 24 s runs all fell in a slow spell moved the ratios by 9 %.)
Train and study train the same seeds, so their sessions (and simulated seconds) are the same.

``--passes FILE ...`` measures nothing: it reads the passes kept in earlier results (this
script's ``--json``, or ``benchmarks/goals.py``'s, whose ``commands`` part it is) and prints,
over all their passes, each command's CPU range at each size and each ratio's range and
standard deviation relative to its mean: how much one pass varies on the machine.
"""

from __future__ import annotations

import argparse
import csv
import datetime
import json
import os
import platform
import shutil
import statistics
import sys
import tempfile
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
from recorded_run_cost import astrocpg_command, child_cpu, git_commit, versions  # noqa: E402

STUDY = """[study]
name = "command_cost"
description = "one condition, {trials} seeds in one run, {sessions} sessions (benchmark)"
sessions = {sessions}
seeds = {{ first = 1, count = {trials} }}
batch = {trials}

[conditions.astrocytes]
astrocytes = true
"""


def simulated_trial_seconds(table: Path) -> tuple[float, float]:
    """From a ``sessions.csv`` or a study's ``results.csv`` (run by run): the trained
    trial-seconds (the sum of every session's length) and the stepped ones (the batch steps
    until its last trial has trained all its sessions, the others idle meanwhile: the longest
    trial's sum of lengths, times the trials)."""
    per_run: dict[str, dict[str, float]] = {}
    with open(table, newline="") as f:
        for row in csv.DictReader(f):
            trials = per_run.setdefault(row.get("run_id", ""), {})
            trials[row["trial"]] = trials.get(row["trial"], 0.0) + float(row["length_s"])
    trained = sum(sum(t.values()) for t in per_run.values())
    stepped = sum(max(t.values()) * len(t) for t in per_run.values())  # each run's batch
    return trained, stepped


def run_cmd(seconds: float, trials: int, codegen: str, out: Path, record: bool) -> list[str]:
    cmd = astrocpg_command() + ["run", "--trials", str(trials), "--codegen", codegen,
                                "--seconds", f"{seconds:g}", "--out", str(out)]
    if not record:
        cmd += ["--spikes", "none", "--traces", "none",
                "--robot-stride", str(int(round(seconds * 1000)))]
    return cmd


def measure(kind: str, size: float, args: argparse.Namespace,
            tmp: Path) -> tuple[float, float, float]:
    """(CPU s, simulated trial-s, stepped trial-s) of one command of ``kind`` at ``size``
    (seconds or sessions)."""
    out = tmp / f"{kind}_{size:g}"
    shutil.rmtree(out, ignore_errors=True)
    if kind in ("run", "recorded"):
        cpu = child_cpu(run_cmd(size, args.trials, args.codegen, out, kind == "recorded"))
        simulated = stepped = size * args.trials
    elif kind == "train":
        cpu = child_cpu(astrocpg_command() + [
            "train", "--trials", str(args.trials), "--sessions", f"{size:g}", "--codegen",
            args.codegen, "--seed", "1", "--out", str(out)])
        simulated, stepped = simulated_trial_seconds(out / "sessions.csv")
    else:
        spec = tmp / f"study_{size:g}.toml"
        spec.write_text(STUDY.format(trials=args.trials, sessions=int(size)))
        cpu = child_cpu(astrocpg_command() + ["study", str(spec), "--out", str(out),
                                              "--workers", "1", "--codegen", args.codegen])
        simulated, stepped = simulated_trial_seconds(out / "results.csv")
    shutil.rmtree(out, ignore_errors=True)  # the disk kept free for the next command
    return cpu, simulated, stepped


def pass_order(kinds: list[str]) -> list[str]:
    """The order of the commands within a pass at each size: ``run`` in the middle, so that
    every ratio's two sides run as close together as the kinds allow (``train``, ``run``,
    ``study``: each next to ``run``). A drift of the machine's speed over the minutes of a pass
    then moves both sides of a ratio more alike. With ``run`` first, ``study`` ran two commands
    after it, and its ratio varied more from pass to pass than ``train``'s (one standard
    deviation 9 % against 6 % over the 27 passes of the three tables of 2026-12-05)."""
    others = [k for k in kinds if k != "run"]
    half = len(others) // 2
    return others[:half] + ["run"] + others[half:]


def _figures(points: dict[str, dict[float, tuple[float, float, float]]]) -> dict:
    """One pass's slopes (CPU per trained and per stepped trial-second, each kind) and their
    ratios to ``run``'s."""
    slope, stepped = {}, {}
    for kind, p in points.items():
        (c1, s1, q1), (c2, s2, q2) = (p[k] for k in sorted(p))
        slope[kind] = (c2 - c1) / (s2 - s1)
        stepped[kind] = (c2 - c1) / (q2 - q1)
    return {"points": {k: {f"{size:g}": {"cpu_s": round(c, 3), "trial_s": round(s, 3),
                                         "stepped_trial_s": round(q, 3)}
                           for size, (c, s, q) in p.items()} for k, p in points.items()},
            "ms_per_trial_s": {k: 1e3 * v for k, v in slope.items()},
            "ratio_to_run": {k: v / slope["run"] for k, v in slope.items() if k != "run"},
            "ms_per_stepped_trial_s": {k: 1e3 * v for k, v in stepped.items()},
            "stepped_ratio_to_run": {k: v / stepped["run"] for k, v in stepped.items()
                                     if k != "run"}}


def _repeat(passes: list[dict]) -> dict:
    """A repeat's figures: the median over its passes of each pass's own figures (a ratio is
    taken within a pass, between commands run minutes apart, so that a slow spell of the
    machine slows both sides of it), each pass kept."""
    row: dict = {"passes": [p["points"] for p in passes]}
    for key in ("ms_per_trial_s", "ratio_to_run", "ms_per_stepped_trial_s",
                "stepped_ratio_to_run"):
        row[key] = {k: round(statistics.median(p[key][k] for p in passes), 3 if "ratio" in key
                             else 2) for k in passes[0][key]}
    return row


def pass_statistics(docs: list[dict]) -> dict:
    """Over every pass of ``docs`` (this script's JSON, or goals.py's with a ``commands``
    part): per kind and size the CPU seconds' range, and per ratio (per stepped trial-second,
    to ``run``) its values' range and standard deviation over their mean."""
    passes = [p for doc in docs for r in doc.get("commands", doc)["repeats"]
              for p in r["passes"]]
    if not passes:
        raise SystemExit("no passes in these files (written before passes were kept)")
    cpu: dict[str, dict[str, list[float]]] = {}
    ratios: dict[str, list[float]] = {}
    for points in passes:
        for kind, sizes in points.items():
            for size, point in sizes.items():
                cpu.setdefault(kind, {}).setdefault(size, []).append(point["cpu_s"])
        p = {kind: {float(size): (v["cpu_s"], v["trial_s"], v["stepped_trial_s"])
                    for size, v in sizes.items()} for kind, sizes in points.items()}
        for kind, value in _figures(p)["stepped_ratio_to_run"].items():
            ratios.setdefault(kind, []).append(value)
    return {"passes": len(passes),
            "cpu_s": {k: {size: [min(v), max(v)] for size, v in by.items()}
                      for k, by in cpu.items()},
            "ratios": {k: {"min": min(v), "max": max(v),
                           "relative_sd": statistics.stdev(v) / statistics.mean(v)
                           if len(v) > 1 else 0.0} for k, v in ratios.items()}}


def _print_passes(files: list[str]) -> None:
    stats = pass_statistics([json.loads(Path(f).read_text()) for f in files])
    print(f"{stats['passes']} passes of {', '.join(files)}")
    for kind, by in stats["cpu_s"].items():
        print(f"{kind:<9}" + "  ".join(f"{size} {lo:.2f}-{hi:.2f} s (range {hi - lo:.2f})"
                                       for size, (lo, hi) in sorted(by.items(),
                                                                    key=lambda x: float(x[0]))))
    for kind, r in stats["ratios"].items():
        print(f"{kind} stepped / run, one pass: {r['min']:.3f}-{r['max']:.3f}, standard "
              f"deviation {100 * r['relative_sd']:.1f} % of the mean")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--trials", type=int, default=20)
    ap.add_argument("--codegen", default="cython", choices=["numpy", "cython"])
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--run-seconds", type=float, nargs=2, default=[3.0, 12.0], metavar="S")
    ap.add_argument("--sessions", type=int, nargs=2, default=[2, 6], metavar="K")
    ap.add_argument("--runs", type=int, default=1,
                    help="passes per repeat (each runs every command at both sizes); a "
                         "repeat's figure is the median of its passes' (default 1)")
    ap.add_argument("--kinds", nargs="+", default=["run", "recorded", "train", "study"],
                    choices=["run", "recorded", "train", "study"])
    ap.add_argument("--json", default=None, metavar="FILE")
    ap.add_argument("--passes", nargs="+", default=None, metavar="FILE",
                    help="measure nothing: the passes of earlier results, summarised")
    args = ap.parse_args()
    if args.passes:
        _print_passes(args.passes)
        return
    if "run" not in args.kinds:
        ap.error("--kinds needs run: the other commands are compared with it")
    os.environ.setdefault("OMP_NUM_THREADS", "1")
    sizes = {k: (sorted(args.run_seconds) if k in ("run", "recorded") else
                 sorted(map(float, args.sessions))) for k in args.kinds}
    rows = []
    with tempfile.TemporaryDirectory(prefix="command_cost_") as name:
        tmp = Path(name)
        child_cpu(run_cmd(0.1, 1, args.codegen, tmp / "warm", True))  # build or find extensions
        print(f"{'repeat':<7}" + "".join(f"{k + ' ms':>13}" for k in args.kinds)
              + "".join(f"{k + '/run':>14}" for k in args.kinds if k != "run")
              + "".join(f"{k + ' stepped':>16}" for k in args.kinds if k in ("train", "study")),
              flush=True)
        for r in range(args.repeats):
            passes = []  # each pass: every kind at both sizes, run within a few minutes
            for _ in range(args.runs):
                points: dict[str, dict[float, tuple[float, float, float]]] = \
                    {k: {} for k in args.kinds}
                for size_index in range(2):  # interleaved: each kind's small, then large sizes
                    for kind in pass_order(args.kinds):
                        size = sizes[kind][size_index]
                        points[kind][size] = measure(kind, size, args, tmp)
                passes.append(_figures(points))
            row = _repeat(passes)
            rows.append(row)
            print(f"{r:<7}" + "".join(f"{row['ms_per_trial_s'][k]:>13.1f}" for k in args.kinds)
                  + "".join(f"{row['ratio_to_run'][k]:>14.3f}" for k in args.kinds if k != "run")
                  + "".join(f"{row['stepped_ratio_to_run'][k]:>16.3f}" for k in args.kinds
                            if k in ("train", "study")), flush=True)
    summary = {}
    for kind in args.kinds:
        if kind == "run":
            continue
        for key, label in (("ratio_to_run", ""), ("stepped_ratio_to_run", " stepped")):
            values = [row[key][kind] for row in rows]
            if kind == "recorded" and label:
                continue
            summary[kind + label.replace(" ", "_")] = entry = {
                "ratios": values, "median": round(statistics.median(values), 3),
                "spread": round(max(values) / min(values) - 1, 3)}
            print(f"{kind}{label} / run: median {entry['median']:.3f}, spread "
                  f"{100 * entry['spread']:.0f} %")
    if args.json:
        doc = {"benchmark": "benchmarks/command_cost.py", "argv": sys.argv,
               "date": datetime.datetime.now().astimezone().isoformat(timespec="seconds"),
               "machine": {"platform": platform.platform(),
                           "processor": platform.processor() or platform.machine(),
                           "cpu_count": os.cpu_count(), "load_average": list(os.getloadavg())},
               "versions": versions(), "astrocpg_commit": git_commit(),
               "trials": args.trials, "codegen": args.codegen, "sizes": sizes,
               "order": pass_order(args.kinds),
               "summary": summary, "repeats": rows}
        Path(args.json).parent.mkdir(parents=True, exist_ok=True)
        Path(args.json).write_text(json.dumps(doc, indent=1) + "\n")
        print(f"wrote {args.json}")


if __name__ == "__main__":
    main()
