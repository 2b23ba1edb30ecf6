"""The analyses of docs/beyond that ``astrocpg report`` does not draw, from studies'
``results.csv`` (or ``.csv.gz``):

    # Fig. 3c on two grounds, side by side (mean +- std across seeds, trailing mean of 10)
    python docs/beyond/analyse.py fig3c docs/ablation/streams/results.csv.gz \
        docs/beyond/rough_ablation/results.csv.gz --titles "flat ground" "rough terrain 2 cm" \
        --out docs/beyond/rough_ablation/fig3c_flat_rough.png

    # each seed against itself: a study's condition against another's, seed by seed
    python docs/beyond/analyse.py paired docs/ablation/streams/results.csv.gz:astrocytes \
        docs/beyond/load_afferent/results.csv.gz:flat --sessions 150 --last 20

    # the same seeds in two studies, drawn over each other (one column per ground)
    python docs/beyond/analyse.py overlay --sessions 150 \
        --column "flat ground" docs/ablation/streams/results.csv.gz:astrocytes "without" \
            docs/beyond/load_afferent/results.csv.gz:flat "with the load afferent" \
        --out docs/beyond/load_afferent/fig3c_load_afferent.png

    # per run of each study, the measures over the sessions all its seeds have done
    python docs/beyond/analyse.py table docs/ablation/streams/results.csv.gz:astrocytes \
        docs/beyond/drive_full/results.csv.gz --sessions 120 --seeds 1-12

    # the rows of a study folder as they stand (finished or not), as one table
    python docs/beyond/analyse.py rows out/load_afferent --out docs/beyond/load_afferent/rows.csv.gz

    # one reference against each run of a study, unpaired, over the same sessions and seeds
    python docs/beyond/analyse.py versus docs/ablation/streams/results.csv.gz:astrocytes \
        docs/beyond/drive_full/results.csv.gz --sessions 120 --seeds 1-12

    # one column (a value per seed) of two CSV files, unpaired
    python docs/beyond/analyse.py columns docs/variants/delays/gait_interlimb-authors-delays.csv \
        docs/variants/delays/gait_interlimb-synapse.csv --column final_speed_m_per_s

    # astrocpg evaluate's runs, controller by controller, with 95 % confidence intervals
    # (--baseline flat: each world's effect relative to flat ground, and between conditions)
    python docs/beyond/analyse.py worlds docs/beyond/robustness/evaluation.csv

    # one condition's runs in one world, controller by controller (trot gait shares, reasons)
    python docs/beyond/analyse.py controllers docs/beyond/robustness/evaluation.csv --world flat

    # each run of a study against a reference run, seed by seed: evaluated gait, rhythm, speed
    # and falls of the final tables, and the tables' weight structure (final_tables.py folders)
    python docs/beyond/analyse.py against docs/beyond/robustness/evaluation.csv:astrocytes__seeds1-20 \
        docs/ablation/faster_loop/tables docs/beyond/homeostatic_control/evaluation.csv \
        docs/beyond/homeostatic_control/tables --world flat
    # ... at a kept session (both evaluations of it: astrocpg evaluate --session 120), intervals
    # only: --session 120 --describe

    # a measure against a swept parameter: each run of a study and reference points (runs of
    # other evaluations, at the values given), mean and 95 % bootstrap interval over seeds
    python docs/beyond/analyse.py response docs/beyond/adenosine_dose/evaluation.csv \
        docs/beyond/adenosine_dose/tables --axis eta_ADO --unit nV \
        --point "0=docs/beyond/robustness/evaluation.csv:no-astrocytes__seeds1-20@docs/ablation/faster_loop/tables" \
        --point "18=docs/beyond/robustness/evaluation.csv:astrocytes__seeds1-20@docs/ablation/faster_loop/tables" \
        --out docs/beyond/adenosine_dose/response.png

    # a study over two swept parameters, point by point (docs/beyond section 5's rules): the
    # seeds with a gait in most of their runs, the runs, speed, falls and the tables' structure
    python docs/beyond/analyse.py map docs/beyond/gait_map_trained/evaluation.csv \
        docs/beyond/gait_map_trained/tables --axes I_background_0 torque_gain --unit mV/s \
        --out docs/beyond/gait_map_trained/map.png

``worlds`` averages each controller's repeats first (the repeats of one controller are not
independent samples of the condition), then gives per condition and world the mean over
controllers of the falls, the forward speed and the trot with a 95 % bootstrap interval
(10 000 resamples of the controllers, fixed seed), and the difference between the two
conditions with its bootstrap interval and the Mann-Whitney U test's two-sided p.

Per seed, over its sessions 1..S (``--sessions``; default all): the mean over the last N
sessions (``--last``) of the forward speed, the final x and the session length; the share of
those N sessions that ran the full L_max (the robot did not fall); the falls over all S sessions
(sessions that ended before L_max); and the session at which the trailing mean of 10 session
lengths first reached 90 % of L_max ("learnt by"; a seed that never did counts as its last
session, censored there and never dropped: ``astrocpg.studies.analysis.events``). ``paired`` prints each measure's mean ± std for
both sides, the mean per-seed difference with its 95 % bootstrap interval over seeds, the
two-sided sign-flip permutation p of the per-seed differences and that p Holm-adjusted over the
table's measures.
"""

from __future__ import annotations

import argparse
import csv
import gzip
import math
import sys
from pathlib import Path

import numpy as np

L_MAX = 10.0  # the paper's maximum session length (s): a session shorter than it ended in a fall
LEARNT = 0.9  # "learnt by": trailing mean of 10 session lengths >= 0.9 L_max


def _study_rows(folder: Path) -> list[dict[str, str]]:
    """The rows of a study folder that has not finished (no results.csv yet): each run's
    sessions.csv, with its condition, run id and seed (the run's first seed + trial)."""
    import json

    rows = []
    for run in sorted((folder / "runs").iterdir()):
        spec = json.loads((run / "status.json").read_text())["spec"]
        if not (run / "sessions.csv").exists():
            continue
        gaits = {}  # a finished run's final gait per trial (gait.csv)
        if (run / "gait.csv").exists():
            with open(run / "gait.csv", newline="") as f:
                gaits = {r["trial"]: r["final_gait"] for r in csv.DictReader(f)}
        with open(run / "sessions.csv", newline="") as f:
            for r in csv.DictReader(f):
                rows.append({**r, "run_id": run.name, "condition": spec["condition"],
                             "seed": str(int(spec["seed"]) + int(r["trial"])),
                             "final_gait": gaits.get(r["trial"], "")})
    return rows


def read_rows(spec: str) -> tuple[list[dict[str, str]], str | None]:
    """``PATH[:CONDITION]`` -> (rows of that condition, condition). PATH is a study's
    results.csv (or .csv.gz), or a study folder still running (its runs' sessions)."""
    path, _, condition = spec.partition(":")
    if Path(path).is_dir():
        rows = _study_rows(Path(path))
    else:
        opener = gzip.open if path.endswith(".gz") else open
        with opener(path, "rt", newline="") as f:
            rows = list(csv.DictReader(f))
    if condition:
        rows = [r for r in rows if r["condition"] == condition]
        if not rows:
            sys.exit(f"analyse.py: no rows of condition {condition!r} in {path}")
    return rows, condition or None


