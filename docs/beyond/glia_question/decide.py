"""The glia question's tests, as RULES.md fixes them: H1 (the drive window) and H2 (the
lopsided body), from the evaluations of the final tables (``astrocpg evaluate``, flat ground,
10 s, 5 repeats, learning off).

    python docs/beyond/glia_question/decide.py h1 --glia-drive GLIA_DRIVE_EVAL.csv > h1.md
    python docs/beyond/glia_question/decide.py h2 --glia-lopsided GLIA_LOPSIDED_EVAL.csv \\
        --glia-drive GLIA_DRIVE_EVAL.csv > h2.md

The arms are read from each row's ``source`` (the run id): ``graded-astrocyte`` the graded
astrocyte, ``homeostatic-interlimb-synapse`` the activity control, ``constant-depression`` the
constant control, ``no-astrocytes`` none (left out), any other the paper's astrocyte; the drive from ``I_background_0`` in it
(1104, 1242, 1380, 1518, 1656 mV/s: 0.8-1.2 x; none: 1.0 x). The paper's astrocyte at
0.8-1.2 x is ``docs/beyond/drive_full/evaluation.csv``, at 1.0 x the flat world of
``docs/beyond/robustness/evaluation.csv`` (the flat ablation), the controls at 1.0 x
``docs/beyond/homeostatic_control/evaluation.csv``: the defaults. Seeds 1-12 only.

The unit is the seed: each seed's share of its 5 runs with a trot (gait, from the feet; rhythm,
the CPG's), averaged over the drives 0.8, 0.9, 1.1 and 1.2 x for H1 (its off-drive share). Arms
are compared seed by seed (a seed draws the same noise in every arm): the mean difference, its
95 % bootstrap interval over seeds (10 000 resamples, generator seed 0), the exact two-sided
sign-flip p (all 2^12 sign patterns) and Holm's adjustment over the family's tests.
"""

from __future__ import annotations

import argparse
import itertools
import math
import sys
from pathlib import Path

import numpy as np
import pandas as pd

DOCS = Path(__file__).resolve().parents[2]
SEEDS = range(1, 13)
DRIVES = {"1104": 0.8, "1242": 0.9, "1380": 1.0, "1518": 1.1, "1656": 1.2}
OFF = (0.8, 0.9, 1.1, 1.2)
MEASURES = {"rhythm": "trot rhythm (thigh bursts)", "gait": "trot gait (feet, upright)"}
#: equivalence margins (RULES.md): H1 on the off-drive share, H2 on the lopsided share
MARGINS = {"h1": {"rhythm": 0.10, "gait": 0.05}, "h2": {"rhythm": 0.15, "gait": 0.10}}
PRIMARY = (("graded", "constant"), ("activity", "constant"))
SECONDARY = (("graded", "paper"), ("graded", "activity"), ("paper", "constant"))
ALPHA, POWER_Z = 0.05, 0.8416  # two-sided 5 %, 80 % power


def arm_of(source: str) -> str:
    if source.startswith(("no-astrocytes", "no_astrocytes")):
        return "none"
    if "graded-astrocyte" in source:
        return "graded"
    if "homeostatic-interlimb-synapse" in source:
        return "activity"
    if "constant-depression" in source:
        return "constant"
    return "paper"


def drive_of(source: str) -> float:
    for key, drive in DRIVES.items():
        if f"I_background_0={key}" in source:
            return drive
    return 1.0


def shares(path: Path, *, lopsided: bool = False, world: str = "flat") -> pd.DataFrame:
    """Per (arm, drive, seed): the share of its runs with a trot gait and with a trot rhythm."""
    t = pd.read_csv(path)
    t = t[(t["world"] == world) & t["seed"].isin(SEEDS)].copy()
    t["arm"] = t["source"].map(arm_of)
    t["drive"] = "lopsided" if lopsided else t["source"].map(drive_of)
    t["gait"] = (t["gait"] == "trot").astype(float)
    t["rhythm"] = (t["rhythm"] == "trot").astype(float)
    return t.groupby(["arm", "drive", "seed"], as_index=False)[["gait", "rhythm"]].mean() \
        .assign(runs=t.groupby(["arm", "drive", "seed"]).size().to_numpy())


def sign_flip_p(d: np.ndarray) -> float:
    """Exact two-sided sign-flip p of the mean of ``d`` (every one of the 2^n patterns)."""
    d = np.asarray(d, dtype=float)
    observed = abs(d.mean())
    if observed == 0:
        return 1.0
    signs = np.array(list(itertools.product((1.0, -1.0), repeat=len(d))))
    return float(np.mean(np.abs(signs @ d / len(d)) >= observed - 1e-12))


