"""What recording costs a run: its share of a step and its memory per trial per simulated second.

    python benchmarks/recording_cost.py [--trials 20] [--seconds 3] [--codegen numpy cython]
                                        [--memory-seconds 2] [--memory-trials 1 20]

- **Share of a step**: the closed loop's CPU per trial-step with what ``astrocpg run`` records
  by default (every spike, every trace at 1 ms, the robot every step) against none, measured as
  ``speed.py`` measures (steady state, one process, the two interleaved). Goal: at most 15 %.
- **Memory**: the peak resident memory of ``astrocpg.run`` with the default recording, less that
  of the same run recording nothing (``spikes="none", traces="none"``, the robot once), each
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
r = ac.run(seconds=seconds, trials=trials, seed=1, progress=False, trace_dtype=dtype, **kw)
sim = r.simulation
held = 0
if record:
    held += sim.monitors["traces"].nbytes()
    held += sum(m.t_[:].nbytes + m.i_[:].nbytes for k, m in sim.monitors.items() if k != "traces")
    held += sum(np.asarray(getattr(sim.robot, f)).nbytes for f in ("joint_angles", "torques",
                "torso_position", "torso_velocity", "reward", "alive", "foot_force",
                "torso_quaternion"))
print(json.dumps({"peak": resource.getrusage(resource.RUSAGE_SELF).ru_maxrss * 1024,
                  "held": held}))
""".replace("import astrocpg as ac", "import astrocpg as ac\nimport numpy as np")


def peak_memory(seconds: float, trials: int, record: bool, dtype: str = "float32") -> dict:
    out = subprocess.run([sys.executable, "-c", _CHILD, str(seconds), str(trials),
                          "1" if record else "0", dtype],
                         check=True, capture_output=True, text=True)
    return json.loads(out.stdout.strip().splitlines()[-1])


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--trials", type=int, default=20)
    ap.add_argument("--seconds", type=float, default=3.0)
    ap.add_argument("--codegen", nargs="*", default=["numpy", "cython"],
                    choices=["numpy", "cython"], help="targets of the share (none: skip it)")
    ap.add_argument("--repeats", type=int, default=2)
    ap.add_argument("--memory-seconds", type=float, default=2.0)
    ap.add_argument("--memory-trials", type=int, nargs="+", default=[1, 20])
    args = ap.parse_args()
    MiB = 2.0 ** 20
    print(f"recording's share of a trial-step, {args.trials} trials, {args.seconds:g} simulated "
          f"s per point, {args.repeats} interleaved repeats (medians)")
    print(f"{'target':<8}{'off us':>10}{'on us':>10}{'share':>9}{'goal':>7}")
    for target in args.codegen:
        off, on = [], []
        for _ in range(args.repeats):
            off.append(speed.measure(args.trials, args.seconds, False, codegen=target)
                       ["trial_step_us"])
            on.append(speed.measure(args.trials, args.seconds, True, codegen=target)
                      ["trial_step_us"])
        a, b = float(np.median(off)), float(np.median(on))
        print(f"{target:<8}{a:>10.1f}{b:>10.1f}{100 * (b / a - 1):>8.1f}%{'15%':>7}", flush=True)
    print()
    print(f"memory of `astrocpg.run` ({args.memory_seconds:g} s, numpy), per trial per "
          f"simulated second: peak RSS with the default recording less without; the "
          f"recorders' arrays")
    print(f"{'trials':<8}{'dtype':>9}{'peak RSS':>12}{'arrays':>10}{'goal':>7}")
    for trials in args.memory_trials:
        bare = peak_memory(args.memory_seconds, trials, False)
        for dtype in ("float32", "float64"):
            rec = peak_memory(args.memory_seconds, trials, True, dtype)
            per = (rec["peak"] - bare["peak"]) / trials / args.memory_seconds / MiB
            held = rec["held"] / trials / args.memory_seconds / MiB
            goal = "2.0" if dtype == "float32" else ""
            print(f"{trials:<8}{dtype:>9}{per:>9.2f} MiB{held:>7.2f} MiB{goal:>7}", flush=True)


if __name__ == "__main__":
    main()
