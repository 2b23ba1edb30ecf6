"""A trial-step of the closed loop (CPG + A1, fixed weights) against MuJoCo's own step of the
same robot, one process, one core, steady state.

    python benchmarks/speed.py [--trials 1 20] [--codegen numpy cython] [--seconds 5]
                               [--mj-seconds 1] [--repeats 1] [--record] [--check-every N]
                               [--delays default authors] [--check-cost]
                               [--authors-command "CMD" --authors-seconds S]
                               [--runner lean brian2]

How it measures (so that the ratio holds on a machine whose speed drifts): one ``Network.run``
per point, after a 0.1 s warm-up. Every ``--every`` steps (128: two of the numpy target's noise
blocks of 64 steps in every stretch) a hook inside the run stops the loop's clock and times
MuJoCo's ``mj_step`` alone (:class:`Interleaved`), then starts the loop's clock again; the
loop's CPU time is taken over the stretches between these marks, so it leaves out
``Network.run``'s fixed cost per call and the timing itself. ``mj_step`` is timed on the
loop's own states: at each mark every trial's state is copied, set into a scratch MjData and
stepped once, the batch repeated (the cost of setting the states taken off). Beside it, as
earlier tables timed it, ``mj_step`` with held controls: hundreds of steps in a row from a copy
of one trial's state (the trials in turn), its controls held, the robot drifting away from the
loop's states (``constraints`` and ``iterations``: MuJoCo's ``nefc`` and solver iterations of a
step, loop / held, the held ones where each held run ends). Each is timed for ``--mj-seconds``
(at least 1 s) in all, spread evenly over the run. All figures are medians over their
stretches (a burst of other work on the machine lands in a few of them). ``x mj_step`` is a
trial-step's CPU time (the loop's per step divided by the trials) over ``mj_step``'s on the
loop's states; ``x held`` over the held-control figure. Goals:
2.0 x on Cython and 3.5 x on numpy at 20 trials (the floor of this design is about 1.7 x:
MuJoCo plus the compiled model with no Python at all).

``--repeats N`` measures every point N times (a new network each time, the points interleaved)
and prints the median and the spread of each column. Start-up (import, build, code generation,
first step) is reported apart: it is paid once per run. ``--record`` turns on what ``astrocpg
run`` records by default. ``--check-every 0`` turns the bridge's CPG divergence check off;
``--check-cost`` also times the divergence checks alone, as a share of the loop.
``--delays default authors`` measures each point with the built-in inter-limb delays (1 ms) and
with the authors' preset (``models/variants/interlimb_authors_delays.toml``). ``--runner lean
brian2`` measures each point with the step loop every run uses (``lean``: each step's compiled
code called directly, :mod:`astrocpg.network.runner`) and with Brian2's ``Network.run``
(``brian2``), the points interleaved.

``--authors-command`` runs a command that simulates ``--authors-seconds`` of one trial of the
authors' code (which astrocpg does not ship), parsed as a shell would split it (not run by a
shell), and times its CPU; the last table then gives both speeds side by side. Give two
durations and a ``{seconds}`` in the command (``--authors-command "python their_main.py
--seconds {seconds}" --authors-seconds 5 10``) to count their loop only: the slope between the
two runs leaves out their imports and set-up.
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
from astrocpg.studies.commands.simulate import add_monitors  # noqa: E402


class Interleaved:
    """A bridge hook (last of its stage) that, every ``every`` steps, closes a stretch of the
    loop's CPU and wall time and times MuJoCo's step alone, two ways:

    - **on the loop's states** (the ratio's denominator): every trial's state as the loop left
      it is copied, then each is set into a scratch MjData and stepped once, the batch repeated
      ``mj_steps // trials`` times (the cost of setting the states, timed the same way without
      the steps, taken off): MuJoCo's own cost for the very states the loop steps, its data
      warm in the cache;
    - **with held controls** (the figure of earlier tables): ``mj_steps`` steps in a row from a
      copy of one trial's state (the trials in turn), its controls held, so the robot drifts
      away from the loop's states for hundreds of steps.

    Stretches start at the first mark, so the run's fixed cost before its first steps is left
    out."""

    def __init__(self, bridge, every: int, mj_steps: int) -> None:
        import mujoco

        self.bridge, self.every, self.mj_steps = bridge, int(every), int(mj_steps)
        self.model = bridge.model
        self.scratch = mujoco.MjData(self.model)
        self.spec = mujoco.mjtState.mjSTATE_INTEGRATION
        size = mujoco.mj_stateSize(self.model, self.spec)
        self.rows = [np.empty(size) for _ in range(bridge.n_trials)]
        self.replays = max(3, self.mj_steps // bridge.n_trials)
        self.loop_cpu = self.loop_wall = self.mj_cpu = 0.0
        self.loop_steps = self.mj_total = self.marks = 0
        # per stretch: CPU s per step of the loop, and of mj_step alone (medians: a burst of
        # another process's work on the machine lands in a few stretches, not in the median)
        self.loop_chunks: list[float] = []
        self.mj_chunks: list[float] = []  # on the loop's states
        self.held_chunks: list[float] = []  # controls held, mj_steps in a row
        # MuJoCo's constraints (nefc) and solver iterations of a step: the loop's states, and
        # where each held run ends
        self.loop_work: list[tuple[int, int]] = []
        self.held_work: list[tuple[int, int]] = []
        self._cpu = self._wall = None
        self._at = 0

    def __call__(self) -> None:
        n = self.bridge.step_count
        if n % self.every:
            return
        import mujoco

        cpu, wall = time.process_time(), time.perf_counter()
        if self._cpu is not None:
            self.loop_cpu += cpu - self._cpu
            self.loop_wall += wall - self._wall
            self.loop_steps += n - self._at
            self.loop_chunks.append((cpu - self._cpu) / (n - self._at))
        model, scratch, spec = self.model, self.scratch, self.spec
        step, set_state, clock = mujoco.mj_step, mujoco.mj_setState, time.process_time
        for row, d in zip(self.rows, self.bridge.data):
            mujoco.mj_getState(model, d, row, spec)
            self.loop_work.append((int(d.nefc), int(d.solver_niter[0])))
        b = self.marks % self.bridge.n_trials
        self.marks += 1
        # controls held: mj_steps steps in a row from trial b's state
        set_state(model, scratch, self.rows[b], spec)
        c0 = clock()
        for _ in range(self.mj_steps):
            step(model, scratch)
        spent = clock() - c0
        self.held_chunks.append(spent / self.mj_steps)
        self.held_work.append((int(scratch.nefc), int(scratch.solver_niter[0])))
        # the loop's states: each trial's state set and stepped once, the batch repeated; the
        # same sets without the steps timed alike and taken off (medians over the repeats)
        stepped, set_only = [], []
        rows = self.rows
        for _ in range(self.replays):
            c0 = clock()
            for row in rows:
                set_state(model, scratch, row, spec)
                step(model, scratch)
            c1 = clock()
            for row in rows:
                set_state(model, scratch, row, spec)
            c2 = clock()
            stepped.append(c1 - c0)
            set_only.append(c2 - c1)
        per_step = (float(np.median(stepped)) - float(np.median(set_only))) / len(rows)
        self.mj_chunks.append(per_step)
        self.mj_cpu += spent + sum(stepped)
        self.mj_total += self.mj_steps + self.replays * len(rows)
        self._at, self._cpu, self._wall = n, time.process_time(), time.perf_counter()


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
            delays: str = "default", mj_seconds: float = 1.0, every: int = 128,
            mj_step_guess_us: float = 15.0, runner: str = "lean") -> dict[str, float]:
    """One point: the loop's steady-state cost per trial-step and MuJoCo's step, interleaved
    in one run (:class:`Interleaved`)."""
    t_start = time.perf_counter()
    loop = build_closed_loop(delay_models(delays), n_trials=n_trials, seed=1,
                             check_every=check_every, codegen=codegen)
    cpg = loop.cpg
    if record:  # what `astrocpg run` records by default: the robot, every spike and trace
        n = int(round((seconds + 0.1) / float(cpg.dt)))
        loop.bridge.start_recording(n, 1)
        add_monitors(cpg, 1 * ms, True, n_steps=n)
    lean = {"lean": True, "brian2": False}[runner]
    loop.run(0.1, lean=lean)  # code generation and first steps
    startup = time.perf_counter() - t_start
    steps = int(round(seconds / float(cpg.dt)))
    marks = max(1, steps // every)
    # MuJoCo timed for mj_seconds in all (at least), spread over the marks
    timer = Interleaved(loop.bridge, every,
                        max(200, int(mj_seconds * 1e6 / mj_step_guess_us / marks) + 1))
    loop.bridge.add_hook("after_physics", "benchmark", timer, order=1e9)
    loop.run(seconds, lean=lean)
    loop.bridge.remove_hook("benchmark")
    mj = float(np.median(timer.mj_chunks)) * 1e6
    held = float(np.median(timer.held_chunks)) * 1e6
    cpu_step = float(np.median(timer.loop_chunks))  # s per step
    per_trial_step_us = cpu_step / n_trials * 1e6
    sim = float(cpg.dt)
    out = {"trials": n_trials, "codegen": codegen, "mj_step_us": mj, "mj_seconds": timer.mj_cpu,
           "trial_step_us": per_trial_step_us, "x_mj_step": per_trial_step_us / mj,
           "mj_step_held_us": held, "x_mj_step_held": per_trial_step_us / held,
           "constraints_loop": float(np.mean([w[0] for w in timer.loop_work])),
           "constraints_held": float(np.mean([w[0] for w in timer.held_work])),
           "iterations_loop": float(np.mean([w[1] for w in timer.loop_work])),
           "iterations_held": float(np.mean([w[1] for w in timer.held_work])),
           "wall_per_sim_s": timer.loop_wall / timer.loop_steps / sim,
           "cpu_per_sim_s": cpu_step / sim, "cpu_per_trial": cpu_step / sim / n_trials,
           "startup_s": startup, "check_every": check_every, "runner": runner}
    if check_cost:
        out.update(_check_cost(loop, cpu_step))
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


def authors_speed(command: str, seconds: float | list[float]) -> float:
    """CPU seconds per simulated second of the authors' code, their loop only.

    ``command`` (split as a shell would, run without one) simulates one trial. With two
    durations (``seconds`` = [T1, T2]) and a ``{seconds}`` in the command, it runs for each and
    the cost is the slope (CPU(T2) - CPU(T1)) / (T2 - T1): their imports, network build and
    set-up, the same in both runs, cancel, so the figure counts their loop from their first
    session on, as astrocpg's per-step figures do. With one duration it is CPU / T, start-up
    included (which flatters astrocpg by that share)."""
    import resource
    import shlex
    import subprocess

    durations = [float(seconds)] if isinstance(seconds, (int, float)) else \
        [float(x) for x in seconds]
    if len(durations) == 2 and "{seconds}" not in command:
        raise SystemExit("two --authors-seconds need a command with {seconds} in it")

    def cpu(t: float) -> float:
        before = resource.getrusage(resource.RUSAGE_CHILDREN)
        subprocess.run(shlex.split(command.replace("{seconds}", f"{t:g}")), check=True,
                       stdout=subprocess.DEVNULL)
        after = resource.getrusage(resource.RUSAGE_CHILDREN)
        return (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)

    if len(durations) == 1:
        return cpu(durations[0]) / durations[0]
    (t1, t2) = sorted(durations)
    if not t2 > t1:
        raise SystemExit("--authors-seconds T1 T2 must differ")
    return (cpu(t2) - cpu(t1)) / (t2 - t1)


COLUMNS = ("CPU s/sim s", "per trial", "wall s/sim s", "trial-step us", "mj_step us",
           "x mj_step", "held us", "x held", "start-up s")
KEYS = ("cpu_per_sim_s", "cpu_per_trial", "wall_per_sim_s", "trial_step_us", "mj_step_us",
        "x_mj_step", "mj_step_held_us", "x_mj_step_held", "startup_s")


def _row(label: str, values: list[str]) -> str:
    return f"{label:<32}" + "".join(f"{v:>14}" for v in values)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--seconds", type=float, default=5.0, help="simulated s per point")
    ap.add_argument("--trials", type=int, nargs="+", default=[1, 20])
    ap.add_argument("--codegen", nargs="+", default=["numpy", "cython"],
                    choices=["numpy", "cython"], help="Brian2 targets, interleaved per point")
    ap.add_argument("--mj-seconds", type=float, default=1.0,
                    help="CPU seconds of mj_step timed alone per point, each way (on the "
                         "loop's states, with held controls; at least 1)")
    ap.add_argument("--every", type=int, default=128,
                    help="steps between two timings of mj_step inside the run")
    ap.add_argument("--repeats", type=int, default=1,
                    help="measure every point this many times (medians and spread)")
    ap.add_argument("--record", action="store_true",
                    help="also record spikes, traces and the robot, as `astrocpg run` does")
    ap.add_argument("--check-every", type=int, nargs="+", default=[10], metavar="N",
                    help="steps between CPG divergence checks (0: off)")
    ap.add_argument("--check-cost", action="store_true",
                    help="also time the divergence checks alone, as a share of the loop")
    ap.add_argument("--delays", nargs="+", default=["default"], choices=["default", "authors"],
                    help="inter-limb delays: built in (1 ms) and/or the authors' preset")
    ap.add_argument("--authors-command", default=None, metavar="CMD",
                    help="a command that runs --authors-seconds of the authors' code, one trial")
    ap.add_argument("--authors-seconds", type=float, nargs="+", default=None,
                    help="simulated s of the authors' run; two values (T1 T2) and {seconds} "
                         "in the command: their loop only, the slope between the two")
    ap.add_argument("--runner", nargs="+", default=["lean"], choices=["lean", "brian2"],
                    help="the step loop: lean (what every run uses) and/or Brian2's "
                         "Network.run, interleaved per point")
    ap.add_argument("--json", default=None, metavar="FILE",
                    help="also write every repeat of every point to FILE")
    args = ap.parse_args()
    if args.mj_seconds < 1.0:
        ap.error("--mj-seconds must be at least 1 (a shorter timing of mj_step drifts)")
    if (args.authors_command is None) != (args.authors_seconds is None):
        ap.error("--authors-command and --authors-seconds go together")
    import platform

    print(f"closed loop, {args.seconds:g} simulated s per point, mj_step timed "
          f"{args.mj_seconds:g} s per point, recording {'on' if args.record else 'off'}; "
          f"{platform.processor() or platform.machine()}, {os.cpu_count()} cores, affinity "
          f"{len(os.sched_getaffinity(0))}, {time.strftime('%Y-%m-%d')}")
    print(_row("point", list(COLUMNS)))
    points = [(n, every, target, delays, runner) for n in args.trials
              for every in args.check_every for target in args.codegen for delays in args.delays
              for runner in args.runner]
    results: dict[tuple, list[dict[str, float]]] = {p: [] for p in points}
    for _ in range(args.repeats):
        for point in points:
            n, every, target, delays, runner = point
            r = measure(n, args.seconds, args.record, every, args.check_cost, target, delays,
                        mj_seconds=args.mj_seconds, every=args.every, runner=runner)
            results[point].append(r)
            print(_row(_label(point, args), [f"{r[k]:.3f}" if k.endswith("s") and "us" not in k
                                             else f"{r[k]:.2f}" for k in KEYS]), flush=True)
            if args.check_cost:
                print(f"{'':>6} divergence checks: robot {r['robot_check_us']:.2f} us every "
                      f"step, CPG {r['cpg_check_us']:.1f} us every {r['every']} steps, loop "
                      f"{r['loop_us']:.0f} us CPU per step: {100 * r['check_share']:.2f}% "
                      f"of the loop", flush=True)
    authors = None
    if args.authors_command:
        authors = authors_speed(args.authors_command, args.authors_seconds)
    print()
    print("side by side (medians" + (f" of {args.repeats} repeats; spread = max/min - 1"
                                     if args.repeats > 1 else "") + "):")
    head = ["trial-step us", "mj_step us", "x mj_step", "goal x", "x held", "constraints",
            "iterations", "s/sim s/trial"]
    if args.repeats > 1:
        head.append("spread x")
    if authors is not None:
        head.append("x authors")
    print(_row("point", head))
    for point, rs in results.items():
        med = {k: float(np.median([r[k] for r in rs])) for k in KEYS}
        goal = {"cython": 2.0, "numpy": 3.5}[point[2]] if point[0] >= 16 else None
        cells = [f"{med['trial_step_us']:.1f}", f"{med['mj_step_us']:.1f}",
                 f"{med['x_mj_step']:.2f}", "" if goal is None else f"{goal:.1f}",
                 f"{med['x_mj_step_held']:.2f}",
                 "{:.0f} / {:.0f}".format(*(np.median([r[k] for r in rs]) for k in
                                            ("constraints_loop", "constraints_held"))),
                 "{:.1f} / {:.1f}".format(*(np.median([r[k] for r in rs]) for k in
                                            ("iterations_loop", "iterations_held"))),
                 f"{med['cpu_per_trial']:.4f}"]
        if args.repeats > 1:
            xs = [r["x_mj_step"] for r in rs]
            cells.append(f"{100 * (max(xs) / min(xs) - 1):.1f}%")
        if authors is not None:
            cells.append(f"{authors / med['cpu_per_trial']:.1f}")
        print(_row(_label(point, args), cells))
    if args.json:
        import json
        import sys

        Path(args.json).write_text(json.dumps({
            "benchmark": "speed", "argv": sys.argv, "date": time.strftime("%Y-%m-%d %H:%M"),
            "cpu_count": os.cpu_count(), "load_average": list(os.getloadavg()),
            "seconds": args.seconds, "authors_cpu_per_sim_s": authors,
            "points": [{"label": _label(point, args), "trials": point[0], "codegen": point[2],
                        "runner": point[4], "repeats": rs}
                       for point, rs in results.items()]}, indent=1))
    if authors is not None:
        print(f"authors' code: {authors:.3f} CPU s per simulated s (one trial"
              + (", their loop only: slope between two durations)"
                 if len(args.authors_seconds) == 2 else ", start-up included)"))


def _label(point: tuple, args: argparse.Namespace) -> str:
    n, every, target, delays, runner = point
    label = f"{target} {n} trial{'s' if n > 1 else ''}"
    if len(args.check_every) > 1:
        label += f" check {every or 'off'}"
    if len(args.delays) > 1:
        label += f" {delays} delays"
    if len(args.runner) > 1:
        label += f" {runner}"
    return label


if __name__ == "__main__":
    main()
