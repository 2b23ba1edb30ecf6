"""Times to an event ("learnt by session N") with the seeds that never got there counted.

A seed that had not learnt by its last session is not a missing value: it is a seed that took
*longer* than the study ran (right-censored at its last session). Dropping it compares only the
seeds that learnt, which favours the condition that learnt rarely but early. Here every seed
counts:

* :func:`first_reached`: the session at which a trailing mean first reaches a threshold, and
  whether it did (``observed``); a seed that never did gets its last session and
  ``observed = False``;
* :func:`censored_compare`: two groups of such times compared on the *censored-at-end* values
  (a seed that never learnt counts as its last session, so no seed is dropped): the difference
  of the restricted mean time (the mean of the censored-at-end values, a lower bound of the
  mean time whose restriction is the study's length), its 95% bootstrap interval and
  permutation p (paired by seed where asked: sign flips of the per-seed differences), and the
  log-rank test (unpaired; :func:`logrank`) of the two groups' times with their censoring.
"""

from __future__ import annotations

import math
from typing import Any, Sequence

import numpy as np

from .compare import compare


def first_reached(values: Sequence[float], threshold: float, window: int = 10
                  ) -> tuple[float, bool]:
    """``(session, observed)``: the first session (1-based, the window's last) at which the
    trailing mean of ``window`` values reaches ``threshold``; a series that never does is
    censored at its last session (``observed`` False)."""
    v = np.asarray(values, dtype=float)
    if len(v) >= window:
        trailing = np.convolve(v, np.ones(window) / window, mode="valid")
        reached = np.flatnonzero(trailing >= threshold)
        if len(reached):
            return float(reached[0] + window), True
    return float(len(v)), False


def logrank(times_a: Sequence[float], observed_a: Sequence[bool], times_b: Sequence[float],
            observed_b: Sequence[bool]) -> dict[str, float]:
    """The two-sided log-rank test of two groups of right-censored times: ``chi2`` (1 degree
    of freedom) and ``p``; p = 1 where no event happened in either group."""
    from scipy import stats

    t = np.concatenate([np.asarray(times_a, float), np.asarray(times_b, float)])
    e = np.concatenate([np.asarray(observed_a, bool), np.asarray(observed_b, bool)])
    g = np.concatenate([np.zeros(len(times_a), bool), np.ones(len(times_b), bool)])
    o_minus_e = var = 0.0
    for time in np.unique(t[e]):
        at_risk = t >= time
        n, n_a = at_risk.sum(), (at_risk & ~g).sum()
        d = (e & (t == time)).sum()
        d_a = (e & (t == time) & ~g).sum()
        o_minus_e += d_a - d * n_a / n
        if n > 1:
            var += d * (n_a / n) * (1 - n_a / n) * (n - d) / (n - 1)
    if var <= 0:
        return {"chi2": 0.0, "p": 1.0}
    chi2 = o_minus_e ** 2 / var
    return {"chi2": float(chi2), "p": float(stats.chi2.sf(chi2, 1))}


def censored_compare(a: Sequence[tuple[float, bool]], b: Sequence[tuple[float, bool]], *,
                     paired: bool = False) -> dict[str, Any]:
    """Times to an event of two groups (``(time, observed)`` per seed, :func:`first_reached`),
    every seed counted: :func:`~astrocpg.studies.analysis.compare.compare` of the
    censored-at-end values (``difference``: restricted mean of ``a`` minus that of ``b``, its
    interval and permutation p; ``paired``: seed k of one against seed k of the other), with
    ``never_a``, ``never_b`` (seeds censored) and the log-rank ``logrank_p`` (unpaired)."""
    out = compare([t for t, _ in a], [t for t, _ in b], paired=paired)
    out["never_a"] = sum(not o for _, o in a)
    out["never_b"] = sum(not o for _, o in b)
    rank = logrank([t for t, _ in a], [o for _, o in a], [t for t, _ in b], [o for _, o in b])
    out["logrank_chi2"], out["logrank_p"] = rank["chi2"], rank["p"]
    return out


def observed_only(a: Sequence[tuple[float, bool]], b: Sequence[tuple[float, bool]], *,
                  paired: bool = False) -> dict[str, Any]:
    """The comparison that drops the seeds that never got there (only for showing how much it
    differs: it is not a test of the time to the event)."""
    if paired:
        keep = [(x, y) for (x, ox), (y, oy) in zip(a, b) if ox and oy]
        return compare([x for x, _ in keep], [y for _, y in keep], paired=True)
    return compare([t if o else math.nan for t, o in a], [t if o else math.nan for t, o in b])


__all__ = ["first_reached", "logrank", "censored_compare", "observed_only"]
