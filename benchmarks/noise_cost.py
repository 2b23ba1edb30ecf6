"""What the noise costs within a step of the closed loop, with the framework's counter-based
streams and with Brian2's own generator (what astrocpg used before the streams), per Brian2
target and batch size.

    python benchmarks/noise_cost.py [--seconds 2] [--trials 1 20] [--codegen numpy cython]
                                    [--rounds 3]

Two measurements, each the median of ``--rounds`` interleaved rounds of CPU time:

* the closed loop's step (CPG + A1, untrained weights), drawing with either generator;
* the draws of one step alone: groups of the network's size (two draws per motor neuron,
  one per interneuron, per trial) evaluating ``x = rand()`` each step against the same groups
  evaluating ``x = 0.5 + 1e-20*i`` (the same code objects, a number per element, no draw);
  the difference is what the draws cost.

The noise's share of a step is the second over the first.
"""

from __future__ import annotations

import argparse
import os
import statistics
import time

os.environ.setdefault("OMP_NUM_THREADS", "1")
os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

import brian2  # noqa: E402
import numpy as np  # noqa: E402
from brian2 import ms  # noqa: E402

from astrocpg.coupling.assembly import build_closed_loop  # noqa: E402
from astrocpg.models import DEFAULT_MODELS  # noqa: E402
from astrocpg.network import noise  # noqa: E402
from astrocpg.network.layout import Layout  # noqa: E402

MODES = ("streams", "brian")


def step_us(mode: str, n_trials: int, seconds: float, codegen: str) -> float:
    """CPU microseconds per 1 ms step of a ``n_trials`` closed loop drawing with ``mode``."""
    noise.DRAWS = mode
    try:
        loop = build_closed_loop(DEFAULT_MODELS, n_trials=n_trials, seed=1, codegen=codegen)
    finally:
        noise.DRAWS = "streams"
    loop.run(0.1)  # code generation and first steps
    c0 = time.process_time()
    loop.run(seconds)
    return (time.process_time() - c0) / (seconds * 1000) * 1e6


def draws_us(mode: str, n_trials: int, steps: int, codegen: str) -> float:
    """CPU microseconds per step of the network's draws alone (``mode``: streams or brian)."""
    layout = Layout(n_trials=n_trials, pool_size=int(DEFAULT_MODELS.value("pool_size")))
    cls = brian2.CythonCodeObject if codegen == "cython" else brian2.NumpyCodeObject
    seeds = list(range(1, n_trials + 1))
    offset = np.zeros(1, dtype=np.int64)

    def groups(value: str) -> brian2.Network:
        net = brian2.Network()
        for name, per, n_draws in (("motor", layout.motor_per_trial, 2),
                                   ("interneuron", layout.interneurons_per_trial, 1)):
            draws = noise.Rewriter(name)
            eqs = "\n".join(f"x{k} = {value} : 1 (constant over dt)" for k in range(n_draws))
            code = draws(eqs) if mode == "streams" else eqs
            namespace = {}
            if draws.sites:
                seed, cell = noise.trial_major(np.arange(per * n_trials), per, seeds)
                namespace = draws.bind(seed, cell, per, offset).functions
            net.add(brian2.NeuronGroup(per * n_trials, code, namespace=namespace, dt=1 * ms,
                                       codeobj_class=cls))
        return net

    spent = {}
    for value in ("rand()", "0.5 + 1e-20*i"):
        net = groups(value)
        net.run(10 * ms)  # code generation
        c0 = time.process_time()
        net.run(steps * ms)
        spent[value] = (time.process_time() - c0) / steps * 1e6
    return spent["rand()"] - spent["0.5 + 1e-20*i"]


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--seconds", type=float, default=2.0)
    ap.add_argument("--trials", type=int, nargs="+", default=[1, 20])
    ap.add_argument("--codegen", nargs="+", default=["numpy", "cython"],
                    choices=["numpy", "cython"])
    ap.add_argument("--rounds", type=int, default=3)
    args = ap.parse_args()
    brian2.prefs.codegen.target = "numpy"
    print("| target | trials | step, streams (us) | draws, streams (us) | share | step, Brian2's "
          "rand (us) | draws, Brian2's rand (us) | share |")
    print("|---|---|---|---|---|---|---|---|")
    for codegen in args.codegen:
        brian2.prefs.codegen.target = codegen
        for n in args.trials:
            step: dict[str, list[float]] = {m: [] for m in MODES}
            draw: dict[str, list[float]] = {m: [] for m in MODES}
            for _ in range(args.rounds):
                for mode in MODES:  # interleaved: a drift of the machine hits both
                    step[mode].append(step_us(mode, n, args.seconds, codegen))
                    draw[mode].append(draws_us(mode, n, int(args.seconds * 1000), codegen))
            s = {m: statistics.median(v) for m, v in step.items()}
            d = {m: max(0.0, statistics.median(v)) for m, v in draw.items()}
            print(f"| {codegen} | {n} | {s['streams']:.0f} | {d['streams']:.1f} | "
                  f"{d['streams'] / s['streams']:.1%} | {s['brian']:.0f} | {d['brian']:.1f} | "
                  f"{d['brian'] / s['brian']:.1%} |", flush=True)


if __name__ == "__main__":
    main()
