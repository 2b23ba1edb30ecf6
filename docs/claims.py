"""The figures and stated differences of the results and beyond pages (and the README's), checked
against the committed tables.

``docs/claims.toml`` lists the claims: each names its page, the text it quotes from the page, the
computation that gives its figures from a committed table, the figures as printed, and the
direction word the text gives the difference (higher, lower, opposite, same, not shown to differ).

    python docs/claims.py                 # check every claim; one line per claim
    python docs/claims.py analyse         # the analyses behind the newer claims, as markdown
    python docs/claims.py coverage        # how many of each page's numbers a claim covers
    python docs/claims.py coverage --list # and every number none covers, with its line
    python docs/claims.py differences     # every figure of a stated difference no claim checks

A claim holds when (a) its quoted text is on its page (whitespace and line breaks aside), (b)
each figure recomputed from the tables equals the figure printed, to the printed precision, and
(c) its direction follows from the table: ``higher``/``lower``: the 95 % interval of the
difference excludes 0 on that side (and its p, where the computation gives one, is below 0.05);
``differ``: the interval excludes 0 or the (Holm) p is below 0.05;
``not shown to differ``: the interval holds 0 or the p is 0.05 or more; ``same``: only with a
margin declared in the claim, and the whole 95 % interval inside (-margin, +margin) (two one-sided
tests at 2.5 %); ``none``: a figure without a difference.

The statistics, all over the unit of replication (a seed's table or training, never the runs of
one table as if independent): a seed's repeats are averaged first; intervals are 95 % percentile
bootstrap intervals over seeds (10 000 resamples, fixed seed); p-values are two-sided sign-flip
permutation tests of per-seed differences (10 000 flips, fixed seed); Holm's adjustment over the
family a claim names. Times to event count the seeds that never got there: a seed that never
learnt is counted at its last session (censored there, never dropped, as
``astrocpg.studies.analysis.events`` and ``analyse.py paired`` count it: the mean is the
restricted mean time to learn, and a difference is a bound on the true one). The smallest
difference a paired comparison of n seeds detects with 80 % power at a two-sided alpha of 0.05
is (t(0.975, n-1) + t(0.80, n-1)) x sd(per-seed differences) / sqrt(n).

Exit codes: 0 every claim holds, 2 bad input (a claim or table that cannot be read; nothing
checked), 3 a claim does not follow from its table.
"""

from __future__ import annotations

import csv
import gzip
import math
import re
import sys
import tomllib
from collections import defaultdict
from functools import lru_cache
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
CLAIMS = Path(__file__).with_name("claims.toml")
N_RESAMPLE = 10000
BOOT_SEED = 20231215   # the seed of astrocpg's own comparisons, so the intervals agree
FLIP_SEED = 20231215
L_MAX = 10.0       # a session shorter than this ended in a fall
LEARNT = 0.9       # "learnt by": trailing mean of 10 session lengths first >= 0.9 L_max
LEGS3 = ("FL", "RR", "RL")   # the legs whose footfall locking the evaluation rows keep


class BadInput(Exception):
    """A claim or a table that cannot be read."""


# ---------------------------------------------------------------- statistics over seeds

def bootstrap(d: np.ndarray) -> tuple[float, float]:
    """95 % percentile bootstrap interval of the mean of ``d`` (resampling seeds)."""
    rng = np.random.default_rng(BOOT_SEED)
    means = d[rng.integers(0, len(d), (N_RESAMPLE, len(d)))].mean(axis=1)
    lo, hi = np.percentile(means, [2.5, 97.5])
    return float(lo), float(hi)


def sign_flip(d: np.ndarray) -> float:
    """Two-sided sign-flip permutation p of the mean of the per-seed differences ``d``."""
    rng = np.random.default_rng(FLIP_SEED)
    signs = rng.choice([-1.0, 1.0], size=(N_RESAMPLE, len(d)))
    hits = int(np.sum(np.abs((signs * d).mean(axis=1)) >= abs(d.mean()) - 1e-12))
    return (hits + 1) / (N_RESAMPLE + 1)


def holm(p: list[float]) -> list[float]:
    order = np.argsort(p)
    out, running = [0.0] * len(p), 0.0
    for rank, k in enumerate(order):
        running = max(running, min(1.0, (len(p) - rank) * p[k]))
        out[k] = running
    return out


def mdd(d: np.ndarray) -> float:
    """Smallest mean difference a paired test of these seeds detects (80 % power, alpha 0.05)."""
    from scipy import stats

    n = len(d)
    return float((stats.t.ppf(0.975, n - 1) + stats.t.ppf(0.80, n - 1)) * d.std(ddof=1)
                 / math.sqrt(n))


def effect(d: np.ndarray) -> dict[str, float]:
    lo, hi = bootstrap(d)
    return {"d": float(d.mean()), "lo": lo, "hi": hi, "p": sign_flip(d), "n": float(len(d))}


# ---------------------------------------------------------------- committed tables

def _path(name: str) -> Path:
    p = ROOT / name
    if not p.is_file():
        raise BadInput(f"{name}: no such table")
    return p


@lru_cache(maxsize=None)
def _csv(name: str) -> tuple[dict[str, str], ...]:
    p = _path(name)
    opener = gzip.open if p.suffix == ".gz" else open
    with opener(p, "rt", newline="") as f:
        return tuple(csv.DictReader(f))


def _run_measure(measure: str):
    if measure in ("gait", "rhythm"):
        return lambda r: float(r[measure] == "trot")
    if measure == "speed":
        return lambda r: float(r["mean_speed_m_per_s"])
    if measure == "falls":
        return lambda r: float(r["fell"])
    raise BadInput(f"unknown evaluation measure {measure!r}")


def evaluated(table: str, source: str, world: str, measure: str) -> dict[int, list[float]]:
    """seed -> the measure of each of its runs, for rows whose source or condition is
    ``source`` in ``world``."""
    f = _run_measure(measure)
    out: dict[int, list[float]] = defaultdict(list)
    for r in _csv(table):
        if source in (r["source"], r["condition"]) and r["world"] == world:
            out[int(r["seed"])].append(f(r))
    if not out:
        raise BadInput(f"{table}: no runs of {source!r} in world {world!r}")
    return dict(sorted(out.items()))


def per_seed(table: str, source: str, world: str, measure: str) -> dict[int, float]:
    return {s: float(np.mean(v)) for s, v in evaluated(table, source, world, measure).items()}


def _paired(a: dict[int, float], b: dict[int, float]) -> np.ndarray:
    seeds = sorted(set(a) & set(b))
    if len(seeds) < 2:
        raise BadInput("fewer than two seeds in common")
    return np.array([b[s] - a[s] for s in seeds])


