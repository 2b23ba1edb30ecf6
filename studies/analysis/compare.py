"""Two groups of seeds compared: the difference of means with its 95% bootstrap interval,
a permutation test of that difference, the Mann-Whitney U test and effect sizes (Hedges' g,
Cohen's d, the rank-biserial correlation); Welch's t alongside.

Used by ``astrocpg report`` for the contrast between a study's conditions (e.g. astrocytes vs
none), one final figure per seed on each side. With a handful of seeds a p-value is only as
small as the test allows: the permutation test enumerates every relabelling when there are
at most :data:`N_PERM` of them (exact), else draws :data:`N_PERM` of them (seeded; its p is
never below ``1 / (N_PERM + 1)``, and is given as that bound when no draw reached the
observed difference); the Mann-Whitney p is exact when no value is tied. Paired comparisons
(a study that declares ``paired = true``: seed k of one condition against seed k of the
other) use the sign-flip permutation test and a bootstrap over pairs. :func:`holm` adjusts
a family of p-values (Holm 1979).

A difference that is not shown is no evidence of sameness, and a multiplicity adjustment only
makes a difference harder to show. So every comparison also gives the smallest difference the
test could detect (:func:`detectable_difference`: 80 % power, two-sided alpha 0.05, from the
data's own spread), and, where a margin was declared before the data (a study file's
``[margins]``), the equivalence test of that margin (:func:`tost`: two one-sided t-tests);
:func:`reading_words` says which of "its 95% interval excludes 0", "equivalent within the
margin" and "not shown to differ; the smallest difference this study could detect is X" the
numbers support.
"""

from __future__ import annotations

import itertools
import math
import warnings
from typing import Any, Sequence

import numpy as np

# Fewer seeds than this on a side: no test (a t-test needs a variance on each side)
MIN_SEEDS = 2
N_PERM = 10000
"""Permutations (or sign flips) of a Monte Carlo permutation test; fewer relabellings than
this are all enumerated (an exact test)."""
N_BOOT = 10000
"""Bootstrap resamples of a difference's 95% interval."""
SEED = 20231215
"""The fixed seed of every resampling here (bootstrap, Monte Carlo permutations): a report
gives the same intervals and p-values every time it is made."""


def _finite(x: np.ndarray, y: np.ndarray) -> bool:
    """Every value of both groups a number: a NaN or an infinity makes a test's statistic
    undefined, and counting relabellings against it would give a small, false p."""
    return bool(np.all(np.isfinite(x)) and np.all(np.isfinite(y)))


def bootstrap_interval(a: Sequence[float], b: Sequence[float], *, paired: bool = False,
                       n_boot: int = N_BOOT, seed: int = SEED,
                       level: float = 0.95) -> tuple[float, float]:
    """Percentile bootstrap interval of mean(a) - mean(b): seeds resampled with replacement
    within each group (``paired``: pairs (a_k, b_k) resampled together); (nan, nan) with
    fewer than two values on a side."""
    x, y = np.asarray(a, dtype=float), np.asarray(b, dtype=float)
    if len(x) < 2 or len(y) < 2 or not _finite(x, y):
        return math.nan, math.nan
    rng = np.random.default_rng(seed)
    if paired:
        d = x - y
        stats_ = d[rng.integers(0, len(d), (n_boot, len(d)))].mean(axis=1)
    else:
        stats_ = (x[rng.integers(0, len(x), (n_boot, len(x)))].mean(axis=1)
                  - y[rng.integers(0, len(y), (n_boot, len(y)))].mean(axis=1))
    q = (1.0 - level) / 2.0
    lo, hi = np.quantile(stats_, [q, 1.0 - q])
    return float(lo), float(hi)