def bootstrap(d: np.ndarray, n: int = 10_000, seed: int = 0) -> tuple[float, float]:
    rng = np.random.default_rng(seed)
    means = np.asarray(d, dtype=float)[rng.integers(0, len(d), (n, len(d)))].mean(axis=1)
    return float(np.quantile(means, 0.025)), float(np.quantile(means, 0.975))


def holm(p: list[float]) -> list[float]:
    order = np.argsort(p)
    out, running = [0.0] * len(p), 0.0
    for rank, k in enumerate(order):
        running = max(running, min(1.0, (len(p) - rank) * p[k]))
        out[k] = running
    return out


def z(q: float) -> float:
    """The standard normal quantile (bisection on erf; no scipy needed)."""
    lo, hi = -10.0, 10.0
    for _ in range(100):
        mid = (lo + hi) / 2
        lo, hi = (mid, hi) if 0.5 * (1 + math.erf(mid / math.sqrt(2))) < q else (lo, mid)
    return (lo + hi) / 2


def mdd(sd: float, n: int, tests: int) -> float:
    """The smallest mean per-seed difference found with 80 % power at the strictest Holm level
    (two-sided ``ALPHA / tests``), for per-seed differences of standard deviation ``sd``."""
    return (z(1 - ALPHA / tests / 2) + POWER_Z) * sd / math.sqrt(n)


def compare(values: dict[str, pd.Series], pairs, measure: str, margin: float) -> list[dict]:
    """Per pair (a, b): the per-seed differences a - b and their figures."""
    rows = []
    for a, b in pairs:
        if a not in values or b not in values:
            continue
        both = pd.concat([values[a], values[b]], axis=1, keys=["a", "b"]).dropna()
        d = (both["a"] - both["b"]).to_numpy()
        lo, hi = bootstrap(d)
        rows.append({"pair": f"{a} - {b}", "measure": measure, "seeds": len(d),
                     "a": float(both["a"].mean()), "b": float(both["b"].mean()),
                     "diff": float(d.mean()), "lo": lo, "hi": hi, "p": sign_flip_p(d),
                     "sd": float(np.std(d, ddof=1)) if len(d) > 1 else float("nan"),
                     "equivalent": -margin < lo and hi < margin, "margin": margin})
    return rows


def family(rows: list[dict]) -> list[dict]:
    for row, adjusted in zip(rows, holm([r["p"] for r in rows])):
        row["holm"] = adjusted
        row["mdd"] = mdd(row["sd"], row["seeds"], len(rows))
    return rows


def verdict(primary: list[dict]) -> str:
    """RULES.md: supported if a primary test is positive at Holm p < 0.05; against if one is
    negative at Holm p < 0.05, or if every primary interval lies inside its margins; else
    inconclusive at 12 seeds."""
    if any(r["holm"] < ALPHA and r["diff"] > 0 for r in primary):
        return "supported"
    if any(r["holm"] < ALPHA and r["diff"] < 0 for r in primary):
        return "against (a following depression does worse)"
    if primary and all(r["equivalent"] for r in primary):
        return "against (every primary difference within its margin)"
    return "inconclusive at 12 seeds"


def table(rows: list[dict], title: str) -> list[str]:
    out = [f"**{title}**", "", "| comparison | measure | seeds | first | second | difference "
           "[95 % interval] | sign-flip p | Holm p | within margin | MDD |",
           "|---|---|---|---|---|---|---|---|---|---|"]
    for r in rows:
        out.append(f"| {r['pair']} | {MEASURES[r['measure']]} | {r['seeds']} | {r['a']:.3f} | "
                   f"{r['b']:.3f} | {r['diff']:+.3f} [{r['lo']:+.3f}, {r['hi']:+.3f}] | "
                   f"{r['p']:.4g} | {r['holm']:.4g} | "
                   f"{'yes' if r['equivalent'] else 'no'} (±{r['margin']:g}) | {r['mdd']:.3f} |")
    return out + [""]


def describe(s: pd.DataFrame) -> list[str]:
    """Each arm's mean share per drive with its 95 % bootstrap interval over seeds."""
    drives = sorted(s["drive"].unique(), key=lambda d: (isinstance(d, str), d))
    out = ["| arm | measure | " + " | ".join(f"{d} x" if not isinstance(d, str) else d
                                              for d in drives) + " |",
           "|---|---|" + "---|" * len(drives)]
    for arm in ("paper", "graded", "activity", "constant"):
        for m in MEASURES:
            cells = []
            for d in drives:
                v = s[(s["arm"] == arm) & (s["drive"] == d)][m].to_numpy()
                if not len(v):
                    cells.append("")
                    continue
                lo, hi = bootstrap(v)
                cells.append(f"{v.mean():.2f} [{lo:.2f}, {hi:.2f}] (n={len(v)})")
            if any(cells):
                out.append(f"| {arm} | {MEASURES[m]} | " + " | ".join(cells) + " |")
    return out + [""]


