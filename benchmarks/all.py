"""The project's speed and memory figures side by side, in one run: a trial-step's cost
against MuJoCo's step, what recording adds, start-up against the import, a study's worker
utilisation, the training's writes and the paper's ablation projected on this machine.

    python benchmarks/all.py [--seconds 3] [--codegen numpy cython] [--workers 2]
                             [--markdown docs/benchmarks.md]

- **Trial-step**: the closed loop at 1 and 20 trials (``speed.py``: steady state, MuJoCo's step
  timed alone for 1 s inside the same run), each point ``--speed-repeats`` times, interleaved;
  medians, and the spread of the ratio between repeats. Goals at 20 trials: 2.0 x MuJoCo's
  step on Cython, 3.5 x on numpy.
- **Recording**: ``astrocpg run``'s default recording against none at 20 trials, and its peak
  memory per trial per simulated second (``recording_cost.py``; goals 15 % and 2 MiB).
- **Start-up**: ``run --seconds 0.1`` and ``describe`` against ``import brian2, mujoco``
  (``startup.py``; goals 1.3 x and 0.5 s), medians of interleaved repeats.
- **Utilisation**: a study of 6 runs of unequal length on 2 workers; the seconds a worker was
  free while a run waited (goal: none beyond the hand-over).
- **Training writes**: outputs and checkpoint of 20 trials after 0 to 400 sessions
  (``checkpoint_cost.py``), and what writing them at every session end would add per simulated
  second (trainings space them: at most 2 % of the wall time).
- **Projected ablation** (2 conditions x 20 seeds x 400 sessions, one run of 20 seeds per
  condition): each run's simulated time (its slowest trial's sessions: 3673 s with astrocytes
  and 2660 s without in ``docs/ablation/streams``, from ``python docs/ablation/gaits.py
  OUT/results.csv``) times the CPU seconds per simulated second measured above at 20 trials,
  the runs scheduled longest first on ``--workers`` (two runs side by side are a few % slower
  than one alone). Then the batch that ``batch = "auto"`` chooses with the cost per trial
  measured now (``trial_cost.py``).

``--markdown FILE`` also writes the tables, the machine, the date and the command as a page;
the manual's performance page includes ``docs/benchmarks.md``, made this way.
"""

from __future__ import annotations

import argparse
import os
import sys
import tempfile
import time
from pathlib import Path

os.environ.setdefault("OMP_NUM_THREADS", "1")
os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
sys.path.insert(0, str(Path(__file__).resolve().parent))

import checkpoint_cost  # noqa: E402
import recording_cost  # noqa: E402
import speed  # noqa: E402
import startup  # noqa: E402
import study_utilisation as utilisation_benchmark  # noqa: E402

from astrocpg.studies.parameter_studies.trial_cost import measure_trial_cost  # noqa: E402
from astrocpg.studies.parameter_studies.batching import choose_batch, longest_first_makespan  # noqa: E402
from astrocpg.studies.parameter_studies.study import consecutive_groups  # noqa: E402

UNEQUAL = """
[study]
name = "unequal"
sessions = 2
seeds = { first = 1, count = 6 }
batch = 3
[conditions.long]
set = { L_max = "1*second" }
[conditions.short]
set = { L_max = "0.5*second" }
"""


def trial_steps(seconds: float, targets: list[str], at_20: dict[str, float],
                repeats: int = 3) -> list[str]:
    """The closed loop at 1 and 20 trials per target (``speed.py``: steady state, MuJoCo's step
    timed for 1 s inside the same run), ``repeats`` times interleaved, medians and the spread of
    the ratio; ``at_20`` gets each target's CPU s per simulated s at 20 trials (for the
    projected ablation)."""
    import numpy as np

    points = [(n, target) for n in (1, 20) for target in targets]
    rs: dict[tuple[int, str], list[dict[str, float]]] = {p: [] for p in points}
    for _ in range(repeats):
        for n, target in points:
            rs[(n, target)].append(speed.measure(n, seconds, False, 10, False, target))
    lines = [f"{'target':>7} {'trials':>6} {'s/sim s':>8} {'per trial':>10} "
             f"{'trial-step us':>14} {'mj_step us':>11} {'x mj_step':>10} {'spread':>7}"]
    for (n, target), runs in rs.items():
        med = {k: float(np.median([r[k] for r in runs])) for k in runs[0] if k != "codegen"}
        if n == 20:
            at_20[target] = med["cpu_per_sim_s"]
        xs = [r["x_mj_step"] for r in runs]
        lines.append(f"{target:>7} {n:>6} {med['cpu_per_sim_s']:>8.3f} "
                     f"{med['cpu_per_trial']:>10.4f} {med['trial_step_us']:>14.1f} "
                     f"{med['mj_step_us']:>11.1f} {med['x_mj_step']:>10.2f} "
                     f"{100 * (max(xs) / min(xs) - 1):>6.1f}%")
    return lines