def per_seed(rows: list[dict[str, str]], sessions: int | None) -> dict[int, np.ndarray]:
    """seed -> (session, [length, final_x, speed, reward]) for sessions 1..sessions."""
    out: dict[int, dict[int, list[float]]] = {}
    for r in rows:
        s = int(r["session"])
        if sessions is None or s <= sessions:
            out.setdefault(int(r["seed"]), {})[s] = [
                float(r["length_s"]), float(r["final_x_m"]),
                float(r["mean_forward_speed_m_per_s"]), float(r["mean_reward"])]
    return {seed: np.array([v[s] for s in sorted(v)]) for seed, v in sorted(out.items())}


MEASURES = ("speed (m/s)", "final x (m)", "session length (s)", "full-length share",
            "falls", "learnt by (session)")


def measures(series: np.ndarray, last: int) -> list[float]:
    """A seed's measures (:data:`MEASURES`); "learnt by" is censored at the seed's last session
    where it never learnt (:func:`learnt`, which says whether it did)."""
    tail = series[-last:]
    length = series[:, 0]
    return [float(tail[:, 2].mean()), float(tail[:, 1].mean()), float(tail[:, 0].mean()),
            float(np.mean(tail[:, 0] >= L_MAX - 1e-9)), float(np.sum(length < L_MAX - 1e-9)),
            learnt(series)[0]]


def learnt(series: np.ndarray) -> tuple[float, bool]:
    """(session, learnt): the session at which the trailing mean of 10 session lengths first
    reached 90 % of L_max; a seed that never did: its last session, False (censored there)."""
    from astrocpg.studies.analysis.events import first_reached

    return first_reached(series[:, 0], LEARNT * L_MAX, window=10)


def paired(a_spec: str, b_spec: str, sessions: int | None, last: int) -> str:
    from astrocpg.studies.analysis.compare import compare, holm, p_text
    from astrocpg.studies.analysis.events import censored_compare

    a_rows, _ = read_rows(a_spec)
    b_rows, _ = read_rows(b_spec)
    a, b = per_seed(a_rows, sessions), per_seed(b_rows, sessions)
    seeds = sorted(set(a) & set(b))
    common = min(min(len(a[s]), len(b[s])) for s in seeds)  # a study still running: its
    a = {s: a[s][:common] for s in seeds}                    # sessions every seed has done
    b = {s: b[s][:common] for s in seeds}
    n_a = {len(a[s]) for s in seeds} | {len(b[s]) for s in seeds}
    if len(n_a) != 1:
        sys.exit(f"analyse.py: the seeds do not all have the same sessions ({sorted(n_a)})")
    S = n_a.pop()
    ma = np.array([measures(a[s], last) for s in seeds])
    mb = np.array([measures(b[s], last) for s in seeds])
    tests = [compare(mb[:, k], ma[:, k], paired=True) for k in range(len(MEASURES))]
    # "learnt by": every seed counted, a seed that never learnt censored at its last session
    la, lb = [learnt(a[s]) for s in seeds], [learnt(b[s]) for s in seeds]
    tests[-1] = censored_compare(lb, la, paired=True)
    adjusted = holm([t["perm_p"] for t in tests])
    lines = [f"{len(seeds)} seeds ({seeds[0]}-{seeds[-1]}), sessions 1-{S}, last {last} sessions; "
             f"A = {a_spec}, B = {b_spec}. B − A per seed: mean [95 % bootstrap interval over "
             f"seeds]; p: two-sided sign-flip permutation test of the per-seed differences; "
             f"Holm: adjusted over the {len(MEASURES)} measures of this table. Learnt by: a "
             f"seed that never learnt counts as its last session ({S}: censored there, never "
             f"dropped), so its mean is the restricted mean time to learn.", "",
             "| measure | A: mean ± std | B: mean ± std | B − A per seed [95 % interval] "
             "| p | Holm p |", "|---|---|---|---|---|---|"]
    for k, name in enumerate(MEASURES):
        x, y, t = ma[:, k], mb[:, k], tests[k]
        never = ""
        if name.startswith("learnt"):
            never = (f" (never, counted at session {S}: A {t['never_b']}, B {t['never_a']})")
        if t["difference_low"] is not None:
            d = f"{t['difference']:+.3f} [{t['difference_low']:+.3f}, {t['difference_high']:+.3f}]"
        else:
            d = f"{t['difference']:+.3f} ({t['note']})"
        lines.append(f"| {name}{never} | {np.nanmean(x):.3f} ± {np.nanstd(x):.3f} | "
                     f"{np.nanmean(y):.3f} ± {np.nanstd(y):.3f} | {d} | "
                     f"{p_text(t['perm_p'], t['perm_p_min'], bool(t['perm_bound']))} | "
                     f"{p_text(adjusted[k])} |")
    return "\n".join(lines) + "\n"


def _final_labels(rows: list[dict[str, str]]) -> str:
    """The final runs' labels of a run's seeds, each measure named: ``rhythm trot 8; gait trot
    5, none 3`` (a study that reads both), or ``rhythm trot 8`` for rows written before the
    gait was read from the feet (their ``final_gait`` is the CPG's rhythm)."""
    seeds = {r["seed"]: r for r in rows}
    new = any("final_rhythm" in r for r in seeds.values())
    kinds = (("rhythm", "final_rhythm"), ("gait", "final_gait")) if new else \
        (("rhythm", "final_gait"),)
    parts = []
    for name, column in kinds:
        counts: dict[str, int] = {}
        for r in seeds.values():
            label = r.get(column, "") or "–"
            counts[label] = counts.get(label, 0) + 1
        parts.append(f"{name} " + ", ".join(
            f"{k} {v}" for k, v in sorted(counts.items(), key=lambda kv: -kv[1])))
    return "; ".join(parts)


def versus(ref_spec: str, spec: str, sessions: int | None, last: int, seeds: str | None
           ) -> str:
    """Each run of ``spec`` against the runs of ``ref_spec`` (unpaired, one value per seed over
    the same sessions): for speed and session length, the difference ref − run with its 95 %
    bootstrap interval, the Mann-Whitney p (exact where no value is tied) and that p
    Holm-adjusted over the runs of ``spec``."""
    from astrocpg.studies.analysis.compare import compare, holm, p_text

    keep = None
    if seeds:
        lo, _, hi = seeds.partition("-")
        keep = set(range(int(lo), int(hi or lo) + 1))

    def values(rows: list[dict[str, str]]) -> np.ndarray:
        series = per_seed(rows, sessions)
        series = {s: v for s, v in series.items() if keep is None or s in keep}
        S = min(len(v) for v in series.values())
        return np.array([measures(v[:S], last) for _, v in sorted(series.items())])

    ref_rows, _ = read_rows(ref_spec)
    ref = values(ref_rows)
    rows, _ = read_rows(spec)
    lines = [f"A = {ref_spec} ({len(ref)} seeds); sessions up to {sessions or 'all'}, last "
             f"{last}. A − run: mean [95 % bootstrap interval over seeds]; Mann-Whitney p; "
             "Holm over the runs below.", ""]
    for k in (0, 2):
        runs = list(dict.fromkeys(r["run_id"] for r in rows))
        tests = [compare(ref[:, k], values([r for r in rows if r["run_id"] == run])[:, k])
                 for run in runs]
        adjusted = holm([t["mwu_p"] for t in tests])
        lines += [f"**{MEASURES[k]}**", "", "| run | A − run [95 % interval] | p | Holm p |",
                  "|---|---|---|---|"]
        for run, t, adj in zip(runs, tests, adjusted):
            d = (f"{t['difference']:+.2f} [{t['difference_low']:+.2f}, {t['difference_high']:+.2f}]"
                 if t["difference_low"] is not None else f"{t['difference']:+.2f} ({t['note']})")
            lines.append(f"| {run} | {d} | {p_text(t['mwu_p'])} | {p_text(adj)} |")
        lines.append("")
    return "\n".join(lines)


