"""Issue 13's figures side by side, in one run: a trial-step's cost against MuJoCo's step,
start-up against the import, a study's worker utilisation, and the paper's ablation projected
on this machine.

    python benchmarks/all.py [--seconds 3] [--codegen numpy cython] [--workers 2]

- **Trial-step**: the closed loop at 1 and 20 trials (``speed.py``), each against MuJoCo's own
  step of the same robot timed in the same process (goal: 1.5 x at 16-20 trials).
- **Start-up**: ``run --seconds 0.1`` and ``describe`` against ``import brian2, mujoco``
  (``startup.py``; goals 1.3 x and 0.5 s), medians of interleaved repeats.
- **Utilisation**: a study of 6 runs of unequal length on 2 workers; the seconds a worker was
  free while a run waited (goal: none beyond the hand-over).
- **Training writes**: outputs and checkpoint of 20 trials after 0 to 400 sessions
  (``checkpoint_cost.py``), and what writing them at every session end would add per simulated
  second (trainings now space them: at most 2 % of the wall time).
- **Projected ablation** (2 conditions x 20 seeds x 400 sessions, one run of 20 seeds per
  condition): each run's simulated time (its slowest trial's sessions: 3713 s with astrocytes and
  2675 s without in the measured run of ``docs/ablation/cython_2cores``, from
  ``python docs/ablation/gaits.py OUT/results.csv``) times the wall seconds
  per simulated second measured above at 20 trials, the runs scheduled longest first on
  ``--workers``. That measured run took 55 min 14 s against 53.5 min projected from the sitting's
  0.865 s (two runs side by side are a few % slower than one alone). Then the batch that
  ``batch = "auto"`` chooses with the cost per trial measured now (``trial_cost.py``).
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
import speed  # noqa: E402
import startup  # noqa: E402
import study_utilisation as utilisation_benchmark  # noqa: E402

from astrocpg.studies.experiments.trial_cost import measure_trial_cost  # noqa: E402
from astrocpg.studies.sweeps.batching import choose_batch, longest_first_makespan  # noqa: E402
from astrocpg.studies.sweeps.study import consecutive_groups  # noqa: E402

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


def trial_steps(seconds: float, targets: list[str], at_20: dict[str, float]) -> list[str]:
    """The closed loop at 1 and 20 trials per target; ``at_20`` gets each target's wall s per
    simulated s at 20 trials (for the projected ablation)."""
    lines = [f"{'target':>7} {'trials':>6} {'s/sim s':>8} {'per trial':>10} "
             f"{'trial-step us':>14} {'mj_step us':>11} {'x mj_step':>10}"]
    for n in (1, 20):
        for target in targets:
            r = speed.measure(n, seconds, False, 10, False, target)
            if n == 20:
                at_20[target] = r["wall_per_sim_s"]
            lines.append(f"{target:>7} {n:>6} {r['wall_per_sim_s']:>8.3f} "
                         f"{r['wall_per_trial']:>10.3f} {r['trial_step_us']:>14.1f} "
                         f"{r['mj_step_us']:>11.1f} {r['x_mj_step']:>10.2f}")
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
        lines.append(f"{'':>7}  batch auto chooses {auto['batch']} per run ({auto['runs']} runs), "
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
    ap.add_argument("--run-with", type=float, default=3713.0,
                    help="simulated s of the ablation's run with astrocytes (its slowest "
                         "trial's sessions, docs/ablation/cython_2cores)")
    ap.add_argument("--run-without", type=float, default=2675.0,
                    help="simulated s of the run without astrocytes")
    args = ap.parse_args()
    at_20: dict[str, float] = {}
    sections = [
        ("trial-step against MuJoCo's step (goal 1.5 x at 20 trials)",
         lambda: trial_steps(args.seconds, args.codegen, at_20)),
        ("start-up (goals: run 0.1 s <= 1.3 x the import; describe < 0.5 s)",
         lambda: start_up(args.repeats)),
        ("study utilisation", study_utilisation),
        ("training writes (20 trials; before: at every session end; now at most 2% of the wall)",
         lambda: checkpoint_cost.lines(20, (0, 200, 400), args.session_with)),
        ("the ablation projected (2 x 20 seeds x 400 sessions; goal 60 min on 2 cores)",
         lambda: projected_ablation(args.codegen, args.workers, args.run_with,
                                    args.run_without, at_20)),
    ]
    print(f"astrocpg benchmarks, {os.cpu_count()} cores, Python {sys.version.split()[0]}")
    for title, run in sections:
        t0 = time.time()
        lines = run()
        print(f"\n{title} [{time.time() - t0:.0f} s]")
        for line in lines:
            print(f"  {line}", flush=True)


if __name__ == "__main__":
    main()