def authors(command: str | None, seconds: list[float] | None, at_20: dict[str, float]
            ) -> list[str]:
    """The authors' code beside astrocpg, where a command to run it is given."""
    if not command:
        return ["authors' code: not measured (give --authors-command and --authors-seconds)"]
    if seconds is None:
        raise SystemExit("--authors-command needs --authors-seconds")
    theirs = speed.authors_speed(command, seconds)
    what = "their loop only" if len(seconds) == 2 else "start-up included"
    return [f"authors' code: {theirs:.3f} CPU s per simulated s (one trial, {what}); astrocpg per "
            f"trial at 20 trials: " + ", ".join(f"{t} {theirs / (v / 20):.1f} x faster"
                                                for t, v in at_20.items())]


def recording(seconds: float, targets: list[str]) -> list[str]:
    """What ``astrocpg run``'s default recording adds to a 20-trial step, and its memory per
    trial per simulated second (``recording_cost.py``)."""
    import numpy as np

    lines = []
    for target in targets:
        pairs = [recording_cost.share_in_run(20, seconds, target) for _ in range(2)]
        a = float(np.median([p[0] for p in pairs]))
        b = float(np.median([p[1] for p in pairs]))
        lines.append(f"{target:>7}: {a:.1f} us per trial-step without recording, {b:.1f} with: "
                     f"{100 * (b / a - 1):.1f}%")
    MiB = 2.0 ** 20
    bare = recording_cost.peak_memory(2.0, 20, False)
    for dtype in ("float32", "float64"):
        rec = recording_cost.peak_memory(2.0, 20, True, dtype)
        per = (rec["rss"] - bare["rss"]) / 20 / 2.0 / MiB
        held = rec["held"] / 20 / 2.0 / MiB
        lines.append(f"traces as {dtype}: {per:.2f} MiB resident memory per trial per simulated s "
                     f"(20 trials, 2 s), {held:.2f} MiB in the recorders' arrays")
    return lines


def start_up(repeats: int) -> list[str]:
    med = startup.medians(repeats)
    base = med["import brian2 + mujoco"]
    return [f"{name:<28} {v:6.2f} s  {v / base:5.2f} x the import" for name, v in med.items()]


def study_utilisation() -> list[str]:
    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / "unequal.toml"
        path.write_text(UNEQUAL)
        total, _, u = utilisation_benchmark.measure(path, Path(tmp) / "out", 2)
    return [f"6 runs on 2 workers: command {total:.1f} s, first start to last end "
            f"{u['wall_s']:.1f} s, utilisation {u['utilisation']:.0%}",
            f"free while runs waited: {u['idle_pending_s']:.1f} worker-s in all, longest "
            f"{u['longest_idle_pending_s']:.1f} s"]


