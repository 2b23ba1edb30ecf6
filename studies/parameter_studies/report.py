"""``astrocpg report DIR``: the paper's Fig. 3c for any study, its final figures, the final
figures against the swept values and the tests between conditions.

For every group of runs that differ only by seed (a condition, at one sweep point), per session:
mean +- std across seeds of the session's mean reward, final x and length (``fig3c.png``). The
final figures per group (``final_figures.csv`` and ``report.md``): over the last ``last`` (50;
fewer where a seed trained fewer) sessions of each seed, mean reward, forward speed, final x,
session length and the share of sessions that reached L_max, then mean +- std across seeds; and
from the trained weights the limb pairs with two inhibitory and two excitatory synapses and the
share of weights above 0.9 w_max and below 0.9 w_min and of excitatory weights (the paper's contrast

A sweep: each final figure against the swept value, one line per condition
(``sweep_<axis>.png``); over two axes swept as a grid, one heatmap per final figure
(``heatmap_<figure>.png``). An axis of model files is categorical, its ticks the files' stems.
Two or more conditions: every pair compared at every sweep point, one value per seed: the
difference with its 95% bootstrap interval (seeded), a permutation test (exact for a handful of
seeds), Mann-Whitney U (exact without ties), both Holm-adjusted over the final figures of one
pair at one point, Hedges' g, rank-biserial; paired by seed only where the study file declares
``paired = true`` (``condition_tests.csv`` and ``report.md``).

Runs still in progress are included with the sessions they have and marked as such. A group
(condition and point) with a run that diverged is no result: it is listed as diverged, with
its error, and is in none of the figures, the curves or the tests. The report reads the runs
the study file now names (``study.json``'s ``current``), not those of an earlier version of
the file left in the folder.
"""

from __future__ import annotations

import itertools
import os
import zipfile
import zlib
from pathlib import Path
from typing import Any

import numpy as np

from ...errors import InputError, setting
from ...support.reading import check_regular, read_json
from ..analysis.compare import N_BOOT, N_PERM, SEED, p_text, reading_words
from ..analysis.final_figures import (CURVES, MEASURES, WEIGHT_MEASURES, Measure, across_seeds,
                                      condition_tests, seed_finals, session_curve)
from ..analysis.gait import weight_structure
from ...models.compose import model_set
from ..settings.populations import population_models
from ..outputs.folder import OutputFolder, verify
from ..outputs.study_index import current_specs
from ..figures.save import save_figure
from ..figures.study_report import fig3c, sweep_figures
from ..outputs.writing import atomic_write, write_manifest
from .execute import read_status
from .layout import GAITS, RUNS, STUDY_INDEX

def _load(folder: Path) -> tuple[dict[str, Any], list[dict[str, Any]]]:
    import pandas as pd

    try:
        index = read_json(folder / STUDY_INDEX)
    except InputError:  # not a regular file, nested too deeply: refused, naming it
        raise
    except (OSError, ValueError):
        raise InputError(f"not a study folder (no readable {STUDY_INDEX})",
                         culprit=f"report {folder}") \
            from None
    runs = []
    for run_id, spec in current_specs(index).items():
        rdir = folder / RUNS / run_id
        status = read_status(rdir)
        state = status.get("state", "not run")
        if state == "diverged":  # not a result: nothing of it is read
            runs.append({"spec": spec, "state": state, "sessions": None, "folder": rdir,
                         "weights": None, "gaits": None, "error": status.get("error", "")})
            continue
        if state == "finished":  # what it read is what its manifest lists
            verify(rdir, culprit=f"report {rdir}", strict=False, only=READ)
        df = weights = None
        if (rdir / "sessions.csv").exists():
            try:
                for name in ("sessions.csv", "weights.npz", GAITS):  # never wait on a FIFO
                    check_regular(rdir / name, f"report {rdir}")
                df = pd.read_csv(rdir / "sessions.csv")
                if (rdir / "weights.npz").exists():
                    with np.load(rdir / "weights.npz", allow_pickle=False) as z:
                        weights = np.asarray(z["final_weights_mV"], dtype=float) * 1e-3
            except (OSError, ValueError, KeyError, EOFError, zipfile.BadZipFile,
                    zlib.error) as e:
                if isinstance(e, InputError):
                    raise
                raise InputError(f"cannot read sessions.csv or weights.npz ({type(e).__name__}"
                                 f"): corrupt or truncated", culprit=f"report {rdir}") from None
        gaits = None
        if state == "finished" and (rdir / GAITS).exists():  # runs trained before: none
            try:
                gaits = pd.read_csv(rdir / GAITS)
            except (OSError, ValueError) as e:
                raise InputError(f"cannot read {GAITS} ({type(e).__name__})",
                                 culprit=f"report {rdir}") from None
        runs.append({"spec": spec, "state": state, "sessions": df, "folder": rdir,
                     "weights": weights, "gaits": gaits})
    return index, runs