def columns(a_csv: str, b_csv: str, column: str) -> str:
    """One numeric column of two CSV files (a value per seed each), unpaired: the means, the
    difference a − b with its 95 % bootstrap interval, the permutation and Mann-Whitney p."""
    from astrocpg.studies.analysis.compare import compare, p_text

    def read(path: str) -> list[float]:
        with open(path, newline="") as f:
            return [float(r[column]) for r in csv.DictReader(f)]

    t = compare(read(a_csv), read(b_csv))
    return (f"{column}: A = {a_csv} {t['mean_a']:.3f} (n={t['n_a']}), B = {b_csv} "
            f"{t['mean_b']:.3f} (n={t['n_b']}); A − B {t['difference']:+.3f} [95 % bootstrap "
            f"interval {t['difference_low']:+.3f}, {t['difference_high']:+.3f}]; permutation "
            f"p {p_text(t['perm_p'], t['perm_p_min'], bool(t['perm_bound']))}, Mann-Whitney p "
            f"{p_text(t['mwu_p'])}\n")


def table(specs: list[str], sessions: int | None, last: int, seeds: str | None) -> str:
    """Per run (a condition and sweep point) of each study: the measures of :func:`measures`,
    mean ± std over its seeds, over the sessions all its seeds have done (at most
    ``sessions``), and the count of each final gait (a 5 s run of each seed's final table;
    "–" where the run has not finished)."""
    keep = None
    if seeds:
        lo, _, hi = seeds.partition("-")
        keep = set(range(int(lo), int(hi or lo) + 1))
    lines = ["| run | seeds | sessions | " + " | ".join(MEASURES) + " | final labels |",
             "|---|---|---|" + "---|" * (len(MEASURES) + 1)]
    for spec in specs:
        rows, _ = read_rows(spec)
        for run_id in dict.fromkeys(r["run_id"] for r in rows):
            series = per_seed([r for r in rows if r["run_id"] == run_id], sessions)
            if keep is not None:
                series = {s: v for s, v in series.items() if s in keep}
            S = min(len(v) for v in series.values())
            m = np.array([measures(v[:S], last) for v in series.values()])
            n_never = sum(not learnt(v[:S])[1] for v in series.values())
            cells = []
            for k, name in enumerate(MEASURES):
                x = m[:, k]
                never = (f" ({n_never} never: counted at session {S})"
                         if name.startswith("learnt") and n_never else "")
                cells.append(f"{np.nanmean(x):.2f} ± {np.nanstd(x):.2f}{never}")
            cells.append(_final_labels(
                [r for r in rows if r["run_id"] == run_id
                 and (keep is None or int(r["seed"]) in keep)]))
            lines.append(f"| {run_id} | {len(series)} | 1–{S} | " + " | ".join(cells) + " |")
    return "\n".join(lines) + "\n"


def _bootstrap_mean(x: np.ndarray, rng: np.random.Generator) -> tuple[float, float, float]:
    """Mean of ``x`` and its 95 % bootstrap interval (10 000 resamples)."""
    means = x[rng.integers(0, len(x), (10000, len(x)))].mean(axis=1)
    return float(x.mean()), float(np.percentile(means, 2.5)), float(np.percentile(means, 97.5))


def worlds(path: str, baseline: str | None = None) -> str:
    """astrocpg evaluate's runs, controller by controller: per condition and world, the mean over
    controllers (each controller's repeats averaged first) of falls, speed, and the share of
    runs with a trot rhythm and (evaluations that read it) a trot gait, with 95 % bootstrap
    intervals, and the two conditions' difference with its interval, Mann-Whitney p and that p
    Holm-adjusted over the worlds (the module docstring says how)."""
    from astrocpg.studies.analysis.compare import compare, holm, p_text

    with open(path, newline="") as f:
        rows = list(csv.DictReader(f))
    # evaluations written before the gait was read from the feet have no ``rhythm`` column:
    # their ``gait`` is the CPG's rhythm
    new = bool(rows) and "rhythm" in rows[0]
    columns = [("falls (share of runs)", lambda r: float(r["fell"])),
               ("speed (m/s)", lambda r: float(r["mean_speed_m_per_s"])),
               ("trot rhythm (share of runs)",
                lambda r: float(r["rhythm" if new else "gait"] == "trot"))]
    if new:
        columns.append(("trot gait, from the feet while upright (share of runs)",
                        lambda r: float(r["gait"] == "trot")))
    rng = np.random.default_rng(1)
    # condition -> world -> controller -> [measures] per repeat
    table: dict[str, dict[str, dict[str, list[list[float]]]]] = {}
    for r in rows:
        table.setdefault(r["condition"], {}).setdefault(r["world"], {}).setdefault(
            f'{r["source"]}:{r["seed"]}', []).append([f(r) for _, f in columns])
    conditions = list(table)
    world_names = list(dict.fromkeys(w for c in conditions for w in table[c]))

    def per_controller(c: str, w: str) -> np.ndarray:
        return np.array([np.mean(v, axis=0) for v in table[c][w].values()])

    def ci(x: np.ndarray) -> tuple[float, float]:
        return _bootstrap_mean(x, rng)[1:]

    n = {c: len(next(iter(table[c].values()))) for c in conditions}
    reps = {c: len(next(iter(next(iter(table[c].values())).values()))) for c in conditions}
    lines = [f"Controllers: {', '.join(f'{c} {n[c]} ({reps[c]} repeats each)' for c in conditions)}."
             " Mean over controllers [95 % bootstrap interval]; difference [95 % bootstrap "
             "interval]; Mann-Whitney p (exact where no value is tied) and, in the last column, "
             f"Holm-adjusted over the {len(world_names)} worlds of the table.", ""]
    for k, (label, _) in enumerate(columns):
        head = " | ".join(c.replace("_", " ") for c in conditions)
        two = len(conditions) == 2
        lines += [f"**{label}**", "", f"| world | {head} |"
                  + (" difference (first − second) | Mann-Whitney p | Holm p |" if two else ""),
                  "|---|" + "---|" * (len(conditions) + (3 if two else 0))]
        body, tests = [], []
        for w in world_names:
            cells, values = [], []
            for c in conditions:
                x = per_controller(c, w)[:, k] if w in table[c] else np.array([])
                lo, hi = ci(x) if len(x) else (math.nan, math.nan)
                cells.append(f"{x.mean():.2f} [{lo:.2f}, {hi:.2f}]" if len(x) else "–")
                values.append(x)
            t = compare(*values) if two and all(len(v) for v in values) else None
            tests.append(t)
            body.append((w, cells, t))
        adjusted = holm([t["mwu_p"] if t else None for t in tests])
        for (w, cells, t), adj in zip(body, adjusted):
            if len(conditions) == 2:
                if t is None:
                    cells += ["–", "–", "–"]
                elif t["difference_low"] is None:
                    cells += [f"{t['difference']:+.2f} ({t['note']})", "–", "–"]
                else:
                    cells += [f"{t['difference']:+.2f} [{t['difference_low']:+.2f}, "
                              f"{t['difference_high']:+.2f}]",
                              p_text(t["mwu_p"]), p_text(adj)]
            lines.append(f"| {w} | " + " | ".join(cells) + " |")
        lines.append("")
    if baseline is not None:
        lines += _baseline_table(rows, baseline)
    return "\n".join(lines)


