"""``astrocpg report DIR``: the paper's Fig. 3c for any study, and its final figures.

For every group of runs that differ only by seed (a condition, at one sweep point), per session:
mean +- std across seeds of the session's mean reward, final x and length (``fig3c.png``). The
final figures per group (``final_figures.csv`` and ``report.md``): over the last ``last`` (50)
sessions of each seed, mean reward, forward speed, final x, session length and the share of
sessions that reached L_max, then mean +- std across seeds; and from the trained weights the
limb pairs with two inhibitory and two excitatory synapses and the share of weights above
0.9 w_max (the paper's contrast between the two conditions).

Runs still in progress are included with the sessions they have and marked as such.
"""

from __future__ import annotations

import json
import os
import zipfile
import zlib
from pathlib import Path
from typing import Any

import numpy as np

from ...errors import InputError
from ..analysis.gait import weight_structure
from ..experiments.settings import model_set
from ..files.folder import OutputFolder, verify
from ..files.outputs import atomic_write, write_manifest
from .study import RUNS, STUDY_INDEX, read_status

CURVES = (("mean_reward", "mean reward"), ("final_x_m", "final x (m)"),
          ("length_s", "session length (s)"))


def _load(folder: Path) -> tuple[dict[str, Any], list[dict[str, Any]]]:
    import pandas as pd

    try:
        index = json.loads((folder / STUDY_INDEX).read_text())
    except (OSError, ValueError):
        raise InputError(f"not a study folder (no readable {STUDY_INDEX})",
                         culprit=f"report {folder}") \
            from None
    runs = []
    for run_id, spec in index.get("specs", {}).items():
        rdir = folder / RUNS / run_id
        state = read_status(rdir).get("state", "not run")
        if state == "finished":  # what it read is what its manifest lists
            verify(rdir, culprit=f"report {rdir}", strict=False, only=READ)
        df = weights = None
        if (rdir / "sessions.csv").exists():
            try:
                df = pd.read_csv(rdir / "sessions.csv")
                if (rdir / "weights.npz").exists():
                    with np.load(rdir / "weights.npz", allow_pickle=False) as z:
                        weights = np.asarray(z["final_weights_mV"], dtype=float) * 1e-3
            except (OSError, ValueError, KeyError, EOFError, zipfile.BadZipFile,
                    zlib.error) as e:
                raise InputError(f"cannot read sessions.csv or weights.npz ({type(e).__name__}"
                                 f"): corrupt or truncated", culprit=f"report {rdir}") from None
        runs.append({"spec": spec, "state": state, "sessions": df, "folder": rdir,
                     "weights": weights})
    return index, runs


READ = ("sessions.csv", "weights.npz")  # what a report reads of each run


def _group_label(spec: dict[str, Any]) -> str:
    point = ", ".join(f"{k}={v}" for k, v in spec["point"].items())
    return spec["condition"] + (f" ({point})" if point else "")


def _model_values(spec: dict[str, Any]) -> tuple[float, float]:
    """w_max (volt) and L_max (s) of a run, from its overrides."""
    models = model_set(list(spec["overrides"]), {}, models=spec.get("models") or None)
    return (float(np.asarray(models.interlimb_synapse.parameters["w_max"].value)),
            float(np.asarray(models.progress.parameters["L_max"].value)))


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


def report(folder: Path, *, last: int = 50, smooth: int = 1, out: Path | None = None,
           overwrite: bool = False) -> dict[str, Any]:
    """Write ``fig3c.png``, ``final_figures.csv`` and ``report.md`` of the study in ``folder``
    into ``out`` (default ``folder/report``, which each report replaces whole)."""
    if not (Path(folder) / STUDY_INDEX).is_file():
        raise InputError(f"not a study folder (no {STUDY_INDEX})", culprit=f"report {folder}")
    target = Path(out) if out is not None else Path(folder) / REPORT
    OutputFolder(target, overwrite=overwrite or out is None).check()
    with OutputFolder(target, overwrite=overwrite or out is None) as tmp:
        written = _report(Path(folder), tmp, last=last, smooth=smooth)
        write_manifest(tmp, command="report", seed=0, models_json={},
                       settings={"study": os.path.abspath(folder), "last": last,
                                 "smooth": smooth},
                       files={"fig3c.png": "mean +- std across seeds per session and group "
                                           "(paper Fig. 3c)",
                              "final_figures.csv": f"per group, over the last {last} sessions",
                              "report.md": "the final figures as a table"})
    written["files"] = [target / p.name for p in written["files"]]
    return written


