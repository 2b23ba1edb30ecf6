"""Two runs of a study, or two evaluations, compared row by row: the same rows, column by column?

    python docs/ablation/compare_rows.py out/ablation/results.csv \
        docs/ablation/faster_loop/results.csv.gz
    python docs/ablation/compare_rows.py out/ablation_eval/evaluation.csv \
        docs/beyond/robustness/evaluation.csv

Reads both CSV files (or their ``.gz``) and matches rows by (condition, seed, session) for a
study's ``results.csv``, or by (condition, point, seed, world, repeat) for ``astrocpg
evaluate``'s ``evaluation.csv``; compares every other column as written (text), except the
names that depend on how the seeds were batched or where the tables were read from (``run_id``,
``trial``, ``source``). Prints the rows each holds, the rows compared and the differences per
column; exits 1 when there is one, or when no row is in both.
"""

from __future__ import annotations

import argparse
import csv
import gzip
import io
import sys
from pathlib import Path

IGNORED = ("run_id", "trial", "source")  # names that depend on how the seeds were batched
STUDY_KEY = ("condition", "seed", "session")
EVALUATION_KEY = ("condition", "point", "seed", "world", "repeat")


def rows(path: Path) -> tuple[tuple[str, ...], dict[tuple[str, ...], dict[str, str]]]:
    """The key columns of the file's kind, and its rows by key."""
    raw = path.read_bytes()
    text = gzip.decompress(raw).decode() if path.suffix == ".gz" else raw.decode()
    table = list(csv.DictReader(io.StringIO(text)))
    key = STUDY_KEY if table and "session" in table[0] else EVALUATION_KEY
    return key, {tuple(r[k] for k in key): r for r in table}


def _order(key: tuple[str, ...]) -> tuple:
    return tuple(int(v) if v.isdigit() else v for v in key)


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("first", type=Path)
    ap.add_argument("second", type=Path)
    args = ap.parse_args()
    (names, a), (names_b, b) = rows(args.first), rows(args.second)
    if names != names_b:
        sys.exit(f"compare_rows.py: {args.first} and {args.second} are not the same kind of table")
    common = sorted(set(a) & set(b), key=_order)
    if not common:
        print(f"{len(a)} rows in {args.first}, {len(b)} in {args.second}; none in both")
        return 1
    columns = [c for c in a[common[0]] if c not in IGNORED and c not in names]
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
        where = ", ".join(f"{k} {v}" for k, v in zip(names, key))
        print(f"{c}: {n} rows differ (first: {where}: {x} against {y})")
    return 1


if __name__ == "__main__":
    sys.exit(main())