def _baseline_table(rows: list[dict[str, str]], baseline: str) -> list[str]:
    """Each world's effect relative to ``baseline`` (astrocpg evaluate --baseline's
    baseline.csv, from the rows): per condition the mean over controllers of world minus
    baseline, and between two conditions the difference of those effects, paired by seed."""
    from astrocpg.studies.commands.evaluate import baseline_effects

    if not any(r["world"] == baseline for r in rows):
        sys.exit(f"analyse.py: no runs in the baseline world {baseline!r}")
    lines = [f"**Relative to {baseline}** (per controller its figure in the world minus in "
             f"{baseline}, each over its repeats; then the mean over controllers [95 % t "
             "interval over controllers]; a pair of conditions: the difference of their "
             "effects, paired by seed [95 % bootstrap interval], sign-flip p and what it "
             "supports)", "", "| world | condition | measure | effect [95 % interval] | p | "
             "reading |", "|---|---|---|---|---|---|"]
    for e in baseline_effects(rows, baseline):
        iv = (f" [{e['effect_low']:+.3f}, {e['effect_high']:+.3f}]"
              if e["effect_low"] is not None and np.isfinite(e["effect_low"]) else "")
        p = f"{e['p']:.2g}" if e["p"] is not None and np.isfinite(e["p"]) else "–"
        lines.append(f"| {e['world']} | {e['condition']} | {e['measure']} | "
                     f"{e['effect']:+.3f}{iv} | {p} | {e['reading'] or '–'} |")
    return lines + [""]


AGAINST = (("trot gait (share of runs)", "gait"), ("trot rhythm (share of runs)", "rhythm"),
           ("speed (m/s)", "speed"), ("falls (share of runs)", "falls"),
           ("weights above 0.9 w_max (share)", "share_above_0.9_w_max"),
           ("weights below 0.9 w_min (share)", "share_below_0.9_w_min"),
           ("mixed limb pairs (of 12)", "mixed_limb_pairs"))
"""The measures of ``against``, fixed before the studies they read had finished: four from the
evaluation runs of each seed's final table (each averaged over the seed's repeats first), three
from the table itself (:func:`astrocpg.studies.analysis.gait.weight_structure`)."""


def _axis_value(run: str, axis: str) -> float:
    """The value of the swept parameter ``axis`` in a run id (``...AXIS=VALUE-UNIT...``)."""
    import re

    m = re.search(rf"(?:^|__|_){re.escape(axis)}=([0-9.]+)", run)
    if not m:
        sys.exit(f"analyse.py: run {run!r} names no {axis}=VALUE")
    return float(m.group(1))


def _evaluation_rows(path: str, world: str) -> list[dict[str, str]]:
    """The rows of ``astrocpg evaluate``'s evaluation.csv in ``world``; refused when there are
    none or they predate the gait read from the feet."""
    with open(path, newline="") as f:
        rows = [r for r in csv.DictReader(f) if r["world"] == world]
    if not rows:
        sys.exit(f"analyse.py: no runs in world {world!r} in {path}")
    if "rhythm" not in rows[0]:
        sys.exit(f"analyse.py: {path} predates the gait read from the feet (no rhythm column)")
    return rows


def _evaluated(path: str, world: str) -> dict[str, dict[int, dict[str, float]]]:
    """run id -> seed -> the evaluation measures of AGAINST, each seed's repeats averaged."""
    rows = _evaluation_rows(path, world)
    runs: dict[str, dict[int, list[list[float]]]] = {}
    for r in rows:
        runs.setdefault(r["source"], {}).setdefault(int(r["seed"]), []).append(
            [float(r["gait"] == "trot"), float(r["rhythm"] == "trot"),
             float(r["mean_speed_m_per_s"]), float(r["fell"])])
    return {run: {seed: dict(zip(("gait", "rhythm", "speed", "falls"), np.mean(v, axis=0)))
                  for seed, v in seeds.items()} for run, seeds in runs.items()}


def _check_session(evaluation: str, session: int | None) -> None:
    """An evaluation of other tables than those compared is refused: the manifest beside
    ``evaluation`` (``astrocpg evaluate``'s) says which tables it ran."""
    import json

    manifest = Path(evaluation).with_name("manifest.json")
    if not manifest.is_file():
        return
    ran = json.loads(manifest.read_text()).get("settings", {}).get("tables", "final")
    want = "final" if session is None else f"after session {session}"
    if ran != want:
        sys.exit(f"analyse.py: {evaluation} ran the tables {ran}, not {want} "
                 f"({'--session ' + str(session) if session else 'no --session'})")


def _structures(tables: Path, run: str, session: int | None = None) -> dict[int, dict[str, float]]:
    """seed -> weight structure of its final table (``final_tables.py``'s ``RUN.npz``), or with
    ``session`` of its table after that session (kept, or final where every seed did exactly
    that many), with the bounds of the model the run trained with."""
    import json

    from astrocpg.models import DEFAULT_MODELS
    from astrocpg.studies.analysis.gait import weight_structure

    npz, meta = tables / f"{run}.npz", tables / f"{run}.json"
    if not npz.is_file():
        sys.exit(f"analyse.py: no final tables {npz} (python docs/ablation/final_tables.py)")
    overrides = json.loads(meta.read_text())["settings"].get("overrides", {}) \
        if meta.is_file() else {}
    if {"w_max", "w_min"} & set(overrides or {}):
        sys.exit(f"analyse.py: {run} trained with its own weight bounds; not supported here")
    w_max, w_min = (float(DEFAULT_MODELS.value(k)) * 1e3 for k in ("w_max", "w_min"))  # mV
    with np.load(npz, allow_pickle=False) as f:
        done = f["sessions_done"] if "sessions_done" in f.files else np.array([-1])
        if session is None or (done.min() == done.max() == session):
            key = "final_weights_mV"
        elif f"weights_mV_after_{session}" in f.files:
            key = f"weights_mV_after_{session}"
        else:
            sys.exit(f"analyse.py: {npz} keeps no tables after session {session}")
        return {int(seed): weight_structure(table, w_max, w_min)
                for seed, table in zip(f["seeds"], f[key])}


MARGIN_KEYS = {"gait": "trot_gait_share", "rhythm": "trot_rhythm_share"}
"""AGAINST's keys as a study file's [margins] names them (the others are the same)."""


