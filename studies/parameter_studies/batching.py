"""``batch = "auto"`` in a study file: the seeds per run that finish the study soonest on the
workers at hand.

For each candidate batch size the study's seeds are split into runs as they would be
(consecutive seeds, per condition and sweep point), each run costed with the machine's measured
:class:`~astrocpg.studies.parameter_studies.trial_cost.TrialCost` and the simulated time of its busiest
seed, and the runs scheduled longest first on the workers, the way the study dispatches them (a
free worker takes the next run). The batch with the shortest projected wall time wins; within
2 % of it the largest batch wins (it spends the least CPU).

A seed's simulated time is its training's length: at most ``sessions x L_max``, which is all
that is known before a study has run. A study's ``plan_from`` (an earlier study's folder)
gives each seed the length it trained in that study of the same conditions
(``measured_lengths``), so that a condition whose robots walk longer (longer sessions) is
costed longer than one whose robots fall.

One batch for every group leaves a core idle at the end when the groups do not share out
evenly (5 conditions on 2 workers: the fifth runs alone; or one condition trains longer than
the other). So the choice is then refined group by group: a group may be split into smaller
runs than the others (runs of ``b`` consecutive seeds and the rest: 19 and 1 of 20) when that
shortens the projected wall time by more than 2 % (on the 2-core machine's measured cost shape,
3 conditions of 20 seeds on 2 workers: runs of 20, 20, 10 and 10, 15 % sooner than three runs
of 20; 5 conditions: four runs of 20 and one condition as two runs of 10, 10 % sooner).
Splitting never comes free: each run pays the fixed part of the cost again, which is why two
conditions of equal length on two workers stay one run each.

With a ``scheduler`` the cost is measured where the command runs, not on the cluster's machines.
Only the ratio of the fixed part to a trial's part matters to the choice, but that ratio does
vary between machines, targets and sittings (about 4 trials' with Cython, about 13 with numpy,
on the same 2-core machine), so on a cluster unlike the submitting machine give ``batch`` a
number.
"""

from __future__ import annotations

import heapq
import math
from typing import Any, Callable, Mapping, Sequence, Union

from .trial_cost import TrialCost

TIE = 0.02  # projected wall times within 2 % count as equal: the larger batch wins
MAX_RUNS_PER_WORKER = 8  # smaller batches are never faster: the fixed cost per run dominates

#: a group's simulated seconds per trial: one figure for every seed (``sessions x L_max``), or
#: each seed's own (measured in an earlier study)
Lengths = Union[float, Mapping[int, float]]


def run_simulated(lengths: Lengths, first: int, n: int) -> float:
    """Simulated seconds of the run of seeds ``first .. first+n-1``: its busiest seed's (the
    run's trials step together until the last one has done its sessions)."""
    if isinstance(lengths, Mapping):
        return max(float(lengths[s]) for s in range(first, first + n))
    return float(lengths)


def longest_first_makespan(run_seconds: Sequence[float], workers: int) -> list[float]:
    """Each worker's busy time when runs are started longest first, each on the worker that is
    free first (what the study's dispatcher does); the study's wall time is the maximum."""
    loads = [0.0] * max(1, workers)
    heapq.heapify(loads)
    for s in sorted(run_seconds, reverse=True):
        heapq.heappush(loads, heapq.heappop(loads) + s)
    return sorted(loads, reverse=True)