def h1(s: pd.DataFrame) -> list[str]:
    off = s[s["drive"].isin(OFF)]
    counts = off.groupby(["arm", "seed"]).size()
    lines = ["## H1: the drive window", "", "Each arm's share of runs with a trot per drive, "
             "mean over seeds [95 % bootstrap interval]:", "", *describe(s)]
    incomplete = counts[counts != len(OFF)]
    if len(incomplete):
        lines += [f"Seeds without all four off-paper drives (left out of H1): "
                  f"{', '.join(f'{a} seed {k}' for a, k in incomplete.index)}", ""]
    complete = off.set_index(["arm", "seed"]).loc[counts[counts == len(OFF)].index]
    per_seed = complete.groupby(["arm", "seed"])[list(MEASURES)].mean()
    at_one = s[s["drive"] == 1.0].set_index(["arm", "seed"])
    return lines + _tests(per_seed, "h1", "off-drive share (mean of 0.8, 0.9, 1.1, 1.2 x)",
                          extra=(at_one, "at the paper's drive (1.0 x), described"))


def h2(lop: pd.DataFrame, sym: pd.DataFrame) -> list[str]:
    lines = ["## H2: the lopsided body (FL drive +20 %)", "",
             "Each arm's share of runs with a trot, lopsided and at the symmetric paper's drive "
             "(1.0 x), mean over seeds [95 % bootstrap interval]:", "",
             *describe(pd.concat([lop, sym[sym["drive"] == 1.0]]))]
    per_seed = lop.set_index(["arm", "seed"])[list(MEASURES)]
    return lines + _tests(per_seed, "h2", "share under the lopsided body")


def _tests(per_seed: pd.DataFrame, h: str, what: str, extra=None) -> list[str]:
    values = {m: {arm: per_seed.xs(arm, level="arm")[m] for arm in
                  per_seed.index.get_level_values("arm").unique()} for m in MEASURES}
    primary = family([r for m in MEASURES for r in
                      compare(values[m], PRIMARY, m, MARGINS[h][m])])
    secondary = family([r for m in MEASURES for r in
                        compare(values[m], SECONDARY, m, MARGINS[h][m])])
    lines = table(primary, f"Primary tests ({what}; Holm over {len(primary)})")
    lines += table(secondary, f"Secondary tests ({what}; Holm over {len(secondary)})")
    if extra is not None:
        frame, title = extra
        ex = {m: {arm: frame.xs(arm, level="arm")[m] for arm in
                  frame.index.get_level_values("arm").unique()} for m in MEASURES}
        lines += table(family([r for m in MEASURES for r in
                               compare(ex[m], PRIMARY, m, MARGINS[h][m])]), title)
    return lines + [f"**Verdict ({h.upper()}): {verdict(primary)}.**", ""]


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("hypothesis", choices=("h1", "h2"))
    p.add_argument("--glia-drive", type=Path,
                   help="evaluation.csv of the glia_drive study's final tables (h1; for h2 "
                        "only the description of the graded arm at the symmetric drive needs "
                        "it, the tests do not)")
    p.add_argument("--glia-lopsided", type=Path, help="evaluation.csv of glia_lopsided (h2)")
    p.add_argument("--drive-full", type=Path, default=DOCS / "beyond/drive_full/evaluation.csv")
    p.add_argument("--paper", type=Path, default=DOCS / "beyond/robustness/evaluation.csv",
                   help="the paper's astrocyte at 1.0 x (rows of source astrocytes__seeds1-20)")
    p.add_argument("--controls", type=Path,
                   default=DOCS / "beyond/homeostatic_control/evaluation.csv")
    a = p.parse_args(argv)
    paper = shares(a.paper)
    paper = paper[paper["arm"] == "paper"]
    if a.glia_drive is None and a.hypothesis == "h1":
        p.error("h1 needs --glia-drive")
    drive = [] if a.glia_drive is None else [shares(a.glia_drive)]
    sym = pd.concat([*drive, shares(a.drive_full), paper, shares(a.controls)],
                    ignore_index=True)
    if a.glia_drive is None:
        print("(Without --glia-drive: the graded astrocyte at the symmetric drive is not "
              "described; the tests below do not use it.)\n")
    if a.hypothesis == "h1":
        print("\n".join(h1(sym)))
    else:
        if a.glia_lopsided is None:
            p.error("h2 needs --glia-lopsided")
        print("\n".join(h2(shares(a.glia_lopsided, lopsided=True), sym)))
    return 0


if __name__ == "__main__":
    sys.exit(main())