def read_study_margins(path: str) -> dict[str, float]:
    """The ``[margins]`` of a study file (astrocpg.studies.analysis.margins), checked."""
    import tomllib

    from astrocpg.studies.analysis.margins import read_margins

    with open(path, "rb") as f:
        return read_margins(tomllib.load(f).get("margins"), f"study {Path(path).name}")


def against(reference: str, reference_tables: Path, evaluation: str, tables: Path,
            world: str, session: int | None = None, describe: bool = False,
            margins: dict[str, float] | None = None) -> str:
    """Each run of a study against a reference run, seed by seed, on the measures of AGAINST:
    B − A per seed with its 95 % bootstrap interval over seeds, the two-sided sign-flip
    permutation p, and that p Holm-adjusted over every run and measure of the table. The pairing
    is real: a seed has the same initial weights and noise draws in every study of this page.
    ``session``: the weight structure of both sides' tables after that session (their
    evaluations must be of the same session); ``describe``: the intervals only, no test.
    ``margins`` (a study file's ``[margins]``, declared before the data): the equivalence test
    (TOST) of each measure that has one; every other test says at best "not shown to differ"
    with the smallest difference it could detect (reading_words), never "the same"."""
    from astrocpg.studies.analysis.compare import compare, holm, p_text, reading_words
    margins = margins or {}

    ref_eval, _, ref_run = reference.rpartition(":")
    for ev in (ref_eval, evaluation):
        _check_session(ev, session)
    ref_runs = _evaluated(ref_eval, world)
    if ref_run not in ref_runs:
        sys.exit(f"analyse.py: no run {ref_run!r} in {ref_eval} (runs: {', '.join(ref_runs)})")
    ref_structure = _structures(reference_tables, ref_run, session)
    ref = {s: {**v, **ref_structure[s]} for s, v in ref_runs[ref_run].items()
           if s in ref_structure}
    runs = _evaluated(evaluation, world)
    results = []
    for run, seeds_eval in runs.items():
        if run == ref_run and Path(evaluation).resolve() == Path(ref_eval).resolve():
            continue  # the reference against itself: not a test
        structure = _structures(tables, run, session)
        seeds = sorted(set(seeds_eval) & set(ref) & set(structure))
        for label, key in AGAINST:
            a = [float(ref[s][key]) for s in seeds]
            b = [float({**seeds_eval[s], **structure[s]}[key]) for s in seeds]
            # compare(b, a): its mean_a is B's, mean_b A's and difference B − A
            results.append((run, label, seeds, compare(
                b, a, paired=True, margin=margins.get(MARGIN_KEYS.get(key, key)))))
    adjusted = holm([t["perm_p"] for *_, t in results])
    when = "final tables" if session is None else f"tables after session {session}"
    lines = [f"A = {ref_run} ({ref_eval}, tables {reference_tables}); B = each run of "
             f"{evaluation} (tables {tables}); {when}; world {world!r}. Each seed's repeats "
             "averaged first. B − A per seed: mean [95 % bootstrap interval over seeds]; "
             + ("described only, no test." if describe else
                "p: two-sided sign-flip permutation test of the per-seed differences; Holm: "
                f"adjusted over all {len(results)} tests of this table. Reading: a difference "
                "not shown is no evidence of sameness (nor is a large adjusted p): where no "
                "equivalence margin was declared, it gives the smallest difference the test "
                "could detect (80 % power, alpha 0.05, from the seeds' spread); where one was "
                "([margins] of the study file, --margins), its equivalence test (TOST)."), ""]
    current = None
    for (run, label, seeds, t), adj in zip(results, adjusted):
        if run != current:
            current = run
            lines += [""] * bool(lines[-1]) + [f"**{run}** ({len(seeds)} seeds: "
                      f"{seeds[0]}–{seeds[-1]})", ""] + (
                      ["| measure | A: mean | B: mean | B − A per seed [95 % interval] |",
                       "|---|---|---|---|"] if describe else
                      ["| measure | A: mean | B: mean | B − A per seed [95 % interval] | p "
                       "| Holm p | reading |", "|---|---|---|---|---|---|---|"])
        if t["difference_low"] is not None:
            d = f"{t['difference']:+.3f} [{t['difference_low']:+.3f}, {t['difference_high']:+.3f}]"
            p = p_text(t["perm_p"], t["perm_p_min"], bool(t["perm_bound"]))
        else:
            d, p = f"{t['difference']:+.3f} ({t['note']})", "–"
        lines.append(f"| {label} | {t['mean_b']:.3f} | {t['mean_a']:.3f} | {d} |" + (
            "" if describe else f" {p} | {p_text(adj) if adj is not None else '–'} | "
                                f"{reading_words(t)} |"))
    return "\n".join(lines) + "\n"


def response(evaluation: str, tables: Path, axis: str, unit: str, points: list[str],
             world: str, out: Path | None, session: int | None = None,
             seeds: str | None = None) -> str:
    """The measures of AGAINST at each value of a swept parameter: every run of the study
    (its value read from the run id, ``AXIS=VALUE-UNIT``) and each ``--point
    VALUE=EVALUATION.csv:RUN_ID@TABLES`` (a run of another evaluation standing for that value).
    Per value: the mean over seeds (each seed's repeats averaged first) with its 95 % bootstrap
    interval over seeds. Described only: no test (``against`` tests each run against the
    reference). With ``out``, one panel per measure. ``session``: the weight structure of the
    tables after that session, as their evaluations were. ``seeds``: ``FIRST-LAST``, only these
    seeds at every value (a reference of 20 seeds beside a study of 12)."""

    at: list[tuple[float, str, str, Path]] = []  # value, evaluation, run, tables
    for run in _evaluated(evaluation, world):
        at.append((_axis_value(run, axis), evaluation, run, tables))
    for spec in points:
        value, _, rest = spec.partition("=")
        source, _, table_dir = rest.rpartition("@")
        ev, _, run = source.rpartition(":")
        if not (value and ev and run and table_dir):
            sys.exit(f"analyse.py: --point {spec!r} is not VALUE=EVALUATION.csv:RUN_ID@TABLES")
        at.append((float(value), ev, run, Path(table_dir)))
    at.sort()
    rng = np.random.default_rng(1)
    table: list[tuple[float, int, list[tuple[float, float, float]]]] = []
    for value, ev, run, tdir in at:
        _check_session(ev, session)
        evaluated = _evaluated(ev, world)
        if run not in evaluated:
            sys.exit(f"analyse.py: no run {run!r} in {ev}")
        structure = _structures(tdir, run, session)
        kept = sorted(set(evaluated[run]) & set(structure))
        if seeds:
            first, _, last = seeds.partition("-")
            kept = [s for s in kept if int(first) <= s <= int(last or first)]
        cells = [_bootstrap_mean(np.array([float({**evaluated[run][s], **structure[s]}[key])
                                           for s in kept]), rng) for _, key in AGAINST]
        table.append((value, len(kept), cells))
    when = "final tables" if session is None else f"tables after session {session}"
    lines = [f"Each measure against {axis} ({unit}), {when}, world {world!r}: mean over seeds [95 % "
             "bootstrap interval over seeds]; each seed's repeats averaged first. Described "
             "only, no test.", "",
             f"| measure | " + " | ".join(f"{v:g} {unit} (n={n})" for v, n, _ in table) + " |",
             "|---|" + "---|" * len(table)]
    for k, (label, _) in enumerate(AGAINST):
        lines.append(f"| {label} | " + " | ".join(
            f"{c[k][0]:.3g} [{c[k][1]:.3g}, {c[k][2]:.3g}]" for _, _, c in table) + " |")
    if out is not None:
        import matplotlib
        matplotlib.use("Agg")
        import matplotlib.pyplot as plt

        fig, axes = plt.subplots(1, len(AGAINST), figsize=(3.0 * len(AGAINST), 3.0))
        x = np.arange(len(table))
        for k, (ax, (label, _)) in enumerate(zip(axes, AGAINST)):
            mean = np.array([c[k][0] for _, _, c in table])
            err = np.array([[c[k][0] - c[k][1], c[k][2] - c[k][0]] for _, _, c in table]).T
            ax.errorbar(x, mean, yerr=err, fmt="o-", color="tab:red", capsize=3)
            ax.set_xticks(x, [f"{v:g}" for v, _, _ in table])
            ax.set_xlabel(f"{axis} ({unit})")
            ax.set_title(label, fontsize=9)
        fig.tight_layout()
        fig.savefig(out, dpi=120)
        plt.close(fig)
        print(f"wrote {out}", file=sys.stderr)  # stdout is the table alone
    return "\n".join(lines) + "\n"


