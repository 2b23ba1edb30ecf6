"""What recording costs a run: its share of a step and its memory per trial per simulated second.

    python benchmarks/recording_cost.py [--trials 20] [--seconds 3] [--codegen numpy cython]
                                        [--memory-seconds 2] [--memory-trials 1 20]

- **Share of a step**: the closed loop's CPU per trial-step with what ``astrocpg run`` records
  by default (every spike, every trace at 1 ms, the robot every step) against none, in one run:
  the recorders are switched on and off every 100 steps, and each state's cost is the median
  of its stretches (:func:`share_in_run`). Goal: at most 15 %.
- **Memory**: the resident memory of ``astrocpg.run`` at its end (its recordings still held) with
  the default recording, less that of the same run recording nothing (``spikes="none", traces="none"``, the robot once), each
  in a fresh process, per trial per simulated second; beside it what the recorders' arrays hold
  (float32 traces by default; ``--trace-dtype float64`` in ``astrocpg run`` doubles the traces).
  Goal: at most 2 MiB per trial per simulated second.
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
from pathlib import Path

os.environ.setdefault("OMP_NUM_THREADS", "1")
sys.path.insert(0, str(Path(__file__).resolve().parent))

import numpy as np  # noqa: E402

import speed  # noqa: E402

_CHILD = r"""
import json, resource, sys
import astrocpg as ac
seconds, trials, record, dtype = float(sys.argv[1]), int(sys.argv[2]), sys.argv[3] == "1", sys.argv[4]
kw = {} if record else {"spikes": "none", "traces": "none", "robot_stride": int(seconds * 1000)}
r = ac.run(seconds=seconds, trials=trials, seed=1, progress=False, trace_dtype=dtype, workers=1,
           **kw)  # one process: what it keeps is this process's memory
sim = r.simulation
held = 0
if record:
    held += sim.monitors["traces"].nbytes()
    held += sum(m.t_[:].nbytes + m.i_[:].nbytes for k, m in sim.monitors.items() if k != "traces")
    held += sum(np.asarray(getattr(sim.robot, f)).nbytes for f in ("joint_angles", "torques",
                "torso_position", "torso_velocity", "reward", "alive", "foot_force",
                "torso_quaternion"))
import os
with open("/proc/self/statm") as f:  # resident pages now, the recordings still held
    rss = int(f.read().split()[1]) * os.sysconf("SC_PAGE_SIZE")
print(json.dumps({"peak": resource.getrusage(resource.RUSAGE_SELF).ru_maxrss * 1024,
                  "rss": rss, "held": held}))
""".replace("import astrocpg as ac", "import astrocpg as ac\nimport numpy as np")


def share_in_run(trials: int, seconds: float, codegen: str, every: int = 100) -> tuple[float, float]:
    """CPU us per trial-step of the loop with ``astrocpg run``'s default recording and without,
    in one run: every ``every`` steps the recorders (spike monitors, traces, the robot's
    samples) are switched on or off, and each state's cost is the median of its stretches. A
    stretch without recording leaves no samples, so the recorded data of such a run is not a
    run's; only the timing is."""
    import time

    from brian2 import ms

    from astrocpg.coupling.assembly import build_closed_loop
    from astrocpg.models import DEFAULT_MODELS
    from astrocpg.studies.commands.simulate import add_monitors

    loop = build_closed_loop(DEFAULT_MODELS, n_trials=trials, seed=1, codegen=codegen)
    bridge, cpg = loop.bridge, loop.cpg
    n = int(round((seconds + 0.2) / float(cpg.dt)))
    bridge.start_recording(n, 1)
    monitors = add_monitors(cpg, 1 * ms, True, n_steps=n)
    brian_recorders = [m for k, m in monitors.items() if k != "traces"]
    brian_recorders.append(next(o for o in cpg.net.objects if o.name == "trace_recorder"))
    robot_hook = bridge.hooks("after_physics")
    record_fn = next(h.fn for h in robot_hook if h.name == "recording")
    loop.run(0.1)
    chunks: dict[bool, list[float]] = {True: [], False: []}
    state = {"on": True, "cpu": None, "at": 0}

    def switch(on: bool) -> None:
        for obj in brian_recorders:  # Brian2 calls obj.run() at every step: skip it or not
            if on:
                obj.__dict__.pop("run", None)
            else:
                obj.run = lambda: None
        if on:
            bridge.add_hook("after_physics", "recording", record_fn, order=30)
        else:
            bridge.remove_hook("recording")

    def hook() -> None:
        step = bridge.step_count
        if step % every:
            return
        cpu = time.process_time()
        if state["cpu"] is not None:
            chunks[state["on"]].append((cpu - state["cpu"]) / (step - state["at"]))
        state["on"] = not state["on"]
        switch(state["on"])
        state["at"], state["cpu"] = step, time.process_time()

    bridge.add_hook("after_physics", "benchmark", hook, order=1e9)
    loop.run(seconds)
    off = float(np.median(chunks[False])) / trials * 1e6
    on = float(np.median(chunks[True])) / trials * 1e6
    return off, on


