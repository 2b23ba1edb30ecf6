"""The learning curves of ``models/variants/compare_delays.toml`` compared block by block, and
the gait each seed learnt, from the study's folder:

    python docs/variants/delays/blocks.py out/compare_delays [--block 20] > blocks.md

Per block of sessions: each seed's mean, then mean ± std across seeds per delay table, the
difference of the two tables' means (second minus first) with its 95 % bootstrap interval over
seeds, the two-sided permutation p of that difference (10 000 draws with a fixed seed: never below
1/10001, "<= 0.0001" a bound) and that p Holm-adjusted over the blocks of one measure (one
question per measure: do the learning curves differ?), unpaired, from
``astrocpg.studies.analysis.compare``. Then each seed's gait with its final table (``gait.csv``
of each run: learning off, 5 s) and the two tables' speeds compared the same way, with the
Mann-Whitney p.
"""

from __future__ import annotations

import argparse
import csv
from pathlib import Path

import numpy as np

from astrocpg.studies.analysis.compare import compare, holm, p_text

MEASURES = ("mean_reward", "length_s", "mean_forward_speed_m_per_s", "final_x_m")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("study", type=Path)
    ap.add_argument("--block", type=int, default=20)
    args = ap.parse_args()
    rows = list(csv.DictReader((args.study / "results.csv").open()))
    tables = sorted({r["interlimb_synapse"] for r in rows})
    per = {t: {} for t in tables}
    for r in rows:
        per[r["interlimb_synapse"]].setdefault(int(r["seed"]), []).append(r)
    n_sessions = min(len(v) for t in tables for v in per[t].values())
    print(f"Blocks of {args.block} sessions; per seed the block's mean, then mean ± std "
          f"(ddof=0) across seeds; difference {tables[-1]} minus {tables[0]} with its 95 % "
          f"bootstrap interval over seeds, permutation p, and that p Holm-adjusted over the "
          f"blocks of the measure.\n")
    print("| measure | sessions | " + " | ".join(tables)
          + " | difference [95 % interval] | permutation p | Holm p |")
    print("|---|---|" + "---|" * len(tables) + "---|---|---|")
    for key in MEASURES:
        lines, tests = [], []
        for a in range(0, n_sessions, args.block):
            b = min(a + args.block, n_sessions)
            values = []
            for t in tables:
                values.append(np.array([np.mean([float(r[key]) for r in sorted(
                    seeds, key=lambda r: int(r["session"]))[a:b]]) for seeds in per[t].values()]))
            c = compare(values[-1], values[0]) if len(values) == 2 else None
            tests.append(c)
            cells = " | ".join(f"{v.mean():.3f} ± {v.std():.3f}" for v in values)
            lines.append((key, a, b, cells))
        adjusted = holm([c["perm_p"] if c else None for c in tests])
        for (key, a, b, cells), c, p_holm in zip(lines, tests, adjusted):
            if c is None or c["perm_p"] is None:
                test = " | | "
            else:
                test = (f"{c['difference']:+.3f} [{c['difference_low']:+.3f}, "
                        f"{c['difference_high']:+.3f}] | "
                        f"{p_text(c['perm_p'], c['perm_p_min'], c['perm_bound'])} | "
                        f"{p_text(p_holm, p_holm, c['perm_bound'])}")
            print(f"| {key} | {a + 1}-{b} | {cells} | {test} |")
    print("\nEach seed's rhythm and gait with its final table (learning off, 5 s):\n")
    print("| table | seed | rhythm | gait | speed (m/s) | rhythm phase FL, RR, RL (of FR's cycle) |")
    print("|---|---|---|---|---|---|")
    speeds: dict[str, list[float]] = {}
    for run in sorted((args.study / "runs").iterdir()):
        manifest_rows = [r for r in rows if r["run_id"] == run.name]
        if not manifest_rows or not (run / "gait.csv").exists():
            continue
        table = manifest_rows[0]["interlimb_synapse"]
        seeds = sorted({int(r["seed"]) for r in manifest_rows})
        for g in csv.DictReader((run / "gait.csv").open()):
            seed = seeds[int(g["trial"])]
            # a study of astrocpg 0.1.0 has the rhythm only, named final_gait and final_phase_*
            new = "final_rhythm" in g
            rhythm = g["final_rhythm"] if new else g["final_gait"]
            gait = g["final_gait"] + (f" ({g['final_gait_reason']})"
                                      if g.get("final_gait_reason") else "") if new else "-"
            phase = "final_rhythm_phase_{}" if new else "final_phase_{}"
            phases = ", ".join(f"{float(g[phase.format(leg)]):.2f}" for leg in ("FL", "RR", "RL"))
            print(f"| {table} | {seed} | {rhythm} | {gait} | "
                  f"{float(g['final_speed_m_per_s']):.2f} | {phases} |")
            speeds.setdefault(table, []).append(float(g["final_speed_m_per_s"]))
    if len(speeds) == 2:
        (ta, a), (tb, b) = sorted(speeds.items())
        c = compare(b, a)
        tested = ("n/a (fewer than two seeds a side)" if c["perm_p"] is None else
                  f"{c['difference']:+.3f} m/s [95 % interval {c['difference_low']:+.3f}, "
                  f"{c['difference_high']:+.3f}], permutation p "
                  f"{p_text(c['perm_p'], c['perm_p_min'], c['perm_bound'])}, Mann-Whitney p "
                  f"{p_text(c['mwu_p'])}")
        print(f"\nSpeed with the final table: {ta} {np.mean(a):.3f} ± {np.std(a):.3f}, {tb} "
              f"{np.mean(b):.3f} ± {np.std(b):.3f} m/s; {tb} minus {ta}: {tested}.")


if __name__ == "__main__":
    main()
