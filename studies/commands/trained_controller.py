"""What a trained controller does: its gait (``astrocpg gait``) and the figures of its training
(``astrocpg plot``), from a run of its trained tables."""

from __future__ import annotations

import math
import os
from collections import Counter
from pathlib import Path
from typing import Any, Mapping, Sequence

import numpy as np

from ...errors import InputError, setting
from ...network import LEGS
from ..analysis.gait import (MEASURE_COLUMNS, NAMED, leg_phases, phase_matrix, trial_measures,
                             weight_structure)
from ..analysis.fall import fall_words, first_fall
from ..analysis.share import share_words, wilson_interval
from ..outputs.folder import OutputFolder, as_path
from ..outputs.writing import write_manifest
from ..runtime.progress import Bar
from .run import alive_words, replay, training_settings


GAIT_REPEATS = 5
"""Evaluation runs per trained table by default (``astrocpg gait``, ``evaluate``): a
controller's gait is the share of its runs that show it, with its Wilson interval."""


def gait_runs(folder: str | Path, *, seconds: float = 10.0, repeats: int = GAIT_REPEATS,
              seed: int | None = None, world: Sequence[str] = (),
              progress: bool = True, variant: Mapping[str, Any] | None = None,
              workers: int | None = None) -> tuple[list[dict[str, Any]], np.ndarray, Any]:
    """Run every trained table of the training in ``folder`` (or every trial's table of a run
    folder; ``variant``: a model variant over its models, :func:`~astrocpg.studies.commands.
    run.with_variant`; ``workers``: processes the runs are split over) ``repeats`` times for
    ``seconds``, learning off (run ``b = r * n + k``: table ``k``, repeat ``r``, seed
    ``seed + b``; :func:`~astrocpg.studies.commands.run.replay`); one row per run: table,
    repeat, seed, speed, upright share, the fall, and the rhythm and the gait over the run's
    second half (:func:`~astrocpg.studies.analysis.gait.trial_measures`). Returns the rows,
    the tables (volt) and the models the runs used."""
    if seed is None:
        seed = training_settings(folder).get("seed", 1)
    result, weights = replay(folder, seconds=seconds, seed=seed, progress=progress,
                             repeats=repeats, world=world, variant=variant, workers=workers)
    first_seed = int(seed)
    t, i = result.spikes["motor"]
    rec = result.robot
    n = len(weights)
    rows = []
    for b in range(result.cpg.n_trials):
        r, k = divmod(b, n)
        fall = first_fall(rec.t, rec.alive[b])
        rows.append({"table": k, "repeat": r,
                     "seed": first_seed + b,
                     "mean_speed_m_per_s": float(rec.torso_velocity[b, :, 0].mean()),
                     "upright_share": float(rec.alive[b].mean()),
                     "lowest_torso_height_m": float(rec.torso_position[b, :, 2].min()),
                     "fell": int(fall is not None),
                     "time_to_fall_s": fall.t_s if fall is not None else math.nan,
                     "fall": fall_words(fall),
                     **trial_measures(t, i, result.cpg.layout, rec, b, seconds / 2, seconds)})
    return rows, weights, result.cpg.models


def _phases(row: Mapping[str, Any], kind: str) -> str:
    return ", ".join(f"{leg} {row[f'{kind}_phase_{leg}']:.2f} (lock "
                     f"{row[f'{kind}_locking_{leg}']:.2f})" for leg in LEGS[1:])


def run_words(row: Mapping[str, Any]) -> str:
    """``rhythm trot (...); gait none: fell at 2.16 s``: one run's two labels, named."""
    rhythm = (f"rhythm (thigh-extensor bursts) {row['rhythm']}"
              + (f" (phases relative to FR: {_phases(row, 'rhythm')})"
                 if np.isfinite(row["rhythm_period_s"]) else ""))
    if row["gait_reason"] and not np.isfinite(row["gait_period_s"]):
        gait = f"gait (footfalls) none: {row['gait_reason']}"
    else:
        gait = (f"gait (footfalls) {row['gait']}{': ' + row['gait_reason'] if row['gait_reason'] else ''}"
                f" (stances relative to FR: {_phases(row, 'gait')}; duty factor "
                f"{row['gait_duty_factor']:.2f})")
    return f"{rhythm}; {gait}"