def training(table: str, run: str, sessions: int | None) -> dict[int, np.ndarray]:
    """seed -> (session, [length, final x, speed]) of the rows whose run id or condition is
    ``run``, sessions 1..sessions."""
    out: dict[int, dict[int, list[float]]] = defaultdict(dict)
    for r in _csv(table):
        if run in (r["run_id"], r["condition"]) and (sessions is None or
                                                      int(r["session"]) <= sessions):
            out[int(r["seed"])][int(r["session"])] = [
                float(r["length_s"]), float(r["final_x_m"]),
                float(r["mean_forward_speed_m_per_s"])]
    if not out:
        raise BadInput(f"{table}: no rows of {run!r}")
    return {s: np.array([v[k] for k in sorted(v)]) for s, v in sorted(out.items())}


TRAINING = ("speed", "final_x", "length", "full_length", "falls", "learnt_by")


def training_measures(series: np.ndarray, last: int) -> dict[str, float]:
    """A seed's training measures over its last ``last`` sessions; falls over all; learnt by:
    the session at which the trailing mean of 10 lengths first reached 0.9 L_max, or the
    last session when it never did (censored there; ``never`` is 1 then)."""
    tail, length = series[-last:], series[:, 0]
    trailing = np.convolve(length, np.ones(10) / 10, mode="valid")
    reached = np.flatnonzero(trailing >= LEARNT * L_MAX - 1e-9)
    return {"speed": float(tail[:, 2].mean()), "final_x": float(tail[:, 1].mean()),
            "length": float(tail[:, 0].mean()),
            "full_length": float(np.mean(tail[:, 0] >= L_MAX - 1e-9)),
            "falls": float(np.sum(length < L_MAX - 1e-9)),
            "learnt_by": float(reached[0] + 10) if len(reached) else float(len(length)),
            "never": float(not len(reached))}


# ---------------------------------------------------------------- computations

def c_share(table: str, source: str, world: str, measure: str) -> dict[str, float]:
    """Mean over seeds of a measure (each seed's runs averaged first) with its interval."""
    runs = evaluated(table, source, world, measure)
    x = np.array([np.mean(v) for v in runs.values()])
    lo, hi = bootstrap(x)
    return {"mean": float(x.mean()), "lo": lo, "hi": hi, "tables": float(len(x)),
            "runs": float(sum(len(v) for v in runs.values())),
            "count": float(sum(sum(v) for v in runs.values()))}


def _trot_phases(r: dict[str, str], tolerance: float = 0.15) -> bool:
    """The footfall phases of a run (FR at 0) are a trot, whatever their locking (the
    classifier's own rule, ``astrocpg.studies.analysis.gait.phase_label``)."""
    p = {"FR": 0.0, **{leg: float(r[f"gait_phase_{leg}"]) for leg in LEGS3}}
    if not all(math.isfinite(v) for v in p.values()):
        return False

    def circ(a: float, b: float) -> float:
        d = abs(a - b) % 1.0
        return min(d, 1.0 - d)

    return (circ(p["FR"], p["RL"]) <= tolerance and circ(p["FL"], p["RR"]) <= tolerance
            and abs(circ(p["FR"], p["FL"]) - 0.5) <= tolerance)


def c_gait_threshold(table: str, source: str, world: str, threshold: float) -> dict[str, float]:
    """Share of runs whose footfalls are a trot with every kept leg's locking at or above
    ``threshold`` (the label uses 0.7 and FR's locking too, which the rows do not keep, so
    this is the label's share or just above it), and the runs whose phases are a trot at all."""
    rows = [r for r in _csv(table) if source in (r["source"], r["condition"])
            and r["world"] == world]
    if not rows:
        raise BadInput(f"{table}: no runs of {source!r} in world {world!r}")
    locked = [_trot_phases(r) and min(float(r[f"gait_locking_{leg}"]) for leg in LEGS3)
              >= threshold for r in rows]
    return {"share": float(np.mean(locked)), "count": float(sum(locked)),
            "phases": float(sum(_trot_phases(r) for r in rows)), "runs": float(len(rows))}


def c_tables_differ(table: str, source: str, world: str, measure: str = "gait"
                    ) -> dict[str, float]:
    """Do the tables (seeds) differ in their share of runs with a trot? Chi-square of the
    seeds x (trot, not) counts, its p by permuting runs across tables; and the tables with at
    least one and with most runs trotting, observed and expected under one common share."""
    from scipy import stats

    runs = evaluated(table, source, world, measure)
    counts = np.array([sum(v) for v in runs.values()])
    n = np.array([len(v) for v in runs.values()])
    share = counts.sum() / n.sum()

    def chi2(c: np.ndarray) -> float:
        e1, e0 = n * share, n * (1 - share)
        return float(np.sum((c - e1) ** 2 / e1 + ((n - c) - e0) ** 2 / e0))

    observed = chi2(counts)
    flat = np.concatenate([np.asarray(v, dtype=float) for v in runs.values()])
    label = np.repeat(np.arange(len(n)), n)
    rng = np.random.default_rng(FLIP_SEED)
    hits = sum(chi2(np.bincount(label, weights=rng.permutation(flat), minlength=len(n)))
               >= observed - 1e-9 for _ in range(N_RESAMPLE))
    most = int(n.max()) // 2 + 1
    return {"chi2": observed, "p": (hits + 1) / (N_RESAMPLE + 1), "share": float(share),
            "any": float(np.sum(counts > 0)), "most": float(np.sum(counts >= most)),
            "expected_any": float(np.sum(1 - (1 - share) ** n)),
            "expected_most": float(np.sum(stats.binom.sf(most - 1, n, share)))}


def c_versus(table: str, source: str, other_table: str, other_source: str, world: str,
             measure: str) -> dict[str, float]:
    """``other`` minus ``source`` seed by seed (same seeds), with the smallest detectable
    difference."""
    d = _paired(per_seed(table, source, world, measure),
                per_seed(other_table, other_source, world, measure))
    return {**effect(d), "mdd": mdd(d)}


WORLDS_SKIP = ("flat",)


def _worlds(table: str) -> list[str]:
    return sorted({r["world"] for r in _csv(table)} - set(WORLDS_SKIP))


def c_world_minus_flat(table: str, source: str, world: str, measure: str) -> dict[str, float]:
    """A world against flat ground for the same controllers, seed by seed (world minus flat),
    Holm over every world of the table."""
    def d(w: str) -> np.ndarray:
        return _paired(per_seed(table, source, "flat", measure),
                       per_seed(table, source, w, measure))
    worlds = _worlds(table)
    out = effect(d(world))
    out["holm"] = holm([sign_flip(d(w)) for w in worlds])[worlds.index(world)]
    return out


