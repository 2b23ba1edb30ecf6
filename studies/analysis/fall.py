"""Did the robot fall, and when: read from the ``alive`` samples a run recorded.

The model's own definition decides (``models/alive.py``: the torso counts as upright while
its z axis points up by at least ``Thres_z_alive``; the recording holds that indicator per
sample): the robot *fell* at the first recorded sample that is not upright. Every summary
(``run``, ``gait``, ``evaluate``) and every figure of the robot says so in the same words
(:func:`fall_words`), so that a robot that ends on its back is never reported by its upright
share alone.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np


@dataclass(frozen=True)
class Fall:
    """The first fall of one trial: ``t_s`` the time (simulated s) of its first sample not
    upright, ``upright_at_end`` whether it was upright again at its last sample, ``down_share``
    the share of samples not upright."""

    t_s: float
    upright_at_end: bool
    down_share: float


def first_fall(t: Any, alive: Any) -> Fall | None:
    """The first fall in ``alive`` (one trial's samples, bool) at times ``t`` (s), or None
    when every sample is upright (or nothing was recorded)."""
    alive = np.asarray(alive, dtype=bool).reshape(-1)
    t = np.asarray(t, dtype=float).reshape(-1)
    if alive.size == 0 or alive.all():
        return None
    k = int(np.argmin(alive))
    return Fall(t_s=float(t[k]) if k < t.size else math.nan,
                upright_at_end=bool(alive[-1]), down_share=float(1.0 - alive.mean()))


def falls(t: Any, alive: Any) -> list[Fall | None]:
    """:func:`first_fall` of each trial of ``alive`` (trials, samples)."""
    alive = np.asarray(alive, dtype=bool)
    return [first_fall(t, a) for a in alive.reshape(len(alive), -1)] if alive.ndim > 1 \
        else [first_fall(t, alive)]


def fall_words(fall: Fall | None) -> str:
    """``fell at 1.23 s (not upright from then on)``, ``fell at 1.23 s (upright again at the
    end; not upright 12% of the time)``, or ``""`` when it did not fall."""
    if fall is None:
        return ""
    if fall.upright_at_end:
        return (f"fell at {fall.t_s:.2f} s (upright again at the end; not upright "
                f"{fall.down_share:.0%} of the time)")
    return f"fell at {fall.t_s:.2f} s (not upright at the end)"


__all__ = ["Fall", "first_fall", "falls", "fall_words"]
