"""How the timing of the cost per trial behind ``batch = "auto"`` changes what it finds: the
fitted fixed part of a run, in trials' worth, timed the old way (0.1 s of warm-up, 1 s timed)
and the current way (0.5 s, 3 s), the two in turn, ``--repeats`` times.

    python benchmarks/trial_cost_timing.py [--repeats 3] [--codegen cython]

Each measurement is :func:`astrocpg.studies.parameter_studies.trial_cost.measure_trial_cost` at batch
sizes 1, 4, 10 and 20 (the closed loop, default models, fixed weights, CPU time per simulated
second), nothing stored. A study's choice of runs depends only on the ratio ``fixed /
per_trial``: how many trials' worth of work every run pays whatever its size.
"""

from __future__ import annotations

import argparse
import json
import platform
from datetime import datetime, timezone

from astrocpg.studies.parameter_studies.trial_cost import SECONDS, WARM_UP, measure_trial_cost

TIMINGS = {"old (0.1 s + 1 s)": (0.1, 1.0), f"current ({WARM_UP:g} s + {SECONDS:g} s)":
           (WARM_UP, SECONDS)}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--codegen", default="cython", choices=("numpy", "cython"))
    ap.add_argument("--json", help="also write the measurements here")
    args = ap.parse_args()
    rows = []
    print(f"{'repeat':>6s} {'timing':22s} {'1 trial':>8s} {'20 trials':>9s} {'fixed':>7s} "
          f"{'per trial':>9s} {'fixed / per trial':>17s}")
    for k in range(args.repeats):
        for label, (warm_up, seconds) in TIMINGS.items():
            c = measure_trial_cost(args.codegen, warm_up=warm_up, seconds=seconds,
                                   progress=False)
            ratio = c.fixed / c.per_trial
            rows.append({"repeat": k, "timing": label, "warm_up_s": warm_up,
                         "timed_s": seconds, "measured": c.measured, "fixed": c.fixed,
                         "per_trial": c.per_trial, "ratio": ratio})
            print(f"{k:6d} {label:22s} {c.measured[1]:8.3f} {c.measured[20]:9.3f} "
                  f"{c.fixed:7.3f} {c.per_trial:9.4f} {ratio:17.1f}")
    for label in TIMINGS:
        ratios = sorted(r["ratio"] for r in rows if r["timing"] == label)
        print(f"{label}: fixed part {ratios[0]:.1f}-{ratios[-1]:.1f} trials' "
              f"({len(ratios)} measurements)")
    if args.json:
        with open(args.json, "w") as f:
            json.dump({"command": "python benchmarks/trial_cost_timing.py",
                       "args": vars(args), "machine": platform.node(),
                       "when": datetime.now(timezone.utc).isoformat(timespec="seconds"),
                       "rows": rows}, f, indent=1)


if __name__ == "__main__":
    main()