def c_advantage_vs_flat(table: str, source: str, other: str, world: str, measure: str
                        ) -> dict[str, float]:
    """How much the difference ``source`` minus ``other`` in a world departs from the same
    difference on flat ground, seed by seed (the two conditions share their seeds):
    (source - other)[world] - (source - other)[flat]; Holm over every world of the table."""
    def d(w: str) -> np.ndarray:
        a = _paired(per_seed(table, other, w, measure), per_seed(table, source, w, measure))
        f = _paired(per_seed(table, other, "flat", measure),
                    per_seed(table, source, "flat", measure))
        return a - f
    worlds = _worlds(table)
    out = effect(d(world))
    out["holm"] = holm([sign_flip(d(w)) for w in worlds])[worlds.index(world)]
    out["raw"] = float(effect(_paired(per_seed(table, other, world, measure),
                                      per_seed(table, source, world, measure)))["d"])
    return out


def _training_pairs(table: str, run: str, other_table: str, other_run: str,
                    sessions: int | None, last: int) -> tuple[dict, dict, int]:
    a, b = training(table, run, sessions), training(other_table, other_run, sessions)
    seeds = sorted(set(a) & set(b))
    S = min(min(len(a[s]), len(b[s])) for s in seeds)
    return ({s: training_measures(a[s][:S], last) for s in seeds},
            {s: training_measures(b[s][:S], last) for s in seeds}, S)


def c_training(table: str, run: str, other_table: str, other_run: str, measure: str,
               sessions: int | None = None, last: int = 20, family: tuple = ()
               ) -> dict[str, float]:
    """Training rows, ``other`` minus ``run`` seed by seed: the measures of
    :func:`training_measures` (learnt by censored), each side's mean and never-learnt count,
    and Holm's adjustment over the six measures of this comparison and of the same comparison
    for each run of ``other_table`` named in ``family``."""
    if measure not in TRAINING:
        raise BadInput(f"unknown training measure {measure!r}")
    ma, mb, S = _training_pairs(table, run, other_table, other_run, sessions, last)
    seeds = sorted(ma)

    def diffs(a: dict, b: dict) -> dict[str, np.ndarray]:
        return {m: np.array([b[s][m] - a[s][m] for s in sorted(a)]) for m in TRAINING}

    mine = diffs(ma, mb)
    ps = [sign_flip(mine[m]) for m in TRAINING]
    for other in family:
        if other != other_run:
            ps += [sign_flip(d) for d in diffs(*_training_pairs(
                table, run, other_table, other, sessions, last)[:2]).values()]
    out = {**effect(mine[measure]), "mdd": mdd(mine[measure]),
           "a": float(np.mean([ma[s][measure] for s in seeds])),
           "b": float(np.mean([mb[s][measure] for s in seeds])),
           "never_a": float(sum(ma[s]["never"] for s in seeds)),
           "never_b": float(sum(mb[s]["never"] for s in seeds)),
           "relative": float(mine[measure].mean() / np.mean([ma[s][measure] for s in seeds])),
           "holm": holm(ps)[TRAINING.index(measure)], "tests": float(len(ps))}
    return out


REFRACTORY_S = 0.3   # the astrocyte's refractory_ADO: at most one release per 0.3 s


def c_release(table: str, run: str = "") -> dict[str, float]:
    """Adenosine releases per second per astrocyte (8 a seed) against the ceiling the
    refractory period allows, per run of a study's rows (``run``: a run id or condition;
    empty: every run with astrocytes): the lowest and highest over runs of the overall rate
    and of the share of sessions at 95 % of the ceiling or more."""
    rates: dict[str, list[tuple[float, float]]] = defaultdict(list)
    for r in _csv(table):
        if (run in (r["run_id"], r["condition"])) if run else r["condition"] != "no_astrocytes":
            rates[r["run_id"]].append((float(r["adenosine_releases"]), float(r["length_s"])))
    if not rates:
        raise BadInput(f"{table}: no rows of {run!r}")
    overall, within = [], []
    for v in rates.values():
        a = np.array(v)
        overall.append(a[:, 0].sum() / (8 * a[:, 1].sum()))
        within.append(np.mean(a[:, 0] / (8 * a[:, 1]) >= 0.95 / REFRACTORY_S))
    return {"ceiling": 1 / REFRACTORY_S, "rate_min": float(min(overall)),
            "rate_max": float(max(overall)), "within_min": float(min(within)),
            "within_max": float(max(within)), "runs": float(len(rates))}


def c_final(table: str, run: str, measure: str, sessions: int | None = None, last: int = 50
            ) -> dict[str, float]:
    """A training measure per seed (:func:`training_measures`), mean and std (ddof 0) over
    seeds."""
    if measure not in TRAINING:
        raise BadInput(f"unknown training measure {measure!r}")
    x = np.array([training_measures(v, last)[measure]
                  for v in training(table, run, sessions).values()])
    return {"mean": float(x.mean()), "std": float(x.std()), "seeds": float(len(x))}


_NUM = r"[+\-−]?\d+(?:\.\d+)?(?:e[+\-]?\d+)?"


def _md_table(file: str, block: str = "") -> tuple[list[str], list[str], int]:
    """The lines of a committed markdown table (from the heading line that contains ``block``,
    if given), its header cells (markup stripped) and the index of its header line."""
    lines = _path(file).read_text().splitlines()
    if block:
        start = next((k for k, line in enumerate(lines) if block in line), None)
        if start is None:
            raise BadInput(f"{file}: no block {block!r}")
        lines = lines[start + 1:]
    head = next((k for k, line in enumerate(lines) if line.startswith("|")), None)
    if head is None:
        raise BadInput(f"{file}: no table under block {block!r}")
    return lines, _cells(lines[head]), head


def _cells(line: str) -> list[str]:
    return [c.strip().replace("*", "").replace("`", "").strip()
            for c in line.strip().strip("|").split("|")]


def column_index(header: list[str], name: str | int, where: str) -> int:
    """The position of the column headed ``name`` in ``header``: the header equal to it, or
    else the one header that starts with it. A committed table is read by its headers, never
    by position, so a column added to it (a "reading", say) moves nothing; an ``int`` is taken
    as a position (only for the hand-written tables of the pages)."""
    if isinstance(name, int):
        return name
    if not isinstance(name, str) or not name:
        raise BadInput(f"{where}: a column is named by its header, not {name!r}")
    exact = [k for k, h in enumerate(header) if h == name]
    if len(exact) == 1:
        return exact[0]
    starts = [k for k, h in enumerate(header) if h.startswith(name)]
    if len(exact) > 1 or len(starts) != 1:
        raise BadInput(f"{where}: {len(exact) or len(starts)} columns headed {name!r} "
                       f"(headers: {' | '.join(header)})")
    return starts[0]


