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
import re
import zipfile
import zlib
from pathlib import Path
from typing import Any

import numpy as np

from ...errors import InputError
from ...reading import check_regular, read_json
from ...models import DEFAULT_MODELS
from ..analysis.compare import N_BOOT, N_PERM, SEED, compare, holm, p_text
from ..analysis.gait import weight_structure
from ...models.compose import model_set
from ..outputs.folder import OutputFolder, verify
from ..outputs.study_index import current_specs
from ..figures.save import save_figure
from ..figures.sweep import Axis, Measure, measure_heatmap, measure_vs_value
from ..outputs.writing import atomic_write, write_manifest
from .execute import read_status
from .layout import GAITS, RUNS, STUDY_INDEX

CURVES = (("mean_reward", "mean reward"), ("final_x_m", "final x (m)"),
          ("length_s", "session length (s)"))


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
    models = model_set(list(spec["overrides"]), {}, models=spec.get("models") or None)
    return models.value("w_max"), models.value("L_max"), models.value("w_min")


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


REPORT = "report"

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
TESTS = "condition_tests.csv"
_NUMBER = re.compile(r"\s*([-+]?(?:\d+\.?\d*|\.\d+)(?:[eE][-+]?\d+)?)\s*(?:\*\s*(.+?))?\s*")


def report(folder: Path, *, last: int = 50, smooth: int = 1, out: Path | None = None,
           overwrite: bool = False) -> dict[str, Any]:
    """Write the report of the study in ``folder`` into ``out`` (default ``folder/report``,
    which each report replaces whole): ``fig3c.png``, ``final_figures.csv``, ``report.md``;
    for a sweep, the final figures against the swept values (``sweep_<axis>.png``, or one
    ``heatmap_<measure>.png`` per measure over two axes); for two or more conditions,
    ``condition_tests.csv``. Returns files, rows, text, figures ({file: Figure}), tests."""
    check_regular(Path(folder) / STUDY_INDEX)  # a FIFO is refused, never waited on
    if not (Path(folder) / STUDY_INDEX).is_file():
        raise InputError(f"not a study folder (no {STUDY_INDEX})", culprit=f"report {folder}")
    target = Path(out) if out is not None else Path(folder) / REPORT
    # never the study it reports on, nor inside it but at its report/ (--overwrite: of a study)
    OutputFolder(target, overwrite=overwrite or out is None, inputs=[folder]).check()
    with OutputFolder(target, overwrite=overwrite or out is None, inputs=[folder]) as tmp:
        written = _report(Path(folder), tmp, last=last, smooth=smooth)
        write_manifest(tmp, command="report", seed=0, models_json={},
                       settings={"study": os.path.abspath(folder), "last": last,
                                 "smooth": smooth},
                       files=written["described"])
    written["files"] = [target / p.name for p in written["files"]]
    return written


def _axis(name: str, values: list[str]) -> Axis:
    """How a swept axis is drawn: numeric (sorted by value, labelled with the unit the study
    file writes) when every value is a number with one same unit; otherwise categorical in the
    study file's order, model files by their stem."""
    if name in dict(DEFAULT_MODELS.items()):
        return Axis(name, tuple(values), tuple(float(i) for i in range(len(values))),
                    tuple(Path(v).stem for v in values), f"{name} (model file)", True)
    parsed = [_NUMBER.fullmatch(v) for v in values]
    if all(parsed) and len({m.group(2) for m in parsed}) == 1:
        unit = parsed[0].group(2) or "dimensionless"
        order = sorted(range(len(values)), key=lambda i: float(parsed[i].group(1)))
        return Axis(name, tuple(values[i] for i in order),
                    tuple(float(parsed[i].group(1)) for i in order),
                    tuple(parsed[i].group(1) for i in order), f"{name} ({unit})", False)
    return Axis(name, tuple(values), tuple(float(i) for i in range(len(values))),
                tuple(values), f"{name} (as in the study file)", True)