def controllers(path: str, world: str, condition: str, source: str | None = None) -> str:
    """One condition's evaluation runs in one world, controller by controller: how many
    controllers show a trot gait in at least one run and in most of theirs, and why the runs
    without a gait have none (``gait_reason``), over all runs and over the upright ones.
    ``source``: only the runs of this run id (a study's run: one control, one dose), where a
    condition holds several."""
    from collections import Counter

    from astrocpg.studies.analysis.replication import tables_differ

    with open(path, newline="") as f:
        rows = [r for r in csv.DictReader(f)
                if r["world"] == world and r["condition"] == condition
                and (source is None or r["source"] == source)]
    if not rows:
        what = f"{condition!r}" + (f" from {source!r}" if source else "")
        sys.exit(f"analyse.py: no runs of {what} in world {world!r} in {path}")
    if source:
        condition = source
    per: dict[str, list[bool]] = {}
    for r in rows:
        per.setdefault(f'{r["source"]}:{r["seed"]}', []).append(r["gait"] == "trot")
    shares = sorted(sum(v) / len(v) for v in per.values())
    differ = tables_differ([["trot" if x else "none" for x in v] for v in per.values()],
                           "trot")["p"]
    upright = [r for r in rows if r["fell"] == "0"]
    reasons = Counter((r["gait_reason"] or r["gait"]).split(" at ")[0] for r in rows)
    return (f"{condition}, {world}: {len(rows)} runs of {len(per)} controllers; trot gait in "
            f"{sum(r['gait'] == 'trot' for r in rows)} runs ({sum(r['gait'] == 'trot' for r in upright)}"
            f" of the {len(upright)} upright); per controller the share of its runs is "
            f"{shares[0]:.1f} to {shares[-1]:.1f}: {sum(x > 0 for x in shares)} controllers trot "
            f"in at least one run, {sum(x > 0.5 for x in shares)} in most (do the controllers "
            f"differ in their trot share? permutation p = "
            f"{'–' if not np.isfinite(differ) else f'{differ:.2g}'}; a large p: the spread is "
            f"what one common share gives); gait or reason for "
            f"none: " + ", ".join(f"{k} {v}" for k, v in reasons.most_common()) + "\n")


def _named() -> tuple[str, ...]:
    """The patterns both classifiers name, in the code's order."""
    from astrocpg.studies.analysis.gait import NAMED

    return tuple(NAMED)


def _majority(labels: list[str]) -> str:
    """The label named in more than half of a seed's runs, else ``none``."""
    from collections import Counter

    label, n = Counter(labels).most_common(1)[0]
    return label if label in _named() and n > len(labels) / 2 else "none"


def _cell_words(majorities: list[str], runs: list[str]) -> str:
    """``trot 2/3 (runs: trot 9/15)``: the seeds with each named label (or ``none 3/3``), then
    the runs with each named label where any run has one."""
    from collections import Counter

    n, seeds, per_run = len(majorities), Counter(majorities), Counter(runs)
    head = ", ".join(f"**{g} {seeds[g]}/{n}**" if seeds[g] >= 2 else f"{g} {seeds[g]}/{n}"
                     for g in _named() if seeds[g]) or f"none {n}/{n}"
    tail = ", ".join(f"{g} {per_run[g]}/{len(runs)}" for g in _named() if per_run[g])
    return head + (f" (runs: {tail})" if tail else "")


