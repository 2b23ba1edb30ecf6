"""Two runs of the ablation study compared figure by figure: are the final figures the same
within the spread of the seeds?

    python docs/ablation/compare_tables.py FIRST SECOND [--names A B] [--last 50] > comparison.md

FIRST and SECOND are each a study's rows (``results.csv`` or ``.csv.gz``: one row per condition,
seed and session) or, for a run whose rows were not kept, its report's ``final_figures.csv``
(mean and std across seeds per condition). The final figures per seed are those of ``astrocpg
report``, over each seed's last ``--last`` sessions (``retest.py`` beside this file computes
them). Per condition and final figure, the difference is SECOND minus FIRST.

- Both runs given by their rows: the difference with its 95 % bootstrap interval over seeds, the
  two-sided permutation p (10 000 draws, fixed seed: never below 1/10001) and the Mann-Whitney
  p (exact without ties), all from ``astrocpg.studies.analysis.compare``, unpaired (two runs
  are two samples of seeds), and the permutation p Holm-adjusted over every figure of the table
  (one question: do the runs differ?).
- A run given by its summaries only: no per-seed values, so no bootstrap and no permutation
  test. The interval is then the t interval of a difference of two means from their means,
  standard deviations and counts (unequal variances, Satterthwaite's degrees of freedom), at 95 %
  and at 1 - 0.05/m for the m figures of the table (Bonferroni: all m intervals hold together
  with 95 % confidence), and no p-value is given.

Figures without a spread on either side (12 of 12 limb pairs mixed in every seed) are shown
without a test.
"""

from __future__ import annotations

import argparse
import csv
import math
import sys
from pathlib import Path

import numpy as np
from scipy import stats

from astrocpg.errors import InputError
from astrocpg.studies.analysis.compare import compare, holm, p_text

from retest import read_rows, seed_finals  # beside this file (the script's folder is on the path)

FIGURES = (  # (key of a seed's final figures / column stem of final_figures.csv, label, format)
    ("speed", "forward speed (m/s)", "{:.3f}"),
    ("final_x", "final x (m)", "{:.2f}"),
    ("length", "session length (s)", "{:.2f}"),
    ("reward", "mean reward", "{:.3f}"),
    ("full", "full-length share", "{:.3f}"),
)
SINGLE = (("mixed_limb_pairs_mean", "mixed limb pairs (of 12)", "{:.1f}"),
          ("share_above_0.9_w_max_mean", "weights > 0.9 w_max", "{:.2f}"))


def _read(path: Path, last: int) -> dict[str, dict]:
    """Per condition: ``seeds`` (per figure, the per-seed values; None from a summary), and the
    summary (``{stem}_mean``, ``{stem}_std`` with ddof 0, ``n``, the weight structure if any)."""
    if path.name == "final_figures.csv":
        try:
            with path.open(newline="") as f:
                table = list(csv.DictReader(f))
        except OSError as e:
            raise InputError(f"cannot read ({e.strerror or type(e).__name__})",
                             culprit=str(path)) from None
        return {r.get("condition") or r["group"]: {"seeds": None, "n": int(r["seeds"]),
                **{k: float(v) for k, v in r.items() if k.endswith(("_mean", "_std")) and v}}
                for r in table}
    out: dict[str, dict] = {}
    for o in seed_finals(read_rows(path), last):
        c = out.setdefault(o["condition"], {"seeds": {k: [] for k, _, _ in FIGURES}})
        for k, _, _ in FIGURES:
            c["seeds"][k].append(o[k])
    for c in out.values():
        c["n"] = len(c["seeds"]["speed"])
        for k, _, _ in FIGURES:
            c[f"{k}_mean"], c[f"{k}_std"] = float(np.mean(c["seeds"][k])), float(np.std(c["seeds"][k]))
    return out