def projected_ablation(targets: list[str], workers: int, run_with_s: float,
                       run_without_s: float, at_20: dict[str, float]) -> list[str]:
    seeds = list(range(1, 21))
    lines = []
    for target in targets:
        runs = [run_with_s * at_20[target], run_without_s * at_20[target]]
        wall = longest_first_makespan(runs, workers)[0]
        lines.append(f"{target:>7}: batch 20 (one run per condition): {wall / 60:5.1f} min on "
                     f"{workers} workers (runs of {run_with_s:g} and {run_without_s:g} simulated "
                     f"s at {at_20[target]:.3f} s per simulated s)")
        cost = measure_trial_cost(target, progress=False)
        groups = [(seeds, run_with_s), (seeds, run_without_s)]
        auto = choose_batch(groups, workers=workers, cost=cost, split=consecutive_groups)
        split = "".join(f", group {g} in runs of {n}" for g, n in auto["split"].items())
        lines.append(f"{'':>7}  batch auto chooses {auto['batch']} per run{split} "
                     f"({auto['runs']} runs), "
                     f"from {cost.fixed:.3f} s + {cost.per_trial:.4f} s per trial per simulated "
                     f"s (CPU, at {', '.join(map(str, cost.measured))} trials)")
    return lines


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--seconds", type=float, default=3.0, help="simulated s per speed point")
    ap.add_argument("--codegen", nargs="+", default=["numpy"], choices=["numpy", "cython"])
    ap.add_argument("--workers", type=int, default=2, help="workers of the projected ablation")
    ap.add_argument("--repeats", type=int, default=3, help="start-up repeats")
    ap.add_argument("--session-with", type=float, default=9.64,
                    help="mean session length with astrocytes, s (docs/results.md, the ablation; for the "
                         "training writes)")
    ap.add_argument("--run-with", type=float, default=3673.0,
                    help="simulated s of the ablation's run with astrocytes (its slowest "
                         "trial's sessions, docs/ablation/streams/gaits.md)")
    ap.add_argument("--run-without", type=float, default=2660.0,
                    help="simulated s of the run without astrocytes")
    ap.add_argument("--speed-repeats", type=int, default=3,
                    help="repeats of each trial-step point (medians; the spread of the ratio)")
    ap.add_argument("--authors-command", default=None, metavar="CMD",
                    help="a command that runs --authors-seconds of the authors' code (one "
                         "trial), timed beside astrocpg (their code is not shipped)")
    ap.add_argument("--authors-seconds", type=float, nargs="+", default=None,
                    help="simulated s of the authors' run; two values (T1 T2) and {seconds} "
                         "in the command count their loop only (the slope between the two)")
    ap.add_argument("--markdown", default=None, metavar="FILE",
                    help="also write the tables as a Markdown page (the manual includes "
                         "docs/benchmarks.md)")
    args = ap.parse_args()
    at_20: dict[str, float] = {}
    sections = [
        ("trial-step against MuJoCo's step",
         lambda: trial_steps(args.seconds, args.codegen, at_20, args.speed_repeats)
         + authors(args.authors_command, args.authors_seconds, at_20)),
        ("recording (astrocpg run's default: every spike and trace, the robot every step)",
         lambda: recording(args.seconds, args.codegen)),
        ("start-up",
         lambda: start_up(args.repeats)),
        ("study utilisation", study_utilisation),
        ("training writes (20 trials; a training spaces them: at most 2% of the wall time)",
         lambda: checkpoint_cost.lines(20, (0, 200, 400), args.session_with)),
        ("the ablation projected (2 x 20 seeds x 400 sessions)",
         lambda: projected_ablation(args.codegen, args.workers, args.run_with,
                                    args.run_without, at_20)),
    ]
    import platform

    command = "python benchmarks/all.py " + " ".join(sys.argv[1:])
    head = (f"{time.strftime('%Y-%m-%d')}, {platform.processor() or platform.machine()}, "
            f"{os.cpu_count()} cores, Python {sys.version.split()[0]}, "
            f"{_versions()}")
    print(f"astrocpg benchmarks: {head}")
    page = [f"Measured {head}, with `{command.strip()}`.", ""]
    for title, run in sections:
        t0 = time.time()
        lines = run()
        print(f"\n{title} [{time.time() - t0:.0f} s]")
        for line in lines:
            print(f"  {line}", flush=True)
        page += [f"**{title}** ({time.time() - t0:.0f} s)", "", "```text", *lines, "```", ""]
    if args.markdown:
        Path(args.markdown).write_text("\n".join(page))
        print(f"\nwrote {args.markdown}")


def _versions() -> str:
    from importlib.metadata import version

    return ", ".join(f"{p} {version(p)}" for p in ("brian2", "mujoco", "numpy"))


if __name__ == "__main__":
    main()
