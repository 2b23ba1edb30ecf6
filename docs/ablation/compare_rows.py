"""Two runs of a study compared row by row: did they train the same, session by session?

    python docs/ablation/compare_rows.py out/ablation/results.csv \
        docs/ablation/faster_loop/results.csv.gz

Reads both ``results.csv`` (or their ``.gz``), matches rows by (condition, seed, session) and
compares every other column as written (text), except ``run_id`` (the run's name depends on the
batch). Prints the rows each holds, the rows compared and the differences per column; exits 1
when there is one.
"""

from __future__ import annotations

import argparse
import csv
import gzip
import io
import sys
from pathlib import Path

IGNORED = ("run_id", "trial")  # names that depend on how the seeds were batched


def rows(path: Path) -> dict[tuple[str, str, str], dict[str, str]]:
    raw = path.read_bytes()
    text = gzip.decompress(raw).decode() if path.suffix == ".gz" else raw.decode()
    return {(r["condition"], r["seed"], r["session"]): r
            for r in csv.DictReader(io.StringIO(text))}


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("first", type=Path)
    ap.add_argument("second", type=Path)
    args = ap.parse_args()
    a, b = rows(args.first), rows(args.second)
    common = sorted(set(a) & set(b), key=lambda k: (k[0], int(k[1]), int(k[2])))
    columns = [c for c in next(iter(a.values())) if c not in IGNORED]
    differences: dict[str, int] = {}
    first: dict[str, tuple] = {}
    for key in common:
        for c in columns:
            if a[key].get(c) != b[key].get(c):
                differences[c] = differences.get(c, 0) + 1
                first.setdefault(c, (key, a[key].get(c), b[key].get(c)))
    print(f"{len(a)} rows in {args.first}, {len(b)} in {args.second}; {len(common)} compared, "
          f"{len(columns)} columns each")
    if not differences:
        print("0 differences")
        return 0
    for c, n in differences.items():
        key, x, y = first[c]
        print(f"{c}: {n} rows differ (first: condition {key[0]}, seed {key[1]}, session "
              f"{key[2]}: {x} against {y})")
    return 1


if __name__ == "__main__":
    sys.exit(main())