def shares_words(rows: Sequence[Mapping[str, Any]], kind: str) -> str:
    """``gait trot in 4 of 5 runs (80%, 95% interval 38-96%); none 1 (fell at 2.16 s)``: the
    most common named ``kind`` label (``gait`` or ``rhythm``) of the runs ``rows`` with its
    Wilson interval (or ``no named gait in 5 runs (95% interval 0-43%)``), then the others,
    a gait's ``none`` with its reasons."""
    labels = [r[kind] for r in rows]
    counts = Counter(labels)
    named = [g for g, _ in counts.most_common() if g in NAMED]
    n = len(labels)
    if named:
        head = f"{kind} {named[0]} in {share_words(counts[named[0]], n)}"
    else:
        lo, hi = wilson_interval(0, n)
        head = (f"no named {kind} in {n} run{'s' if n != 1 else ''} (95% interval "
                f"{lo:.0%}-{hi:.0%})")
    rest = []
    for g, c in counts.most_common():
        if named and g == named[0]:
            continue
        why = Counter(r.get(f"{kind}_reason", "") for r in rows if r[kind] == g) \
            if kind == "gait" and g == "none" else Counter()
        because = ", ".join(f"{w} {k}" if k > 1 else w for w, k in why.most_common() if w)
        rest.append(f"{g} {c}" + (f" ({because})" if because else ""))
    return head + (f"; {', '.join(rest)}" if rest else "")


def describe_gait(folder: str | Path, *, seconds: float = 10.0, repeats: int = GAIT_REPEATS,
                  seed: int | None = None, world: Sequence[str] = (),
                  progress: bool = True, variant: Mapping[str, Any] | None = None,
                  workers: int | None = None) -> list[str]:
    """Run every trained table ``repeats`` times (:func:`gait_runs`); a line per run (its
    rhythm and its gait, each named, speed, upright share by the alive model in use, a fall),
    per table the share of its runs with each gait and each rhythm (Wilson 95% intervals over
    that table's runs) and the weight structure, and over all tables (:func:`tables_words`)
    the shares with intervals over tables, the gait's locking and its share at other
    thresholds, and whether the tables differ."""
    rows, weights, models = gait_runs(folder, seconds=seconds, repeats=repeats, seed=seed,
                                      world=world, progress=progress, variant=variant,
                                      workers=workers)
    w_max = models.value("w_max")
    alive = alive_words(models)
    lines = []
    for k in range(len(weights)):
        mine = [r for r in rows if r["table"] == k]
        for r in mine:
            lines.append(
                f"table {k} repeat {r['repeat']} (seed {r['seed']}): {run_words(r)}; mean "
                f"forward speed {r['mean_speed_m_per_s']:.3f} m/s; {alive} "
                f"{r['upright_share']:.0%}, torso centre at least "
                f"{r['lowest_torso_height_m']:.2f} m above the ground"
                f"{'; ' + r['fall'] if r['fall'] else ''}")
        ws = weight_structure(weights[k], w_max)
        lines.append(
            f"table {k}: {shares_words(mine, 'gait')} | {shares_words(mine, 'rhythm')} | "
            f"weights: "
            f"{ws['mixed_limb_pairs']} of {ws['limb_pairs']} limb pairs with two inhibitory "
            f"and two excitatory synapses, {ws['share_above_0.9_w_max']:.0%} above 0.9 w_max, "
            f"{ws['share_below_0.9_w_min']:.0%} below 0.9 w_min")
    return lines + tables_words(rows)


