"""What a training step costs against a fixed-weight step of the same batch, in one process.

    python benchmarks/training_cost.py [--trials 20] [--seconds 2] [--codegen cython]
        [--repeats 3] [--seed 1] [--json docs/benchmarks/training_cost.json]

Two closed loops of the same batch are built in this process, each with
:func:`astrocpg.coupling.assembly.build_closed_loop` as ``astrocpg run`` and ``astrocpg train``
build theirs (the same network, astrocytes on, the same robots, seed and Brian2 target):

- **fixed**: the closed loop alone, inter-limb weights zero and fixed. The plasticity's
  compiled code runs as in every closed loop (``interlimb_learning``: the learning flag is 0,
  so no weight moves), nothing is recorded: what ``astrocpg run`` steps, its recording aside.
- **training**: the same loop with the training's session loop
  (:class:`astrocpg.studies.commands.trainer.Trainer`, as ``astrocpg train`` builds it, no
  sessions recorded): rewards and the learning flag every step, the spike counts of
  interneurons and astrocytes, session ends (a row, the trial's reset, fallen robots
  included), session starts remembered, ``sessions.csv``, ``weights.npz``, the checkpoint and
  the manifest written as the training writes them (a temporary folder).

They run interleaved, fixed then training, ``--repeats`` times, each run ``--seconds`` of
simulated time continuing where the last one stopped (the training trains on: sessions end
and start as they do in a real training's first minutes). The figure is the CPU time of this
process (``time.process_time``: other programs on the machine count less, though sharing a
core slows a run) from the first step of a run to its last, per simulated trial-second: the
start of ``Network.run`` (about 0.3 s a call, the same for both) is left out. ``ratio`` is
training over fixed; the median of the repeats is the figure, the least and the spread
beside it.

The two loops do not do the same model work: the fixed loop's robots fall and stay down
(MuJoCo's step costs more with a torso on the ground) and its network spikes otherwise, while
the training resets its fallen robots. So beside ``ratio``: ``same physics``, the ratio had the
training's MuJoCo step cost what the fixed loop's did (CPU timers around MuJoCo's step in both),
and the breakdown's sum of what the training adds, as a share of the fixed step: the cost of
the training step that is not the closed loop's own work.

The breakdown (a further, instrumented run of the training) says what the training adds: CPU
timers around the session loop's step (without the session ends), the session ends (the
trial's reset of CPG and robot, the row), the session starts remembered, the spike counts, the
checkpoint and rows (written only every so often: at most 2 % of the wall time), and the
learning rule's compiled code (which the fixed loop runs too), each per simulated
trial-second and as a share of the fixed step. A first unmeasured run of each loop builds (or
finds) the Cython extensions.
"""

from __future__ import annotations

import argparse
import datetime
import json
import os
import platform
import shlex
import sys
import tempfile
import time
from collections import defaultdict
from pathlib import Path
from typing import Any, Callable

os.environ.setdefault("OMP_NUM_THREADS", "1")

import numpy as np  # noqa: E402

sys.path.insert(0, str(Path(__file__).resolve().parent))
from recorded_run_cost import git_commit, versions  # noqa: E402

#: sessions per trial of the benchmark's training: more than it can finish
SESSIONS = 100_000


class Stopwatch:
    """A network operation at the start of every step: the CPU time of this process at the
    first step of a run and at its last (the same Python call in both loops)."""

    def __init__(self) -> None:
        self.first: float | None = None
        self.last = 0.0
        self.steps = 0

    def __call__(self) -> None:
        now = time.process_time()
        if self.first is None:
            self.first = now
        self.last = now
        self.steps += 1

    def start(self) -> None:
        self.first, self.steps = None, 0

    def per_step(self) -> float:
        """CPU seconds per step between the first step's start and the last step's start."""
        return (self.last - self.first) / (self.steps - 1)


def add_stopwatch(net: Any, clock: Any) -> Stopwatch:
    from brian2 import NetworkOperation

    watch = Stopwatch()
    net.add(NetworkOperation(watch, clock=clock, when="start", order=-1_000_000,
                             name="benchmark_stopwatch"))
    return watch


