"""Each condition's final gaits and simulated time, from a study's ``results.csv`` (every run
ends with a 5 s run of each seed's final tables, learning off: ``final_gait``,
``final_speed_m_per_s``). The simulated time of a run of seeds trained together is that of its
slowest seed, the sum of its sessions' lengths (``benchmarks/all.py`` projects the ablation
from it):

    python docs/ablation/gaits.py out/ablation/results.csv
"""

from __future__ import annotations

import argparse
import csv
from collections import Counter, defaultdict
from pathlib import Path

import numpy as np


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("results", type=Path)
    args = ap.parse_args()
    seeds: dict[str, dict[str, tuple[str, float]]] = defaultdict(dict)
    simulated: dict[str, dict[str, float]] = defaultdict(lambda: defaultdict(float))
    with args.results.open(newline="") as f:
        for r in csv.DictReader(f):
            seeds[r["condition"]][r["seed"]] = (r["final_gait"], float(r["final_speed_m_per_s"]))
            simulated[r["condition"]][r["seed"]] += float(r["length_s"])
    print("| condition | seeds | gaits | speed with the final table (m/s), mean ± std | "
          "simulated s per seed: slowest, mean |")
    print("|---|---|---|---|---|")
    for condition, per_seed in seeds.items():
        gaits = Counter(g for g, _ in per_seed.values())
        speed = np.array([s for _, s in per_seed.values()])
        sim = np.array(list(simulated[condition].values()))
        text = ", ".join(f"{g} {n}" for g, n in gaits.most_common())
        print(f"| {condition} | {len(per_seed)} | {text} | {speed.mean():.3f} ± {speed.std():.3f} "
              f"| {sim.max():.0f}, {sim.mean():.0f} |")


if __name__ == "__main__":
    main()
