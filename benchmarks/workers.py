"""Wall time of the commands as typed with --workers 1 and --workers 2 (and more where the
machine has the cores), the ratio, and a projection for N cores.

    python benchmarks/workers.py                    # the acceptance sizes (minutes)
    python benchmarks/workers.py --trials 4 --sessions 2 --seconds 0.5   # a quick check

Each command runs as typed (``python -m astrocpg ...``, a fresh process, its output folder
new). The acceptance on a 2-core machine: train at most 0.55 x the wall time of --workers 1,
run at most 0.6 x. The projection: a command of T trials over N processes takes about
``startup * 1 + per_process + per_trial * ceil(T / N)`` seconds, with ``per_trial`` and the
fixed costs solved from the 1- and 2-worker times (``t1 = fixed + per_trial * T``,
``t2 = fixed + per_process + per_trial * ceil(T / 2)``); it is limited by the memory per
worker (``WORKER_PROCESS_BYTES`` plus its batch's records), the start-up of each process and
the largest batch (ceil(T / N) trials: 20 trials on 8 cores wait for batches of 3).
Before the timings, each command runs once small (2 trials, a fraction of a second, both worker
counts), untimed: the first run of a code-generation target compiles its code (Cython: tens of
seconds, cached), which is not what the number of workers changes.
Run it on a quiet machine: timings on a loaded one are meaningless.
"""

from __future__ import annotations

import argparse
import json
import math
import os
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path


def commands(trials: int, sessions: int, seconds: float) -> dict[str, list[str]]:
    short = max(0.2, seconds / 5)
    return {
        "train": ["train", "--trials", str(trials), "--sessions", str(sessions), "--out", "OUT"],
        "run": ["run", "--trials", str(trials), "--seconds", f"{seconds:g}", "--out", "OUT"],
        "unit": ["unit", "--trials", str(trials), "--seconds", f"{short:g}", "--out", "OUT"],
    }


def warm_up(args: list[str], where: Path) -> None:
    """The command once small with 1 and 2 workers, untimed (compiled code cached)."""
    small = {"--trials": "2", "--sessions": "1", "--seconds": "0.2"}
    args = [small.get(prev, a) if prev in small else a
            for prev, a in zip([""] + args[:-1], args)]
    if args[0] == "train":
        args = [*args, "--set", "L_max=0.2*second"]
    for workers in (1, 2):
        timed(args, workers, where / "warm-up")


def timed(args: list[str], workers: int, where: Path) -> float:
    out = where / f"{args[0]}-w{workers}"
    shutil.rmtree(out, ignore_errors=True)
    out.parent.mkdir(parents=True, exist_ok=True)
    typed = [a if a != "OUT" else str(out) for a in args]
    t0 = time.perf_counter()
    p = subprocess.run([sys.executable, "-m", "astrocpg", *typed, "--workers", str(workers),
                        "--no-progress"], capture_output=True, text=True)
    wall = time.perf_counter() - t0
    if p.returncode != 0:
        raise SystemExit(f"astrocpg {' '.join(typed)} --workers {workers}: exit "
                         f"{p.returncode}: {p.stderr.strip()[-300:]}")
    return wall


def projection(t1: float, t2: float, trials: int, cores: int) -> dict[str, float]:
    """Per-trial and fixed costs from the 1- and 2-worker times, and the wall time at
    ``cores`` processes (the largest batch decides)."""
    half = math.ceil(trials / 2)
    per_trial = max(0.0, (t1 - t2) / max(1, trials - half)) if trials > 1 else t1
    fixed = max(0.0, t1 - per_trial * trials)
    per_process = max(0.0, t2 - fixed - per_trial * half)
    return {"per_trial_s": per_trial, "fixed_s": fixed, "per_process_s": per_process,
            "projected_s": fixed + (per_process if cores > 1 else 0.0)
            + per_trial * math.ceil(trials / cores)}


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--trials", type=int, default=20)
    ap.add_argument("--sessions", type=int, default=20)
    ap.add_argument("--seconds", type=float, default=10.0)
    ap.add_argument("--only", action="append", default=None, help="train, run or unit")
    ap.add_argument("--cores", type=int, default=8, help="the N of the projection (default 8)")
    ap.add_argument("--json", metavar="FILE", help="also write the figures as JSON")
    a = ap.parse_args(argv)
    limits = {"train": 0.55, "run": 0.6}
    here = len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else os.cpu_count()
    rows = {}
    with tempfile.TemporaryDirectory(prefix="astrocpg-workers-") as tmp:
        for name, args in commands(a.trials, a.sessions, a.seconds).items():
            if a.only and name not in a.only:
                continue
            warm_up(args, Path(tmp))
            t1, t2 = timed(args, 1, Path(tmp)), timed(args, 2, Path(tmp))
            ratio = t2 / t1
            proj = projection(t1, t2, a.trials, a.cores)
            rows[name] = {"command": "astrocpg " + " ".join(x for x in args if x != "OUT"),
                          "workers_1_s": t1, "workers_2_s": t2, "ratio": ratio, **proj}
            limit = limits.get(name)
            verdict = "" if limit is None else (" (goal <= %.2f: %s)" % (
                limit, "met" if ratio <= limit else "NOT met"))
            print(f"{name}: --workers 1 {t1:.1f} s, --workers 2 {t2:.1f} s, ratio "
                  f"{ratio:.2f}{verdict}; per trial {proj['per_trial_s']:.2f} s, fixed "
                  f"{proj['fixed_s']:.1f} s, per extra process {proj['per_process_s']:.1f} s; "
                  f"projected on {a.cores} cores: {proj['projected_s']:.1f} s (largest batch "
                  f"{math.ceil(a.trials / a.cores)} trials)")
    print(f"machine: {here} core(s) for this process, load average "
          f"{os.getloadavg()[0]:.1f}; limits of the projection: memory per worker, the "
          f"start-up of each process, the largest batch")
    if a.json:
        Path(a.json).write_text(json.dumps({"cores_here": here, "rows": rows}, indent=1))
    return 0


if __name__ == "__main__":
    sys.exit(main())