def _p_columns(header: list[str]) -> tuple[int | None, int | None]:
    """The columns of a test's p (headed ``p`` or ``... p``) and of its Holm-adjusted p
    (``Holm p``), when the table has them."""
    holm = next((k for k, h in enumerate(header) if h == "Holm p"), None)
    p = next((k for k, h in enumerate(header) if k != holm and (h == "p" or h.endswith(" p"))),
             None)
    return p, holm


def c_md_cell(file: str, row: str, column: str, block: str = "", other_column: str = ""
              ) -> dict[str, float]:
    """A cell of a committed markdown table written by a command (``analyse.py against``,
    ``paired``, ...): the row whose first cell starts with ``row`` (or whose cells joined by
    " | " do: ``mean_reward | 81-100``; under the heading line that contains ``block``, if
    given), the cell of the column headed ``column`` (see :func:`column_index`) parsed as
    ``d [lo, hi]``, ``[lo, hi]`` or a number, and the row's p and Holm p (the columns headed
    ``p`` or ``... p`` and ``Holm p``; ``<= x`` read as x). With ``other_column``: its figure
    ``b``, and ``change`` = d / b − 1 and ``drop`` = 1 − d / b (a relative difference)."""
    lines, header, head = _md_table(file, block)
    where = f"{file} block {block!r}" if block else file
    if not isinstance(column, str):
        raise BadInput(f"{where}: name the column by its header, not {column!r}")
    at = column_index(header, column, where)
    for line in lines[head + 1:]:
        if not line.startswith("|"):
            break
        cells = [c.strip() for c in line.strip().strip("|").split("|")]
        if " | ".join(cells).replace("*", "").startswith(row):
            break
    else:
        raise BadInput(f"{where}: no row {row!r}")
    if len(cells) != len(header):
        raise BadInput(f"{where}: row {row!r} has {len(cells)} cells, its header {len(header)}")
    nums = [float(x.replace("−", "-")) for x in re.findall(_NUM, cells[at])]
    if not nums:
        raise BadInput(f"{where}: row {row!r}, column {column!r} holds no figure")
    out = {"d": nums[0]}
    if len(nums) >= 3:
        out.update(lo=nums[1], hi=nums[2])
    elif len(nums) == 2 and re.match(r"\s*\[", cells[at]):   # an interval alone
        out = {"lo": nums[0], "hi": nums[1]}
    if other_column:
        other = [float(x.replace("−", "-"))
                 for x in re.findall(_NUM, cells[column_index(header, other_column, where)])]
        if not other:
            raise BadInput(f"{where}: row {row!r}, column {other_column!r} holds no figure")
        out["b"] = other[0]
        if other[0]:
            out.update(change=out["d"] / other[0] - 1, drop=1 - out["d"] / other[0])
    for key, k in zip(("p", "holm"), _p_columns(header)):
        if k is not None and re.search(_NUM, cells[k]):
            out[key] = float(re.findall(_NUM, cells[k])[0])
    return out


def c_md_summaries(file: str, row: str, column: str, other_column: str, n: int,
                   other_n: int | None = None, block: str = "", ddof: int = 0
                   ) -> dict[str, float]:
    """Two cells ``mean ± std`` of a committed markdown table whose per-seed values were not
    kept (the row as in :func:`c_md_cell`): ``a`` and ``b`` the means, ``d`` = a − b, and the
    95 % Welch t interval of d from the two summaries (``n`` and ``other_n`` seeds; the std as
    written has ``ddof``, 0 as astrocpg's tables write it, and is made the sample std). A
    summary allows no permutation test: the interval is all the direction is read from."""
    from scipy import stats

    def cell(col: str) -> tuple[float, float]:
        lines, header, head = _md_table(file, block)
        for line in lines[head + 1:]:
            cells = [c.strip() for c in line.strip().strip("|").split("|")]
            if " | ".join(cells).replace("*", "").startswith(row):
                nums = re.findall(_NUM, cells[column_index(header, col, file)])
                if len(nums) < 2:
                    raise BadInput(f"{file}: row {row!r}, column {col!r} is not 'mean ± std'")
                return float(nums[0].replace("−", "-")), float(nums[1].replace("−", "-"))
        raise BadInput(f"{file}: no row {row!r}")

    (a, sa), (b, sb) = cell(column), cell(other_column)
    m = other_n or n
    # a std over n seeds with ddof 0 (as the tables are written) to the sample std (ddof 1)
    ssa, ssb = sa * math.sqrt(n / (n - 1 + ddof)), sb * math.sqrt(m / (m - 1 + ddof))
    va, vb = ssa ** 2 / n, ssb ** 2 / m
    se = math.sqrt(va + vb)
    dof = (va + vb) ** 2 / (va ** 2 / (n - 1) + vb ** 2 / (m - 1)) if se > 0 else n + m - 2
    half = float(stats.t.ppf(0.975, dof)) * se
    return {"a": a, "b": b, "sd_a": sa, "sd_b": sb, "d": a - b, "lo": a - b - half,
            "hi": a - b + half}


def c_columns(table: str, other_table: str, column: str) -> dict[str, float]:
    """One numeric column of two committed CSV files (a value per seed each), unpaired, with
    astrocpg's own comparison (``astrocpg.studies.analysis.compare.compare``, what
    ``analyse.py columns`` prints): ``a``, ``b`` the means, ``d`` = a − b with its 95 %
    bootstrap interval ``lo``, ``hi``, the permutation ``p`` and the Mann-Whitney ``mwu``."""
    from astrocpg.studies.analysis.compare import compare

    def read(name: str) -> list[float]:
        return [float(r[column]) for r in _csv(name)]
    t = compare(read(table), read(other_table))
    return {"a": t["mean_a"], "b": t["mean_b"], "d": t["difference"],
            "lo": t["difference_low"], "hi": t["difference_high"], "p": t["perm_p"],
            "mwu": t["mwu_p"]}