READ = ("sessions.csv", "weights.npz")  # what a report reads of each run



def _group_label(spec: dict[str, Any]) -> str:
    point = ", ".join(f"{k}={v}" for k, v in spec["point"].items())
    return spec["condition"] + (f" ({point})" if point else "")


def _model_values(spec: dict[str, Any]) -> tuple[float, float, float]:
    """w_max (volt), L_max (s) and w_min (volt) of a run, from its overrides."""
    models = model_set(list(spec["overrides"]), {}, models=spec.get("models") or None,
                       added=population_models(spec.get("populations")))
    return models.value("w_max"), models.value("L_max"), models.value("w_min")


REPORT = "report"

TESTS = "condition_tests.csv"


def report(folder: Path, *, last: int = 50, smooth: int = 1, out: Path | None = None,
           overwrite: bool = False) -> dict[str, Any]:
    """Write the report of the study in ``folder``: its figures and tables.

    Into ``out`` (default ``folder/report``, which each report replaces whole): ``fig3c.png``, ``final_figures.csv``, ``report.md``;
    for a sweep, the final figures against the swept values (``sweep_<axis>.png``, or one
    ``heatmap_<measure>.png`` per measure over two axes); for two or more conditions,
    ``condition_tests.csv``. Returns files, rows, text, figures ({file: Figure}), tests."""
    check_regular(Path(folder) / STUDY_INDEX)  # a FIFO is refused, never waited on
    if not (Path(folder) / STUDY_INDEX).is_file():
        raise InputError(f"not a study folder (no {STUDY_INDEX})", culprit=f"report {folder}")
    target = Path(out) if out is not None else Path(folder) / REPORT
    # never the study it reports on, nor inside it but at its report/ (overwrite: of a study)
    OutputFolder(target, overwrite=overwrite or out is None, inputs=[folder]).check()
    with OutputFolder(target, overwrite=overwrite or out is None, inputs=[folder]) as tmp:
        written = _report(Path(folder), tmp, last=last, smooth=smooth)
        write_manifest(tmp, command="report", seed=0, models_json={},
                       settings={"study": os.path.abspath(folder), "last": last,
                                 "smooth": smooth},
                       files=written["described"])
    written["files"] = [target / p.name for p in written["files"]]
    return written


