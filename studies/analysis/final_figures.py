"""The numbers of a parameter study's report: per seed its final figures (means over its last
sessions) and its trained table's structure; per group the curves over sessions (mean and std
across seeds); per cell of a sweep the mean, std and count; and the tests between conditions.
Arrays and tables in, numbers out: nothing here draws or writes a file (the report's figures
are :mod:`astrocpg.studies.figures.study_report`'s, its files the report's own)."""

from __future__ import annotations

import itertools
from dataclasses import dataclass
from typing import Any, Mapping

import numpy as np

from .compare import compare, holm, reading_words


@dataclass(frozen=True)
class Measure:
    """A final figure of a seed: key (column of final_figures.csv without _mean/_std), title,
    unit (in the axis label)."""

    key: str
    title: str
    unit: str

    @property
    def label(self) -> str:
        return f"{self.title} ({self.unit})"


# the curves of Fig. 3c: (column of sessions.csv, what it is)
CURVES = (("mean_reward", "mean reward"), ("final_x_m", "final x (m)"),
          ("length_s", "session length (s)"))

# the final figures of a seed (over its last sessions), in the order of the tables and figures
MEASURES = (Measure("speed", "forward speed", "m/s"), Measure("final_x", "final x", "m"),
            Measure("length", "session length", "s"),
            Measure("reward", "mean reward", "dimensionless"),
            Measure("full", "full-length sessions", "fraction"))
# from a seed's trained table (weights.npz), when the runs saved one
WEIGHT_MEASURES = (Measure("mixed_limb_pairs", "mixed limb pairs", "count"),
                   Measure("share_above_0.9_w_max", "weights above 0.9 w_max",
                           "fraction"),
                   Measure("share_below_0.9_w_min", "weights below 0.9 w_min",
                           "fraction"),
                   Measure("share_excitatory", "excitatory weights", "fraction"))


def moving_mean(table: np.ndarray, width: int) -> np.ndarray:
    """Trailing mean over the last ``width`` sessions (fewer at the start), NaN-aware."""
    valid = np.isfinite(table)
    filled = np.where(valid, table, 0.0)
    csum = np.cumsum(filled, axis=1)
    ccount = np.cumsum(valid, axis=1)
    csum[:, width:] = csum[:, width:] - csum[:, :-width].copy()
    ccount[:, width:] = ccount[:, width:] - ccount[:, :-width].copy()
    out = np.full_like(table, np.nan)
    np.divide(csum, ccount, out=out, where=(ccount > 0) & valid)
    return out


def session_curve(series: Mapping[int, Any], key: str, n: int, smooth: int
                  ) -> tuple[np.ndarray, np.ndarray]:
    """Mean and std (ddof=0) across seeds of the column ``key`` per session 1..``n``, from one
    table of sessions per seed (``series``: seed -> its rows, ``session`` numbered from 1;
    NaN where no seed has that session); ``smooth`` > 1: each seed's trailing mean over that
    many sessions first (:func:`moving_mean`)."""
    table = np.full((len(series), n), np.nan)
    for row, s in enumerate(series.values()):
        table[row, s["session"].to_numpy(int) - 1] = s[key].to_numpy(float)
    if smooth > 1:  # moving mean over sessions, per seed, before the across-seed stats
        table = moving_mean(table, smooth)
    return np.nanmean(table, axis=0), np.nanstd(table, axis=0)


def seed_finals(condition: str, point: tuple[str, ...], series: dict[int, Any],
                 structure: dict[int, dict[str, float]], *, last: int,
                 L_max: float) -> list[dict[str, Any]]:
    """One row per seed of a group: its final figures (means over its ``last`` sessions) and,
    where its weights were read, their structure."""
    seeds_here = []
    for seed, s in series.items():
        tail = s.tail(last)
        one = {"condition": condition, "point": point, "seed": seed,
               "sessions": len(s), "last_sessions": len(tail),
               "speed": float(tail["mean_forward_speed_m_per_s"].mean()),
               "final_x": float(tail["final_x_m"].mean()),
               "length": float(tail["length_s"].mean()),
               "reward": float(tail["mean_reward"].mean()),
               "full": float((tail["length_s"] >= L_max - 1e-6).mean())}
        if seed in structure:
            one["mixed_limb_pairs"] = float(structure[seed]["mixed_limb_pairs"])
            one["limb_pairs"] = int(structure[seed]["limb_pairs"])
            for key in ("share_above_0.9_w_max", "share_below_0.9_w_min",
                        "share_excitatory"):
                one[key] = structure[seed][key]
        seeds_here.append(one)
    return seeds_here


