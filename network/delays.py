"""Inter-limb delays: from the projection's delay table to the order in which the limbs integrate
within one 1 ms step.

Every pair of limbs has a delay of 0 or one step (``delay_X_Y`` of the inter-limb synapse model).
One step is what every synapse of Brian2's schedule gives: the input of step n's spikes reaches
its target at step n + 1. A delay of 0 means that limb Y, within the same step, integrates with
the spikes limb X fired in that step; so X must integrate and fire *before* Y. The limbs are
therefore put into *stages*: the limbs of one stage integrate together, the stages one after
another, and a pair has a delay of 0 exactly when its source's stage comes before its target's.

A table can be built this way when its 0 ms pairs order the limbs in stages (a strict weak order).
The default (1 ms everywhere) is one stage: the network as it always was. The authors' code (0 ms
from a lower-index to a higher-index limb, docs/model.md) is four stages, FR, FL, RR, RL. Anything else,
e.g. FR->FL at 0 ms while FR->RR and RR->FL stay at 1 ms, cannot be ordered and is refused,
naming a pair.
"""

from __future__ import annotations

import itertools
from typing import Any, Sequence

import numpy as np

from ..errors import InputError
from ..models import ModelSet


def delay_steps(models: ModelSet, legs: Sequence[str], dt: Any) -> dict[tuple[str, str], int]:
    """The delay of every ordered pair of ``legs`` in steps (0 or 1), from the inter-limb synapse
    model's ``delay_X_Y`` parameters (a pair without one: one step, as every synapse)."""
    params = models.interlimb_synapse.parameters
    step = float(dt)
    out = {}
    for a, b in itertools.permutations(legs, 2):
        name = f"delay_{a}_{b}"
        if name not in params:
            out[a, b] = 1
            continue
        seconds = models.value(name)
        if not np.isfinite(seconds) or not (abs(seconds) <= 1e-12 * step
                                            or abs(seconds - step) <= 1e-9 * step):
            raise InputError(f"must be 0 ms or one step ({step * 1e3:g} ms), got "
                             f"{seconds * 1e3:g} ms",
                             culprit=f"interlimb_synapse.{name}")
        out[a, b] = 0 if abs(seconds) <= 1e-12 * step else 1
    return out


def limb_stages(models: ModelSet, legs: Sequence[str], dt: Any) -> tuple[tuple[int, ...], ...]:
    """The stages (tuples of leg positions in ``legs``) in the order they integrate within a
    step, such that the delay from limb a to limb b is 0 exactly when a's stage comes first.
    One stage holding every leg when every delay is one step."""
    legs = tuple(legs)
    delays = delay_steps(models, legs, dt)
    n = len(legs)
    if all(d == 1 for d in delays.values()):
        return (tuple(range(n)),)
    best: tuple[int, ...] | None = None
    # a handful of limbs: try every assignment of stages, keep the one with the fewest stages
    for stage in itertools.product(range(n), repeat=n):
        if all((stage[i] < stage[j]) == (delays[legs[i], legs[j]] == 0)
               for i, j in itertools.permutations(range(n), 2)):
            if best is None or len(set(stage)) < len(set(best)):
                best = stage
    if best is None:
        raise InputError(_why_not(delays, legs), culprit="interlimb_synapse delays")
    levels = sorted(set(best))
    return tuple(tuple(i for i in range(n) if best[i] == s) for s in levels)


def _completion(zero: set[tuple[str, str]], legs: tuple[str, ...]) -> list[tuple[str, str]]:
    """The fewest pairs to set to 0 ms as well so that the 0 ms pairs order the limbs in stages
    (empty when none can: two limbs at 0 ms both ways)."""
    n, best = len(legs), None
    for stage in itertools.product(range(n), repeat=n):
        at = dict(zip(legs, stage))
        if all(at[a] < at[b] for a, b in zero):
            more = sorted((a, b) for a, b in itertools.permutations(legs, 2)
                          if at[a] < at[b] and (a, b) not in zero)
            if best is None or len(more) < len(best):
                best = more
    return best or []


def _why_not(delays: dict[tuple[str, str], int], legs: tuple[str, ...]) -> str:
    """One line naming pairs that no order of the limbs within a step can give, why, and the
    fewest further 0 ms pairs that would make the table one.

    Why a 1 ms pair can fail: the limbs integrate one stage after another within a step, and a
    limb's inter-limb input is summed, just before its stage integrates, from the latest spikes
    of each source; a source of an earlier stage has already fired this step. So a pair is at
    0 ms exactly when its source's stage comes first, and at 1 ms when it does not: a limb
    cannot read one limb's spikes of this step and another's (of the same earlier stage) of
    the step before."""
    zero = {p for p, d in delays.items() if d == 0}
    for a, b in zero:
        if (b, a) in zero:
            return (f"delay_{a}_{b} and delay_{b}_{a} are both 0 ms: two limbs cannot each "
                    f"integrate before the other within one step")
    more = _completion(zero, legs)
    hint = ("; e.g. also set " + ", ".join(f"delay_{a}_{b}=0*ms" for a, b in more)
            if more else "")
    why = ("(a limb that integrates after another within a step reads that limb's spikes of "
           "the same step: its pair is 0 ms; a 1 ms pair's target must integrate before or "
           "with its source)")
    for a, b in sorted(zero):
        for c in legs:
            if c in (a, b):
                continue
            # a before b; c must come after a, before b, or both
            if (a, c) not in zero and (c, b) not in zero:
                return (f"delay_{a}_{b} is 0 ms, so {a} integrates before {b}; {c} must then "
                        f"follow {a} (delay_{a}_{c} = 0 ms) or precede {b} "
                        f"(delay_{c}_{b} = 0 ms), and neither is {why}{hint}")
    return ("the 0 ms pairs do not order the limbs in stages (a 0 ms pair needs its source "
            f"to integrate before its target, and every 1 ms pair the opposite or together)"
            f"{hint}")