def _report(folder: Path, dest: Path, *, last: int, smooth: int) -> dict[str, Any]:
    index, runs = _load(folder)
    name = index.get("name", folder.name)
    swept: list[str] = list(index.get("sweep", []))
    groups: dict[tuple[str, tuple[str, ...]], list[dict[str, Any]]] = {}
    for r in runs:
        key = (r["spec"]["condition"], tuple(str(r["spec"]["point"].get(k, "")) for k in swept))
        groups.setdefault(key, []).append(r)
    if not any(r["sessions"] is not None and len(r["sessions"]) for r in runs):
        gone = sorted({_group_label(r["spec"]) for r in runs if r["state"] == "diverged"})
        raise InputError("no run has finished a session yet" if not gone else
                         f"no result to report: every run with sessions diverged "
                         f"({'; '.join(gone)})", culprit=f"report {folder}")
    study_sessions = sorted({int(r["spec"]["n_sessions"]) for r in runs})

    curves: list[tuple[int, str, list[tuple[np.ndarray, np.ndarray]]]] = []  # Fig. 3c's lines
    rows: list[dict[str, Any]] = []
    empty: list[dict[str, Any]] = []  # groups without a finished session (a partial study)
    diverged: list[dict[str, Any]] = []  # groups with a diverged run: shown, never a result
    per_seed: list[dict[str, Any]] = []  # one row per (condition, point, seed)
    for k, ((condition, point), members) in enumerate(groups.items()):
        label = _group_label(members[0]["spec"])
        # one series per seed: table[seed, session-1]
        series: dict[int, Any] = {}
        structure: dict[int, dict[str, float]] = {}
        w_max = None
        states = [m["state"] for m in members]
        if "diverged" in states:  # no figures, curves or tests over it (nor its other seeds)
            first = next(m for m in members if m["state"] == "diverged")
            diverged.append({"group": label, "condition": condition,
                             **dict(zip(swept, point)), "seeds": 0,
                             "runs_finished": f"{states.count('finished')}/{len(states)}",
                             "state": "diverged",
                             "runs_diverged": f"{states.count('diverged')}/{len(states)}",
                             "error": " ".join(str(first.get("error", "")).split())})
            continue
        for m in members:
            df = m["sessions"]
            if df is None or not len(df):
                continue
            for trial, sdf in df.groupby("trial"):
                series[m["spec"]["seed"] + int(trial)] = sdf.sort_values("session")
            if m["weights"] is not None:
                w_max, _, w_min = _model_values(m["spec"])
                for trial, w in enumerate(m["weights"]):
                    structure[m["spec"]["seed"] + trial] = weight_structure(w, w_max, w_min)
        if not series:  # no run of the group has finished a session: said, not dropped
            empty.append({"group": label, "condition": condition, **dict(zip(swept, point)),
                          "seeds": 0,
                          "runs_finished": f"{states.count('finished')}/{len(states)}",
                          "states": ", ".join(sorted(set(states)))})
            continue
        n = max(int(s["session"].max()) for s in series.values())
        curves.append((k, f"{label} (n={len(series)})",
                       [session_curve(series, key, n, smooth) for key, _ in CURVES]))
        L_max = _model_values(members[0]["spec"])[1]
        seeds_here = seed_finals(condition, point, series, structure, last=last, L_max=L_max)
        per_seed.extend(seeds_here)
        rows.append({
            "group": label, "condition": condition, **dict(zip(swept, point)),
            "seeds": len(series),
            "runs_finished": f"{states.count('finished')}/{len(states)}",
            "sessions_min": min(len(s) for s in series.values()),
            "sessions_max": max(len(s) for s in series.values()),
            "last_sessions_min": min(o["last_sessions"] for o in seeds_here),
            "last_sessions_max": max(o["last_sessions"] for o in seeds_here),
            **across_seeds(seeds_here), **final_gaits(members),
        })
    figures: dict[str, Any] = {"fig3c.png": fig3c(name, curves, smooth)}
    shows = {"fig3c.png": "mean reward, final x (m) and session length (s) per session, "
                          "mean ± std across seeds, one line per group (paper Fig. 3c)"
                          + (f"; each seed's trailing mean over {smooth} sessions"
                             if smooth > 1 else "")}
    measures = [m for m in MEASURES + WEIGHT_MEASURES if any(m.key in o for o in per_seed)]
    if swept:
        sweep_figures(name, swept, runs, per_seed, measures, figures, shows)
    tests = condition_tests(swept, [c for c, _ in groups], per_seed, measures,
                             skip={(d["condition"], tuple(str(d.get(k, "")) for k in swept))
                                   for d in diverged},
                             paired=bool(index.get("paired", False)),
                             margins=dict(index.get("margins") or {}))

    files, described, text = _write_files(
        dest, name, figures, shows, rows, tests, per_seed, study_sessions, last=last,
        swept=swept, measures=measures, empty=empty, diverged=diverged)
    return {"files": files, "rows": rows, "text": text, "figures": figures, "tests": tests,
            "per_seed": per_seed, "described": described,
            "no_data": [e["group"] for e in empty],
            "diverged": [d["group"] for d in diverged]}


