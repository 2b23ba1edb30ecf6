"""What stepping the robots in one call of compiled code saves, A/B within one run.

    python benchmarks/compiled_physics.py [--trials 20] [--seconds 6] [--codegen cython]

The closed loop runs once; every 100 steps a hook switches the robots between the compiled
step (``coupling/compiled.py``) and the Python loop over the trials, and each way's CPU time
per step is the median of its stretches. Both ways give the same state bit for bit
(``tests/test_compiled_physics.py``), so one run can alternate between them.
"""

from __future__ import annotations

import argparse
import os
import time

os.environ.setdefault("OMP_NUM_THREADS", "1")

import numpy as np  # noqa: E402

from astrocpg.coupling.assembly import build_closed_loop  # noqa: E402
from astrocpg.models import DEFAULT_MODELS  # noqa: E402


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--trials", type=int, default=20)
    ap.add_argument("--seconds", type=float, default=6.0)
    ap.add_argument("--codegen", choices=("numpy", "cython"), default="cython")
    args = ap.parse_args()
    loop = build_closed_loop(DEFAULT_MODELS, n_trials=args.trials, seed=1, codegen=args.codegen)
    robots, bridge = loop.bridge.robots, loop.bridge
    compiled = robots._compiled
    if compiled is None:
        raise SystemExit("the compiled step is not available here (no C compiler?)")
    loop.run(0.1)
    chunks: dict[bool, list[float]] = {True: [], False: []}
    state = {"on": True, "cpu": None, "at": 0}

    def switch() -> None:
        step = bridge.step_count
        if step % 100:
            return
        cpu = time.process_time()
        if state["cpu"] is not None:
            chunks[state["on"]].append((cpu - state["cpu"]) / (step - state["at"]))
        state["on"] = not state["on"]
        robots._compiled = compiled if state["on"] else None
        state["at"], state["cpu"] = step, time.process_time()

    bridge.add_hook("after_physics", "benchmark", switch, order=1e9)
    loop.run(args.seconds)
    on, off = (float(np.median(chunks[k])) * 1e6 for k in (True, False))
    print(f"{args.codegen}, {args.trials} trials: {on:.0f} us per step with the compiled "
          f"physics, {off:.0f} us with the Python loop: {off - on:.0f} us saved "
          f"({100 * (off - on) / off:.1f}%)")


if __name__ == "__main__":
    main()