def choose_batch(groups: Sequence[tuple[Sequence[int], Lengths]], *, workers: int,
                 cost: TrialCost, split: Callable[[Sequence[int], int], list[tuple[int, int]]],
                 fits: Callable[[int], bool] = lambda n: True) -> dict[str, Any]:
    """The batch size for ``groups`` (one per condition and sweep point: its seeds and the
    simulated seconds of one trial's training, ``sessions x L_max``, or each seed's as
    measured: :data:`Lengths`) on ``workers``.

    split(seeds, batch): the runs ``(first seed, n)`` a batch size gives (the study's own
    rule); fits(n): whether a run of ``n`` trials fits in memory alongside the others. Returns
    ``batch`` (seeds per run), ``split`` (``{group index: seeds per run}`` for the groups split
    into smaller runs than ``batch``: :func:`refine_groups`), ``workers``, ``projected_s``
    (wall), ``cpu_s``, ``runs``, ``run_seconds`` (``[(group index, first seed, projected
    CPU s)]``: the dispatcher starts the longest first) and, for comparison, ``candidates``
    (``{batch: projected wall s}``, one batch for every group) and ``uniform_projected_s``
    (``batch`` for every group)."""
    n_groups = len(groups)
    # batch sizes that give different splits, from one run per group to ~8 runs per worker
    most_runs = max(1, math.ceil(MAX_RUNS_PER_WORKER * workers / n_groups))

    def sizes(n_seeds: int) -> list[int]:  # the uniform candidates
        return sorted({math.ceil(n_seeds / k) for k in range(1, min(n_seeds, most_runs) + 1)})

    def planned(batches: Sequence[int]) -> list[tuple[int, int, float]]:
        return [(g, first, cost.run_seconds(n, run_simulated(lengths, first, n)))
                for g, ((seeds, lengths), b) in enumerate(zip(groups, batches))
                for first, n in split(seeds, b)]

    def costed(batches: Sequence[int]) -> tuple[float, float, int]:
        runs = [s for _, _, s in planned(batches)]
        return longest_first_makespan(runs, workers)[0], sum(runs), len(runs)

    largest = max(len(seeds) for seeds, _ in groups)
    table: dict[int, tuple[float, float, int]] = {}
    for b in sizes(largest):
        if fits(b):
            table[b] = costed([b] * n_groups)
    if not table:
        return {"batch": None}
    # each uniform batch refined group by group (any smaller run size: runs of b seeds and the
    # rest, so one long group may give a short run to the worker that would idle); the shortest
    # projected wall wins, and within 2 % of it the plan that spends the least CPU
    plans = []
    for b in table:
        batches = refine_groups(groups, [b] * n_groups, costed,
                                lambda n: list(range(1, n + 1)), fits)
        wall, cpu, n_runs = costed(batches)
        plans.append((wall, cpu, -b, batches, n_runs))
    best = min(p[0] for p in plans)
    wall, cpu, neg_b, batches, n_runs = min((p for p in plans if p[0] <= best * (1 + TIE)),
                                            key=lambda p: (p[1], p[2]))
    batch = -neg_b
    return {"batch": batch, "workers": workers, "projected_s": wall, "cpu_s": cpu,
            "runs": n_runs, "candidates": {b: round(t[0], 1) for b, t in table.items()},
            "uniform_projected_s": table[batch][0],
            "split": {i: b for i, b in enumerate(batches) if b != batch},
            "run_seconds": planned(batches)}


def refine_groups(groups: Sequence[tuple[Sequence[int], Lengths]], batches: list[int],
                  costed: Callable[[Sequence[int]], tuple[float, float, int]],
                  sizes: Callable[[int], list[int]],
                  fits: Callable[[int], bool]) -> list[int]:
    """``batches`` (one per group) with single groups split into smaller runs, one change at a
    time, while a change shortens the projected wall time by more than ``TIE``; among equal
    walls the change that spends the least CPU. Batches only shrink, so this ends."""
    batches = list(batches)
    wall, cpu, _ = costed(batches)
    while True:
        best: tuple[float, float, int, int] | None = None
        for g, (seeds, _) in enumerate(groups):
            for b in sizes(len(seeds)):
                if b >= min(batches[g], len(seeds)) or not fits(b):
                    continue
                trial = batches[:g] + [b] + batches[g + 1:]
                w, c, _ = costed(trial)
                if w < wall * (1 - TIE) and (best is None or (w, c) < best[:2]):
                    best = (w, c, g, b)
        if best is None:
            return batches
        wall, cpu, g, b = best
        batches[g] = b