def _write_files(dest: Path, name: str, figures: dict[str, Any], shows: dict[str, str],
                 rows: list[dict[str, Any]], tests: list[dict[str, Any]],
                 per_seed: list[dict[str, Any]], study_sessions: list[int], *, last: int,
                 swept: list[str], measures: list[Measure], empty: list[dict[str, Any]],
                 diverged: list[dict[str, Any]]) -> tuple[list[Path], dict[str, str], str]:
    """The report's files in ``dest``: the figures, final_figures.csv, the tests between
    conditions and report.md. Returns the files, what each shows and report.md's text."""
    files = []
    for file, f in figures.items():
        save_figure(f, dest / file)
        files.append(dest / file)
    table_rows = rows + [{k: v for k, v in e.items() if k != "states"} for e in empty] \
        + diverged
    atomic_write(dest / "final_figures.csv", lambda f: f.write(_csv(table_rows).encode()))
    files.append(dest / "final_figures.csv")
    described = dict(shows)
    described["final_figures.csv"] = (f"per group (condition and sweep point): the final figures "
                                      f"of each seed (mean over its last sessions, "
                                      f"{setting('last')} {last}), mean and std across seeds"
                                      + ("; a group with no data yet has seeds 0 and no figures"
                                         if empty else "")
                                      + ("; a group with a diverged run has state diverged, "
                                         "its error and no figures (not a result)"
                                         if diverged else ""))
    if tests:
        atomic_write(dest / TESTS, lambda f: f.write(_csv(tests).encode()))
        files.append(dest / TESTS)
        described[TESTS] = ("per sweep point, pair of conditions and final figure: means, "
                            "difference with its 95% bootstrap interval (difference_low, "
                            "difference_high), permutation p (perm_p, perm_exact, perm_p_min, "
                            "perm_bound; perm_p_holm), Mann-Whitney U and p (mwu_p_holm), "
                            "Welch's t and p, Hedges' g, rank-biserial correlation, paired; "
                            "detectable: the smallest difference the test could detect (80% "
                            "power, alpha 0.05); margin, tost_p, tost_low, tost_high, "
                            "equivalent: the equivalence test of the study file's [margins]; "
                            "reading: what the numbers support, in words")
    described["report.md"] = ("this page: the final figures, the tests between conditions, "
                              "the files written")
    text = _markdown(name, rows, tests, per_seed, study_sessions, last, swept, measures,
                     described, empty, diverged)
    atomic_write(dest / "report.md", lambda f: f.write(text.encode()))
    files.append(dest / "report.md")
    return files, described, text


