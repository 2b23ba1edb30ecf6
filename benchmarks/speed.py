"""Wall seconds per simulated second of the closed loop (CPG + A1, fixed weights), numpy target,
one core, for 1, 4 and 16 trials batched in one network.

    python benchmarks/speed.py [--seconds 5] [--trials 1 4 16] [--record] [--check-every N]
                               [--codegen numpy cython]

Targets (issue 2): <= 1.2 s per simulated second for one trial, <= 0.2 s per trial at 16.
Start-up (import, build, code generation, first step) is reported apart: it is paid once per run.
Pin to one core with ``taskset -c 0`` for a one-core figure; the script also reports CPU time.
``--check-every 0`` turns the bridge's CPG divergence check off (the robot's is always on), to
measure what the check costs: ``--check-every 10 0`` measures both, interleaved. On a loaded
machine the difference drowns in noise; ``--check-cost`` also times the divergence checks
themselves in the same process (the robot's every step, the CPG's every N steps) and gives them
as a share of the loop's CPU time per step. ``--codegen numpy cython`` measures each trial count
under both Brian2 targets (Cython's first build compiles for minutes; later ones load the
cache). Each point also times MuJoCo's own step of the same robot in the same process, and
gives a trial-step's cost as a multiple of it (issue 13's goal: 1.5 x at 16-20 trials).
``--delays default authors`` measures each point with the built-in inter-limb delays (1 ms, one
stage) and with the authors' preset (``models/variants/interlimb_authors_delays.toml``: the limbs
integrate in four stages, each with its own motor-neuron group and synapses), interleaved.
"""

from __future__ import annotations

import argparse
import os
import time
from pathlib import Path

os.environ.setdefault("OMP_NUM_THREADS", "1")
os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

import numpy as np  # noqa: E402
from brian2 import ms  # noqa: E402

from astrocpg.coupling.assembly import build_closed_loop  # noqa: E402
from astrocpg.models import DEFAULT_MODELS  # noqa: E402
from astrocpg.studies.experiments.simulate import add_monitors  # noqa: E402


def mj_step_us(model, data, steps: int = 3000) -> float:
    """MuJoCo's step of this robot alone (us, wall), from a copy of a trial's state."""
    import mujoco

    d = mujoco.MjData(model)
    spec = mujoco.mjtState.mjSTATE_INTEGRATION
    state = np.empty(mujoco.mj_stateSize(model, spec))
    mujoco.mj_getState(model, data, state, spec)
    mujoco.mj_setState(model, d, state, spec)
    t = time.perf_counter()
    for _ in range(steps):
        mujoco.mj_step(model, d)
    return (time.perf_counter() - t) / steps * 1e6


AUTHORS = Path(__file__).resolve().parents[1] / "models" / "variants" \
    / "interlimb_authors_delays.toml"


def delay_models(delays: str):
    """The model set of a ``--delays`` choice."""
    if delays == "default":
        return DEFAULT_MODELS
    from astrocpg.models.compose import model_set
    return model_set(models={"interlimb_synapse": AUTHORS.read_text()})


def measure(n_trials: int, seconds: float, record: bool, check_every: int = 10,
            check_cost: bool = False, codegen: str = "numpy",
            delays: str = "default") -> dict[str, float]:
    t_start = time.perf_counter()
    loop = build_closed_loop(delay_models(delays), n_trials=n_trials, seed=1, check_every=check_every,
                             codegen=codegen)
    cpg = loop.cpg
    if record:
        loop.bridge.start_recording(int(seconds * 1000) + 200, 1)
        add_monitors(cpg, 1 * ms, True)
    loop.run(0.1)  # code generation and first steps
    startup = time.perf_counter() - t_start
    w0, c0 = time.perf_counter(), time.process_time()
    loop.run(seconds)
    wall, cpu = time.perf_counter() - w0, time.process_time() - c0
    mj = mj_step_us(loop.bridge.model, loop.bridge.data[0])
    per_trial_step_us = wall / seconds / n_trials * 1e3  # 1 ms steps: s per sim s -> us per step
    out = {"trials": n_trials, "codegen": codegen, "mj_step_us": mj,
           "trial_step_us": per_trial_step_us, "x_mj_step": per_trial_step_us / mj,
           "wall_per_sim_s": wall / seconds,
           "cpu_per_sim_s": cpu / seconds, "wall_per_trial": wall / seconds / n_trials,
           "startup_s": startup, "check_every": check_every}
    if check_cost:
        out.update(_check_cost(loop, cpu / (seconds / float(cpg.dt))))
    return out