def permutation_test(a: Sequence[float], b: Sequence[float], *, paired: bool = False,
                     n_perm: int = N_PERM, seed: int = SEED) -> dict[str, Any]:
    """Two-sided permutation test of mean(a) - mean(b): the share of relabellings (paired:
    sign flips of the pair differences) whose |difference| reaches the observed one.

    Returns ``p``, ``exact`` (every relabelling enumerated), ``n`` (relabellings counted),
    ``p_min`` (the smallest p this test can give: 1/n of the relabellings exact, else
    1/(n_perm + 1)) and ``bound`` (True when no Monte Carlo draw reached the observed
    difference: p is then ``< p_min``-style, written ``<= 1/(n_perm+1)``)."""
    x, y = np.asarray(a, dtype=float), np.asarray(b, dtype=float)
    if not _finite(x, y):  # a NaN reaches no observed difference: p would read as tiny
        return {"p": math.nan, "exact": False, "n": 0, "p_min": math.nan, "bound": False}
    tol = 1e-12 * max(1.0, float(np.abs(np.concatenate([x, y])).max(initial=0.0)))
    if paired:
        d = x - y
        observed = abs(d.mean())
        m = len(d)
        if 2 ** m <= n_perm:
            signs = ((np.arange(2 ** m)[:, None] >> np.arange(m)) & 1) * 2 - 1
            stats_ = np.abs((signs * d).mean(axis=1))
            hits = int(np.sum(stats_ >= observed - tol))
            return {"p": hits / len(stats_), "exact": True, "n": len(stats_),
                    "p_min": 1.0 / len(stats_), "bound": False}
        rng = np.random.default_rng(seed)
        signs = rng.choice([-1.0, 1.0], size=(n_perm, m))
        stats_ = np.abs((signs * d).mean(axis=1))
    else:
        pooled = np.concatenate([x, y])
        n, k = len(pooled), len(x)
        observed = abs(x.mean() - y.mean())
        total = pooled.sum()
        if math.comb(n, k) <= n_perm:
            sums = np.array([pooled[list(c)].sum() for c in itertools.combinations(range(n), k)])
            stats_ = np.abs(sums / k - (total - sums) / (n - k))
            hits = int(np.sum(stats_ >= observed - tol))
            return {"p": hits / len(stats_), "exact": True, "n": len(stats_),
                    "p_min": 1.0 / len(stats_), "bound": False}
        rng = np.random.default_rng(seed)
        idx = np.argsort(rng.random((n_perm, n)), axis=1)[:, :k]
        sums = pooled[idx].sum(axis=1)
        stats_ = np.abs(sums / k - (total - sums) / (n - k))
    hits = int(np.sum(stats_ >= observed - tol))
    return {"p": (hits + 1) / (n_perm + 1), "exact": False, "n": n_perm,
            "p_min": 1.0 / (n_perm + 1), "bound": hits == 0}


def mann_whitney(x: np.ndarray, y: np.ndarray) -> tuple[float, float, float]:
    """U of ``x``, its two-sided p (exact when no value is tied, else the normal
    approximation with tie correction) and the smallest p the exact test can give,
    2 / C(n_x + n_y, n_x)."""
    from scipy import stats

    p_min = min(1.0, 2.0 / math.comb(len(x) + len(y), len(x)))
    if not _finite(np.asarray(x, dtype=float), np.asarray(y, dtype=float)):
        return math.nan, math.nan, p_min  # no ranks for a NaN: no test, never a small p
    pooled = np.concatenate([x, y])
    method = "exact" if len(np.unique(pooled)) == len(pooled) else "asymptotic"
    u = stats.mannwhitneyu(x, y, alternative="two-sided", method=method)
    # the normal approximation may go below what any ordering of these n values can give
    return float(u.statistic), max(float(u.pvalue), p_min), p_min


def holm(p: Sequence[float | None]) -> list[float | None]:
    """Holm's step-down adjustment of a family of p-values (None: no test, left out of the
    family and returned as None): the k-th smallest of m times (m - k + 1), made monotone,
    at most 1."""
    known = [(v, i) for i, v in enumerate(p) if v is not None and np.isfinite(v)]
    m = len(known)
    out: list[float | None] = [None] * len(p)
    running = 0.0
    for rank, (v, i) in enumerate(sorted(known)):
        running = max(running, min(1.0, (m - rank) * v))
        out[i] = running
    return out


def p_text(p: float | None, p_min: float | None = None, bound: bool = False) -> str:
    """A p-value as the report writes it: ``0.0079``, or ``<= 0.0001`` when it is a bound
    (no Monte Carlo draw reached the observed difference)."""
    if p is None or not np.isfinite(p):
        return "n/a"
    if bound and p_min is not None:
        return f"<= {p_min:.2g}"
    return f"{p:.2g}"