def final_gaits(members: list[dict[str, Any]]) -> dict[str, Any]:
    """A group's final gaits (each seed's final table, one run with learning off: the runs'
    ``gait.csv``), one run per seed, so the seed is the unit: ``final_seeds`` (seeds with a
    final run), ``final_trot_gait_k`` and its share with the Wilson 95% interval over seeds
    (``_share``, ``_low``, ``_high``), ``final_gait_locking_mean`` (the measure the label
    thresholds, over the seeds read that far), ``final_trot_gait_at_<x>`` (the share at other
    locking thresholds; 0: the footfall phases alone) and ``final_trot_rhythm_share``. Empty
    where no run has a ``gait.csv``."""
    from ..analysis.gait import THRESHOLDS, gait_at
    from ..analysis.share import wilson_interval

    seeds = []
    for m in members:
        g = m.get("gaits")
        if g is None or "final_gait" not in g:
            continue
        for row in g.to_dict("records"):
            seeds.append({k[len("final_"):]: v for k, v in row.items()
                          if str(k).startswith("final_")})
    if not seeds:
        return {}
    n = len(seeds)
    k = sum(s["gait"] == "trot" for s in seeds)
    low, high = wilson_interval(k, n)
    locks = [float(s.get("gait_locking", np.nan)) for s in seeds]
    locks = [x for x in locks if np.isfinite(x)]
    out: dict[str, Any] = {"final_seeds": n, "final_trot_gait_k": k,
                           "final_trot_gait_share": k / n, "final_trot_gait_low": low,
                           "final_trot_gait_high": high,
                           "final_gait_locking_mean": float(np.mean(locks)) if locks
                           else float("nan")}
    for x in (0.0, *THRESHOLDS):
        out[f"final_trot_gait_at_{x:g}"] = sum(gait_at(s, x) == "trot" for s in seeds) / n
    if "rhythm" in seeds[0]:
        out["final_trot_rhythm_share"] = sum(s["rhythm"] == "trot" for s in seeds) / n
    return out


def _gait_lines(rows: list[dict[str, Any]]) -> list[str]:
    """report.md's final gaits: a line per group that has them."""
    from ..analysis.gait import THRESHOLDS

    have = [r for r in rows if r.get("final_seeds")]
    if not have:
        return []
    lines = ["", "## Final gaits", "",
             "Each seed's final table run once with learning off (the study's final runs, "
             "`gait.csv`): one run per seed, so the seed is the unit and the interval is "
             "Wilson's over seeds. The trot gait label needs every foot's locking at 0.7 or "
             "more; the locking (the smallest foot's, mean over the seeds read that far) and "
             "the trot share at other thresholds (0: the footfall phases alone) say how much "
             "of the share the threshold sets.", "",
             "| group | seeds | trot gait [95% interval] | locking | trot gait at "
             + " / ".join(f"{x:g}" for x in (0.0, *THRESHOLDS)) + " | trot rhythm |",
             "|---|---|---|---|---|---|"]
    for r in have:
        lock = r["final_gait_locking_mean"]
        rhythm = r.get("final_trot_rhythm_share")
        lines.append(
            f"| {r['group']} | {r['final_seeds']} | {r['final_trot_gait_k']} "
            f"({r['final_trot_gait_share']:.0%}) [{r['final_trot_gait_low']:.0%}, "
            f"{r['final_trot_gait_high']:.0%}] | "
            f"{'n/a' if not np.isfinite(lock) else f'{lock:.2f}'} | "
            + " / ".join(f"{r[f'final_trot_gait_at_{x:g}']:.0%}" for x in (0.0, *THRESHOLDS))
            + f" | {'n/a' if rhythm is None else f'{rhythm:.0%}'} |")
    return lines


def _csv(rows: list[dict[str, Any]]) -> str:
    cols = list(dict.fromkeys(k for r in rows for k in r))
    return ",".join(cols) + "\n" + "".join(
        ",".join(_cell(r.get(c, "")) for c in cols) + "\n" for r in rows)


def _cell(v: Any) -> str:
    if v is None:
        return ""
    if isinstance(v, float):
        return f"{v:.6g}"
    s = str(v)
    return f'"{s}"' if "," in s else s


def _pm(row: dict[str, Any], key: str, fmt: str) -> str:
    if key + "_mean" not in row:
        return "n/a"
    text = f"{format(row[key + '_mean'], fmt)} ± {format(row[key + '_std'], fmt)}"
    low, high = row.get(key + "_low"), row.get(key + "_high")
    if low is not None and np.isfinite(low):
        text += f" [{format(low, fmt)}, {format(high, fmt)}]"
    return text


