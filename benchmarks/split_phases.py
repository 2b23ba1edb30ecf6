"""Where the wall time of ``astrocpg run`` goes, with one worker process and with several: the
start (Python, the imports, the settings), the simulation (with several workers: the batches
side by side, their records coming back to the command, putting them together) and the end
(writing the folder, the summary).

    python benchmarks/split_phases.py                          # 20 trials x 10 s, 1 and 2 workers
    python benchmarks/split_phases.py --trials 4 --seconds 1   # a quick look

Each command runs as typed in a fresh process (``python -m astrocpg run ... --out DIR``), with
timing hooks around the command's simulation (``run._simulate``), each batch
(``batched.simulate_batch``, in its worker) and the merge (``batched.merge_batches``); the
hooks only read the clock (``time.monotonic``, one clock for every process of the machine),
so the commands do what they do untimed. A first small call of each, untimed, caches what the
target compiles. Run it on a quiet machine.
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

#: The child's hooks: each event is one JSON line on stderr, prefixed so it is found among the
#: command's own output.
TAG = "split-phase "

_INNER = r"""
import json, sys, time
TAG = %r
def say(event, **kw):
    sys.stderr.write(TAG + json.dumps({"event": event, "t": time.monotonic(), **kw}) + "\n")
    sys.stderr.flush()
import astrocpg.studies.commands.batched as batched
import astrocpg.studies.commands.run as run
simulate, batch, merge = run._simulate, batched.simulate_batch, batched.merge_batches
def timed_simulate(*a, **k):
    say("simulate start")
    try:
        return simulate(*a, **k)
    finally:
        say("simulate end")
def timed_batch(kind, spec, first, count):
    say("batch start", first=first)
    out = batch(kind, spec, first, count)
    say("batch end", first=first, simulated=out.get("wall_seconds"))
    return out
timed_batch.__module__, timed_batch.__qualname__ = batch.__module__, "simulate_batch"
def timed_merge(parts, wall):
    say("merge start")
    try:
        return merge(parts, wall)
    finally:
        say("merge end")
run._simulate, batched.simulate_batch, batched.merge_batches = timed_simulate, timed_batch, timed_merge
from astrocpg.studies.cli import main
sys.exit(main(sys.argv[1:]))
"""


def phases(trials: int, seconds: float, workers: int, where: Path) -> dict[str, float]:
    """One ``astrocpg run`` as typed: the seconds of each phase."""
    out = where / f"run-w{workers}-{trials}x{seconds:g}"
    args = ["run", "--trials", str(trials), "--seconds", f"{seconds:g}", "--workers",
            str(workers), "--no-progress", "--out", str(out)]
    t0 = time.monotonic()
    done = subprocess.run([sys.executable, "-c", _INNER % TAG, *args], capture_output=True,
                          text=True)
    t_end = time.monotonic()
    if done.returncode != 0:
        raise SystemExit(f"astrocpg {' '.join(args)}: exit {done.returncode}: "
                         f"{done.stderr.strip()[-300:]}")
    events = [json.loads(line[len(TAG):]) for line in done.stderr.splitlines()
              if line.startswith(TAG)]
    at = {}
    for e in events:
        at.setdefault(e["event"], []).append(e)
    first = lambda name: min(e["t"] for e in at[name])  # noqa: E731
    last = lambda name: max(e["t"] for e in at[name])  # noqa: E731
    result = {"total": t_end - t0, "start": first("simulate start") - t0,
              "simulation": last("simulate end") - first("simulate start"),
              "end": t_end - last("simulate end")}
    if "batch start" in at:  # split over processes
        result |= {"batches": last("batch end") - first("batch start"),
                   "simulating (longest batch)": max(e["simulated"] for e in at["batch end"]),
                   "records coming back": first("merge start") - last("batch end"),
                   "merge": last("merge end") - first("merge start")}
    result["folder MB"] = sum(f.stat().st_size for f in out.iterdir()) / 1e6
    return result


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--trials", type=int, default=20)
    ap.add_argument("--seconds", type=float, default=10.0)
    ap.add_argument("--workers", type=int, nargs="+", default=[1, 2])
    ap.add_argument("--json", metavar="FILE", help="also write the figures as JSON")
    args = ap.parse_args(argv)
    rows = {}
    with tempfile.TemporaryDirectory() as tmp:
        where = Path(tmp)
        for w in args.workers:  # untimed: compiled code cached, files warm
            phases(min(2, args.trials), 0.2, w, where / "warm-up")
        for w in args.workers:
            rows[w] = phases(args.trials, args.seconds, w, where)
    target = os.environ.get("ASTROCPG_CODEGEN", "numpy")
    print(f"astrocpg run --trials {args.trials} --seconds {args.seconds:g} ({target}; "
          f"{len(os.sched_getaffinity(0))} cores for this process, load average "
          f"{os.getloadavg()[0]:.1f}):")
    for w, r in rows.items():
        print(f"  --workers {w}: {r['total']:.1f} s = start {r['start']:.1f} + simulation "
              f"{r['simulation']:.1f} + writing and summary {r['end']:.1f} "
              f"({r['folder MB']:.0f} MB written)")
        if "batches" in r:
            print(f"      simulation: batches side by side {r['batches']:.1f} (the longest "
                  f"simulating {r['simulating (longest batch)']:.1f}), records coming back "
                  f"{r['records coming back']:.1f}, merge {r['merge']:.1f}")
    if args.json:
        Path(args.json).write_text(json.dumps({str(k): v for k, v in rows.items()}, indent=1))
    return 0


if __name__ == "__main__":
    sys.exit(main())
