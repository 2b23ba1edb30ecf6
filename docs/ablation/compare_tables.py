"""Two runs of the ablation study compared figure by figure, from their ``final_figures.csv``
(``astrocpg report`` writes it): are the final figures the same within the spread of the seeds?

    python docs/ablation/compare_tables.py docs/ablation/final_figures.csv \
        out/ablation/report/final_figures.csv [--names numpy cython] > comparison.md

Per condition (group) and final figure: each run's mean ± std across seeds (ddof = 0, as
``report`` writes it) and Welch's two-sided p for the difference of the two means, computed from
those summaries (``scipy.stats.ttest_ind_from_stats`` with the sample std, n seeds per side).
Figures without a spread on either side (e.g. 12 of 12 limb pairs mixed in every seed) are
shown without a p. With 10 tests (5 figures x 2 conditions), at least one p below 0.05 comes by
chance about two times in five.
"""

from __future__ import annotations

import argparse
import csv
import math
from pathlib import Path

from scipy import stats

FIGURES = (  # (column stem in final_figures.csv, label, format)
    ("speed", "forward speed (m/s)", "{:.3f}"),
    ("final_x", "final x (m)", "{:.2f}"),
    ("length", "session length (s)", "{:.2f}"),
    ("reward", "mean reward", "{:.3f}"),
    ("full", "full-length share", "{:.3f}"),
)
SINGLE = (("mixed_limb_pairs_mean", "mixed limb pairs (of 12)", "{:.1f}"),
          ("share_above_0.9_w_max_mean", "weights > 0.9 w_max", "{:.2f}"))


def _rows(path: Path) -> dict[str, dict[str, str]]:
    return {r["group"]: r for r in csv.DictReader(path.open())}


def welch_p(m1: float, s1: float, n1: int, m2: float, s2: float, n2: int) -> float:
    """Welch's two-sided p from means, population stds (ddof 0) and counts."""
    if n1 < 2 or n2 < 2 or (s1 == 0 and s2 == 0):
        return math.nan
    # report's std has ddof = 0: the sample std is sqrt(n / (n - 1)) times it
    s1, s2 = s1 * math.sqrt(n1 / (n1 - 1)), s2 * math.sqrt(n2 / (n2 - 1))
    return float(stats.ttest_ind_from_stats(m1, s1, n1, m2, s2, n2, equal_var=False).pvalue)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("first", type=Path)
    ap.add_argument("second", type=Path)
    ap.add_argument("--names", nargs=2, default=("first", "second"))
    args = ap.parse_args()
    a, b = _rows(args.first), _rows(args.second)
    name_a, name_b = args.names
    print(f"Final figures per condition, mean ± std across seeds (ddof 0); Welch's two-sided p "
          f"for {name_a} vs {name_b}.\n")
    print(f"| condition | figure | {name_a} | {name_b} | Welch p |")
    print("|---|---|---|---|---|")
    n_low = n_tests = 0
    for group in a:
        if group not in b:
            continue
        ra, rb = a[group], b[group]
        na, nb = int(ra["seeds"]), int(rb["seeds"])
        for stem, label, fmt in FIGURES:
            ma, sa = float(ra[f"{stem}_mean"]), float(ra[f"{stem}_std"])
            mb, sb = float(rb[f"{stem}_mean"]), float(rb[f"{stem}_std"])
            p = welch_p(ma, sa, na, mb, sb, nb)
            if not math.isnan(p):
                n_tests += 1
                n_low += p < 0.05
            cell = "{} ± {}".format(fmt, fmt)
            print(f"| {group} | {label} | {cell.format(ma, sa)} | {cell.format(mb, sb)} | "
                  f"{'' if math.isnan(p) else f'{p:.2f}'} |")
        for key, label, fmt in SINGLE:
            print(f"| {group} | {label} | {fmt.format(float(ra[key]))} | "
                  f"{fmt.format(float(rb[key]))} | |")
    print(f"\n{n_low} of {n_tests} tests below p = 0.05.")


if __name__ == "__main__":
    main()