def c_csv_row(table: str, where: dict) -> dict[str, float]:
    """The one row of a committed CSV (``condition_tests.csv``, ...) whose cells equal
    ``where``: every numeric cell by its column's name, and ``d``, ``lo``, ``hi``, ``p``,
    ``holm`` for the columns ``difference``, ``difference_low``, ``difference_high``,
    ``perm_p``, ``perm_p_holm`` where the table has them."""
    rows = [r for r in _csv(table) if all(r.get(k) == str(v) for k, v in dict(where).items())]
    if len(rows) != 1:
        raise BadInput(f"{table}: {len(rows)} rows where {dict(where)}")
    out = {}
    for k, v in rows[0].items():
        try:
            out[k] = float(v)
        except (TypeError, ValueError):
            pass
    for key, column in (("d", "difference"), ("lo", "difference_low"),
                        ("hi", "difference_high"), ("p", "perm_p"), ("holm", "perm_p_holm")):
        if column in out:
            out[key] = out[column]
    return out


def c_separated(table: str, run: str, other_run: str, measure: str, last: int = 50
                ) -> dict[str, float]:
    """Is every seed of ``other_run`` above every seed of ``run`` in a training measure?
    ``d``: the lowest of ``other_run`` minus the highest of ``run`` (above 0: separated)."""
    if measure not in TRAINING:
        raise BadInput(f"unknown training measure {measure!r}")
    a = [training_measures(v, last)[measure] for v in training(table, run, None).values()]
    b = [training_measures(v, last)[measure] for v in training(table, other_run, None).values()]
    return {"d": float(min(b) - max(a))}


def c_md_block(file: str, block: str, column: str = "") -> dict[str, float]:
    """Every row of one block of a committed markdown table of tests (``analyse.py against``,
    ``worlds``): the largest and smallest Holm p (the column headed ``Holm p``) and the rows;
    ``holm`` is the largest, so a claim that every measure of the block differs is checked
    against it. With ``column`` (a difference's header): ``lo``, the lowest lower bound, and
    ``hi``, the highest upper bound, of its rows' intervals (``d``: the largest difference
    when every one is negative, else the smallest), so ``lower`` (``higher``) holds only when
    every row's interval lies below (above) 0, and ``not shown to differ`` only when no row's
    Holm p is below 0.05 (``holm_min``)."""
    lines, header, head = _md_table(file, block)
    where = f"{file} block {block!r}"
    _, at = _p_columns(header)
    if at is None:
        raise BadInput(f"{where}: no column headed 'Holm p'")
    rows = list(_md_rows(lines, head).values())
    holms = [float(re.findall(_NUM, cells[at])[0]) for cells in rows
             if re.search(_NUM, cells[at])]
    if not holms:
        raise BadInput(f"{where}: no Holm p")
    out = {"holm": max(holms), "holm_min": min(holms), "rows": float(len(holms))}
    if column:
        if not isinstance(column, str):
            raise BadInput(f"{where}: name the column by its header, not {column!r}")
        k = column_index(header, column, where)
        nums = [[float(x.replace("−", "-")) for x in re.findall(_NUM, cells[k])][:3]
                for cells in rows]
        if any(len(n) < 3 for n in nums):
            raise BadInput(f"{where}: a row of column {column!r} is not 'd [lo, hi]'")
        d = [n[0] for n in nums]
        out.update(lo=min(n[1] for n in nums), hi=max(n[2] for n in nums),
                   d=max(d) if max(d) < 0 else min(d))
    return out


COMPUTE = {"share": c_share, "gait_threshold": c_gait_threshold,
           "tables_differ": c_tables_differ, "versus": c_versus,
           "world_minus_flat": c_world_minus_flat, "advantage_vs_flat": c_advantage_vs_flat,
           "training": c_training, "md_cell": c_md_cell, "release": c_release, "md_block": c_md_block,
           "separated": c_separated, "md_summaries": c_md_summaries,
           "columns": c_columns, "csv_row": c_csv_row,
           "final": c_final}


@lru_cache(maxsize=None)
def _compute(name: str, args: tuple) -> dict[str, float]:
    if name not in COMPUTE:
        raise BadInput(f"unknown computation {name!r}")
    try:
        return COMPUTE[name](**dict(args))
    except TypeError as e:
        raise BadInput(f"computation {name!r}: {e}") from None


def compute(claim: dict) -> dict[str, float]:
    """What a claim's computation gives; with a difference ``d`` (and its interval) also the
    same difference read the other way, ``less`` = −d, ``less_lo`` = −hi, ``less_hi`` = −lo,
    for a text that says "lower by 0.53 [0.44, 0.64]"."""
    args = {k: tuple(v) if isinstance(v, list) else
            tuple(sorted(v.items())) if isinstance(v, dict) else v
            for k, v in claim.get("args", {}).items()}
    out = dict(_compute(claim["compute"], tuple(sorted(args.items()))))
    if "d" in out:
        out.setdefault("less", -out["d"])
        if "lo" in out and "hi" in out:
            out.setdefault("less_lo", -out["hi"])
            out.setdefault("less_hi", -out["lo"])
    return out


# ---------------------------------------------------------------- checking

DIRECTIONS = ("higher", "lower", "differ", "not shown to differ", "same", "none")


def _words(text: str) -> str:
    return " ".join(text.replace("\u2009", " ").split())


def printed_matches(printed: str, value: float, scale: float = 1.0) -> bool:
    """Is ``value`` (times ``scale``) the figure ``printed`` to its printed precision?"""
    m = re.fullmatch(r"\s*(<=|≤|<)?\s*(" + _NUM + r")\s*%?\s*", printed)
    if not m:
        raise BadInput(f"figure {printed!r} is not a number")
    shown = float(m.group(2).replace("−", "-"))
    decimals = len(m.group(2).split(".")[1]) if "." in m.group(2) else 0
    v = value * scale
    if m.group(1):
        return v <= shown + 1e-12 or round(v, decimals) <= shown
    return abs(v - shown) <= 0.5 * 10 ** -decimals + 1e-9


def direction_follows(word: str, c: dict[str, float], margin: float | None) -> bool:
    lo, hi, p = c.get("lo"), c.get("hi"), c.get("holm", c.get("p"))
    if word == "none":
        return True
    if word in ("higher", "lower"):
        sign = 1 if word == "higher" else -1
        if lo is None and "d" not in c:
            raise BadInput(f"{word!r}: the computation gives no difference (a block needs "
                           f"its difference's column)")
        if lo is not None:
            ok = (lo > 0) if sign > 0 else (hi < 0)
        else:
            ok = c["d"] * sign > 0
        return ok and (p is None or p < 0.05)
    if word == "differ":   # two-sided: the interval excludes 0, or p below 0.05
        return (lo is not None and (lo > 0 or hi < 0)) or (p is not None and p < 0.05)
    if word == "not shown to differ":
        if "holm_min" in c:   # a block: no row shown to differ
            return c["holm_min"] >= 0.05
        return (lo is not None and lo <= 0 <= hi) or (p is not None and p >= 0.05)
    if word == "same":
        return margin is not None and lo is not None and -margin < lo and hi < margin
    raise BadInput(f"unknown direction {word!r} (one of {', '.join(DIRECTIONS)})")


