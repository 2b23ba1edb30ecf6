"""A share of runs (k of n) and its 95% interval.

A controller's gait is the share of its evaluation runs that show it; with a handful of runs
the share alone says little, so every share comes with the Wilson score interval (Wilson 1927;
it keeps inside [0, 1] and covers close to its nominal 95% for small n, unlike the normal
approximation).
"""

from __future__ import annotations

import math

Z95 = 1.959963984540054  # the two-sided 95% quantile of the standard normal


def wilson_interval(k: int, n: int, z: float = Z95) -> tuple[float, float]:
    """The Wilson score interval of the share ``k / n`` (95% by default); (nan, nan) for
    ``n == 0``."""
    if n <= 0:
        return math.nan, math.nan
    if not 0 <= k <= n:
        raise ValueError(f"k = {k} is not within 0..{n}")
    p = k / n
    z2 = z * z
    centre = (p + z2 / (2 * n)) / (1 + z2 / n)
    half = z * math.sqrt(p * (1 - p) / n + z2 / (4 * n * n)) / (1 + z2 / n)
    # k = 0 and k = n: the bound on that side is 0 or 1 exactly (not off by rounding)
    return (0.0 if k == 0 else max(0.0, centre - half)), (1.0 if k == n else min(1.0, centre + half))


def share_words(k: int, n: int) -> str:
    """``3 of 5 runs (60%, 95% interval 23-88%)``."""
    lo, hi = wilson_interval(k, n)
    if n == 0:
        return "0 runs"
    return f"{k} of {n} run{'s' if n != 1 else ''} ({k / n:.0%}, 95% interval {lo:.0%}-{hi:.0%})"


def label_shares(labels: list[str], named: tuple[str, ...]) -> dict[str, dict[str, float]]:
    """Each label of ``named`` that occurs in ``labels`` (one per run): ``k`` runs of ``n``,
    the ``share`` and its Wilson interval ``low``-``high``; and ``any``: the runs with any
    label of ``named``."""
    n = len(labels)
    out: dict[str, dict[str, float]] = {}
    for name in [*(x for x in named if x in labels), "any"]:
        k = sum(x in named for x in labels) if name == "any" else labels.count(name)
        lo, hi = wilson_interval(k, n)
        out[name] = {"k": k, "n": n, "share": k / n if n else math.nan, "low": lo, "high": hi}
    return out


__all__ = ["wilson_interval", "share_words", "label_shares", "Z95"]