def tables_words(rows: Sequence[Mapping[str, Any]]) -> list[str]:
    """Over all tables (runs grouped by ``table``): the trot gait and trot rhythm shares, each
    the mean of the tables' shares with its 95% interval over tables
    (:mod:`~astrocpg.studies.analysis.replication`), the gait's locking (the measure its label
    thresholds) and its trot share at other thresholds, and whether the tables differ from
    each other in their trot gait share (a permutation test)."""
    from ..analysis.gait import THRESHOLDS
    from ..analysis.replication import (gait_measures, group_by_table, interval_words,
                                        share_over_tables)

    tables = list(group_by_table(rows, ("table",)).values())
    n, runs = len(tables), len(rows)
    gait = share_over_tables([[r["gait"] for r in t] for t in tables], "trot")
    rhythm = share_over_tables([[r["rhythm"] for r in t] for t in tables], "trot")
    m = gait_measures(tables)
    differ = m["gait_trot_tables_differ_p"]
    lock = m["gait_locking_mean"]
    return [f"all {n} table{'s' if n != 1 else ''} ({runs} runs; each table's share first, "
            f"then the mean over tables with its 95% interval over tables): gait (footfalls) "
            f"trot {interval_words(gait)}, rhythm (thigh bursts) trot "
            f"{interval_words(rhythm)}",
            f"gait measures: locking (the smallest foot's; the label needs 0.7) "
            + (f"{lock:.2f}" if np.isfinite(lock) else "n/a (no run read that far)")
            + "; trot gait share by locking threshold: "
            + ", ".join(f"{m[f'gait_trot_share_at_{x:g}']:.0%} at {x:g}" for x in THRESHOLDS)
            + f"; footfall phases alone {m['gait_trot_share_at_0']:.0%}; do the tables differ "
            f"in their trot share? " + (f"permutation p = {differ:.2g}" if np.isfinite(differ)
                                        else "one table only")]


GAIT_COLUMNS = ("final_speed_m_per_s", *(f"final_{c}" for c in MEASURE_COLUMNS))
"""What :func:`final_gaits` says of each trained trial (study results carry them per seed):
the rhythm (``final_rhythm``, thigh-extensor bursts) and the gait (``final_gait``, footfalls,
with ``final_gait_reason`` when it is none)."""


def final_gaits(models, tables: np.ndarray, *, seconds: float = 5.0,
                seed: int = 1, populations: Any = None) -> list[dict[str, Any]]:
    """The rhythm and the gait of each trained table (volt, (trials, 8, 8)) with learning off:
    one run of ``seconds`` for all of them, both read over its second half
    (:func:`~astrocpg.studies.analysis.gait.trial_measures`), and the mean forward speed; one
    dict of :data:`GAIT_COLUMNS` per trial. Table ``b`` runs with seed ``seed + b`` (give a
    training's seed: each table on the network and noise it trained with; ``populations``:
    its population table, None: the built-in rows)."""
    from .simulate import simulate_closed_loop

    result = simulate_closed_loop(models, seconds=seconds, seed=seed, n_trials=len(tables),
                                  weights=tables, record_traces=False, spikes=("motor",),
                                  progress=False, populations=populations)
    t, i = result.spikes["motor"]
    rows = []
    for b in range(len(tables)):
        g = trial_measures(t, i, result.cpg.layout, result.robot, b, seconds / 2, seconds)
        rows.append({"final_speed_m_per_s": float(result.robot.torso_velocity[b, :, 0].mean()),
                     **{f"final_{k}": v for k, v in g.items()}})
    return rows


FIGURES = "figures"