SAMENESS = re.compile(r"\b(the same (?:as|picture|place|trot|structure)|unchanged|"
                      r"do(?:es)? not differ|did not differ|no difference|as often as|equal to|does what|do what|"
                      r"within these intervals)\b", re.IGNORECASE)


def unqualified_sameness(text: str) -> list[str]:
    """Sentences of ``text`` that state a sameness ("do not differ", "unchanged", ...) without
    saying it was not shown to differ: such a sentence needs an equivalence test (a claim
    with direction ``same`` and a margin) or the words "not shown"."""
    sentences = re.split(r"(?<=[.;:])\s+(?=[A-Z*(])", _words(text))
    return [s for s in sentences if SAMENESS.search(s)
            and not any(q in s for q in SAMENESS_QUALIFIED)]


SAMENESS_QUALIFIED = (
    "not shown",                        # the reading for a difference that was not found
    "is shown",                         # "no difference ... is shown"
    "does not show that",               # a sameness denied
    "no difference in any column",      # a training repeated row for row: an identity
    "every session the same as",        # the same, read from the rows
)


def check(claim: dict, pages: dict[str, str] | None = None) -> list[str]:
    """What is wrong with one claim; empty when it holds."""
    for key in ("page", "text", "compute", "values", "direction"):
        if key not in claim:
            raise BadInput(f"claim {claim.get('id', '?')}: no {key!r}")
    pages = pages if pages is not None else {}
    if claim["page"] not in pages:
        pages[claim["page"]] = _words(_path(claim["page"]).read_text())
    problems = []
    text = _words(claim["text"])
    if text not in pages[claim["page"]]:
        problems.append(f"text not on {claim['page']}: {text[:70]!r}")
    c = compute(claim)
    scale = float(claim.get("scale", 1.0))
    for key, printed in claim["values"].items():
        if key not in c:
            raise BadInput(f"claim {claim['id']}: computation gives no {key!r}")
        if _words(str(printed)).replace("−", "-") not in text.replace("−", "-"):
            problems.append(f"figure {printed!r} not in the quoted text")
        if not printed_matches(str(printed), c[key], 1.0 if key in ("p", "holm") else scale):
            problems.append(f"{key}: printed {printed}, the table gives {c[key] * scale:.6g}")
    if claim["direction"] != "same" and unqualified_sameness(text):
        problems.append("states a sameness without an equivalence test: say 'not shown to "
                        "differ' or declare a margin")
    if not direction_follows(claim["direction"], c, claim.get("margin")):
        problems.append(f"direction {claim['direction']!r} does not follow: "
                        + ", ".join(f"{k} {c[k]:.4g}" for k in ("d", "lo", "hi", "p", "holm")
                                    if k in c))
    return problems


def _md_rows(lines: list[str], start: int, key_cells: int = 1) -> dict[str, list[str]]:
    """The rows of the markdown table whose header is ``lines[start]``, keyed by their first
    cell (markup stripped; by their first ``key_cells`` cells joined with " | " where one
    cell does not name a row); an empty first cell continues the row above (``label#2``,
    ...)."""
    rows: dict[str, list[str]] = {}
    last = ""
    for line in lines[start + 1:]:
        if not line.startswith("|"):
            break
        cells = [c.strip() for c in line.strip().strip("|").split("|")]
        if set(cells[0]) <= {"-"} and all(set(c) <= {"-", ":"} for c in cells):
            continue
        label = " | ".join(c.replace("*", "").replace("`", "").strip()
                           for c in cells[:key_cells])
        if label:
            last, key = label, label
        else:
            n = sum(k.startswith(last + "#") for k in rows)
            key = f"{last}#{n + 1}"
        rows[key] = cells
    return rows


def _figures(cell: str) -> list[tuple[str, float]]:
    return [(x, float(x.replace("−", "-"))) for x in re.findall(_NUM, cell.replace("*", ""))]


def check_table(spec: dict) -> list[str]:
    """A table of a page against the committed table a command wrote: each figure of each
    mapped cell equals the source cell's figure in the same place, to the precision of both.
    ``columns``: [page column (its position on the page), block, source column (its header in
    the committed table: :func:`column_index`)]; ``key_cells``: how many leading cells name a
    page row (1 unless given)."""
    for key in ("page", "header", "source", "rows", "columns"):
        if key not in spec:
            raise BadInput(f"table {spec.get('id', '?')}: no {key!r}")
    page = _path(spec["page"]).read_text().splitlines()
    at = [k for k, line in enumerate(page) if line.startswith("|") and spec["header"] in line]
    if "occurrence" in spec and len(at) > spec["occurrence"]:
        at = [at[spec["occurrence"]]]
    if len(at) != 1:
        return [f"header {spec['header']!r} found {len(at)} times on {spec['page']}"]
    mine = _md_rows(page, at[0], int(spec.get("key_cells", 1)))
    source = _path(spec["source"]).read_text().splitlines()
    problems = []
    for page_row, source_row in spec["rows"].items():
        if page_row not in mine:
            problems.append(f"no row {page_row!r} on the page")
            continue
        for page_col, block, source_col in spec["columns"]:
            lines = source
            if block:
                first = next((k for k, line in enumerate(source) if block in line), None)
                if first is None:
                    raise BadInput(f"{spec['source']}: no block {block!r}")
                lines = source[first:]
            head = next(k for k, line in enumerate(lines) if line.startswith("|"))
            if not isinstance(source_col, str):
                raise BadInput(f"table {spec['id']}: name {spec['source']}'s column by its "
                               f"header, not {source_col!r}")
            at = column_index(_cells(lines[head]), source_col,
                              f"{spec['source']} block {block!r}")
            theirs = _md_rows(lines, head)
            match = [v for k, v in theirs.items() if k.startswith(source_row)]
            if not match:
                raise BadInput(f"{spec['source']}: no row {source_row!r} in block {block!r}")
            shown, given = _figures(mine[page_row][page_col]), _figures(match[0][at])
            if not shown or len(shown) > len(given):
                problems.append(f"{page_row!r} column {page_col}: {mine[page_row][page_col]!r} "
                                f"against {match[0][at]!r}")
                continue
            for (text, value), (text2, value2) in zip(shown, given):
                tol = sum(0.5 * 10 ** -(len(t.split(".")[1]) if "." in t else 0)
                          for t in (text, text2))
                if abs(value - value2) > tol + 1e-9:
                    problems.append(f"{page_row!r} column {page_col}: printed {text}, "
                                    f"{spec['source']} gives {text2}")
    return problems