def _check_cost(loop, cpu_per_step: float, calls: int = 3000) -> dict[str, float]:
    """CPU seconds of the divergence checks per step, timed in this process, interleaved."""
    bridge, cpg = loop.bridge, loop.cpg
    robot = cpg_check = 0.0
    for _ in range(5):
        c0 = time.process_time()
        for _ in range(calls):
            bridge._robot_unstable()
        c1 = time.process_time()
        for _ in range(calls // 10):
            cpg.first_invalid()
        c2 = time.process_time()
        robot += (c1 - c0) / (5 * calls)
        cpg_check += (c2 - c1) / (5 * (calls // 10))
    every = bridge.check_every or 10
    share = (robot + cpg_check / every) / cpu_per_step
    return {"loop_us": cpu_per_step * 1e6, "robot_check_us": robot * 1e6,
            "cpg_check_us": cpg_check * 1e6, "check_share": share, "every": every}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--seconds", type=float, default=5.0)
    ap.add_argument("--trials", type=int, nargs="+", default=[1, 4, 16])
    ap.add_argument("--record", action="store_true",
                    help="also record spikes, Ca2+/astrocyte traces and the robot every step")
    ap.add_argument("--check-every", type=int, nargs="+", default=[10], metavar="N",
                    help="steps between CPG divergence checks (0: off); several values are "
                         "measured one after the other for each trial count")
    ap.add_argument("--check-cost", action="store_true",
                    help="also time the divergence checks alone, as a share of the loop")
    ap.add_argument("--codegen", nargs="+", default=["numpy"], choices=["numpy", "cython"],
                    help="Brian2 targets to measure, interleaved per trial count")
    ap.add_argument("--delays", nargs="+", default=["default"], choices=["default", "authors"],
                    help="inter-limb delays: built in (1 ms) and/or the authors' preset, "
                         "interleaved per trial count")
    args = ap.parse_args()
    print(f"closed loop, {args.seconds:g} simulated s per point, "
          f"recording {'on' if args.record else 'off'}")
    print(f"{'delays':>8} {'target':>7} {'trials':>6} {'check':>6} {'wall s/sim s':>13} {'per trial':>10} "
          f"{'CPU s/sim s':>12} {'start-up s':>11} {'trial-step us':>14} {'mj_step us':>11} "
          f"{'x mj_step':>10}")
    for n in args.trials:
        for every in args.check_every:
            for target, delays in [(t, d) for t in args.codegen for d in args.delays]:
                r = measure(n, args.seconds, args.record, every, args.check_cost, target, delays)
                check = str(every) if every else "off"
                print(f"{delays:>8} {target:>7} {r['trials']:>6} {check:>6} {r['wall_per_sim_s']:>13.3f} "
                      f"{r['wall_per_trial']:>10.3f} {r['cpu_per_sim_s']:>12.3f} "
                      f"{r['startup_s']:>11.1f} {r['trial_step_us']:>14.1f} "
                      f"{r['mj_step_us']:>11.1f} {r['x_mj_step']:>10.2f}", flush=True)
            if args.check_cost:
                print(f"{'':>6} divergence checks: robot {r['robot_check_us']:.2f} us every "
                      f"step, CPG {r['cpg_check_us']:.1f} us every {r['every']} steps, loop "
                      f"{r['loop_us']:.0f} us CPU per step: {100 * r['check_share']:.2f}% "
                      f"of the loop", flush=True)


if __name__ == "__main__":
    main()