def gait_map(evaluation: str, tables: Path, axes: list[str], unit: str, world: str,
             out: Path | None) -> str:
    """A study swept over two axes, read by the rules of docs/beyond section 5: per point, the
    seeds whose runs name a gait (and a rhythm) in most of their runs, the runs with each, the
    speed, the falls and the final tables' structure; per value of the first axis, the seeds
    with a trot gait and with any other gait, with Wilson 95 % intervals. Described only."""
    from collections import defaultdict

    from astrocpg.studies.analysis.replication import tables_differ
    from astrocpg.studies.analysis.share import wilson_interval

    rows = _evaluation_rows(evaluation, world)
    _check_session(evaluation, None)
    ya, xa = axes
    by_run: dict[str, dict[int, list[dict[str, str]]]] = defaultdict(lambda: defaultdict(list))
    for r in rows:
        by_run[r["source"]][int(r["seed"])].append(r)
    point: dict[tuple[float, float], str] = {}
    for run in by_run:
        point[(_axis_value(run, ya), _axis_value(run, xa))] = run
    ys = sorted({y for y, _ in point})
    xs = sorted({x for _, x in point})
    cells: dict[tuple[float, float], dict[str, object]] = {}
    for key, run in point.items():
        structure = _structures(tables, run)
        seeds = sorted(by_run[run])
        gaits = [[r["gait"] for r in by_run[run][s]] for s in seeds]
        rhythms = [[r["rhythm"] for r in by_run[run][s]] for s in seeds]
        per_seed = {name: [float(np.mean([float(r[col]) for r in by_run[run][s]])) for s in seeds]
                    for name, col in (("speed", "mean_speed_m_per_s"), ("falls", "fell"))}
        for name in ("mixed_limb_pairs", "share_above_0.9_w_max", "share_below_0.9_w_min"):
            per_seed[name] = [float(structure[s][name]) for s in seeds]
        cells[key] = {"run": run, "seeds": seeds, "gait": [_majority(g) for g in gaits],
                      "rhythm": [_majority(g) for g in rhythms],
                      "gait_runs": [x for g in gaits for x in g],
                      "rhythm_runs": [x for g in rhythms for x in g], **per_seed}
    repeats = sorted({len(v) for run in by_run.values() for v in run.values()})
    head = (f"| {ya} ({unit}) \\ {xa} | " + " | ".join(f"{x:g}" for x in xs) + " |",
            "|---|" + "---|" * len(xs))
    lines = [f"Each seed's final table, world {world!r}, {'/'.join(map(str, repeats))} runs per "
             "seed, learning off. A seed's gait (rhythm) is the one named in more than half "
             "of its runs; bold: found (at least 2 seeds of the point). Described only, no "
             "test.", "", "**Gait** (the feet, while the robot stands): seeds with each gait, "
             "then the runs with each", "", *head]
    for measure in ("gait", "rhythm"):
        if measure == "rhythm":
            lines += ["", "**Rhythm** (the CPG's phase pattern): seeds with each rhythm, then "
                      "the runs with each", "", *head]
        for y in ys:
            lines.append(f"| {y:g} | " + " | ".join(
                _cell_words(cells[(y, x)][measure], cells[(y, x)][f"{measure}_runs"])
                if (y, x) in cells else "–" for x in xs) + " |")
    lines += ["", "**Per point**: mean over seeds (lowest – highest seed); each seed's runs "
              "averaged first; the last column: do the seeds differ from each other in their "
              "share of trot gait runs (permutation test of the chi-square statistic, the "
              "runs' labels shuffled between seeds; a large p: the spread over seeds is what "
              "one common share gives, so the runs do not show which seeds trot)", "",
              f"| {ya} ({unit}) | {xa} | seeds | speed (m/s) | falls "
              "(share of runs) | mixed limb pairs (of 12) | weights above 0.9 w_max | "
              "weights below 0.9 w_min | seeds differ in trot gait: p |",
              "|---|---|---|---|---|---|---|---|---|"]
    for (y, x), c in sorted(cells.items()):
        vals = " | ".join(f"{np.mean(c[k]):.2f} ({min(c[k]):.2f} – {max(c[k]):.2f})"
                          for k in ("speed", "falls", "mixed_limb_pairs",
                                    "share_above_0.9_w_max", "share_below_0.9_w_min"))
        differ = tables_differ([[r["gait"] for r in by_run[c["run"]][s]] for s in c["seeds"]],
                               "trot")["p"]
        lines.append(f"| {y:g} | {x:g} | {len(c['seeds'])} | {vals} | "
                     f"{'–' if not np.isfinite(differ) else f'{differ:.2g}'} |")
    lines += ["", f"**Per {ya}** (all {xa} values pooled): seeds with a gait, Wilson 95 % "
              "interval over seeds", "", f"| {ya} ({unit}) | seeds | trot gait | other gait "
              "(pace, bound, walk) | trot rhythm | other rhythm |", "|---|---|---|---|---|---|"]

    def share(k: int, n: int, digits: int = 0) -> str:
        lo, hi = wilson_interval(k, n)
        return f"{k} ({k / n:.{digits}%}, {lo:.{digits}%}–{hi:.{digits}%})"

    for y in ys:
        row = [c for (yy, _), c in cells.items() if yy == y]
        n = sum(len(c["seeds"]) for c in row)
        counts = [sum(sum(m == g for m in c[measure]) for c in row) if g == "trot" else
                  sum(sum(m in _named() and m != "trot" for m in c[measure]) for c in row)
                  for measure in ("gait", "rhythm") for g in ("trot", "other")]
        lines.append(f"| {y:g} | {n} | " + " | ".join(share(k, n) for k in counts) + " |")
    runs = {m: [x for c in cells.values() for x in c[f"{m}_runs"]] for m in ("gait", "rhythm")}
    lines += ["", "**All points**: runs with each named pattern, Wilson 95 % interval over runs "
              "(runs of one seed are not independent: a description, not an estimate)", "",
              "| measure | runs | " + " | ".join(_named()) + " |",
              "|---|---|" + "---|" * len(_named())]
    for m, name in (("gait", "gait (feet)"), ("rhythm", "rhythm (thigh bursts)")):
        lines.append(f"| {name} | {len(runs[m])} | " + " | ".join(
            share(sum(x == g for x in runs[m]), len(runs[m]), 1) for g in _named()) + " |")
    if out is not None:
        from astrocpg.studies.figures.gait_map import gait_map_figures
        from astrocpg.studies.figures.save import save_figure

        grid = [{**r, "grid_" + ya: f"{y:g}", "grid_" + xa: f"{x:g}",
                 "mean_speed_m_per_s": float(r["mean_speed_m_per_s"]), "fell": float(r["fell"])}
                for (y, x), run in point.items() for seed in by_run[run].values() for r in seed]
        figure = gait_map_figures(grid, [(ya, [f"{y:g}" for y in ys]), (xa, [f"{x:g}" for x in xs])],
                                  {ya: f"{ya} ({unit})", xa: xa},
                                  (("gait", "gait (feet)"),
                                   ("rhythm", "rhythm (thigh bursts)")))["gait_map.png"]
        save_figure(figure, out)
        print(f"wrote {out}", file=sys.stderr)  # stdout is the table alone
    return "\n".join(lines) + "\n"


PANELS = (("mean_reward", "mean reward"), ("final_x_m", "final x (m)"),
          ("length_s", "session length (s)"))