def load_tables(path: Path = CLAIMS) -> list[dict]:
    try:
        return tomllib.loads(path.read_text()).get("table", [])
    except (OSError, tomllib.TOMLDecodeError) as e:
        raise BadInput(f"{path}: {e}") from None


def load(path: Path = CLAIMS) -> list[dict]:
    try:
        claims = tomllib.loads(path.read_text())["claim"]
    except (OSError, KeyError, tomllib.TOMLDecodeError) as e:
        raise BadInput(f"{path}: {e}") from None
    ids = [c.get("id") for c in claims]
    if len(set(ids)) != len(ids) or None in ids:
        raise BadInput(f"{path}: every claim needs its own id")
    return claims


#: the pages whose figures the claims check
CLAIM_PAGES = ("README.md", "docs/results.md", "docs/beyond/README.md")
_FIGURE = re.compile(r"(?<![\w.])[-+−]?\d+(?:\.\d+)?(?:\s?%)?")


def _page_figures(page: str) -> tuple[str, list[tuple[int, int, str, bool]]]:
    """A page's prose as one line (code blocks, inline code and headings left out) and each
    number in it: ``(position, line, number, checked)``: checked when a claim prints it (one
    of the claim's values, in its quote) or a checked table holds it."""
    claims, tables = load(), load_tables()
    text = re.sub(r"```.*?```", lambda m: "\n" * m.group(0).count("\n"),
                  _path(page).read_text(), flags=re.S)
    lines = text.splitlines()
    in_tables = set()
    for spec in (t for t in tables if t["page"] == page):
        for k, line in enumerate(lines):
            if line.startswith("|") and spec["header"] in line:
                j = k
                while j < len(lines) and lines[j].startswith("|"):
                    in_tables.add(j)
                    j += 1
    flat, figures = "", []
    for k, line in enumerate(lines):
        shown = "" if line.lstrip().startswith("#") else _words(re.sub(r"`[^`]*`", "", line))
        for m in _FIGURE.finditer(shown):
            figures.append((len(flat) + m.start(), k + 1, m.group(0), k in in_tables))
        # a table row ends its own sentence: its cells are not read into the next line
        flat += shown + (" | " if line.startswith("|") else " ")
    # a figure is checked where a claim prints it: the claim's quote is on the page there and
    # the figure is one of the claim's values (recomputed and compared), not merely quoted
    checked: set[int] = set()
    for claim in (c for c in claims if c["page"] == page):
        quote = _words(re.sub(r"`[^`]*`", "", claim["text"]))
        if not quote:
            continue
        printed = {_words(str(v)).replace("−", "-") for v in claim["values"].values()}
        for m in re.finditer(re.escape(quote), flat):
            for f in _FIGURE.finditer(quote):
                if f.group(0).strip().replace("−", "-").rstrip("%").strip() in printed:
                    checked.add(m.start() + f.start())
    return flat, [(at, line, number, tabled or at in checked)
                  for at, line, number, tabled in figures]


def coverage(pages: tuple[str, ...] = CLAIM_PAGES) -> list[tuple[str, int, int, list]]:
    """Per page: the numbers in its prose and tables (code blocks, inline code and headings
    left out), how many a claim's quote or a checked table covers, and the others as
    ``(line, number, context)``. Every number counts, parameters and sizes too: the count says
    how much of a page is checked, not which numbers are results."""
    out = []
    for page in pages:
        flat, figures = _page_figures(page)
        missing = [(line, number, flat[max(0, at - 40):at + len(number) + 30])
                   for at, line, number, covered in figures if not covered]
        out.append((page, len(figures), len(figures) - len(missing), missing))
    return out


#: what states a difference on a page (:func:`stated_differences`): a figure with an explicit
#: sign (a difference: +0.43, −0.029 m/s), an interval in brackets ([−0.36, −0.05]), a figure
#: with a comparative (0.16 m/s slower, 43 fewer falls, 2.5 % lower, lower by 0.53), and two
#: figures set against each other (53 % against 10 %, 0.41 → 0.65)
_N = r"[-+−]?\d+(?:\.\d+)?(?:\s?%)?"
_UNIT = r"(?:\s+(?:m/s|m|s|sessions?|falls?|runs?|nV|pp|per\s+seed))?"  # not "seeds": "20 seeds against 20" is a size
_COMPARATIVE = (r"(?:higher|lower|faster|slower|more|fewer|less|shorter|longer|greater|"
                r"smaller|larger|wider|narrower|better|worse)")
DIFFERENCE = re.compile(
    r"(?<![\w.])[+−]\d+(?:\.\d+)?(?:\s?%)?"                        # +0.43, −0.029
    r"|(?<=[\s(\[])-\d+(?:\.\d+)?(?:\s?%)?"                          # -0.2 typed with a hyphen
    r"|\[\s*" + _N + r"\s*,\s*" + _N + r"\s*\]"                      # [lo, hi]
    r"|(?<![\w.])\d+(?:\.\d+)?(?:\s?%)?" + _UNIT + r"\s+" + _COMPARATIVE + r"\b"  # 2 s shorter
    r"|\b" + _COMPARATIVE + r"\s+by\s+" + _N                           # lower by 0.53
    + r"|(?<![\w.])\d+(?:\.\d+)?(?:\s?%)?" + _UNIT + r"\s+(?:against|→)\s+" + _N)  # 53 % against 10 %


def stated_differences(page: str) -> list[tuple[int, str, str]]:
    """The differences a page states that no claim and no checked table covers: each figure
    that is part of a stated difference (:data:`DIFFERENCE`) and not covered, as ``(line,
    figure, context)``. Empty when every stated difference of the page is checked against its
    table, direction included (a claim gives the direction; a checked table, each figure)."""
    flat, figures = _page_figures(page)
    at_figure = {at: (line, number, covered) for at, line, number, covered in figures}
    out = []
    for m in DIFFERENCE.finditer(flat):
        for f in _FIGURE.finditer(m.group(0)):
            at = m.start() + f.start()
            line, number, covered = at_figure.get(at, (None, f.group(0), False))
            if line is None:   # a figure _FIGURE reads differently in the page: find its line
                line = next((ln for a, ln, _, _ in reversed(figures) if a <= at), 0)
            if not covered:
                out.append((line, number.strip(), flat[max(0, m.start() - 50):m.end() + 30]))
    return list(dict.fromkeys(out))


