"""How busy a study keeps its workers: runs a small study on a local Dask cluster (or a study
file of yours), or reads the timeline of a study that ran (``--folder``), and prints its
timeline, the utilisation (run seconds / (workers x wall)), the seconds workers sat free while
runs had not started (idle while pending) and each worker's idle share of the wall (first start
to last end: waiting, or done before the last run ended); with ``--folder``, also each run's
busiest seed's simulated seconds (from the folder's results table; the runs that finished in
one attempt), its wall seconds per simulated second and the CPU seconds the plan projected.

    python benchmarks/study_utilisation.py [--workers 8] [--runs 16] [--sessions 2]
                                           [--batch 1] [--session-length 1*second]
                                           [--study FILE] [--out DIR]
    python benchmarks/study_utilisation.py --folder out/ablation [--workers 2]

The default is 8 workers x 16 runs of one seed (half with astrocytes, half without), which
reproduces on two cores the shape of a 16-worker x 32-run study (runs <= 2 x
workers: Dask does not treat them as root tasks). Oversubscribed cores make every run slower,
but a worker that is free while runs wait shows as idle all the same.
"""

from __future__ import annotations

import argparse
import json
import os
import tempfile
import time
from pathlib import Path

os.environ.setdefault("OMP_NUM_THREADS", "1")

from astrocpg.studies.parameter_studies.study import load_study, run_study  # noqa: E402
from astrocpg.studies.parameter_studies.tables import timeline, utilisation  # noqa: E402

STUDY = """
[study]
name = "utilisation"
sessions = {sessions}
seeds = {{ first = 1, count = {seeds} }}
batch = {batch}
[base]
L_max = "{length}"
[conditions.astrocytes]
astrocytes = true
[conditions.no_astrocytes]
astrocytes = false
"""


def measure(path: Path, out: Path, workers: int) -> tuple[float, list, dict]:
    """Run the study file ``path`` into ``out`` on ``workers`` local workers: the command's
    wall seconds, its timeline rows and :func:`utilisation` of them."""
    study = load_study(path)
    t0 = time.time()
    run_study(study, out, workers=workers, progress=False)
    total = time.time() - t0
    rows = timeline(study, out)
    return total, rows, utilisation(rows, workers)


def read_timeline(folder: Path) -> list[dict]:
    """The rows of a study folder's ``timeline.csv``, times as numbers."""
    from astrocpg.studies.parameter_studies.tables import read_timeline as read

    return read(folder, culprit="--folder")


def run_costs(folder: Path) -> list[str]:
    """Per run of a study folder that kept its results table and ran in one attempt
    (:func:`~astrocpg.studies.parameter_studies.measured.measured_run_costs`, what
    ``--plan-from`` fits the cost to): the simulated seconds of its busiest seed (what its
    wall time follows), its wall seconds per simulated second and, where the folder's
    study.json holds a plan (``batch = "auto"``, ``--plan-from``), the CPU seconds it was
    projected to take."""
    from astrocpg.studies.parameter_studies.measured import TABLES, measured_run_costs

    if not any((folder / name).is_file() for name in TABLES):
        return []
    try:
        index = json.loads((folder / "study.json").read_text())
        projected = (index.get("batch_choice") or {}).get("run_seconds") or {}
    except (OSError, ValueError):
        projected = {}
    lines = [f"{'run':44s} {'trials':>6s} {'busiest s':>10s} {'s per sim s':>11s} "
             f"{'projected s':>11s}"]
    for r in measured_run_costs(folder, culprit="--folder"):
        plan = projected.get(r.run_id) if isinstance(projected, dict) else None
        lines.append(f"{r.run_id:44s} {r.n_trials:6d} {r.busiest_s:10.1f} "
                     f"{r.per_simulated_s:11.3f} {'' if plan is None else f'{plan:.1f}':>11s}")
    return lines


def show(rows: list, stats: dict, workers: int, total: float | None) -> None:
    first = min(r["started"] for r in rows)
    names: dict[str, str] = {}
    print(f"{'run':44s} {'worker':>6s} {'start':>7s} {'end':>7s}")
    for r in rows:
        w = names.setdefault(r["worker"], f"w{len(names)}")
        end = r["ended"] - first if r["ended"] is not None else float("nan")
        print(f"{r['run_id']:44s} {w:>6s} {r['started'] - first:7.1f} {end:7.1f}")
    command = f"command {total:.1f} s, " if total is not None else ""
    print(f"\n{len(rows)} runs on {workers} workers ({len(names)} ran a run): {command}"
          f"first start to last end {stats['wall_s']:.1f} s")
    print(f"utilisation {stats['utilisation']:.0%}; idle while runs waited: "
          f"{stats['idle_pending_s']:.1f} worker-seconds, longest stretch "
          f"{stats['longest_idle_pending_s']:.1f} s")
    for w, share in stats["worker_idle_share"].items():
        print(f"worker {names.get(w, w)}: busy {stats['worker_busy_s'][w]:.1f} s, idle "
              f"{share:.1%} of the wall")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--workers", type=int, default=None,
                    help="workers (default 8; with --folder, those that ran a run)")
    ap.add_argument("--runs", type=int, default=16, help="runs (even: two conditions)")
    ap.add_argument("--sessions", type=int, default=2)
    ap.add_argument("--batch", type=int, default=1)
    ap.add_argument("--session-length", default="1*second", help="L_max of every session")
    ap.add_argument("--study", help="a study file instead of the generated one")
    ap.add_argument("--out", help="study folder (default: a temporary one)")
    ap.add_argument("--folder", help="read this study folder's timeline.csv; run nothing")
    args = ap.parse_args()
    if args.folder:
        rows = read_timeline(Path(args.folder))
        stats = utilisation(rows, args.workers or 0)
        show(rows, stats, stats["workers"], None)
        costs = run_costs(Path(args.folder))
        if costs:
            print()
            print("\n".join(costs))
        return
    workers = args.workers or 8
    with tempfile.TemporaryDirectory(prefix="astrocpg-utilisation-") as tmp:
        if args.study:
            path = Path(args.study)
        else:
            path = Path(tmp) / "utilisation.toml"
            path.write_text(STUDY.format(sessions=args.sessions, seeds=args.runs // 2 * args.batch,
                                         batch=args.batch, length=args.session_length))
        out = Path(args.out) if args.out else Path(tmp) / "out"
        total, rows, stats = measure(path, out, workers)
        show(rows, stats, workers, total)


if __name__ == "__main__":
    main()