def across_seeds(seeds: list[dict[str, Any]]) -> dict[str, Any]:
    """A group's final figures across its seeds (rows of :func:`seed_finals`): ``<key>_mean``
    and ``<key>_std`` (ddof=0, as in the curves of Fig. 3c) of each measure some seed has,
    ``<key>_low`` and ``<key>_high``: its 95% interval over seeds (the seed is the unit of
    replication; :func:`~astrocpg.studies.analysis.replication.over_tables`), and
    ``limb_pairs`` (the number of limb pairs) where the weights were read."""
    from .replication import over_tables

    out: dict[str, Any] = {}
    for m in MEASURES + WEIGHT_MEASURES:
        vals = [o[m.key] for o in seeds if m.key in o]
        if vals:
            out[f"{m.key}_mean"], out[f"{m.key}_std"] = (float(np.mean(vals)),
                                                         float(np.std(vals)))
            s = over_tables(vals, share=m.unit == "fraction")
            out[f"{m.key}_low"], out[f"{m.key}_high"] = s["low"], s["high"]
    limb_pairs = {o["limb_pairs"] for o in seeds if "limb_pairs" in o}
    if limb_pairs:
        out["limb_pairs"] = limb_pairs.pop()
    return out


def cell_stats(cells: list[list[float]]) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Mean, std (ddof=0) and count of the finite values of each cell (NaN where none)."""
    out = np.full((3, len(cells)), np.nan)
    for i, values in enumerate(cells):
        v = np.asarray([x for x in values if np.isfinite(x)], dtype=float)
        out[2, i] = len(v)
        if len(v):
            out[0, i], out[1, i] = v.mean(), v.std()
    return out[0], out[1], out[2]


def condition_tests(swept: list[str], conditions: list[str], per_seed: list[dict[str, Any]],
                     measures: list[Measure],
                     skip: set[tuple[str, tuple[str, ...]]] = frozenset(),
                     paired: bool = False,
                     margins: Mapping[str, float] | None = None) -> list[dict[str, Any]]:
    """Every pair of conditions (in the study's order, first minus second) at every sweep
    point, every final figure: :func:`~astrocpg.studies.analysis.compare.compare`. The final
    figures of one pair at one point are one family (one question: do the conditions
    differ?): their permutation and Mann-Whitney p-values are Holm-adjusted together
    (``perm_p_holm``, ``mwu_p_holm``). ``paired`` (the study file's ``paired = true``,
    declared before any run): seed k of one condition is compared with seed k of the
    other, on the seeds both have. ``margins`` (the study file's ``[margins]``, declared
    before any run): the equivalence test of each measure that has one; every test gives the
    smallest difference it could detect (``detectable``) and ``reading``, what the numbers
    support in words (:func:`~astrocpg.studies.analysis.compare.reading_words`)."""
    margins = dict(margins or {})
    conditions = list(dict.fromkeys(conditions))
    points = list(dict.fromkeys(o["point"] for o in per_seed))
    out = []
    for point in points:
        for a, b in itertools.combinations(conditions, 2):
            if (a, point) in skip or (b, point) in skip:  # a diverged side: no test
                continue
            family = []
            for m in measures:
                sa = {o["seed"]: o[m.key] for o in per_seed
                      if o["condition"] == a and o["point"] == point and m.key in o}
                sb = {o["seed"]: o[m.key] for o in per_seed
                      if o["condition"] == b and o["point"] == point and m.key in o}
                if not sa and not sb:
                    continue
                if paired:
                    common = sorted(set(sa) & set(sb), key=str)
                    va, vb = [sa[k] for k in common], [sb[k] for k in common]
                else:
                    va, vb = list(sa.values()), list(sb.values())
                t = compare(va, vb, paired=paired, margin=margins.get(m.key))
                t["reading"] = reading_words(t)
                family.append({**dict(zip(swept, point)), "condition_a": a, "condition_b": b,
                               "measure": m.key, "unit": m.unit, **t})
            for key in ("perm_p", "mwu_p"):
                for t, adjusted in zip(family, holm([t[key] for t in family])):
                    t[f"{key}_holm"] = adjusted
            out += family
    return out


__all__ = ["CURVES", "MEASURES", "Measure", "WEIGHT_MEASURES", "across_seeds", "cell_stats",
           "condition_tests", "moving_mean", "seed_finals", "session_curve"]