def _report(folder: Path, dest: Path, *, last: int, smooth: int) -> dict[str, Any]:
    # heavy: only when a report is drawn; outside pyplot, so the caller's backend is left alone
    from matplotlib.figure import Figure

    index, runs = _load(folder)
    groups: dict[str, list[dict[str, Any]]] = {}
    for r in runs:
        groups.setdefault(_group_label(r["spec"]), []).append(r)
    if not any(r["sessions"] is not None and len(r["sessions"]) for r in runs):
        raise InputError("no run has finished a session yet", culprit=f"report {folder}")

    fig = Figure(figsize=(8, 8))
    axes = fig.subplots(3, 1, sharex=True)
    rows: list[dict[str, Any]] = []
    for k, (label, members) in enumerate(groups.items()):
        # one series per seed: table[seed, session-1]
        series: dict[int, Any] = {}
        weights, w_max = [], None
        states = [m["state"] for m in members]
        for m in members:
            df = m["sessions"]
            if df is None or not len(df):
                continue
            for trial, sdf in df.groupby("trial"):
                series[m["spec"]["seed"] + int(trial)] = sdf.sort_values("session")
            if m["weights"] is not None:
                weights.extend(m["weights"])
                w_max = _model_values(m["spec"])[0]
        if not series:
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
        per_seed = {
            "speed": [s["mean_forward_speed_m_per_s"].tail(last).mean() for s in series.values()],
            "final_x": [s["final_x_m"].tail(last).mean() for s in series.values()],
            "length": [s["length_s"].tail(last).mean() for s in series.values()],
            "reward": [s["mean_reward"].tail(last).mean() for s in series.values()],
            "full": [(s["length_s"].tail(last) >= L_max - 1e-6).mean()
                     for s in series.values()],
        }
        row: dict[str, Any] = {
            "group": label, "seeds": len(series),
            "runs_finished": f"{states.count('finished')}/{len(states)}",
            "sessions_min": min(len(s) for s in series.values()),
            "sessions_max": max(len(s) for s in series.values()),
        }
        for key, vals in per_seed.items():
            row[f"{key}_mean"], row[f"{key}_std"] = float(np.mean(vals)), float(np.std(vals))
        if weights and w_max is not None:
            ws = [weight_structure(w, w_max) for w in weights]
            row["mixed_limb_pairs_mean"] = float(np.mean([w["mixed_limb_pairs"] for w in ws]))
            row["share_above_0.9_w_max_mean"] = float(
                np.mean([w["share_above_0.9_w_max"] for w in ws]))
        rows.append(row)
    axes[0].legend(fontsize=8, loc="best")
    axes[-1].set_xlabel("session")
    axes[0].set_title(f"Study {index.get('name', folder.name)}: mean +- std across seeds "
                      f"(paper Fig. 3c)"
                      + (f", trailing mean over {smooth} sessions" if smooth > 1 else ""))
    fig.tight_layout()
    fig_path = dest / "fig3c.png"
    fig.savefig(fig_path, dpi=110)

    cols = list(dict.fromkeys(k for r in rows for k in r))
    csv_text = ",".join(cols) + "\n" + "".join(
        ",".join(_cell(r.get(c, "")) for c in cols) + "\n" for r in rows)
    atomic_write(dest / "final_figures.csv", lambda f: f.write(csv_text.encode()))
    text = _markdown(index.get("name", folder.name), rows, last)
    atomic_write(dest / "report.md", lambda f: f.write(text.encode()))
    return {"files": [fig_path, dest / "final_figures.csv", dest / "report.md"],
            "rows": rows, "text": text}


def _cell(v: Any) -> str:
    if isinstance(v, float):
        return f"{v:.6g}"
    s = str(v)
    return f'"{s}"' if "," in s else s


def _pm(row: dict[str, Any], key: str, fmt: str) -> str:
    return f"{format(row[key + '_mean'], fmt)} ± {format(row[key + '_std'], fmt)}"


def _markdown(name: str, rows: list[dict[str, Any]], last: int) -> str:
    lines = [f"# Study {name}: final figures", "",
             f"Per seed, the mean over its last {last} sessions; then mean ± std across seeds. "
             f"Full-length: share of those sessions that reached L_max.", "",
             "| group | seeds | runs finished | sessions | forward speed (m/s) | final x (m) | "
             "session length (s) | mean reward | full-length | mixed limb pairs (of 12) | "
             "weights > 0.9 w_max |",
             "|---|---|---|---|---|---|---|---|---|---|---|"]
    for r in rows:
        sessions = (str(r["sessions_min"]) if r["sessions_min"] == r["sessions_max"]
                    else f"{r['sessions_min']}–{r['sessions_max']}")
        mixed = r.get("mixed_limb_pairs_mean")
        sat = r.get("share_above_0.9_w_max_mean")
        lines.append(
            f"| {r['group']} | {r['seeds']} | {r['runs_finished']} | {sessions} | "
            f"{_pm(r, 'speed', '.3f')} | {_pm(r, 'final_x', '.2f')} | {_pm(r, 'length', '.2f')} | "
            f"{_pm(r, 'reward', '.3f')} | {r['full_mean']:.0%} ± {r['full_std']:.0%} | "
            f"{'n/a' if mixed is None else f'{mixed:.1f}'} | "
            f"{'n/a' if sat is None else f'{sat:.0%}'} |")
    if len(rows) == 2:
        a, b = rows
        diff = ", ".join(
            f"{label} {a[key + '_mean'] - b[key + '_mean']:+{fmt}}"
            for key, label, fmt in (("reward", "mean reward", ".3f"),
                                    ("final_x", "final x (m)", ".2f"),
                                    ("length", "session length (s)", ".2f"),
                                    ("speed", "forward speed (m/s)", ".3f"),
                                    ("full", "full-length share", ".0%")))
        lines += ["", f"Contrast, {a['group']} minus {b['group']}: {diff}."]
    return "\n".join(lines) + "\n"