def _report(folder: Path, dest: Path, *, last: int, smooth: int) -> dict[str, Any]:
    # heavy: only when a report is drawn; outside pyplot, so the caller's backend is left alone
    from matplotlib.figure import Figure

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

    fig = Figure(figsize=(8, 8))
    axes = fig.subplots(3, 1, sharex=True)
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
        color = f"C{k}"
        for ax, (key, ylabel) in zip(axes, CURVES):
            table = np.full((len(series), n), np.nan)
            for row, s in enumerate(series.values()):
                table[row, s["session"].to_numpy(int) - 1] = s[key].to_numpy(float)
            if smooth > 1:  # moving mean over sessions, per seed, before the across-seed stats
                table = moving_mean(table, smooth)
            mean, std = np.nanmean(table, axis=0), np.nanstd(table, axis=0)
            x = np.arange(1, n + 1)
            ax.plot(x, mean, color=color, lw=1.2, label=f"{label} (n={len(series)})")
            ax.fill_between(x, mean - std, mean + std, color=color, alpha=0.25, lw=0)
            ax.set_ylabel(ylabel)
        L_max = _model_values(members[0]["spec"])[1]
        seeds_here = _seed_finals(condition, point, series, structure, last=last, L_max=L_max)
        per_seed.extend(seeds_here)
        row: dict[str, Any] = {
            "group": label, "condition": condition, **dict(zip(swept, point)),
            "seeds": len(series),
            "runs_finished": f"{states.count('finished')}/{len(states)}",
            "sessions_min": min(len(s) for s in series.values()),
            "sessions_max": max(len(s) for s in series.values()),
            "last_sessions_min": min(o["last_sessions"] for o in seeds_here),
            "last_sessions_max": max(o["last_sessions"] for o in seeds_here),
        }
        for m in MEASURES + WEIGHT_MEASURES:
            vals = [o[m.key] for o in seeds_here if m.key in o]
            if vals:  # std across seeds with ddof=0, as in the curves of fig3c
                row[f"{m.key}_mean"], row[f"{m.key}_std"] = (float(np.mean(vals)),
                                                             float(np.std(vals)))
        limb_pairs = {o["limb_pairs"] for o in seeds_here if "limb_pairs" in o}
        if limb_pairs:
            row["limb_pairs"] = limb_pairs.pop()
        rows.append(row)
    axes[0].legend(fontsize=8, loc="best")
    axes[-1].set_xlabel("session")
    axes[0].set_title(f"Study {name}: mean +- std across seeds "
                      f"(paper Fig. 3c)"
                      + (f", trailing mean over {smooth} sessions" if smooth > 1 else ""))
    fig.tight_layout()
    figures: dict[str, Any] = {"fig3c.png": fig}
    shows = {"fig3c.png": "mean reward, final x (m) and session length (s) per session, "
                          "mean ± std across seeds, one line per group (paper Fig. 3c)"
                          + (f"; each seed's trailing mean over {smooth} sessions"
                             if smooth > 1 else "")}
    measures = [m for m in MEASURES + WEIGHT_MEASURES if any(m.key in o for o in per_seed)]
    if swept:
        _sweep_figures(name, swept, runs, per_seed, measures, figures, shows)
    tests = _condition_tests(swept, [c for c, _ in groups], per_seed, measures,
                             skip={(d["condition"], tuple(str(d.get(k, "")) for k in swept))
                                   for d in diverged},
                             paired=bool(index.get("paired", False)))

    files, described, text = _write_files(
        dest, name, figures, shows, rows, tests, per_seed, study_sessions, last=last,
        swept=swept, measures=measures, empty=empty, diverged=diverged)
    return {"files": files, "rows": rows, "text": text, "figures": figures, "tests": tests,
            "per_seed": per_seed, "described": described,
            "no_data": [e["group"] for e in empty],
            "diverged": [d["group"] for d in diverged]}


def _seed_finals(condition: str, point: tuple[str, ...], series: dict[int, Any],
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
                                      f"of each seed (mean over its last sessions, --last "
                                      f"{last}), mean and std across seeds"
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
                            "Welch's t and p, Hedges' g, rank-biserial correlation, paired")
    described["report.md"] = ("this page: the final figures, the tests between conditions, "
                              "the files written")
    text = _markdown(name, rows, tests, per_seed, study_sessions, last, swept, measures,
                     described, empty, diverged)
    atomic_write(dest / "report.md", lambda f: f.write(text.encode()))
    files.append(dest / "report.md")
    return files, described, text


