"""A study's wall time on 1, 2, 4, 8 and 16 cores, projected from one it ran.

    python benchmarks/study_cores.py docs/ablation/planned      # the paper's ablation

Reads the study folder's ``study.json`` (the cost per trial its planner measured on its machine
and code generation: ``fixed + per_trial * n`` CPU seconds per simulated second for a run of n
trials) and its ``results.csv.gz`` (how long each seed trained), and plans the same seeds for
each number of workers as ``astrocpg study --plan-from FOLDER --workers N`` plans them
(:func:`astrocpg.studies.parameter_studies.batching.choose_batch`): the seeds split into runs, the
longest run first, each worker one core. The projection leaves out the start-up of each worker
(seconds) and assumes the machine has the cores; it is a projection, not a measurement: on 2
workers compare it with the wall time the folder's README measured.
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

from astrocpg.studies.parameter_studies.batching import choose_batch
from astrocpg.studies.parameter_studies.measured import measured_lengths
from astrocpg.studies.parameter_studies.study_file import consecutive_groups
from astrocpg.studies.parameter_studies.trial_cost import TrialCost


def _minutes(s: float) -> str:
    return f"{int(s // 60)} min {int(round(s % 60)):02d} s"


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("folder", type=Path, help="a study folder with study.json and results.csv.gz")
    ap.add_argument("--cores", type=int, nargs="+", default=[1, 2, 4, 8, 16])
    a = ap.parse_args(argv)
    plan = json.loads((a.folder / "study.json").read_text())["batch_choice"]
    c = plan["cost"]
    cost = TrialCost(fixed=c["fixed_s_per_sim_s"], per_trial=c["per_trial_s_per_sim_s"],
                     measured={int(k): v for k, v in c["measured"].items()},
                     codegen=c["codegen"], key="", when=c["when"])
    table = a.folder / "results.csv.gz"
    groups = [(sorted(seeds), {s: total for s, (total, _) in seeds.items()})
              for _, seeds in sorted(measured_lengths(table).items())]
    print(f"{a.folder}: {sum(len(s) for s, _ in groups)} seeds in {len(groups)} groups; cost "
          f"{cost.fixed:.4f} + {cost.per_trial:.4f} x n CPU s per simulated s ({cost.codegen}, "
          f"measured {cost.when})")
    for n in a.cores:
        chosen = choose_batch(groups, workers=n, cost=cost, split=consecutive_groups)
        print(f"  {n:2d} core(s): {_minutes(chosen['projected_s'])} wall projected "
              f"({chosen['runs']} runs, batch {chosen['batch']}, "
              f"{chosen['cpu_s'] / 60:.0f} min of CPU)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
