"""Where a step of the closed loop goes: Brian2's per-object profile and Python's cProfile of
one run of the CPG + A1 at a trial count: what stands between a trial-step and 2.0 x MuJoCo's
step.

    python benchmarks/profile_step.py [--trials 20] [--seconds 2] [--codegen cython]

Prints the wall seconds per simulated second (the profilers add overhead), Brian2's time per
code object (``Network.run(profile=True)``) and the functions with the most own time
(MuJoCo's ``mj_step``, Brian2's per-step loop, the bridge).

``--dispatch`` also splits a step into its parts, each timed in this process with the others
interleaved (blocks of steps in turn; the minimum over the blocks of each, so the load of other
processes on the machine drops out):

* the Brian2 code objects of one step (all scheduled objects but the network operations)
  called as ``Network.run`` calls them (``obj.run()`` -> ``codeobj()`` -> ``run_block``), as the
  lean runner calls them (:mod:`astrocpg.network.runner`: each compiled ``main(namespace)`` or
  ``exec`` directly), and their compiled code alone (Cython's ``main(namespace)``; numpy's
  ``exec``, the numpy code being Python itself). Each is repeated on the same state, so the
  figures are per call, not a simulation;
* whole steps of the closed loop with each runner (``Network.run`` and the lean one), CPU time
  between the first and the last step of a run (the run's start-up left out), and MuJoCo's
  ``mj_step`` alone on a copy of one trial's state;
* the Python of a step: whole steps with every code object's compiled code and the physics
  replaced by no-ops, so that what is left is the Python the step runs (the runner, the
  network operations, the bridge and its numpy calls on arrays of the trials' sizes; on the
  numpy target the generated code, Python too, counts as compiled code here). The
  compiled code and the physics cost more inside the loop than timed alone (cold caches, the
  spikes of a running network): the whole step's figure says how much;
* the step with the robots' compiled physics a no-op (the robots frozen): the network and the
  Python as they cost inside the loop, and by difference the physics inside the loop. Less
  the Python of a step, the whole step is what this design costs with no Python at all.
"""

from __future__ import annotations

import argparse
import cProfile
import os
import pstats
import time

import numpy as np

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
                    help="also split a step: Brian2's and the lean runner's dispatch, the "
                         "compiled code, MuJoCo and the rest (Python)")
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
        dispatch(loop)


def _blocks(timers: dict, rounds: int = 30, per_block: int = 40) -> dict[str, float]:
    """CPU s per call of each timer (a function of no argument), the timers in turn in blocks of
    ``per_block`` calls, ``rounds`` times: the fastest block of each."""
    best = {name: float("inf") for name in timers}
    for _ in range(rounds):
        for name, fn in timers.items():
            c0 = time.process_time()
            for _ in range(per_block):
                fn()
            best[name] = min(best[name], (time.process_time() - c0) / per_block)
    return best


def dispatch(loop, seconds: float = 0.25, rounds: int = 6) -> None:
    """Per step: the code objects as Brian2 and as the lean runner call them against their
    compiled code alone; then the whole step with each runner against MuJoCo's steps."""
    import mujoco
    from brian2 import NetworkOperation

    from astrocpg.network.runner import step_calls

    net = loop.cpg.net
    objects = [o for o in net.sorted_objects if o.active and not isinstance(o, NetworkOperation)]
    lean_calls, owners = step_calls(objects)
    compiled = []  # the compiled code alone: Cython's main(namespace), numpy's exec
    for owner in owners:
        if owner is None:  # called as Brian2 calls it (a namespace to refresh): left out
            continue
        block = owner.compiled_code["run"]
        main = getattr(block, "main", None)
        compiled.append((main, (owner.namespace,)) if main is not None
                        else (exec, (block, owner.namespace)))

    def via_brian2() -> None:
        for obj in objects:
            obj.run()

    def via_lean() -> None:
        for call in lean_calls:
            call()

    def alone() -> None:
        for fn, args in compiled:
            fn(*args)

    code = _blocks({"brian2": via_brian2, "lean": via_lean, "compiled": alone})
    n = len(lean_calls)
    print(f"{n} code objects per step (CPU us per step, fastest of 30 interleaved blocks): as "
          f"Brian2 calls them {code['brian2'] * 1e6:.1f}, as the lean runner calls them "
          f"{code['lean'] * 1e6:.1f}, their compiled code alone {code['compiled'] * 1e6:.1f}: "
          f"dispatch {(code['brian2'] - code['compiled']) * 1e6:.1f} us through Brian2, "
          f"{(code['lean'] - code['compiled']) * 1e6:.1f} us lean")
    steps = _whole_steps(loop, seconds, rounds)
    # last, as they move the robots on: every trial's physics step, and the bridge's whole step
    bridge = loop.bridge
    parts = _blocks({"physics": bridge.robots.physics, "bridge": bridge.step}, per_block=20)
    scratch = mujoco.MjData(bridge.model)
    spec = mujoco.mjtState.mjSTATE_INTEGRATION
    state = np.empty(mujoco.mj_stateSize(bridge.model, spec))
    mujoco.mj_getState(bridge.model, bridge.data[0], state, spec)
    mujoco.mj_setState(bridge.model, scratch, state, spec)
    mj = _blocks({"mj_step": lambda: mujoco.mj_step(bridge.model, scratch)}, per_block=400)
    mj_us, trials = mj["mj_step"] * 1e6, loop.n_trials
    physics, bridge_py = parts["physics"] * 1e6, (parts["bridge"] - parts["physics"]) * 1e6
    print(f"physics of the {trials} trials {physics:.1f} us (mj_step alone on one trial "
          f"{mj_us:.1f} us); the bridge's step around it {bridge_py:.1f} us (its Python and "
          f"numpy calls)")
    python_alone = _python_alone(loop, seconds, rounds)
    for runner in ("brian2", "lean"):
        print(f"Python of a step, {runner:>6} runner (the compiled code and the physics "
              f"replaced by no-ops): {python_alone[runner] * 1e6:.1f} us")
    without_physics = _without_physics(loop, seconds, rounds)
    for runner in ("brian2", "lean"):
        step_us = steps[runner] * 1e6
        alone = physics + code["compiled"] * 1e6 + python_alone[runner] * 1e6
        print(f"whole step, {runner:>6} runner: {step_us:.1f} us = physics {physics:.1f} + "
              f"compiled Brian2 code {code['compiled'] * 1e6:.1f} + Python "
              f"{python_alone[runner] * 1e6:.1f} (each timed alone) + {step_us - alone:.1f} "
              f"(what the compiled parts cost more inside the loop: cold caches, spikes); "
              f"{step_us / trials / mj_us:.2f} x mj_step per trial-step")
    if without_physics is not None:
        lean, python = steps["lean"] * 1e6, python_alone["lean"] * 1e6
        in_loop = lean - without_physics * 1e6
        print(f"inside the loop (lean runner): the physics of the {trials} trials {in_loop:.1f} us "
              f"({in_loop / trials / mj_us:.2f} x mj_step per trial), the network and the "
              f"Python {without_physics * 1e6:.1f} us (the step with the physics a no-op); "
              f"with no Python at all a trial-step would still cost "
              f"{(lean - python) / trials / mj_us:.2f} x mj_step")