def _span(low: int, high: int) -> str:
    return str(low) if low == high else f"{low}–{high}"


FORMATS = {"speed": ".3f", "final_x": ".2f", "length": ".2f", "reward": ".3f", "full": ".0%",
           "mixed_limb_pairs": ".1f", "share_above_0.9_w_max": ".0%",
           "share_below_0.9_w_min": ".0%", "share_excitatory": ".0%"}


def _markdown(name: str, rows: list[dict[str, Any]], tests: list[dict[str, Any]],
              per_seed: list[dict[str, Any]], study_sessions: list[int], last: int,
              swept: list[str], measures: list[Measure], described: dict[str, str],
              empty: list[dict[str, Any]] = (), diverged: list[dict[str, Any]] = ()) -> str:
    trained = [o["sessions"] for o in per_seed]
    used = [o["last_sessions"] for o in per_seed]
    planned = _span(min(study_sessions), max(study_sessions))
    if min(used) == max(used) == min(trained) == max(trained):
        window = (f"its last {used[0]} sessions"
                  + (f" (all it trained: {setting('last', last)} asks for more)"
                     if last > used[0] else ""))
    else:
        window = (f"its last {_span(min(used), max(used))} sessions (at most {last}; a seed "
                  f"that trained fewer uses all of its {_span(min(trained), max(trained))})")
    limb_pairs = {r["limb_pairs"] for r in rows if "limb_pairs" in r}
    pairs = f" (of {limb_pairs.pop()})" if len(limb_pairs) == 1 else ""
    lines = [f"# Study {name}: final figures", "",
             f"The study trains {planned} sessions per seed; "
             f"{_span(min(trained), max(trained))} of them are done. Per seed, the final "
             f"figures are the mean over {window}; then mean ± std (ddof=0) across seeds "
             f"[95% t interval over seeds: the seed is the unit, not its sessions]. "
             f"Full-length: share of those sessions that reached L_max.", "",
             "| group | seeds | runs finished | sessions | last sessions | forward speed (m/s) | "
             "final x (m) | session length (s) | mean reward | full-length | "
             f"mixed limb pairs{pairs} | weights > 0.9 w_max | weights < 0.9 w_min | "
             "excitatory weights |",
             "|---|---|---|---|---|---|---|---|---|---|---|---|---|---|"]
    for r in rows:
        sessions = _span(r["sessions_min"], r["sessions_max"])
        lines.append(
            f"| {r['group']} | {r['seeds']} | {r['runs_finished']} | {sessions} | "
            f"{_span(r['last_sessions_min'], r['last_sessions_max'])} | "
            + " | ".join(_pm(r, m.key, FORMATS[m.key]) for m in MEASURES + WEIGHT_MEASURES)
            + " |")
    if empty:
        lines += ["", f"**No data yet** for {len(empty)} group(s) (no run of theirs has "
                      f"finished a session; not in the table, the curves or the tests): "
                  + "; ".join(f"{e['group']} (runs finished {e['runs_finished']}, states: "
                              f"{e['states']})" for e in empty) + "."]
    if diverged:
        lines += ["", f"**Diverged** ({len(diverged)} group(s); not a result: not in the table, "
                      f"the curves, the sweep figures or the tests): "
                  + "; ".join(f"{d['group']} (runs diverged {d['runs_diverged']}: {d['error']})"
                              for d in diverged) + "."]
    lines += _gait_lines(rows)
    if tests:
        paired = bool(tests[0].get("paired"))
        lines += ["", "## Conditions compared", "",
                  "Per seed one value (its final figure); difference = first condition minus "
                  "second, with its 95% bootstrap interval (" + (
                      "pairs of seeds resampled" if paired else "seeds resampled within each "
                      "condition") + f", {N_BOOT} resamples, seed {SEED}). p: two-sided "
                  "permutation test of the difference of means (" + (
                      "sign flips of each seed's pair difference: the study file declares "
                      "paired = true, seed k of one condition against seed k of the other"
                      if paired else "relabellings of the seeds between the conditions")
                  + f"; exact when there are at most {N_PERM} of them, else {N_PERM} drawn "
                  f"with seed {SEED}, when p is never below 1/{N_PERM + 1} and written "
                  f"'<= 1e-04' if no draw reached the observed difference)"
                  + ("" if paired else "; the Mann-Whitney U test two-sided (exact without "
                     "ties, never below 2/C(n_a+n_b, n_a))")
                  + ". Each pair of conditions at one point is one family of tests: its "
                  "p-values are Holm-adjusted over the final figures (raw, then Holm). Effect "
                  "sizes: Hedges' g (difference over the pooled sample std, small-sample "
                  "corrected)" + ("" if paired else " and the rank-biserial correlation of U "
                  "(+1: every seed of the first condition above every seed of the second)")
                  + ". With fewer than 2 seeds on a side no test is made (n too small). "
                  "A difference not shown is no evidence of sameness (and Holm's adjustment "
                  "only makes a difference harder to show): the last column gives the "
                  "smallest difference the test could detect (80% power, two-sided alpha "
                  "0.05, from the seeds' own spread), or, where the study file declares a "
                  "margin for the figure ([margins]), its equivalence test (TOST: two one-sided "
                  "tests on Student's t).", ""]
        for key, chunk in itertools.groupby(
                tests, key=lambda t: (tuple(t.get(k) for k in swept), t["condition_a"],
                                      t["condition_b"])):
            point, a, b = key
            where = ", ".join(f"{k}={v}" for k, v in zip(swept, point))
            lines += [f"### {a} vs {b}" + (f" ({where})" if where else "")
                      + (" (paired by seed)" if paired else ""), "",
                      f"| final figure | {a} | {b} | difference [95% interval] | "
                      f"permutation p (Holm) | "
                      + ("" if paired else "Mann-Whitney U, p (Holm) | ")
                      + "Hedges' g |" + ("" if paired else " rank-biserial |")
                      + " reading |",
                      "|---|---|---|---|---|" + ("" if paired else "---|") + "---|"
                      + ("" if paired else "---|") + "---|"]
            for t in chunk:
                m = next(x for x in measures if x.key == t["measure"])
                fmt = FORMATS[m.key]
                head = (f"| {m.label} | {format(t['mean_a'], fmt)} (n={t['n_a']}) | "
                        f"{format(t['mean_b'], fmt)} (n={t['n_b']}) | "
                        f"{format(t['difference'], '+' + fmt)}")
                cells = 4 if paired else 6
                if t["note"] == "n too small":
                    lines.append(head + " |" + " n too small |" * cells)
                    continue
                head += (f" [{format(t['difference_low'], '+' + fmt)}, "
                         f"{format(t['difference_high'], '+' + fmt)}] | ")
                perm = (f"{p_text(t['perm_p'], t['perm_p_min'], t['perm_bound'])}"
                        f"{' exact' if t['perm_exact'] else ''} "
                        f"({p_text(t['perm_p_holm'], t['perm_p_holm'], t['perm_bound'])})")
                g = "undefined (no spread)" if t["hedges_g"] is None else f"{t['hedges_g']:.3g}"
                reading = reading_words(t, fmt.lstrip("+"))
                if paired:
                    lines.append(head + f"{perm} | {g} | {reading} |")
                else:
                    lines.append(head + f"{perm} | {t['mwu_U']:.3g}, {p_text(t['mwu_p'])} "
                                        f"({p_text(t['mwu_p_holm'])}) | {g} | "
                                        f"{t['rank_biserial']:+.3g} | {reading} |")
            lines.append("")
        lines.append(f"The same in {TESTS}.")
    lines += ["", "## Files", ""]
    lines += [f"- `{file}`: {what}" for file, what in described.items()]
    return "\n".join(lines) + "\n"
