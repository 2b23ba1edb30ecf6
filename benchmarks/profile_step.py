"""Where a step of the closed loop goes: Brian2's per-object profile and Python's cProfile of
one run of the CPG + A1 at a trial count (issue 13, goal 3: what stands between a trial-step
and 2.0 x MuJoCo's step).

    python benchmarks/profile_step.py [--trials 20] [--seconds 2] [--codegen cython]

Prints the wall seconds per simulated second (the profilers add overhead), Brian2's time per
code object (``Network.run(profile=True)``) and the functions with the most own time
(MuJoCo's ``mj_step``, Brian2's per-step loop, the bridge).

``--dispatch`` (Cython) also splits Brian2's part of a step into its Python dispatch and its
compiled code: each code object called as Brian2 calls it (``codeobj()``: namespace update,
``run_block``) against its compiled ``main(namespace)`` called directly, summed over the code
objects of one step (each repeated on the same state, so the figures are per call, not a
simulation). What fusing the objects' Python calls could save is the difference.
"""

from __future__ import annotations

import argparse
import cProfile
import os
import pstats
import time

os.environ.setdefault("OMP_NUM_THREADS", "1")

from brian2 import profiling_summary, second  # noqa: E402

from astrocpg.coupling.assembly import build_closed_loop  # noqa: E402
from astrocpg.models import DEFAULT_MODELS  # noqa: E402


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--trials", type=int, default=20)
    ap.add_argument("--seconds", type=float, default=2.0)
    ap.add_argument("--codegen", choices=("numpy", "cython"), default="cython")
    ap.add_argument("--top", type=int, default=15)
    ap.add_argument("--dispatch", action="store_true",
                    help="also time Brian2's Python dispatch against its compiled code (Cython)")
    args = ap.parse_args()
    loop = build_closed_loop(DEFAULT_MODELS, n_trials=args.trials, seed=1, codegen=args.codegen)
    loop.run(0.1)  # code generation and first steps, outside the profile
    net = loop.cpg.net
    profiler = cProfile.Profile()
    t0 = time.perf_counter()
    profiler.enable()
    net.run(args.seconds * second, profile=True, namespace={})
    profiler.disable()
    wall = time.perf_counter() - t0
    steps = args.seconds / float(loop.cpg.dt)
    print(f"{args.codegen}, {args.trials} trials, {args.seconds:g} simulated s (profiled): "
          f"{wall / args.seconds:.3f} s per simulated s, {wall / steps * 1e3:.3f} ms per step")
    print(profiling_summary(net, show=args.top))
    pstats.Stats(profiler).sort_stats("tottime").print_stats(args.top)
    if args.dispatch:
        dispatch(net)


def dispatch(net, repeats: int = 2000) -> None:
    """Per step: the code objects called as Brian2 calls them against their compiled
    ``main(namespace)`` alone (Cython code objects only)."""
    import timeit

    via, direct, n = 0.0, 0.0, 0
    for obj in net.sorted_objects:
        for code in obj._code_objects:
            block = getattr(code, "compiled_code", {}).get("run")
            main = getattr(block, "main", None)
            if main is None:
                continue
            namespace = code.namespace
            via += timeit.timeit(code, number=repeats) / repeats
            direct += timeit.timeit(lambda: main(namespace), number=repeats) / repeats
            n += 1
    print(f"{n} compiled code objects per step: {via * 1e6:.1f} us as Brian2 calls them, "
          f"{direct * 1e6:.1f} us calling their compiled main directly: Python dispatch "
          f"{(via - direct) * 1e6:.1f} us per step")


if __name__ == "__main__":
    main()