def _draw(columns: list[tuple[str, list[tuple[list[dict[str, str]], str, str]]]], out: Path,
          smooth: int, sessions: int | None, title: str) -> None:
    """Columns of (title, [(rows, label, colour)]): Fig. 3c's three panels per column."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(len(PANELS), len(columns), figsize=(5.2 * len(columns), 8.5),
                             sharex=True, sharey="row", squeeze=False)
    for col, (column_title, series) in enumerate(columns):
        for rows, label, colour in series:
            seeds = sorted({r["seed"] for r in rows}, key=int)
            for row, (column, ylabel) in enumerate(PANELS):
                table: dict[str, dict[int, float]] = {}
                for r in rows:
                    if sessions is None or int(r["session"]) <= sessions:
                        table.setdefault(r["seed"], {})[int(r["session"])] = float(r[column])
                S = min(len(v) for v in table.values())
                values = np.array([[table[s][k] for k in range(1, S + 1)] for s in seeds])
                kernel = np.ones(smooth) / smooth
                values = np.array([np.convolve(v, kernel, mode="valid") for v in values])
                x = np.arange(smooth, S + 1)
                m, sd = values.mean(axis=0), values.std(axis=0)
                ax = axes[row, col]
                ax.plot(x, m, color=colour, label=f"{label} ({len(seeds)} seeds)")
                ax.fill_between(x, m - sd, m + sd, color=colour, alpha=0.2, lw=0)
                ax.set_ylabel(ylabel)
        axes[0, col].set_title(column_title)
        axes[-1, col].set_xlabel("session")
        axes[0, col].legend(loc="lower right", fontsize=8)
    fig.suptitle(f"{title}: mean ± std across seeds, trailing mean of {smooth} sessions",
                 fontsize=10)
    fig.tight_layout()
    out.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(out, dpi=110)


def fig3c(specs: list[str], titles: list[str], out: Path, smooth: int) -> None:
    """One column per study: its astrocyte and no-astrocyte conditions."""
    columns = []
    for spec, title in zip(specs, titles):
        rows, _ = read_rows(spec)
        columns.append((title, [
            ([r for r in rows if r["condition"] == c], c.replace("_", " "), colour)
            for c, colour in (("astrocytes", "tab:red"), ("no_astrocytes", "tab:blue"))
            if any(r["condition"] == c for r in rows)]))
    _draw(columns, out, smooth, None, "Fig. 3c on two grounds")


def overlay(columns_spec: list[list[str]], out: Path, smooth: int, sessions: int | None) -> None:
    """Columns of TITLE SPEC LABEL [SPEC LABEL ...]: the conditions named, one colour each."""
    colours = ("tab:red", "tab:green", "tab:blue", "tab:orange")
    columns = []
    for spec in columns_spec:
        title, pairs = spec[0], spec[1:]
        if not pairs or len(pairs) % 2:
            sys.exit("analyse.py: --column TITLE SPEC LABEL [SPEC LABEL ...]")
        columns.append((title, [(read_rows(pairs[k])[0], pairs[k + 1], colours[k // 2])
                                for k in range(0, len(pairs), 2)]))
    _draw(columns, out, smooth, sessions, "Each seed with and without")


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    sub = ap.add_subparsers(dest="what", required=True)
    f = sub.add_parser("fig3c")
    f.add_argument("results", nargs="+")
    f.add_argument("--titles", nargs="+", required=True)
    f.add_argument("--out", type=Path, required=True)
    f.add_argument("--smooth", type=int, default=10)
    p = sub.add_parser("paired")
    p.add_argument("a")
    p.add_argument("b")
    p.add_argument("--sessions", type=int)
    p.add_argument("--last", type=int, default=20)
    o = sub.add_parser("overlay")
    o.add_argument("--column", nargs="+", action="append", required=True)
    o.add_argument("--out", type=Path, required=True)
    o.add_argument("--smooth", type=int, default=10)
    o.add_argument("--sessions", type=int)
    t = sub.add_parser("table")
    t.add_argument("results", nargs="+")
    t.add_argument("--sessions", type=int)
    t.add_argument("--last", type=int, default=20)
    t.add_argument("--seeds", help="FIRST-LAST: only these seeds")
    r = sub.add_parser("rows")
    r.add_argument("study", type=Path)
    r.add_argument("--out", type=Path, required=True)
    w = sub.add_parser("worlds")
    w.add_argument("evaluation")
    w.add_argument("--baseline", metavar="WORLD",
                   help="also each world's effect relative to WORLD (e.g. flat), per condition "
                        "and between two conditions, paired by seed")
    v = sub.add_parser("versus")
    v.add_argument("ref")
    v.add_argument("results")
    v.add_argument("--sessions", type=int)
    v.add_argument("--last", type=int, default=20)
    v.add_argument("--seeds", help="FIRST-LAST: only these seeds")
    c = sub.add_parser("columns")
    c.add_argument("a")
    c.add_argument("b")
    c.add_argument("--column", required=True)
    k = sub.add_parser("controllers")
    k.add_argument("evaluation")
    k.add_argument("--world", default="flat")
    k.add_argument("--condition", default="astrocytes")
    k.add_argument("--source", help="RUN_ID: only this run's controllers (the evaluation's "
                                    "source column)")
    g = sub.add_parser("against")
    g.add_argument("reference", help="EVALUATION.csv:RUN_ID, the reference run")
    g.add_argument("reference_tables", type=Path, help="its final_tables.py folder")
    g.add_argument("evaluation", help="the study's evaluation.csv")
    g.add_argument("tables", type=Path, help="the study's final_tables.py folder")
    g.add_argument("--world", default="flat")
    g.add_argument("--session", type=int, help="the tables after this session (both sides' "
                                               "evaluations must be of it: evaluate --session)")
    g.add_argument("--describe", action="store_true", help="intervals only, no test")
    g.add_argument("--margins", metavar="STUDY.toml",
                   help="a study file whose [margins] declare equivalence margins: the "
                        "equivalence test (TOST) of each measure that has one")
    q = sub.add_parser("response")
    q.add_argument("evaluation", help="the study's evaluation.csv")
    q.add_argument("tables", type=Path, help="the study's final_tables.py folder")
    q.add_argument("--axis", required=True, help="the swept parameter, as in the run ids")
    q.add_argument("--unit", default="", help="its unit, for the labels")
    q.add_argument("--point", action="append", default=[],
                   help="VALUE=EVALUATION.csv:RUN_ID@TABLES: another run at that value")
    q.add_argument("--world", default="flat")
    q.add_argument("--out", type=Path, help="a figure, one panel per measure")
    q.add_argument("--session", type=int, help="the tables after this session")
    q.add_argument("--seeds", help="FIRST-LAST: only these seeds at every value")
    m = sub.add_parser("map")
    m.add_argument("evaluation", help="the study's evaluation.csv")
    m.add_argument("tables", type=Path, help="the study's final_tables.py folder")
    m.add_argument("--axes", nargs=2, required=True, metavar=("ROWS", "COLUMNS"),
                   help="the two swept parameters, as in the run ids")
    m.add_argument("--unit", default="", help="the first axis's unit, for the labels")
    m.add_argument("--world", default="flat")
    m.add_argument("--out", type=Path, help="the map: most common gait and rhythm per point")
    args = ap.parse_args(argv)
    if args.what == "fig3c":
        if len(args.titles) != len(args.results):
            ap.error("one title per results file")
        fig3c(args.results, args.titles, args.out, args.smooth)
        print(f"wrote {args.out}")
    elif args.what == "paired":
        sys.stdout.write(paired(args.a, args.b, args.sessions, args.last))
    elif args.what == "overlay":
        overlay(args.column, args.out, args.smooth, args.sessions)
        print(f"wrote {args.out}")
    elif args.what == "table":
        sys.stdout.write(table(args.results, args.sessions, args.last, args.seeds))
    elif args.what == "rows":  # a study's rows as they stand, as one csv.gz
        rows = _study_rows(args.study)
        with gzip.open(args.out, "wt", newline="") as f:
            w = csv.DictWriter(f, fieldnames=list(rows[0]))
            w.writeheader()
            w.writerows(rows)
        print(f"wrote {args.out} ({len(rows)} rows)")
    elif args.what == "worlds":
        sys.stdout.write(worlds(args.evaluation, args.baseline))
    elif args.what == "versus":
        sys.stdout.write(versus(args.ref, args.results, args.sessions, args.last, args.seeds))
    elif args.what == "columns":
        sys.stdout.write(columns(args.a, args.b, args.column))
    elif args.what == "controllers":
        sys.stdout.write(controllers(args.evaluation, args.world, args.condition, args.source))
    elif args.what == "response":
        sys.stdout.write(response(args.evaluation, args.tables, args.axis, args.unit, args.point,
                                  args.world, args.out, args.session, args.seeds))
    elif args.what == "map":
        sys.stdout.write(gait_map(args.evaluation, args.tables, args.axes, args.unit,
                                  args.world, args.out))
    elif args.what == "against":
        sys.stdout.write(against(args.reference, args.reference_tables, args.evaluation,
                                 args.tables, args.world, args.session, args.describe,
                                 read_study_margins(args.margins) if args.margins else None))
    return 0


if __name__ == "__main__":
    sys.exit(main())
