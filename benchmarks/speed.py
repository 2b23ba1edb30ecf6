"""Wall seconds per simulated second of the closed loop (CPG + A1, fixed weights), numpy target,
one core, for 1, 4 and 16 trials batched in one network.

    python benchmarks/speed.py [--seconds 5] [--trials 1 4 16] [--record] [--check-every N]

Targets (issue 2): <= 1.2 s per simulated second for one trial, <= 0.2 s per trial at 16.
Start-up (import, build, code generation, first step) is reported apart: it is paid once per run.
Pin to one core with ``taskset -c 0`` for a one-core figure; the script also reports CPU time.
``--check-every 0`` turns the bridge's CPG divergence check off (the robot's is always on), to
measure what the check costs: ``--check-every 10 0`` measures both, interleaved.
"""

from __future__ import annotations

import argparse
import os
import time

os.environ.setdefault("OMP_NUM_THREADS", "1")
os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

import numpy as np  # noqa: E402
from brian2 import ms  # noqa: E402

from astrocpg.coupling.assembly import build_closed_loop  # noqa: E402
from astrocpg.models import DEFAULT_MODELS  # noqa: E402
from astrocpg.studies.simulate import _monitors  # noqa: E402


def measure(n_trials: int, seconds: float, record: bool,
            check_every: int = 10) -> dict[str, float]:
    t_start = time.perf_counter()
    loop = build_closed_loop(DEFAULT_MODELS, n_trials=n_trials, seed=1, check_every=check_every)
    cpg = loop.cpg
    if record:
        loop.bridge.start_recording(int(seconds * 1000) + 200, 1)
        _monitors(cpg, 1 * ms, True)
    loop.run(0.1)  # code generation and first steps
    startup = time.perf_counter() - t_start
    w0, c0 = time.perf_counter(), time.process_time()
    loop.run(seconds)
    wall, cpu = time.perf_counter() - w0, time.process_time() - c0
    return {"trials": n_trials, "wall_per_sim_s": wall / seconds,
            "cpu_per_sim_s": cpu / seconds, "wall_per_trial": wall / seconds / n_trials,
            "startup_s": startup, "check_every": check_every}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--seconds", type=float, default=5.0)
    ap.add_argument("--trials", type=int, nargs="+", default=[1, 4, 16])
    ap.add_argument("--record", action="store_true",
                    help="also record spikes, Ca2+/astrocyte traces and the robot every step")
    ap.add_argument("--check-every", type=int, nargs="+", default=[10], metavar="N",
                    help="steps between CPG divergence checks (0: off); several values are "
                         "measured one after the other for each trial count")
    args = ap.parse_args()
    print(f"closed loop, numpy target, {args.seconds:g} simulated s per point, "
          f"recording {'on' if args.record else 'off'}")
    print(f"{'trials':>6} {'check':>6} {'wall s/sim s':>13} {'per trial':>10} "
          f"{'CPU s/sim s':>12} {'start-up s':>11}")
    for n in args.trials:
        for every in args.check_every:
            r = measure(n, args.seconds, args.record, every)
            check = str(every) if every else "off"
            print(f"{r['trials']:>6} {check:>6} {r['wall_per_sim_s']:>13.3f} "
                  f"{r['wall_per_trial']:>10.3f} {r['cpu_per_sim_s']:>12.3f} "
                  f"{r['startup_s']:>11.1f}", flush=True)


if __name__ == "__main__":
    main()
