"""``batch = "auto"`` in a study file: the number of seeds per run that finishes the study
soonest on the workers at hand.

For each candidate batch size the study's seeds are split into runs as they would be
(consecutive seeds, per condition and sweep point), each run costed with the machine's measured
:class:`~astrocpg.studies.runtime.trial_cost.TrialCost` and its longest possible sessions
(``sessions x L_max``), and the runs scheduled longest first on the workers, the way the study
dispatches them (a free worker takes the next run). The batch with the shortest projected
wall time wins; within 2 % of it the largest batch wins (it spends the least CPU). Every run is
costed at its longest: how much shorter one condition's sessions will be is not known before
it has run. With ``--scheduler`` the cost is measured where the command runs, not on the
cluster's machines. Only the ratio of the fixed part to a trial's part matters to the choice,
but that ratio does vary between machines (about 5 and about 14 on two sittings of the same
2-core machine), so on a cluster unlike the submitting machine give ``batch`` a number.
"""

from __future__ import annotations

import heapq
import math
from typing import Any, Callable, Sequence

from ..runtime.trial_cost import TrialCost

TIE = 0.02  # projected wall times within 2 % count as equal: the larger batch wins
MAX_RUNS_PER_WORKER = 8  # smaller batches are never faster: the fixed cost per run dominates


def longest_first_makespan(run_seconds: Sequence[float], workers: int) -> list[float]:
    """Each worker's busy time when runs are started longest first, each on the worker that is
    free first (what the study's dispatcher does); the study's wall time is the maximum."""
    loads = [0.0] * max(1, workers)
    heapq.heapify(loads)
    for s in sorted(run_seconds, reverse=True):
        heapq.heappush(loads, heapq.heappop(loads) + s)
    return sorted(loads, reverse=True)


def choose_batch(groups: Sequence[tuple[Sequence[int], float]], *, workers: int,
                 cost: TrialCost, split: Callable[[Sequence[int], int], list[tuple[int, int]]],
                 fits: Callable[[int], bool] = lambda n: True) -> dict[str, Any]:
    """The batch size for ``groups`` (one per condition and sweep point: its seeds and the
    simulated seconds of one trial's training, ``sessions x L_max``) on ``workers``.

    split(seeds, batch): the runs ``(first seed, n)`` a batch size gives (the study's own
    rule); fits(n): whether a run of ``n`` trials fits in memory alongside the others. Returns
    ``batch``, ``workers``, ``projected_s`` (wall), ``cpu_s``, ``runs`` and, for comparison,
    ``candidates``: ``{batch: projected wall s}``.
    """
    largest = max(len(seeds) for seeds, _ in groups)
    n_groups = len(groups)
    # batch sizes that give different splits, from one run per group to ~8 runs per worker
    most_runs = max(1, math.ceil(MAX_RUNS_PER_WORKER * workers / n_groups))
    candidates = sorted({math.ceil(largest / k) for k in range(1, min(largest, most_runs) + 1)})
    table: dict[int, tuple[float, float, int]] = {}
    for b in candidates:
        if not fits(b):
            continue
        runs = [cost.run_seconds(n, simulated)
                for seeds, simulated in groups for _, n in split(seeds, b)]
        table[b] = (longest_first_makespan(runs, workers)[0], sum(runs), len(runs))
    if not table:
        return {"batch": None}
    best = min(wall for wall, _, _ in table.values())
    batch = max(b for b, (wall, _, _) in table.items() if wall <= best * (1 + TIE))
    wall, cpu, n_runs = table[batch]
    return {"batch": batch, "workers": workers, "projected_s": wall, "cpu_s": cpu,
            "runs": n_runs, "candidates": {b: round(t[0], 1) for b, t in table.items()}}