def peak_memory(seconds: float, trials: int, record: bool, dtype: str = "float32") -> dict:
    # numpy in the child whatever the parent measured: a Cython build's own memory would
    # hide the recording's in the peak
    env = dict(os.environ, ASTROCPG_CODEGEN="numpy")
    out = subprocess.run([sys.executable, "-c", _CHILD, str(seconds), str(trials),
                          "1" if record else "0", dtype],
                         check=True, capture_output=True, text=True, env=env)
    return json.loads(out.stdout.strip().splitlines()[-1])


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--trials", type=int, default=20)
    ap.add_argument("--seconds", type=float, default=3.0)
    ap.add_argument("--codegen", nargs="*", default=["numpy", "cython"],
                    choices=["numpy", "cython"], help="targets of the share (none: skip it)")
    ap.add_argument("--repeats", type=int, default=2)
    ap.add_argument("--memory-seconds", type=float, default=2.0)
    ap.add_argument("--memory-trials", type=int, nargs="*", default=[1, 20],
                    help="trial counts of the memory measurement (none: skip it)")
    args = ap.parse_args()
    MiB = 2.0 ** 20
    print(f"recording's share of a trial-step, {args.trials} trials, {args.seconds:g} simulated "
          f"s per run, recording switched every 100 steps, {args.repeats} runs (medians)")
    print(f"{'target':<8}{'off us':>10}{'on us':>10}{'share':>9}{'goal':>7}")
    for target in args.codegen:
        pairs = [share_in_run(args.trials, args.seconds, target) for _ in range(args.repeats)]
        a = float(np.median([p[0] for p in pairs]))
        b = float(np.median([p[1] for p in pairs]))
        print(f"{target:<8}{a:>10.1f}{b:>10.1f}{100 * (b / a - 1):>8.1f}%{'15%':>7}", flush=True)
    print()
    print(f"memory of `astrocpg.run` ({args.memory_seconds:g} s, numpy), per trial per "
          f"simulated second: resident memory at the end with the default recording less "
          f"without; the recorders' arrays")
    print(f"{'trials':<8}{'dtype':>9}{'RSS':>12}{'arrays':>10}{'goal':>7}")
    for trials in args.memory_trials:
        bare = peak_memory(args.memory_seconds, trials, False)
        for dtype in ("float32", "float64"):
            rec = peak_memory(args.memory_seconds, trials, True, dtype)
            per = (rec["rss"] - bare["rss"]) / trials / args.memory_seconds / MiB
            held = rec["held"] / trials / args.memory_seconds / MiB
            goal = "2.0" if dtype == "float32" else ""
            print(f"{trials:<8}{dtype:>9}{per:>9.2f} MiB{held:>7.2f} MiB{goal:>7}", flush=True)


if __name__ == "__main__":
    main()