ALPHA = 0.05
POWER = 0.8


def _se_df(x: np.ndarray, y: np.ndarray, paired: bool) -> tuple[float, float]:
    """The standard error of mean(x) - mean(y) and its degrees of freedom (paired: of the
    differences; else Welch-Satterthwaite)."""
    if paired:
        d = x - y
        return float(d.std(ddof=1) / math.sqrt(len(d))), float(len(d) - 1)
    va, vb = x.var(ddof=1) / len(x), y.var(ddof=1) / len(y)
    se2 = va + vb
    if se2 <= 0:
        return 0.0, float(len(x) + len(y) - 2)
    df = se2 ** 2 / (va ** 2 / (len(x) - 1) + vb ** 2 / (len(y) - 1))
    return float(math.sqrt(se2)), float(df)


def detectable_difference(a: Sequence[float], b: Sequence[float], *, paired: bool = False,
                          alpha: float = ALPHA, power: float = POWER) -> float:
    """The smallest true difference of means a two-sided t-test of these samples would find
    with probability ``power`` at level ``alpha``: (t_{1-alpha/2} + t_{power}) x the standard
    error of the difference, from the samples' own spread (paired: of the per-seed
    differences); nan with fewer than two values on a side."""
    from scipy import stats

    x, y = np.asarray(a, dtype=float), np.asarray(b, dtype=float)
    if len(x) < 2 or len(y) < 2:
        return math.nan
    se, df = _se_df(x, y, paired)
    return float((stats.t.ppf(1 - alpha / 2, df) + stats.t.ppf(power, df)) * se)


def tost(a: Sequence[float], b: Sequence[float], margin: float, *, paired: bool = False,
         alpha: float = ALPHA) -> dict[str, Any]:
    """The equivalence test of mean(a) - mean(b) against the margin +-``margin`` (two
    one-sided t-tests, Schuirmann 1987): ``p`` (the larger one-sided p; below ``alpha``: the
    difference is within the margin), ``low``/``high`` (the 1 - 2 alpha interval, which lies
    within the margin exactly when p < alpha) and ``equivalent``."""
    from scipy import stats

    x, y = np.asarray(a, dtype=float), np.asarray(b, dtype=float)
    if not margin > 0:
        raise ValueError(f"an equivalence margin must be positive, got {margin}")
    if len(x) < 2 or len(y) < 2:
        return {"p": math.nan, "low": math.nan, "high": math.nan, "equivalent": False}
    diff = float(x.mean() - y.mean())
    se, df = _se_df(x, y, paired)
    if se == 0:
        p = 0.0 if abs(diff) < margin else 1.0
        return {"p": p, "low": diff, "high": diff, "equivalent": p < alpha}
    p_low = stats.t.sf((diff + margin) / se, df)   # H0: diff <= -margin
    p_high = stats.t.cdf((diff - margin) / se, df)  # H0: diff >= +margin
    p = float(max(p_low, p_high))
    half = stats.t.ppf(1 - alpha, df) * se
    return {"p": p, "low": diff - half, "high": diff + half, "equivalent": p < alpha}


def reading_words(t: dict[str, Any], fmt: str = ".3g") -> str:
    """What a comparison (:func:`compare`) supports, in words: ``its 95% interval excludes 0
    (not adjusted for the other tests)`` (a difference, before any adjustment for the family
    of tests: the adjusted p says more); ``equivalent within +-m (TOST p = ...)`` where a
    margin was declared and its test passed; else ``not shown to differ; the smallest difference this study could detect (80 %
    power, alpha 0.05) is X`` (and, with a margin, that the equivalence was not shown either).
    Never "the same"."""
    if t.get("difference_low") is None:
        return f"no test ({t.get('note') or 'n too small'})"
    margin = t.get("margin")
    if margin is not None and t.get("equivalent"):
        return (f"equivalent within ±{format(margin, fmt)} (TOST p = "
                f"{p_text(t['tost_p'])})")
    if t["difference_low"] > 0 or t["difference_high"] < 0:
        return "its 95% interval excludes 0 (not adjusted for the other tests)"
    mdd = t.get("detectable")
    words = ("not shown to differ; the smallest difference this study could detect (80% "
             "power, alpha 0.05) is " + (format(mdd, fmt) if mdd is not None
                                         and np.isfinite(mdd) else "n/a"))
    if margin is not None:
        words += (f"; not shown equivalent within ±{format(margin, fmt)} either (TOST p = "
                  f"{p_text(t.get('tost_p'))})")
    return words


