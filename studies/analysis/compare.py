"""Two groups of seeds compared: the difference of means, Welch's t-test, the Mann-Whitney U
test and their effect sizes (Hedges' g, Cohen's d, the rank-biserial correlation).

Used by ``astrocpg report`` for the contrast between a study's conditions (e.g. astrocytes vs
none), one final figure per seed on each side.
"""

from __future__ import annotations

import math
import warnings
from typing import Any, Sequence

import numpy as np

# Fewer seeds than this on a side: no test (a t-test needs a variance on each side)
MIN_SEEDS = 2


def compare(a: Sequence[float], b: Sequence[float]) -> dict[str, Any]:
    """Compare the per-seed values ``a`` and ``b`` (non-finite values are dropped).

    Returns n_a, n_b, mean_a, mean_b, difference (mean_a - mean_b), and, with at least
    :data:`MIN_SEEDS` values on each side: welch_t, welch_p (two-sided Welch's t-test,
    ``scipy.stats.ttest_ind(equal_var=False)``), mwu_U (U of ``a``), mwu_p (two-sided
    ``scipy.stats.mannwhitneyu``), cohens_d and hedges_g (difference over the pooled sample
    standard deviation; g with the small-sample correction 1 - 3/(4(n_a+n_b)-9)), rank_biserial
    (2U/(n_a n_b) - 1: +1 when every value of ``a`` exceeds every value of ``b``). ``note`` says
    why a figure is missing: "n too small" (fewer than two seeds on a side), "no spread" (every
    value equal on both sides, to rounding: t and d undefined)."""
    from scipy import stats

    x = np.asarray([v for v in a if np.isfinite(v)], dtype=float)
    y = np.asarray([v for v in b if np.isfinite(v)], dtype=float)
    out: dict[str, Any] = {
        "n_a": len(x), "n_b": len(y),
        "mean_a": float(x.mean()) if len(x) else math.nan,
        "mean_b": float(y.mean()) if len(y) else math.nan,
    }
    out["difference"] = out["mean_a"] - out["mean_b"]
    keys = ("welch_t", "welch_p", "mwu_U", "mwu_p", "cohens_d", "hedges_g", "rank_biserial")
    out.update({k: None for k in keys})
    if len(x) < MIN_SEEDS or len(y) < MIN_SEEDS:
        out["note"] = "n too small"
        return out
    u = stats.mannwhitneyu(x, y, alternative="two-sided")
    out["mwu_U"], out["mwu_p"] = float(u.statistic), float(u.pvalue)
    out["rank_biserial"] = 2.0 * float(u.statistic) / (len(x) * len(y)) - 1.0
    pooled = math.sqrt(((len(x) - 1) * x.var(ddof=1) + (len(y) - 1) * y.var(ddof=1))
                       / (len(x) + len(y) - 2))
    # both sides constant (to rounding: means of the same sessions summed in another order):
    # t and d divide by zero, or by rounding noise
    if pooled <= 1e-12 * max(abs(out["mean_a"]), abs(out["mean_b"]), 1e-300):
        out["note"] = "no spread"
        return out
    with warnings.catch_warnings():
        # one side constant to rounding (the other spread): its variance is ~0, which is what
        # Welch's test uses; scipy's "precision loss" warning says no more than that
        warnings.filterwarnings("ignore", "Precision loss", RuntimeWarning)
        t = stats.ttest_ind(x, y, equal_var=False)
    out["welch_t"], out["welch_p"] = float(t.statistic), float(t.pvalue)
    d = out["difference"] / pooled
    out["cohens_d"] = d
    out["hedges_g"] = d * (1.0 - 3.0 / (4.0 * (len(x) + len(y)) - 9.0))
    out["note"] = ""
    return out