def main(argv: list[str]) -> int:
    try:
        if argv[:1] == ["analyse"]:
            print(analyse())
            return 0
        if argv[:1] == ["coverage"]:
            for page, total, covered, missing in coverage():
                print(f"{page}: {covered} of {total} numbers in claims or checked tables")
                if argv[1:2] == ["--list"]:
                    for line, number, context in missing:
                        print(f"  {page}:{line}: {number}  ...{context}...")
            return 0
        if argv[:1] == ["differences"]:
            left = 0
            for page in CLAIM_PAGES:
                found = stated_differences(page)
                left += len(found)
                print(f"{page}: {len(found)} figures of stated differences no claim covers")
                for line, number, context in found:
                    print(f"  {page}:{line}: {number}  ...{context}...")
            return 3 if left else 0
        claims = load(Path(argv[0]) if argv else CLAIMS)
        pages: dict[str, str] = {}
        failed = 0
        for claim in claims:
            problems = check(claim, pages)
            failed += bool(problems)
            print(f"{'ok ' if not problems else 'NO '} {claim['id']}: {claim['direction']}"
                  + "".join(f"\n     {p}" for p in problems))
        tables = load_tables(Path(argv[0]) if argv else CLAIMS)
        for spec in tables:
            problems = check_table(spec)
            failed += bool(problems)
            print(f"{'ok ' if not problems else 'NO '} table {spec['id']}"
                  + "".join(f"\n     {p}" for p in problems))
        n = len(claims) + len(tables)
        print(f"{n - failed} of {n} claims and tables follow from their tables")
        return 3 if failed else 0
    except BadInput as e:
        print(f"claims.py: {e}", file=sys.stderr)
        return 2


# ---------------------------------------------------------------- the analyses, printed

ROBUST = "docs/beyond/robustness/evaluation.csv"
CONTROLS = "docs/beyond/homeostatic_control/evaluation.csv"
CONTROL_RUNS = {"constant": "control__interlimb_synapse=constant-depression-interlimb-synapse"
                            "__seeds1-20",
                "activity": "control__interlimb_synapse=homeostatic-interlimb-synapse"
                            "__seeds1-20"}


def _fmt(c: dict[str, float], digits: int = 2) -> str:
    return (f"{c['d']:+.{digits}f} [{c['lo']:+.{digits}f}, {c['hi']:+.{digits}f}]")


def analyse() -> str:
    out = ["## Trot gait share against the locking threshold (flat, astrocytes)", "",
           "| threshold | share of runs | runs |", "|---|---|---|"]
    for thr in (0.5, 0.6, 0.7, 0.8):
        g = c_gait_threshold(ROBUST, "astrocytes", "flat", thr)
        out.append(f"| {thr} | {g['share']:.2f} | {g['count']:.0f} of {g['runs']:.0f} |")
    out.append(f"\nFootfall phases a trot (any locking): {g['phases']:.0f} of {g['runs']:.0f}.")
    t = c_tables_differ(ROBUST, "astrocytes", "flat")
    out += ["", "## Do the tables differ in trot gait share? (flat, astrocytes)", "",
            f"chi2 {t['chi2']:.1f}, permutation p {t['p']:.2f}; tables trotting at least once "
            f"{t['any']:.0f} (expected {t['expected_any']:.1f} at one share {t['share']:.2f}), "
            f"in most runs {t['most']:.0f} (expected {t['expected_most']:.1f})"]
    out += ["", "## Controls minus astrocytes (flat evaluation; MDD: 80 % power, alpha 0.05)", "",
            "| control | measure | difference [95 %] | p | smallest detectable |",
            "|---|---|---|---|---|"]
    for name, run in CONTROL_RUNS.items():
        for m in ("gait", "rhythm", "speed", "falls"):
            c = c_versus(ROBUST, "astrocytes", CONTROLS, run, "flat", m)
            out.append(f"| {name} | {m} | {_fmt(c, 3)} | {c['p']:.2g} | {c['mdd']:.3f} |")
    out += ["", "## Training rows, controls minus astrocytes (last 20 of 400; Holm over 12)", "",
            "| control | measure | astrocytes | control | difference [95 %] | relative "
            "| Holm p | smallest detectable |", "|---|---|---|---|---|---|---|---|"]
    for name, run in CONTROL_RUNS.items():
        for m in TRAINING:
            c = c_training("docs/ablation/faster_loop/results.csv.gz", "astrocytes",
                           "docs/beyond/homeostatic_control/results.csv.gz", run, m,
                           family=tuple(CONTROL_RUNS.values()))
            out.append(f"| {name} | {m} | {c['a']:.3f} | {c['b']:.3f} | {_fmt(c, 3)} | "
                       f"{100 * c['relative']:+.1f} % | {c['holm']:.2g} | {c['mdd']:.3f} |")
    out += ["", "## Learnt by, never-learnt seeds counted (at the last session)", "",
            "| comparison | never (A, B) | A | B | B - A [95 %] | p |", "|---|---|---|---|---|---|"]
    for label, a, ra, b, rb, s in (
            ("rough: astrocytes - none", "docs/beyond/rough_ablation/results.csv.gz",
             "no_astrocytes", "docs/beyond/rough_ablation/results.csv.gz", "astrocytes", 400),
            ("flat: load afferent - none", "docs/ablation/streams/results.csv.gz", "astrocytes",
             "docs/beyond/load_afferent/results.csv.gz", "flat", 200),
            ("rough: load afferent - none", "docs/beyond/rough_ablation/results.csv.gz",
             "astrocytes", "docs/beyond/load_afferent/results.csv.gz", "rough", 200)):
        c = c_training(a, ra, b, rb, "learnt_by", sessions=s)
        out.append(f"| {label} | {c['never_a']:.0f}, {c['never_b']:.0f} | {c['a']:.1f} | "
                   f"{c['b']:.1f} | {_fmt(c, 1)} | {c['p']:.2g} |")
    out += ["", "## Worlds against flat ground, seed by seed (Holm over the 11 worlds)", "",
            "| world | astrocytes: falls - flat | none: falls - flat | astrocytes' advantage "
            "in falls - its flat advantage | Holm p | astrocytes: trot gait - flat | Holm p |",
            "|---|---|---|---|---|---|---|"]
    for w in _worlds(ROBUST):
        a = c_world_minus_flat(ROBUST, "astrocytes", w, "falls")
        n = c_world_minus_flat(ROBUST, "no_astrocytes", w, "falls")
        dd = c_advantage_vs_flat(ROBUST, "astrocytes", "no_astrocytes", w, "falls")
        g = c_world_minus_flat(ROBUST, "astrocytes", w, "gait")
        out.append(f"| {w} | {_fmt(a)} | {_fmt(n)} | {_fmt(dd)} | {dd['holm']:.2g} | "
                   f"{_fmt(g)} | {g['holm']:.2g} |")
    return "\n".join(out) + "\n"


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