def t_interval(ma: float, sa: float, na: int, mb: float, sb: float, nb: int,
               level: float) -> tuple[float, float] | None:
    """The t interval of mb - ma from two summaries (stds with ddof 0, as the report writes
    them), unequal variances, Satterthwaite's degrees of freedom; None without a spread."""
    if na < 2 or nb < 2 or (sa == 0 and sb == 0):
        return None
    va, vb = sa ** 2 / (na - 1), sb ** 2 / (nb - 1)  # sample variance / n, from ddof 0
    se = math.sqrt(va + vb)
    df = (va + vb) ** 2 / (va ** 2 / (na - 1) + vb ** 2 / (nb - 1))
    half = float(stats.t.ppf(0.5 + level / 2, df)) * se
    return (mb - ma) - half, (mb - ma) + half


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("first", type=Path)
    ap.add_argument("second", type=Path)
    ap.add_argument("--names", nargs=2, default=("first", "second"))
    ap.add_argument("--last", type=int, default=50,
                    help="rows: final figures over each seed's last N sessions (default 50)")
    args = ap.parse_args(argv)
    try:
        a, b = _read(args.first, args.last), _read(args.second, args.last)
    except InputError as e:
        print(f"astrocpg: {e}", file=sys.stderr)
        return 2
    name_a, name_b = args.names
    groups = [g for g in a if g in b]
    if not groups:
        print(f"astrocpg: {args.second}: no condition in common with {args.first}",
              file=sys.stderr)
        return 2
    seeds = all(a[g]["seeds"] is not None and b[g]["seeds"] is not None for g in groups)
    fmt2 = "{} ± {}"
    lines = []
    if seeds:
        rows, ps = [], []
        for g in groups:
            for key, label, fmt in FIGURES:
                c = compare(b[g]["seeds"][key], a[g]["seeds"][key])
                rows.append((g, key, label, fmt, c))
                ps.append(c["perm_p"])
        adjusted = holm(ps)
        m = sum(p is not None for p in ps)
        lines += [f"Final figures per condition, mean ± std across seeds (ddof 0), of {name_a} "
                  f"and {name_b}; difference {name_b} minus {name_a} with its 95 % bootstrap "
                  f"interval over seeds (unpaired), two-sided permutation p (10 000 draws: "
                  f"'<= 0.0001' is a bound) and Mann-Whitney p, the permutation p Holm-adjusted "
                  f"over the {m} figures of the table.", "",
                  f"| condition | figure | {name_a} | {name_b} | difference [95 % interval] | "
                  f"permutation p | Mann-Whitney p | Holm p |", "|---|---|---|---|---|---|---|---|"]
        for (g, key, label, fmt, c), p_holm in zip(rows, adjusted):
            cells = [fmt2.format(fmt, fmt).format(s[g][f"{key}_mean"], s[g][f"{key}_std"])
                     for s in (a, b)]
            sfmt = fmt.replace("{:", "{:+")
            if c["perm_p"] is None:
                test = "| | | |"
                diff = sfmt.format(c["difference"])
            else:
                diff = (f"{sfmt.format(c['difference'])} [{sfmt.format(c['difference_low'])}, "
                        f"{sfmt.format(c['difference_high'])}]")
                test = (f"| {p_text(c['perm_p'], c['perm_p_min'], c['perm_bound'])} | "
                        f"{p_text(c['mwu_p'])} | {p_text(p_holm, p_holm, c['perm_bound'])} |")
            lines.append(f"| {g} | {label} | {cells[0]} | {cells[1]} | {diff} {test}")
        known = [(p, c["perm_bound"]) for p, (*_, c) in zip(adjusted, rows) if p is not None]
        smallest = min(known, default=None)
        lines += ["", f"{sum(p < 0.05 for p, _ in known)} of {m} figures differ at Holm p < 0.05; "
                      f"smallest Holm p "
                      f"{p_text(smallest[0], smallest[0], smallest[1]) if smallest else 'n/a'}."]
    else:
        m = sum(1 for g in groups for key, _, _ in FIGURES
                if a[g][f"{key}_std"] > 0 or b[g][f"{key}_std"] > 0)
        wide = 1 - 0.05 / max(m, 1)
        level = f"{wide * 100:.3g} %"
        lines += [f"Final figures per condition, mean ± std across seeds (ddof 0), of {name_a} "
                  f"and {name_b}; difference {name_b} minus {name_a}. A run is given by its "
                  f"summaries only (its per-seed values were not kept), so there is no bootstrap "
                  f"and no permutation test: the intervals are t intervals from the two "
                  f"summaries (unequal variances), at 95 % and at {level} (Bonferroni over "
                  f"the {m} figures: all {m} hold together with 95 % confidence); no p-value.",
                  "",
                  f"| condition | figure | {name_a} | {name_b} | difference [95 % interval] | "
                  f"[{level} interval] |", "|---|---|---|---|---|---|"]
        outside = outside_wide = 0
        for g in groups:
            na, nb = a[g]["n"], b[g]["n"]
            for key, label, fmt in FIGURES:
                sfmt = fmt.replace("{:", "{:+")
                ma, sa = a[g][f"{key}_mean"], a[g][f"{key}_std"]
                mb, sb = b[g][f"{key}_mean"], b[g][f"{key}_std"]
                cells = [fmt2.format(fmt, fmt).format(ma, sa), fmt2.format(fmt, fmt).format(mb, sb)]
                ci, ci_wide = (t_interval(ma, sa, na, mb, sb, nb, lv) for lv in (0.95, wide))
                if ci is None:
                    lines.append(f"| {g} | {label} | {cells[0]} | {cells[1]} | "
                                 f"{sfmt.format(mb - ma)} (no spread) | |")
                    continue
                outside += not ci[0] <= 0 <= ci[1]
                outside_wide += not ci_wide[0] <= 0 <= ci_wide[1]
                lines.append(f"| {g} | {label} | {cells[0]} | {cells[1]} | "
                             f"{sfmt.format(mb - ma)} [{sfmt.format(ci[0])}, "
                             f"{sfmt.format(ci[1])}] | [{sfmt.format(ci_wide[0])}, "
                             f"{sfmt.format(ci_wide[1])}] |")
        lines += ["", f"The 95 % interval excludes 0 for {outside} of the {m} figures, the "
                      f"{level} interval for {outside_wide}."]
    single = [f"{g}, {label}: {fmt.format(a[g][key])} and {fmt.format(b[g][key])}"
              for g in groups for key, label, fmt in SINGLE if key in a[g] and key in b[g]]
    if single:
        lines += ["", "Weight structure, mean over seeds (from the trained tables; no test): "
                  + "; ".join(single) + "."]
    print("\n".join(lines))
    return 0


if __name__ == "__main__":
    sys.exit(main())
