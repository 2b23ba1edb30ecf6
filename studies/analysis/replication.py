"""Shares and means over the unit of replication: the trained table (or seed), never the runs.

An evaluation runs each trained table several times (repeats with different noise). The runs
of one table are not independent samples of its condition: they share the table. So every
figure of a condition is computed in two steps here: each table's own share (or mean) over its
runs, then the mean over tables with an interval over tables:

* :func:`over_tables`: Student's t interval of the tables' values (n - 1 degrees of freedom;
  a share's interval kept within [0, 1]). Where the tables' values do not vary at all (every
  table 0 % or every table 100 %, where the t interval has no width) a share's interval is the
  Wilson interval of the tables as n one-table trials instead (the common share times n as
  its count), so that 0 of 4 tables is not read as an exact 0. One table: no interval (nan).
* :func:`tables_differ`: whether the tables differ from each other in a run-level label (e.g.
  trot), tested before anything speaks of "tables that trot": the chi-square statistic of the
  tables x (label, not) counts, its p by permutation of the runs' labels between the tables
  (seeded, :data:`~astrocpg.studies.analysis.replication.N_PERM` draws; the tables' run
  counts kept). A p well above 0.05 says the
  spread over tables is what one common share would give.
"""

from __future__ import annotations

import math
from typing import Any, Mapping, Sequence

import numpy as np

from .gait import THRESHOLDS, gait_at
from .share import wilson_interval

N_PERM = 10000
"""Permutations of the runs' labels between tables (:func:`tables_differ`)."""
SEED = 20231215
"""The fixed seed of the permutations: the same p every time."""


def group_by_table(rows: Sequence[Mapping[str, Any]],
                   key: Sequence[str] = ("source", "seed")) -> dict[tuple, list[Mapping]]:
    """The runs ``rows`` grouped by their table (the columns ``key``: an evaluation's source
    and seed; a gait's ``table``), in the order they first occur."""
    out: dict[tuple, list[Mapping[str, Any]]] = {}
    for r in rows:
        out.setdefault(tuple(r[k] for k in key), []).append(r)
    return out


def over_tables(values: Sequence[float], *, share: bool = False,
                level: float = 0.95) -> dict[str, Any]:
    """The mean of one value per table (each table's share or mean over its runs) and its
    ``level`` interval over tables (the module's description says how; non-finite values are
    left out): ``{"mean", "low", "high", "n_tables", "method"}`` (method: ``t`` or
    ``wilson over tables``, ``""`` for fewer than two tables)."""
    from scipy import stats

    v = np.asarray([x for x in values if np.isfinite(x)], dtype=float)
    n = len(v)
    out = {"mean": float(v.mean()) if n else math.nan, "low": math.nan, "high": math.nan,
           "n_tables": n, "method": ""}
    if n < 2:
        return out
    sd = float(v.std(ddof=1))
    if share and sd <= 1e-12:  # every table 0 %, every table 100 %, or one common share
        z = stats.norm.ppf(0.5 + level / 2)
        k = out["mean"] * n
        out["low"], out["high"] = wilson_interval(k if abs(k - round(k)) > 1e-9
                                                  else int(round(k)), n, z)
        out["method"] = "wilson over tables"
        return out
    half = stats.t.ppf(0.5 + level / 2, n - 1) * sd / math.sqrt(n)
    lo, hi = out["mean"] - half, out["mean"] + half
    if share:
        lo, hi = max(0.0, lo), min(1.0, hi)
    out["low"], out["high"], out["method"] = float(lo), float(hi), "t"
    return out


def share_over_tables(labels: Sequence[Sequence[str]], label: str | set[str],
                      level: float = 0.95) -> dict[str, Any]:
    """The share of runs with ``label`` (a label or a set of labels), per table first:
    ``labels`` holds each table's run labels. :func:`over_tables` of the tables' shares, with
    ``k`` and ``n_runs`` (runs with the label, runs)."""
    want = {label} if isinstance(label, str) else set(label)
    shares = [sum(x in want for x in t) / len(t) for t in labels if len(t)]
    out = over_tables(shares, share=True, level=level)
    out["k"] = sum(x in want for t in labels for x in t)
    out["n_runs"] = sum(len(t) for t in labels)
    return out


