"""Each condition's final rhythms and gaits and simulated time, from a study's ``results.csv``
(every run ends with a 5 s run of each seed's final tables, learning off: ``final_rhythm``,
thigh-extensor bursts; ``final_gait``, footfalls; ``final_speed_m_per_s``). A results.csv
written before the gait was read from the feet has ``final_gait`` alone, and it is the
rhythm: it is printed as the rhythm. The simulated time of a run of seeds trained together is that of its
slowest seed, the sum of its sessions' lengths (``benchmarks/all.py`` projects the ablation
from it):

    python docs/ablation/gaits.py out/ablation/results.csv
"""

from __future__ import annotations

import argparse
import csv
import gzip
from collections import Counter, defaultdict
from pathlib import Path

import numpy as np


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("results", type=Path)
    args = ap.parse_args()
    seeds: dict[str, dict[str, tuple[str, str, float]]] = defaultdict(dict)
    simulated: dict[str, dict[str, float]] = defaultdict(lambda: defaultdict(float))
    opener = gzip.open if args.results.suffix == ".gz" else open
    with opener(args.results, "rt", newline="") as f:
        reader = csv.DictReader(f)
        old = "final_rhythm" not in (reader.fieldnames or [])
        for r in reader:
            rhythm = r["final_gait"] if old else r["final_rhythm"]
            gait = "" if old else r["final_gait"]
            seeds[r["condition"]][r["seed"]] = (rhythm, gait, float(r["final_speed_m_per_s"]))
            simulated[r["condition"]][r["seed"]] += float(r["length_s"])
    print("| condition | seeds | rhythms (thigh-extensor bursts) | gaits (footfalls) | speed "
          "with the final table (m/s), mean ± std | simulated s per seed: slowest, mean |")
    print("|---|---|---|---|---|---|")
    for condition, per_seed in seeds.items():
        rhythms = Counter(g for g, _, _ in per_seed.values())
        gaits = Counter(g for _, g, _ in per_seed.values())
        speed = np.array([s for _, _, s in per_seed.values()])
        sim = np.array(list(simulated[condition].values()))
        rtext = ", ".join(f"{g} {n}" for g, n in rhythms.most_common())
        gtext = ("not read (results written before the gait was read from the feet)" if old
                 else ", ".join(f"{g} {n}" for g, n in gaits.most_common()))
        print(f"| {condition} | {len(per_seed)} | {rtext} | {gtext} | {speed.mean():.3f} ± "
              f"{speed.std():.3f} | {sim.max():.0f}, {sim.mean():.0f} |")


if __name__ == "__main__":
    main()