def plot_training(folder: str | Path, *, trial: int = 0, seconds: float = 10.0,
                  out: str | Path | None = None, overwrite: bool = False, fmt: str = "png",
                  window: tuple[float, float] | None = None,
                  progress: bool = True, record: dict[str, Any] | None = None) -> list[Path]:
    """weights, training, thigh_extensor_activity and gait figures of one trial of the
    training in ``folder`` (from a run of ``seconds`` with its trained weights; ``window``
    within it, default its last 2 s), and the trace figures of the trial's last recorded
    session (a training's ``record_every``) if any, in ``recording_trialTT_sessionSSSS/``; into
    ``out`` (default ``folder/figures``, which each plot replaces whole); returns the paths.
    ``record``: the plot's settings as its manifest records them (the window drawn is added)."""
    from ..figures import plots
    from ..figures.save import save_figure, save_figures
    from ..figures.traces import FIGURE_FUNCTIONS, trace_figures
    from ..outputs.result import load

    folder = as_path(folder, "folder")
    # the default folder belongs to this command: replaced whole on every plot
    target = Path(out) if out is not None else folder / FIGURES
    OutputFolder(target, overwrite=overwrite or out is None, inputs=[folder]).check()
    training = load(folder)
    if not 0 <= trial < training.n_trials:
        raise InputError(f"{folder} has {training.n_trials} trial(s)",
                         culprit=setting("trial", trial))
    if window is not None and window[0] >= seconds:
        raise InputError(f"starts after the {seconds:g} s run with the trained weights "
                         f"({setting('seconds')})",
                         culprit=setting("window", f"{window[0]:g} {window[1]:g}"))
    recorded = sorted(s for b, s in training.recordings if b == trial)
    result, weights = replay(folder, seconds=seconds, progress=progress)
    b = trial
    names = [f"{n}.{fmt}" for n in ("weights", "training", "thigh_extensor_activity", "gait")]
    window = (window[0], min(window[1], seconds)) if window is not None \
        else (max(0.0, seconds - 2.0), seconds)
    written = [target / n for n in names]
    # a step per figure; a recorded session adds a step per kind of figure, then per file
    bar = Bar(total=len(names) + (len(FIGURE_FUNCTIONS) if recorded else 0), unit="step",
              desc="plot", disable=not progress)
    with bar, OutputFolder(target, overwrite=overwrite or out is None, inputs=[folder]) as tmp:
        save_figure(plots.plot_weights(weights[b] * 1e3, trial=b), tmp / names[0])
        bar.update(1)
        save_figure(plots.plot_training_curves(folder / "sessions.csv"), tmp / names[1])
        bar.update(1)
        save_figure(plots.plot_thigh_extensor_activity(result.spikes, result.cpg.layout,
                                                       trial=b, window=window), tmp / names[2])
        bar.update(1)
        t, i = result.spikes["motor"]
        g = leg_phases(t, i, result.cpg.layout, b, min(1.0, seconds / 5), seconds)
        m = trial_measures(t, i, result.cpg.layout, result.robot, b, seconds / 2, seconds)
        labels = (f"rhythm {m['rhythm']}, gait {m['gait']}"
                  + (f" ({m['gait_reason']})" if m["gait_reason"] else "")
                  + f" (second half of {seconds:g} s)")
        save_figure(plots.plot_gait(result.robot, b, phase_matrix(g["phases"]), g,
                                    window=window, labels=labels), tmp / names[3])
        bar.update(1)
        if recorded:
            session = recorded[-1]
            rec = training.recording(trial, session)
            sub = f"recording_trial{trial:02d}_session{session:04d}"
            # a recorded session is one trial (0); the window: within it, else all of it
            figures = trace_figures(rec, 0, on_part=lambda: bar.update(1))
            bar.finish()
            # the files, on a bar of their own: a bar's total is never changed on the way
            with Bar(total=len(figures), unit="file", desc="plot: saving",
                     disable=not progress) as saving:
                paths = save_figures(figures, tmp / sub, fmt,
                                     on_saved=lambda: saving.update(1))
            written += [target / sub / p.name for p in paths]
        files = dict(zip(names, FIGURE_FILES))
        if recorded:
            files[sub + "/"] = "figures of the trial's last recorded session"
        write_manifest(tmp, command="plot", seed=1, models_json={}, files=files,
                       settings={**(record or {"trial": b, "seconds": seconds,
                                                "window": None, "format": fmt}),
                                 "folder": os.path.abspath(folder),
                                 "window_drawn": list(window)})
    return written


FIGURE_FILES = ("the trial's trained 8x8 inter-limb table (mV)",
                "mean reward, final x and session length per session (mean +- std over trials)",
                "thigh-extensor activity of the 4 limbs in the window",
                "gait diagram (foot contact) with the run's rhythm and gait labels, and the "
                "rhythm's inter-limb phase matrix (thigh-extensor bursts)")
