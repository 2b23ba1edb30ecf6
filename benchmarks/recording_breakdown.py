"""Where the CPU that ``astrocpg run``'s default recording adds goes, part by part.

    python benchmarks/recording_breakdown.py [--seconds 12] [--trials 20] [--codegen cython]

Runs the command's function (:func:`astrocpg.studies.commands.run.run`, writing a folder) once
recording nothing (``--spikes none --traces none``, one robot sample) and once with the default
recording, in this process after the imports, and times with CPU clocks:

- per step, inside the loop (thread CPU time of each call, microseconds per step): the trace
  recorder's sample (``TraceRecorder.sample``, its block rounding and spilling included), the
  spilled traces' block writes to disk alone (``SpilledTrace.write_block``), the robot
  recording (the bridge's ``recording`` hook, ``Bridge._record``) and the spike monitors'
  growth (``SpikeRecorder.resize``);
- per run (process CPU seconds): the loop (``_run``), the summary (``_summarise``) and the
  folder's files with their hashes (``write_run_folder``).

The wrappers cost about a microsecond a call; read the figures as shares, not to the
microsecond. The end-to-end figure, in fresh processes, is ``benchmarks/recorded_run_cost.py``.
"""

from __future__ import annotations

import argparse
import os
import resource
import shutil
import tempfile
import time
from pathlib import Path
from typing import Any, Callable

os.environ.setdefault("OMP_NUM_THREADS", "1")

import astrocpg.studies.commands.run as run_command  # noqa: E402
import astrocpg.studies.commands.simulate as simulate  # noqa: E402
from astrocpg.coupling.bridge import Bridge  # noqa: E402
from astrocpg.network import recording  # noqa: E402

IN_LOOP = [(recording.TraceRecorder, "sample"), (recording.SpilledTrace, "write_block"),
           (Bridge, "_record"), (recording.SpikeRecorder, "resize")]
PHASES = [(simulate, "_run"), (run_command, "_summarise"), (run_command, "write_run_folder")]


def _process_cpu() -> float:
    r = resource.getrusage(resource.RUSAGE_SELF)
    return r.ru_utime + r.ru_stime


def _timed(fn: Callable, clock: Callable[[], float], totals: dict, key: str,
           method: bool) -> Callable:
    if method:  # a bound method Brian2 calls as a network operation takes self alone
        def wrapped_method(self: Any, *args: Any, **kwargs: Any) -> Any:
            t = clock()
            try:
                return fn(self, *args, **kwargs)
            finally:
                totals[key] = totals.get(key, 0.0) + clock() - t
        return wrapped_method

    def wrapped(*args: Any, **kwargs: Any) -> Any:
        t = clock()
        try:
            return fn(*args, **kwargs)
        finally:
            totals[key] = totals.get(key, 0.0) + clock() - t
    return wrapped


def measure(seconds: float, trials: int, record: bool, out: Path) -> dict[str, float]:
    totals: dict[str, float] = {}
    saved = [(owner, name, getattr(owner, name)) for owner, name in IN_LOOP + PHASES]
    try:
        for owner, name in IN_LOOP:
            setattr(owner, name, _timed(getattr(owner, name), time.thread_time, totals,
                                        f"{owner.__name__}.{name}", method=True))
        for owner, name in PHASES:
            setattr(owner, name, _timed(getattr(owner, name), _process_cpu, totals, name,
                                        method=False))
        kw: dict[str, Any] = {} if record else {
            "spikes": "none", "traces": "none", "robot_stride": int(seconds * 1000)}
        run_command.run(seconds=seconds, trials=trials, seed=1, out=out, progress=False,
                        workers=1, **kw)  # one process: its recorders are the ones timed
    finally:
        for owner, name, fn in saved:
            setattr(owner, name, fn)
    return totals


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seconds", type=float, default=12.0)
    ap.add_argument("--trials", type=int, default=20)
    ap.add_argument("--codegen", default="cython", choices=("numpy", "cython"))
    args = ap.parse_args()
    os.environ["ASTROCPG_CODEGEN"] = args.codegen
    steps = args.seconds * 1000.0
    with tempfile.TemporaryDirectory(prefix="astrocpg-recording-") as tmp:
        got = {}
        for record in (False, True):
            out = Path(tmp) / ("recorded" if record else "unrecorded")
            got[record] = measure(args.seconds, args.trials, record, out)
            shutil.rmtree(out, ignore_errors=True)
    print(f"astrocpg run --trials {args.trials} --codegen {args.codegen} --seconds "
          f"{args.seconds:g}, default recording against none (CPU)")
    print("inside the loop, us per step:")
    for owner, name in IN_LOOP:
        key = f"{owner.__name__}.{name}"
        print(f"  {key:28s} {1e6 * got[True].get(key, 0.0) / steps:8.1f}")
    print("per run, CPU s:              recorded  unrecorded")
    for _, name in PHASES:
        print(f"  {name:28s} {got[True].get(name, 0.0):8.3f}  {got[False].get(name, 0.0):10.3f}")


if __name__ == "__main__":
    main()