def build_fixed(models: Any, args: argparse.Namespace) -> Any:
    from astrocpg.coupling.assembly import build_closed_loop

    return build_closed_loop(models, n_trials=args.trials, seed=args.seed, codegen=args.codegen)


def build_training(models: Any, args: argparse.Namespace, out: Path) -> Any:
    """A Trainer as ``astrocpg train`` builds and runs it (the manifest after every
    checkpoint), ready for ``Network.run`` on its own."""
    from astrocpg.studies.runtime.progress import Bar
    from astrocpg.studies.commands.train_files import TRAIN_FILES
    from astrocpg.studies.commands.trainer import Trainer
    from astrocpg.studies.settings import TrainSettings
    from astrocpg.studies.outputs.writing import write_manifest

    settings = TrainSettings(n_sessions=SESSIONS, seed=args.seed, n_trials=args.trials,
                             astrocytes=True)
    trainer = Trainer(models, settings, out, progress=False)
    if trainer.cpg.codegen != args.codegen:
        sys.exit(f"the training was built for {trainer.cpg.codegen}, not {args.codegen}")
    out.mkdir(parents=True, exist_ok=True)
    trainer.bar = Bar(total=SESSIONS * args.trials, unit="session", disable=True)
    manifest = dict(command="train", seed=settings.seed,
                    settings=settings.record() | {"record": None},
                    models_json=trainer.models.to_json(), files=TRAIN_FILES,
                    invocation={"sessions": settings.n_sessions})

    def progress_manifest() -> None:
        write_manifest(out, **manifest, results={
            "status": "running", "sessions_done": trainer.training.sessions_done.tolist()},
            history=True)

    write_manifest(out, **manifest, results={"status": "running"}, history=True)
    trainer.on_checkpoint = progress_manifest
    return trainer


def run_cpu(net: Any, watch: Stopwatch, seconds: float) -> float:
    """CPU seconds per step of one ``Network.run`` of ``seconds`` (its start left out)."""
    from brian2 import second

    from astrocpg.network import run_network

    watch.start()
    run_network(net, seconds * second, namespace={})
    return watch.per_step()


class Timers:
    """CPU seconds (``time.process_time``) spent in wrapped callables, by label."""

    def __init__(self) -> None:
        self.cpu: dict[str, float] = defaultdict(float)
        self.calls: dict[str, int] = defaultdict(int)

    def wrap(self, label: str, fn: Callable[..., Any]) -> Callable[..., Any]:
        cpu, calls, clock = self.cpu, self.calls, time.process_time

        def timed(*a: Any, **k: Any) -> Any:
            t0 = clock()
            try:
                return fn(*a, **k)
            finally:
                cpu[label] += clock() - t0
                calls[label] += 1
        return timed


def instrument(trainer: Any, timers: Timers) -> None:
    """Timers around what the training adds to the closed loop (and the learning rule's
    compiled code, which both loops run)."""
    from astrocpg.coupling.bridge import ORDER_TRAINING

    tr, bridge, cpg = trainer.training, trainer.bridge, trainer.cpg
    bridge.remove_hook("training")
    bridge.add_hook("after_physics", "training", timers.wrap("session loop, per step", tr.step),
                    order=ORDER_TRAINING)
    tr._finish = timers.wrap("session ends", tr._finish)
    # inside a session end
    from astrocpg.coupling import session
    session.reset_trial = timers.wrap("session ends: CPG reset", session.reset_trial)
    bridge.reset_trial = timers.wrap("session ends: robot reset", bridge.reset_trial)
    tr._row = timers.wrap("session ends: row", tr._row)
    tr._plan_session = timers.wrap("session ends: next session planned", tr._plan_session)
    tr.on_session = timers.wrap("session ends: progress bar", tr.on_session)
    for obj in cpg.net.objects:
        label = {"session_starts": "session starts remembered",
                 "checkpoint": "checkpoint and rows written",
                 "count_interneuron": "spike counts (interneurons)",
                 "count_astrocyte": "spike counts (astrocytes)"}.get(obj.name)
        if obj.name.startswith("interlimb_learning"):
            label = "learning rule (compiled; the fixed loop runs it too)"
        if label is not None:
            object.__setattr__(obj, "run", timers.wrap(label, obj.run))