def _sweep_figures(name: str, swept: list[str], runs: list[dict[str, Any]],
                   per_seed: list[dict[str, Any]], measures: list[Measure],
                   figures: dict[str, Any], shows: dict[str, str]) -> None:
    """The final figures against the swept values: one axis, a panel per measure; two axes
    swept as a grid, a heatmap per measure; otherwise each sweep point as a category."""
    conditions = list(dict.fromkeys(o["condition"] for o in per_seed))
    points = list(dict.fromkeys(tuple(str(r["spec"]["point"].get(k, "")) for k in swept)
                                for r in runs))
    values = [list(dict.fromkeys(p[i] for p in points)) for i in range(len(swept))]
    grid = len(swept) == 2 and len(points) == len(values[0]) * len(values[1])
    if len(swept) == 1 or not grid:
        if len(swept) == 1:
            axis, where = _axis(swept[0], values[0]), (lambda p: p[0])
        else:  # zip mode or more than two axes: the points in the study's order
            labels = [", ".join(f"{k}={v}" for k, v in zip(swept, p)) for p in points]
            axis = Axis("sweep point", tuple(labels), tuple(map(float, range(len(labels)))),
                        tuple(labels), "sweep point (values as in the study file)", True)
            where = (lambda p: ", ".join(f"{k}={v}" for k, v in zip(swept, p)))
        series = {m.key: {c: _stats([[o[m.key] for o in per_seed
                                      if o["condition"] == c and where(o["point"]) == v
                                      and m.key in o] for v in axis.values])
                          for c in conditions} for m in measures}
        file = f"sweep_{_file_slug(axis.name)}.png"
        figures[file] = measure_vs_value(
            axis, measures, series, f"Study {name}: final figures against {axis.name}, "
                                    f"mean ± std across seeds")
        shows[file] = (f"each final figure ({', '.join(m.title for m in measures)}) against "
                       f"{axis.name}, mean ± std across seeds, one line per condition")
        return
    x_axis, y_axis = _axis(swept[0], values[0]), _axis(swept[1], values[1])
    _gait_map(name, x_axis, y_axis, runs, figures, shows)
    for m in measures:
        grids = {}
        for c in conditions:
            cells = [[[o[m.key] for o in per_seed if o["condition"] == c and m.key in o
                       and o["point"] == (xv, yv)] for xv in x_axis.values]
                     for yv in y_axis.values]
            mean, std, n = _stats([v for row in cells for v in row])
            shape = (len(y_axis.values), len(x_axis.values))
            grids[c] = (mean.reshape(shape), std.reshape(shape), n.reshape(shape))
        file = f"heatmap_{_file_slug(m.key)}.png"
        figures[file] = measure_heatmap(
            x_axis, y_axis, m, grids, f"Study {name}: {m.title} ({m.unit}) over "
                                      f"{x_axis.name} and {y_axis.name}, mean across seeds")
        shows[file] = (f"{m.title} ({m.unit}), mean (± std, n) across seeds over {x_axis.name} "
                       f"x {y_axis.name}, one panel per condition")


def _gait_map(name: str, x_axis: Axis, y_axis: Axis, runs: list[dict[str, Any]],
              figures: dict[str, Any], shows: dict[str, str]) -> None:
    """``gait_map.png`` over the two swept axes from the runs' ``gait.csv`` (each seed's gait
    with its final tables): the most common label per cell as colour, mean speed as contours.
    Nothing when no run wrote one."""
    from ..figures.gait_map import gait_map_figures

    seeds = []
    old = False  # a gait.csv without final_rhythm: its final_gait is the thigh-pool rhythm
    for r in runs:
        g = r.get("gaits")
        if g is None:
            continue
        old = old or "final_rhythm" not in g.columns
        point = r["spec"]["point"]
        for row in g.to_dict("records"):
            reason = str(row.get("final_gait_reason", "") or "")
            seeds.append({"condition": r["spec"]["condition"], "gait": row["final_gait"],
                          "mean_speed_m_per_s": row["final_speed_m_per_s"],
                          "fell": int(reason.startswith("fell")),
                          f"grid_{y_axis.name}": str(point.get(y_axis.name, "")),
                          f"grid_{x_axis.name}": str(point.get(x_axis.name, ""))})
    if not seeds:
        return
    fig = gait_map_figures(seeds, [(y_axis.name, list(y_axis.values)),
                                   (x_axis.name, list(x_axis.values))],
                           {y_axis.name: y_axis.label, x_axis.name: x_axis.label})
    figures["gait_map.png"] = fig["gait_map.png"]
    what = ("rhythm (thigh-extensor bursts: these runs were written before the gait was read "
            "from the feet)" if old else "gait (footfalls over the upright part)")
    shows["gait_map.png"] = (f"each seed's final {what} (learning off, 5 s) over {x_axis.name} x "
                             f"{y_axis.name}: the most common label per cell (colour, its share "
                             f"written), mean forward speed (contours), one panel per condition")


