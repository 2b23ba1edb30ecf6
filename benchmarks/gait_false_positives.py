"""How often the rhythm and gait classifiers name a pattern where the inter-limb table has no
structure: their false-positive rate.

Tables without structure:

- **no astrocytes**: the final tables of a training without astrocytes (no limb pair holds
  the mixed structure; trained long enough, every weight saturates at w_max): a training
  folder, or an ``.npz`` of its tables (``weights_mV``, (tables, 8, 8)), which then run with
  the astrocyte training's settings and the astrocytes' regulation off (what
  ``--no-astrocytes`` trains with);
- **shuffled**: a trained table with astrocytes whose 48 inter-limb weights (the 12 blocks
  between different limbs) are permuted at random: the same weights, no structure. Each
  permutation is of one trained table (cycling over them), with its own seed.

Each table runs ``--repeats`` times for ``--seconds`` with learning off (run ``b`` of the
list with seed ``--seed + b``, up to ``--batch`` runs in one network), the rhythm
(thigh-extensor bursts) and the gait (footfalls over the upright part) read over the second
half of each run (:func:`astrocpg.studies.analysis.gait.trial_measures`, as ``astrocpg gait``
reads them). Printed per kind of table, and for both together: the share of runs labelled with
any named pattern (trot, pace, bound, walk) with its Wilson 95% interval, for the rhythm and
for the gait. The trained astrocyte tables themselves run too (``trained``: not a
false-positive figure, what the classifiers say of the structure they should find).

    python benchmarks/gait_false_positives.py [--astrocytes DIR] [--no-astrocytes DIR|NPZ]
        [--permutations 5] [--repeats 5] [--seconds 10] [--out FILE.json]

Defaults: ``docs/benchmarks/trained_astrocytes/`` (a training),
``docs/benchmarks/no_astrocytes_tables.npz`` and the output
``docs/benchmarks/gait_false_positives.json``.
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import sys
import time
from collections import Counter
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
BENCH = ROOT / "docs" / "benchmarks"


def shuffled(table: np.ndarray, rng: np.random.Generator) -> np.ndarray:
    """``table`` (8, 8) with its inter-limb weights (the blocks between different limbs)
    permuted among themselves; the blocks within a limb as they were."""
    out = table.copy()
    legs = np.arange(8) // 2
    between = legs[:, None] != legs[None, :]
    out[between] = rng.permutation(table[between])
    return out


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--astrocytes", type=Path, default=BENCH / "trained_astrocytes")
    ap.add_argument("--no-astrocytes", type=Path, default=BENCH / "no_astrocytes_tables.npz")
    ap.add_argument("--permutations", type=int, default=5)
    ap.add_argument("--repeats", type=int, default=5)
    ap.add_argument("--seconds", type=float, default=10.0)
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--batch", type=int, default=20, help="runs per network (default 20)")
    ap.add_argument("--out", type=Path,
                    default=ROOT / "docs" / "benchmarks" / "gait_false_positives.json")
    args = ap.parse_args(argv)

    from astrocpg.studies.analysis.gait import NAMED, trial_measures
    from astrocpg.studies.analysis.share import wilson_interval
    from astrocpg.studies.commands.run import trained_models, training_settings
    from astrocpg.studies.commands.simulate import simulate_closed_loop
    from astrocpg.studies.outputs.weights import load_weights

    astro = load_weights(args.astrocytes, culprit="--astrocytes")
    none = load_weights(args.no_astrocytes, culprit="--no-astrocytes")
    if none.ndim == 2:
        none = none[None]
    settings = {args.astrocytes: training_settings(args.astrocytes),
                args.no_astrocytes: (training_settings(args.no_astrocytes)
                                     if args.no_astrocytes.is_dir() else
                                     {**training_settings(args.astrocytes),
                                      "astrocytes": False})}
    rng = np.random.default_rng(args.seed)
    # (kind, source, table, models): every table a list entry, run --repeats times
    plan = [("no_astrocytes", f"no_astrocytes table {k}", t, args.no_astrocytes)
            for k, t in enumerate(none)]
    plan += [("shuffled", f"astrocytes table {j % len(astro)} permutation {j}",
              shuffled(astro[j % len(astro)], rng), args.astrocytes)
             for j in range(args.permutations)]
    plan += [("trained", f"astrocytes table {k}", t, args.astrocytes)
             for k, t in enumerate(astro)]
    runs = [(p, r) for p in plan for r in range(args.repeats)]
    rows = []
    t0 = time.perf_counter()
    # one network per batch of runs of the same training's models; run b: seed --seed + b
    for folder in (args.no_astrocytes, args.astrocytes):
        models = trained_models(settings[folder])
        mine = [(b, p, r) for b, (p, r) in enumerate(runs) if p[3] == folder]
        for start in range(0, len(mine), args.batch):
            chunk = mine[start:start + args.batch]
            # consecutive b within a chunk: trial k of the network has seed chunk[0].b + k
            assert [b for b, _, _ in chunk] == list(range(chunk[0][0], chunk[0][0] + len(chunk)))
            result = simulate_closed_loop(models, seconds=args.seconds,
                                          seed=args.seed + chunk[0][0], n_trials=len(chunk),
                                          weights=np.stack([p[2] for _, p, _ in chunk]),
                                          record_traces=False, spikes=("motor",),
                                          progress=False)
            t, i = result.spikes["motor"]
            for k, (b, p, r) in enumerate(chunk):
                m = trial_measures(t, i, result.cpg.layout, result.robot, k, args.seconds / 2,
                                   args.seconds)
                rows.append({"kind": p[0], "table": p[1], "repeat": r, "seed": args.seed + b,
                             "rhythm": m["rhythm"], "gait": m["gait"],
                             "gait_reason": m["gait_reason"],
                             "upright_share_of_window": m["gait_share"]})
            print(f"  {len(rows)} of {len(runs)} runs ({time.perf_counter() - t0:.0f} s)",
                  file=sys.stderr)
    wall = time.perf_counter() - t0

    def shares(selected: list[dict]) -> dict:
        out = {"runs": len(selected)}
        for kind in ("rhythm", "gait"):
            k = sum(r[kind] in NAMED for r in selected)
            lo, hi = wilson_interval(k, len(selected))
            out[kind] = {"named": k, "share": k / len(selected) if selected else None,
                         "low": lo, "high": hi,
                         "labels": dict(Counter(r[kind] for r in selected))}
        # why a run has no gait, a fall counted as one reason (each run keeps its time)
        out["gait_reasons"] = dict(Counter(
            "fell" if r["gait_reason"].startswith("fell at") else r["gait_reason"]
            for r in selected if r["gait"] not in NAMED))
        return out

    summary = {kind: shares([r for r in rows if r["kind"] == kind])
               for kind in ("no_astrocytes", "shuffled", "trained")}
    summary["no_structure"] = shares([r for r in rows if r["kind"] != "trained"])
    doc = {"command": " ".join(["python benchmarks/gait_false_positives.py",
                                *(argv if argv is not None else sys.argv[1:])]),
           "settings": {"astrocytes": str(args.astrocytes.relative_to(ROOT)
                                          if args.astrocytes.is_relative_to(ROOT)
                                          else args.astrocytes),
                        "no_astrocytes": str(args.no_astrocytes.relative_to(ROOT)
                                             if args.no_astrocytes.is_relative_to(ROOT)
                                             else args.no_astrocytes),
                        "permutations": args.permutations, "repeats": args.repeats,
                        "seconds": args.seconds, "seed": args.seed, "batch": args.batch},
           "machine": {"python": platform.python_version(), "platform": platform.platform(),
                       "processor": platform.processor() or platform.machine(),
                       "cpus": os.cpu_count()},
           "date": time.strftime("%Y-%m-%d"),
           "wall_seconds": round(wall, 1), "summary": summary, "runs": rows}
    args.out.parent.mkdir(parents=True, exist_ok=True)
    args.out.write_text(json.dumps(doc, indent=1) + "\n")
    for kind, s in summary.items():
        print(f"{kind:<14} {s['runs']:>3} runs: "
              + "; ".join(f"{what} named in {s[what]['named']} ({s[what]['share']:.0%}, 95% "
                          f"interval {s[what]['low']:.0%}-{s[what]['high']:.0%})"
                          for what in ("rhythm", "gait")))
    print(f"wrote {args.out} ({wall:.0f} s wall)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
