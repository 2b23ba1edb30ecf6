"""Wall seconds per simulated second of the closed loop (CPG + A1, fixed weights), numpy target,
one core, for 1, 4 and 16 trials batched in one network.

    python benchmarks/speed.py [--seconds 5] [--trials 1 4 16] [--record]

Targets (issue 2): <= 1.2 s per simulated second for one trial, <= 0.2 s per trial at 16.
Start-up (import, build, code generation, first step) is reported apart: it is paid once per run.
Pin to one core with ``taskset -c 0`` for a one-core figure; the script also reports CPU time.
"""

from __future__ import annotations

import argparse
import os
import time

os.environ.setdefault("OMP_NUM_THREADS", "1")
os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

import numpy as np  # noqa: E402
from brian2 import ms, second  # noqa: E402

from astrocpg.coupling.bridge import Bridge  # noqa: E402
from astrocpg.coupling.robot import A1Parameters, RobotLayout, build_model  # noqa: E402
from astrocpg.models import DEFAULT_MODELS  # noqa: E402
from astrocpg.network import build_cpg, check_runs  # noqa: E402
from astrocpg.studies.experiments.simulate import add_monitors  # noqa: E402


def measure(n_trials: int, seconds: float, record: bool) -> dict[str, float]:
    t_start = time.perf_counter()
    params = A1Parameters()
    robot = build_model(params)
    layout = RobotLayout.from_model(robot, params)
    cpg = build_cpg(DEFAULT_MODELS, n_trials=n_trials, seed=1)
    check_runs(cpg)
    bridge = Bridge(cpg, robot, layout, DEFAULT_MODELS)
    if record:
        bridge.start_recording(int(seconds * 1000) + 200, 1)
        add_monitors(cpg, 1 * ms, True)
    cpg.net.add(bridge.operation())
    cpg.net.run(100 * ms, namespace={})  # code generation and first steps
    startup = time.perf_counter() - t_start
    w0, c0 = time.perf_counter(), time.process_time()
    cpg.net.run(seconds * second, namespace={})
    wall, cpu = time.perf_counter() - w0, time.process_time() - c0
    return {"trials": n_trials, "wall_per_sim_s": wall / seconds,
            "cpu_per_sim_s": cpu / seconds, "wall_per_trial": wall / seconds / n_trials,
            "startup_s": startup}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--seconds", type=float, default=5.0)
    ap.add_argument("--trials", type=int, nargs="+", default=[1, 4, 16])
    ap.add_argument("--record", action="store_true",
                    help="also record spikes, Ca2+/astrocyte traces and the robot every step")
    args = ap.parse_args()
    print(f"closed loop, numpy target, {args.seconds:g} simulated s per point, "
          f"recording {'on' if args.record else 'off'}")
    print(f"{'trials':>6} {'wall s/sim s':>13} {'per trial':>10} {'CPU s/sim s':>12} "
          f"{'start-up s':>11}")
    for n in args.trials:
        r = measure(n, args.seconds, args.record)
        print(f"{r['trials']:>6} {r['wall_per_sim_s']:>13.3f} {r['wall_per_trial']:>10.3f} "
              f"{r['cpu_per_sim_s']:>12.3f} {r['startup_s']:>11.1f}", flush=True)


if __name__ == "__main__":
    main()