def _stats(cells: list[list[float]]) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Mean, std (ddof=0) and count of the finite values of each cell (NaN where none)."""
    out = np.full((3, len(cells)), np.nan)
    for i, values in enumerate(cells):
        v = np.asarray([x for x in values if np.isfinite(x)], dtype=float)
        out[2, i] = len(v)
        if len(v):
            out[0, i], out[1, i] = v.mean(), v.std()
    return out[0], out[1], out[2]


def _file_slug(text: str) -> str:
    return re.sub(r"[^A-Za-z0-9.+-]+", "_", text).strip("_") or "x"


def _condition_tests(swept: list[str], conditions: list[str], per_seed: list[dict[str, Any]],
                     measures: list[Measure],
                     skip: set[tuple[str, tuple[str, ...]]] = frozenset(),
                     paired: bool = False) -> list[dict[str, Any]]:
    """Every pair of conditions (in the study's order, first minus second) at every sweep
    point, every final figure: :func:`~astrocpg.studies.analysis.compare.compare`. The final
    figures of one pair at one point are one family (one question: do the conditions
    differ?): their permutation and Mann-Whitney p-values are Holm-adjusted together
    (``perm_p_holm``, ``mwu_p_holm``). ``paired`` (the study file's ``paired = true``,
    declared before any run): seed k of one condition is compared with seed k of the
    other, on the seeds both have."""
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
                family.append({**dict(zip(swept, point)), "condition_a": a, "condition_b": b,
                               "measure": m.key, "unit": m.unit,
                               **compare(va, vb, paired=paired)})
            for key in ("perm_p", "mwu_p"):
                for t, adjusted in zip(family, holm([t[key] for t in family])):
                    t[f"{key}_holm"] = adjusted
            out += family
    return out


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
    return f"{format(row[key + '_mean'], fmt)} ± {format(row[key + '_std'], fmt)}"


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
        window = (f"its last {used[0]} sessions" + (f" (all it trained: --last {last} asks "
                                                     f"for more)" if last > used[0] else ""))
    else:
        window = (f"its last {_span(min(used), max(used))} sessions (at most {last}; a seed "
                  f"that trained fewer uses all of its {_span(min(trained), max(trained))})")
    limb_pairs = {r["limb_pairs"] for r in rows if "limb_pairs" in r}
    pairs = f" (of {limb_pairs.pop()})" if len(limb_pairs) == 1 else ""
    lines = [f"# Study {name}: final figures", "",
             f"The study trains {planned} sessions per seed; "
             f"{_span(min(trained), max(trained))} of them are done. Per seed, the final "
             f"figures are the mean over {window}; then mean ± std (ddof=0) across seeds. "
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
                  + ". With fewer than 2 seeds on a side no test is made (n too small).", ""]
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
                      + "Hedges' g |" + ("" if paired else " rank-biserial |"),
                      "|---|---|---|---|---|" + ("" if paired else "---|") + "---|"
                      + ("" if paired else "---|")]
            for t in chunk:
                m = next(x for x in measures if x.key == t["measure"])
                fmt = FORMATS[m.key]
                head = (f"| {m.label} | {format(t['mean_a'], fmt)} (n={t['n_a']}) | "
                        f"{format(t['mean_b'], fmt)} (n={t['n_b']}) | "
                        f"{format(t['difference'], '+' + fmt)}")
                cells = 3 if paired else 5
                if t["note"] == "n too small":
                    lines.append(head + " |" + " n too small |" * cells)
                    continue
                head += (f" [{format(t['difference_low'], '+' + fmt)}, "
                         f"{format(t['difference_high'], '+' + fmt)}] | ")
                perm = (f"{p_text(t['perm_p'], t['perm_p_min'], t['perm_bound'])}"
                        f"{' exact' if t['perm_exact'] else ''} "
                        f"({p_text(t['perm_p_holm'], t['perm_p_holm'], t['perm_bound'])})")
                g = "undefined (no spread)" if t["hedges_g"] is None else f"{t['hedges_g']:.3g}"
                if paired:
                    lines.append(head + f"{perm} | {g} |")
                else:
                    lines.append(head + f"{perm} | {t['mwu_U']:.3g}, {p_text(t['mwu_p'])} "
                                        f"({p_text(t['mwu_p_holm'])}) | {g} | "
                                        f"{t['rank_biserial']:+.3g} |")
            lines.append("")
        lines.append(f"The same in {TESTS}.")
    lines += ["", "## Files", ""]
    lines += [f"- `{file}`: {what}" for file, what in described.items()]
    return "\n".join(lines) + "\n"
