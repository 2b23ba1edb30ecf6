"""A study's conditions compared again from its rows, with the statistics ``astrocpg report``
uses now:

    python docs/ablation/retest.py docs/ablation/streams/results.csv.gz [--last 50] > OUT.md

The input is a study's ``results.csv`` (``.csv.gz``), or the rows ``analyse.py rows`` exports: one
row per condition, seed and session. Per seed, its final figures are those of ``astrocpg
report`` (``astrocpg.studies.parameter_studies.report`` and ``astrocpg.studies.analysis.final_figures``, whose functions this script calls): the mean over
the seed's last ``--last`` sessions (fewer where it trained fewer) of the forward speed, the final
x, the session length and the mean reward, and the share of those sessions that reached L_max
(the package's L_max, 10 s). Then every pair of conditions, one value per seed, unpaired: the
difference of means with its 95 % bootstrap interval, the two-sided permutation p (10 000 draws
with a fixed seed: never below 1/10001), the Mann-Whitney U test (exact without ties, never below
2/C(n_a + n_b, n_a), about 1.5e-11 for 20 against 20), both Holm-adjusted over the figures of the
table, Hedges' g and the rank-biserial correlation: the "Conditions compared" section a report
writes now.

The weight structure (mixed limb pairs, shares of saturated weights) comes from a run's trained
tables, not from its rows: it is not recomputed here.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np
import pandas as pd

from astrocpg.errors import InputError
from astrocpg.studies.analysis.final_figures import MEASURES, condition_tests
from astrocpg.studies.analysis.final_figures import seed_finals as report_seed_finals
from astrocpg.studies.parameter_studies.report import FORMATS, TESTS, _markdown, _model_values

COLUMNS = ("condition", "seed", "session", "length_s", "final_x_m", "mean_reward",
           "mean_forward_speed_m_per_s")


def read_rows(path: Path) -> pd.DataFrame:
    """The rows of a study (``results.csv`` or ``.csv.gz``) with the columns the final figures
    need; an input without them is refused, naming the missing columns."""
    try:
        rows = pd.read_csv(path)
    except (OSError, ValueError) as e:
        raise InputError(f"cannot read the rows ({type(e).__name__})", culprit=str(path)) from None
    missing = [c for c in COLUMNS if c not in rows.columns]
    if missing:
        raise InputError(f"not a study's rows (no column {', '.join(missing)})",
                         culprit=str(path))
    # a blank or NaN cell is refused, never dropped: a seed's figures would silently rest on
    # fewer sessions than the other seeds', and the conditions be compared on different rows
    blank = rows[list(COLUMNS)].isna()
    if blank.to_numpy().any():
        row, column = np.argwhere(blank.to_numpy())[0]
        raise InputError(f"line {int(row) + 2} has no value in column {COLUMNS[int(column)]} "
                         f"({int(blank.to_numpy().any(axis=1).sum())} such row(s))",
                         culprit=str(path))
    return rows


def seed_finals(rows: pd.DataFrame, last: int, L_max: float | None = None) -> list[dict]:
    """One dict per condition and seed: its final figures, as ``astrocpg report`` computes them
    (``seed_finals``), in the order the conditions first appear in the rows."""
    if L_max is None:
        L_max = _model_values({"overrides": []})[1]
    out = []
    for condition in dict.fromkeys(rows["condition"]):
        part = rows[rows["condition"] == condition]
        series = {int(seed): s.sort_values("session") for seed, s in part.groupby("seed")}
        out += report_seed_finals(condition, (), series, {}, last=last, L_max=L_max)
    return out


def _span(values: list[int]) -> str:
    low, high = min(values), max(values)
    return str(low) if low == high else f"{low}–{high}"


def retest(path: Path, last: int) -> str:
    """The page: the final figures per condition, then the conditions compared."""
    rows = read_rows(path)
    per_seed = seed_finals(rows, last)
    conditions = list(dict.fromkeys(o["condition"] for o in per_seed))
    if len(conditions) < 2:
        raise InputError(f"one condition only ({conditions[0]}): nothing to compare",
                         culprit=str(path))
    measures = list(MEASURES)
    tests = condition_tests([], conditions, per_seed, measures)
    lines = [f"# {path.parent.name}: the conditions compared from the rows", "",
             f"`python docs/ablation/retest.py {path.as_posix()} --last {last}`. Per seed, the "
             f"mean over its last {last} sessions (fewer where it trained fewer); then mean ± std "
             f"(ddof=0) across seeds.", "",
             "| condition | seeds | sessions | last sessions | "
             + " | ".join(f"{m.label}" for m in measures) + " |",
             "|---|---|---|---|" + "---|" * len(measures)]
    for c in conditions:
        mine = [o for o in per_seed if o["condition"] == c]
        cells = []
        for m in measures:
            v = np.array([o[m.key] for o in mine])
            cells.append(f"{format(v.mean(), FORMATS[m.key])} ± {format(v.std(), FORMATS[m.key])}")
        lines.append(f"| {c} | {len(mine)} | {_span([o['sessions'] for o in mine])} | "
                     f"{_span([o['last_sessions'] for o in mine])} | " + " | ".join(cells) + " |")
    # the section a report writes now, from astrocpg report's own writer
    page = _markdown("", [], tests, per_seed, sorted({o["sessions"] for o in per_seed}), last,
                     [], measures, {})
    section = page[page.index("## Conditions compared"):page.index(f"The same in {TESTS}.")]
    lines += ["", section.rstrip(), "",
              "The weight structure (mixed limb pairs, weights above 0.9 w_max) is read from the "
              "trained tables, not from the rows: it is not in this table."]
    return "\n".join(lines) + "\n"


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("rows", type=Path, help="a study's results.csv or results.csv.gz")
    ap.add_argument("--last", type=int, default=50,
                    help="final figures over each seed's last N sessions (default 50, as report)")
    args = ap.parse_args(argv)
    try:
        if args.last < 1:
            raise InputError("--last must be at least 1", culprit=f"--last {args.last}")
        sys.stdout.write(retest(args.rows, args.last))
    except InputError as e:
        print(f"astrocpg: {e}", file=sys.stderr)
        return 2
    return 0


if __name__ == "__main__":
    sys.exit(main())