def breakdown(trainer: Any, watch: Stopwatch, seconds: float, trials: int,
              fixed_per_trial_s: float, train_per_trial_s: float) -> dict[str, Any]:
    """One instrumented run of the training: CPU per simulated trial-second of each part."""
    timers = Timers()
    instrument(trainer, timers)
    sessions_before = len(trainer.training.memory.rows)
    per_step = run_cpu(trainer.cpg.net, watch, seconds)
    steps = watch.steps
    trial_s = steps * float(trainer.cpg.dt) * trials
    # the session ends are inside the session loop's step
    timers.cpu["session loop, per step"] -= timers.cpu["session ends"]
    parts = {}
    for label in sorted(timers.cpu, key=lambda k: -timers.cpu[k]):
        per = timers.cpu[label] / trial_s
        parts[label] = {"ms_per_trial_s": round(1e3 * per, 3),
                        "share_of_fixed": round(per / fixed_per_trial_s, 4),
                        "calls": timers.calls[label]}
    added = [k for k in parts if not k.startswith(("session ends:", "learning rule"))]
    return {"seconds": seconds, "sessions_ended": len(trainer.training.memory.rows)
            - sessions_before,
            "instrumented_ms_per_trial_s": round(1e3 * per_step / (float(trainer.cpg.dt)
                                                                  * trials), 3),
            "parts": parts,
            "added_share_of_fixed": round(sum(parts[k]["share_of_fixed"] for k in added), 4),
            "measured_excess_share": round(train_per_trial_s / fixed_per_trial_s - 1.0, 4)}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--trials", type=int, default=20)
    ap.add_argument("--seconds", type=float, default=2.0,
                    help="simulated seconds of each timed run (default 2)")
    ap.add_argument("--codegen", default="cython", choices=["numpy", "cython"])
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--no-breakdown", action="store_true", help="skip the instrumented run")
    ap.add_argument("--json", default="none",
                    help="where the figures go (default none: nowhere), e.g. "
                         "docs/benchmarks/training_cost.json")
    ap.add_argument("--label", default="", help="a word stored with the figures (e.g. before)")
    args = ap.parse_args()
    if args.seconds <= 0 or args.repeats < 1 or args.trials < 1:
        ap.error("--seconds, --repeats and --trials must be positive")

    from astrocpg.models import DEFAULT_MODELS

    os.environ["ASTROCPG_CODEGEN"] = args.codegen  # the Trainer builds with the default target
    with tempfile.TemporaryDirectory(prefix="training_cost_") as tmp:
        loop = build_fixed(DEFAULT_MODELS, args)
        trainer = build_training(DEFAULT_MODELS, args, Path(tmp) / "train")
        loops = {"fixed": (loop.cpg.net, add_stopwatch(loop.cpg.net, loop.cpg.clock)),
                 "training": (trainer.cpg.net,
                              add_stopwatch(trainer.cpg.net, trainer.cpg.clock))}
        # MuJoCo's step costs more for a robot lying on the ground (contacts) than for one
        # standing: the training resets its fallen robots, the fixed loop leaves them lying
        physics = Timers()
        for name, bridge in (("fixed", loop.bridge), ("training", trainer.bridge)):
            bridge.robots.physics = physics.wrap(name, bridge.robots.physics)
        for net, watch in loops.values():  # extensions built or found, first steps
            run_cpu(net, watch, 0.1)
        step_s = float(loop.cpg.dt) * args.trials  # simulated trial-seconds per step
        print(f"{args.trials} trials, {args.codegen}, {args.seconds:g} simulated s a run, "
              f"CPU of this process per simulated trial-second (ms)")
        print(f"{'repeat':<8}{'fixed':>9}{'training':>10}{'ratio':>8}{'physics':>17}"
              f"{'same physics':>14}{'sessions':>10}")
        rows = []
        for k in range(args.repeats):
            row: dict[str, Any] = {}
            for name, (net, watch) in loops.items():
                before = physics.cpu[name]
                row[name] = run_cpu(net, watch, args.seconds) / step_s
                row[f"{name}_physics"] = (physics.cpu[name] - before) / (watch.steps * step_s)
            row["ratio"] = row["training"] / row["fixed"]
            # the training's step had its MuJoCo step cost what the fixed loop's did
            row["ratio_same_physics"] = ((row["training"] - row["training_physics"]
                                          + row["fixed_physics"]) / row["fixed"])
            row["sessions_done"] = len(trainer.training.memory.rows)
            rows.append(row)
            print(f"{k:<8}{1e3 * row['fixed']:>9.2f}{1e3 * row['training']:>10.2f}"
                  f"{row['ratio']:>8.3f}{1e3 * row['fixed_physics']:>8.2f}/"
                  f"{1e3 * row['training_physics']:<8.2f}{row['ratio_same_physics']:>14.3f}"
                  f"{row['sessions_done']:>10}", flush=True)
        ratios = np.array([r["ratio"] for r in rows])
        fixed = np.array([r["fixed"] for r in rows])
        train = np.array([r["training"] for r in rows])
        median = float(np.median(ratios))
        least = float(train.min() / fixed.min())
        spread = float((ratios.max() - ratios.min()) / median)
        same = np.array([r["ratio_same_physics"] for r in rows])
        same_median = float(np.median(same))
        print(f"ratio median {median:.3f} (goal 1.15), range {ratios.min():.3f}-"
              f"{ratios.max():.3f} (spread {100 * spread:.0f}% of the median); each loop's "
              f"least: {1e3 * train.min():.2f} against {1e3 * fixed.min():.2f} ms, ratio "
              f"{least:.3f}")
        print(f"with the training's MuJoCo step costing what the fixed loop's did "
              f"('physics': fixed/training, ms): ratio median {same_median:.3f}, range "
              f"{same.min():.3f}-{same.max():.3f}")
        parts = None
        if not args.no_breakdown:
            parts = breakdown(trainer, loops["training"][1], args.seconds, args.trials,
                              float(np.median(fixed)), float(np.median(train)))
            print(f"what the training adds ({parts['sessions_ended']} sessions ended in an "
                  f"instrumented run of {args.seconds:g} s), per simulated trial-second:")
            for label, p in parts["parts"].items():
                print(f"  {label:<55}{p['ms_per_trial_s']:>8.3f} ms {100 * p['share_of_fixed']:>6.2f}%"
                      f" of fixed  ({p['calls']} calls)")
            print(f"  the added parts together: {100 * parts['added_share_of_fixed']:.1f}% of the "
                  f"fixed step; measured excess (median runs): "
                  f"{100 * parts['measured_excess_share']:.1f}%")
    if args.json != "none":
        shown = shlex.join(["python", "benchmarks/training_cost.py", *sys.argv[1:]])
        doc = {"benchmark": "benchmarks/training_cost.py", "argv": sys.argv,
               "command": shown, "label": args.label,
               "date": datetime.datetime.now().astimezone().isoformat(timespec="seconds"),
               "machine": {"platform": platform.platform(),
                           "processor": platform.processor() or platform.machine(),
                           "cpu_count": os.cpu_count(),
                           "load_average": list(os.getloadavg())},
               "versions": versions(), "astrocpg_commit": git_commit(),
               "trials": args.trials, "seconds": args.seconds, "codegen": args.codegen,
               "fixed": "build_closed_loop alone: weights zero and fixed, nothing recorded",
               "unit": "CPU s of this process per simulated trial-second, first to last step",
               "ratio_median": round(median, 4), "ratio_of_least": round(least, 4),
               "ratio_spread": round(spread, 4),
               "ratio_same_physics_median": round(same_median, 4),
               "repeats": [{k: (round(v, 6) if isinstance(v, float) else v)
                            for k, v in r.items()} for r in rows],
               "breakdown": parts}
        path = Path(args.json)
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_text(json.dumps(doc, indent=2) + "\n")
        print(f"wrote {path}")


if __name__ == "__main__":
    main()