def tables_differ(labels: Sequence[Sequence[str]], label: str, *, n_perm: int = N_PERM,
                  seed: int = SEED) -> dict[str, Any]:
    """Do the tables differ from each other in their share of runs with ``label``?
    ``labels``: each table's run labels. The chi-square statistic of the tables x (label,
    other) counts and its p by permutation of the runs' labels between the tables (the tables'
    run counts kept; (hits + 1) / (n_perm + 1)). ``{"chi2", "p", "n_tables", "n_runs"}``; p is
    1 where every run has the same label (nothing to differ in), nan for one table."""
    sizes = np.array([len(t) for t in labels if len(t)])
    hits = np.concatenate([np.array([x == label for x in t], dtype=float)
                           for t in labels if len(t)]) if len(sizes) else np.zeros(0)
    out: dict[str, Any] = {"chi2": math.nan, "p": math.nan, "n_tables": len(sizes),
                           "n_runs": int(sizes.sum())}
    if len(sizes) < 2:
        return out
    total = hits.sum()
    if total == 0 or total == len(hits):
        out["chi2"], out["p"] = 0.0, 1.0
        return out
    ends = np.cumsum(sizes)
    starts = ends - sizes
    expected = sizes * total / len(hits)

    def chi2(h: np.ndarray) -> np.ndarray:
        # h: (..., runs); the label's count per table, against its expected count
        k = np.add.reduceat(h, starts, axis=-1)
        other = sizes - k
        return (((k - expected) ** 2 / expected)
                + ((other - (sizes - expected)) ** 2 / (sizes - expected))).sum(axis=-1)

    observed = float(chi2(hits))
    rng = np.random.default_rng(seed)
    perms = np.argsort(rng.random((n_perm, len(hits))), axis=1)
    stats_ = chi2(hits[perms])
    reached = int(np.sum(stats_ >= observed - 1e-9))
    out["chi2"], out["p"] = observed, (reached + 1) / (n_perm + 1)
    return out


def gait_measures(tables: Sequence[Sequence[Mapping[str, Any]]]) -> dict[str, Any]:
    """What a reader needs to weigh a trot gait share (runs grouped by table): the locking the
    label thresholds (``gait_locking_mean``, over tables), the trot share at other thresholds
    (``gait_trot_share_at_<x>``, 0: the footfall phases alone) and whether the tables differ
    in their trot share (``gait_trot_tables_differ_chi2`` and ``_p``)."""
    locks = []
    for t in tables:
        v = [float(r.get("gait_locking", math.nan)) for r in t]
        v = [x for x in v if np.isfinite(x)]
        locks.append(float(np.mean(v)) if v else math.nan)
    out: dict[str, Any] = {"gait_locking_mean": over_tables(locks)["mean"]}
    for x in (0.0, *THRESHOLDS):
        labels = [[gait_at(r, x) for r in t] for t in tables]
        out[f"gait_trot_share_at_{x:g}"] = share_over_tables(labels, "trot")["mean"]
    differ = tables_differ([[r["gait"] for r in t] for t in tables], "trot")
    out["gait_trot_tables_differ_chi2"] = differ["chi2"]
    out["gait_trot_tables_differ_p"] = differ["p"]
    return out


def interval_words(s: Mapping[str, Any], fmt: str = ".0%") -> str:
    """``40% (12%-68%)``: a mean over tables and its interval (or ``40% (one table)``)."""
    if not np.isfinite(s["low"]):
        return f"{format(s['mean'], fmt)} (one table)" if s["n_tables"] == 1 else \
            format(s["mean"], fmt)
    return f"{format(s['mean'], fmt)} ({format(s['low'], fmt)}-{format(s['high'], fmt)})"


__all__ = ["group_by_table", "over_tables", "share_over_tables", "tables_differ", "gait_measures",
           "interval_words", "N_PERM", "SEED"]
