"""A seed trained alone against its rows in a study: are they the same, session by session?

    python docs/ablation/compare_seed.py out/seed7 docs/ablation/streams/results.csv.gz \
        --condition astrocytes --seed 7
    python docs/ablation/compare_seed.py out/hc_seed5 rows.csv.gz --condition control \
        --seed 5 --run interlimb_synapse=homeostatic

Reads the training's ``sessions.csv`` (one trial) and the study's ``results.csv`` (or its
``.gz``), and compares every column of every session that both hold, as written (text). Prints
the number of sessions compared and every difference; exits 1 when there is one.
"""

from __future__ import annotations

import argparse
import csv
import gzip
import io
import sys
from pathlib import Path


def _rows(path: Path) -> list[dict[str, str]]:
    data = gzip.decompress(path.read_bytes()) if path.suffix == ".gz" else path.read_bytes()
    return list(csv.DictReader(io.StringIO(data.decode())))


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("training", type=Path, help="a training folder of one trial")
    ap.add_argument("results", type=Path, help="a study's results.csv or results.csv.gz")
    ap.add_argument("--condition", required=True)
    ap.add_argument("--seed", required=True)
    ap.add_argument("--run", default="",
                    help="only the rows of runs whose name contains this (a sweep point, e.g. "
                         "interlimb_synapse=homeostatic)")
    args = ap.parse_args()
    study = {r["session"]: r for r in _rows(args.results)
             if r["condition"] == args.condition and r["seed"] == args.seed
             and args.run in r.get("run_id", "")}
    if not study:
        sys.exit(f"compare_seed.py: no row of condition {args.condition!r}, seed {args.seed}"
                 + (f", run {args.run!r}" if args.run else "") + f" in {args.results}")
    alone = _rows(args.training / "sessions.csv")
    columns = [c for c in alone[0] if c != "trial"] if alone else []
    both = [r for r in alone if r["session"] in study]
    differ = [(r["session"], c, r[c], study[r["session"]][c])
              for r in both for c in columns if r[c] != study[r["session"]][c]]
    print(f"{len(both)} sessions compared ({len(columns)} columns each); "
          f"{len(differ)} differences")
    for session, column, a, b in differ[:20]:
        print(f"  session {session} {column}: alone {a}, in the study {b}")
    return 1 if differ else 0


if __name__ == "__main__":
    sys.exit(main())