def compare(a: Sequence[float], b: Sequence[float], *, paired: bool = False,
            margin: float | None = None) -> dict[str, Any]:
    """Compare the per-seed values ``a`` and ``b`` (non-finite values are dropped; ``paired``:
    ``a[k]`` and ``b[k]`` are one pair, a pair with a non-finite side is dropped).

    Returns n_a, n_b, mean_a, mean_b, difference (mean_a - mean_b), paired, and, with at
    least :data:`MIN_SEEDS` values on each side: difference_low and difference_high (its 95%
    bootstrap interval, :func:`bootstrap_interval`), perm_p, perm_exact, perm_p_min,
    perm_bound (:func:`permutation_test`), welch_t, welch_p (two-sided Welch's t-test,
    ``scipy.stats.ttest_ind(equal_var=False)``; not for a handful of seeds: the report gives
    the permutation p), mwu_U (U of ``a``), mwu_p, mwu_p_min (:func:`mann_whitney`; unpaired
    only), cohens_d and hedges_g (difference over the pooled sample
    standard deviation; g with the small-sample correction 1 - 3/(4(n_a+n_b)-9)), rank_biserial
    (2U/(n_a n_b) - 1: +1 when every value of ``a`` exceeds every value of ``b``). ``note`` says
    why a figure is missing: "n too small" (fewer than two seeds on a side), "no spread" (every
    value equal on both sides, to rounding: t and d undefined). ``detectable``: the smallest
    difference the test could detect (:func:`detectable_difference`); with ``margin`` (an
    equivalence margin declared before the data) ``margin``, ``tost_p``, ``tost_low``,
    ``tost_high`` and ``equivalent`` (:func:`tost`)."""
    from scipy import stats

    if paired:
        if len(a) != len(b):
            raise ValueError(f"paired samples of different lengths ({len(a)}, {len(b)})")
        keep = [(u, v) for u, v in zip(a, b) if np.isfinite(u) and np.isfinite(v)]
        x = np.asarray([u for u, _ in keep], dtype=float)
        y = np.asarray([v for _, v in keep], dtype=float)
    else:
        x = np.asarray([v for v in a if np.isfinite(v)], dtype=float)
        y = np.asarray([v for v in b if np.isfinite(v)], dtype=float)
    out: dict[str, Any] = {
        "n_a": len(x), "n_b": len(y), "paired": paired,
        "mean_a": float(x.mean()) if len(x) else math.nan,
        "mean_b": float(y.mean()) if len(y) else math.nan,
    }
    out["difference"] = out["mean_a"] - out["mean_b"]
    keys = ("difference_low", "difference_high", "perm_p", "perm_exact", "perm_p_min",
            "perm_bound", "welch_t", "welch_p", "mwu_U", "mwu_p", "mwu_p_min", "cohens_d",
            "hedges_g", "rank_biserial", "detectable")
    out.update({k: None for k in keys})
    out["margin"] = margin
    if margin is not None:
        out.update({"tost_p": None, "tost_low": None, "tost_high": None, "equivalent": False})
    if len(x) < MIN_SEEDS or len(y) < MIN_SEEDS:
        out["note"] = "n too small"
        return out
    out["detectable"] = detectable_difference(x, y, paired=paired)
    if margin is not None:
        e = tost(x, y, margin, paired=paired)
        out.update({"tost_p": e["p"], "tost_low": e["low"], "tost_high": e["high"],
                    "equivalent": e["equivalent"]})
    out["difference_low"], out["difference_high"] = bootstrap_interval(x, y, paired=paired)
    perm = permutation_test(x, y, paired=paired)
    out.update({"perm_p": perm["p"], "perm_exact": perm["exact"], "perm_p_min": perm["p_min"],
                "perm_bound": perm["bound"]})
    if not paired:
        u, out["mwu_p"], out["mwu_p_min"] = mann_whitney(x, y)
        out["mwu_U"] = u
        out["rank_biserial"] = 2.0 * u / (len(x) * len(y)) - 1.0
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