def _python_alone(loop, seconds: float, rounds: int) -> dict[str, float]:
    """CPU s per step of the closed loop with every Brian2 code object's compiled code and the
    robots' physics replaced by no-ops: what is left is the Python the step runs (the runner,
    the network operations, the bridge and its numpy calls on arrays of the trials' sizes).
    Everything is put back afterwards."""
    from types import SimpleNamespace

    from brian2 import Network

    def noop(*args) -> None:
        return None

    empty = compile("", "(string)", "exec")
    swapped: list = []
    net = loop.cpg.net

    def stub_after_before_run(namespace) -> None:
        # each run makes its code objects anew in before_run: stub those the loop will call
        Network.before_run(net, namespace)
        for obj in net.sorted_objects:
            for codeobj in getattr(obj, "_code_objects", ()):
                blocks = codeobj.compiled_code
                if blocks.get("run"):
                    swapped.append((blocks, blocks["run"]))
                    blocks["run"] = (SimpleNamespace(main=noop) if hasattr(blocks["run"], "main")
                                     else empty)

    robots = loop.bridge.robots
    physics = robots._compiled
    if physics is not None:
        robots._compiled = lambda: 0
    net.before_run = stub_after_before_run
    try:
        return _whole_steps(loop, seconds, rounds)
    finally:
        del net.before_run
        for blocks, block in reversed(swapped):
            blocks["run"] = block
        robots._compiled = physics


def _without_physics(loop, seconds: float, rounds: int) -> float | None:
    """CPU s per step of the closed loop (lean runner) with the robots' compiled physics a
    no-op, the robots frozen: the network and the Python as they cost inside the loop. None
    where the physics is not compiled (stepped from Python, it cannot be stubbed alone)."""
    robots = loop.bridge.robots
    physics = robots._compiled
    if physics is None:
        return None
    robots._compiled = lambda: 0
    try:
        marks: list[float] = []
        from brian2 import NetworkOperation

        net = loop.cpg.net
        op = NetworkOperation(lambda: marks.append(time.process_time()), clock=loop.cpg.clock,
                              when="start", name="profile_step_marks_frozen")
        net.add(op)
        best = float("inf")
        try:
            for _ in range(rounds):
                marks.clear()
                loop.run(seconds, lean=True)
                best = min(best, (marks[-1] - marks[0]) / (len(marks) - 1))
        finally:
            net.remove(op)
        return best
    finally:
        robots._compiled = physics


def _whole_steps(loop, seconds: float, rounds: int) -> dict[str, float]:
    """CPU s per step of the closed loop with each runner: runs of ``seconds`` in turn,
    ``rounds`` times, timed between their first and last step; the fastest run of each."""
    from brian2 import NetworkOperation

    marks: list[float] = []
    net = loop.cpg.net
    op = NetworkOperation(lambda: marks.append(time.process_time()), clock=loop.cpg.clock,
                          when="start", name="profile_step_marks")
    net.add(op)
    best = {"brian2": float("inf"), "lean": float("inf")}
    try:
        for _ in range(rounds):
            for runner in best:
                marks.clear()
                loop.run(seconds, lean=runner == "lean")
                best[runner] = min(best[runner], (marks[-1] - marks[0]) / (len(marks) - 1))
    finally:
        net.remove(op)
    return best


if __name__ == "__main__":
    main()
