"""Gait of a controller: the phase of each leg's thigh-extensor bursts relative to FR, a gait
label from those phases, and stance/swing per leg (foot contact, or extensor bursts when the
robot has no foot touch sensors).

Labels (phases relative to FR, within ``tolerance`` of a cycle):
  trot  FR-RL and FL-RR in phase, the two pairs in anti-phase;
  pace  FR-RR and FL-RL in phase, pairs in anti-phase;
  bound FR-FL and RR-RL in phase, pairs in anti-phase;
  walk  four distinct quarter phases (0, 1/4, 1/2, 3/4 in some order);
  none  anything else, or phases that are not stable (resultant length below ``min_locking``).
"""

from __future__ import annotations

from typing import Any

import numpy as np

from ...network import LEGS, Layout
from .rhythm import cycle_period, detect_bursts, phase_locking

LEG_INDEX = {leg: k for k, leg in enumerate(LEGS)}


def _circ(a: float, b: float) -> float:
    d = abs(a - b) % 1.0
    return min(d, 1.0 - d)


def leg_phases(times: np.ndarray, indices: np.ndarray, layout: Layout, trial: int,
               t_start: float, t_stop: float) -> dict[str, Any]:
    """Phase of each leg's thigh-extensor burst onsets within FR's cycles (circular mean) and
    how locked it is (resultant length, 1 = every cycle the same)."""
    keep = (times >= t_start) & (times < t_stop)
    t, i = times[keep], indices[keep]
    bursts = {leg: detect_bursts(t, i, layout.motor_neurons(trial, k, "thigh_extensor"), t_stop,
                                 t_start=t_start)
              for k, leg in enumerate(layout.legs)}
    phases, locking = {}, {}
    for leg, b in bursts.items():
        phases[leg], locking[leg] = phase_locking(bursts["FR"], b)
    period = cycle_period(bursts["FR"])
    return {"phases": phases, "locking": locking, "period": period,
            "bursts": {leg: b for leg, b in bursts.items()}}


def gait_label(phases: dict[str, float], locking: dict[str, float], *, tolerance: float = 0.15,
               min_locking: float = 0.7) -> str:
    if any(not np.isfinite(phases[leg]) or locking[leg] < min_locking for leg in LEGS):
        return "none"
    p = phases

    def pairs(a: tuple[str, str], b: tuple[str, str]) -> bool:
        return (_circ(p[a[0]], p[a[1]]) <= tolerance and _circ(p[b[0]], p[b[1]]) <= tolerance
                and abs(_circ(p[a[0]], p[b[0]]) - 0.5) <= tolerance)

    if pairs(("FR", "RL"), ("FL", "RR")):
        return "trot"
    if pairs(("FR", "RR"), ("FL", "RL")):
        return "pace"
    if pairs(("FR", "FL"), ("RR", "RL")):
        return "bound"
    quarters = sorted(round((p[leg] % 1.0) * 4) % 4 for leg in LEGS)
    if quarters == [0, 1, 2, 3] and all(
            _circ(p[leg], round(p[leg] * 4) / 4) <= tolerance / 2 for leg in LEGS):
        return "walk"
    return "none"


def trial_gait(times: np.ndarray, indices: np.ndarray, layout: Layout, trial: int,
               t_start: float, t_stop: float) -> dict[str, Any]:
    """One trial's gait between t_start and t_stop: ``gait`` (label), ``period_s`` and each
    leg's ``phase_<leg>`` and ``locking_<leg>`` relative to FR (what evaluate and a study's
    gait.csv report)."""
    g = leg_phases(times, indices, layout, trial, t_start, t_stop)
    row: dict[str, Any] = {"gait": gait_label(g["phases"], g["locking"]),
                           "period_s": float(g["period"])}
    for leg in LEGS[1:]:
        row[f"phase_{leg}"] = float(g["phases"][leg])
        row[f"locking_{leg}"] = float(g["locking"][leg])
    return row


def phase_matrix(phases: dict[str, float]) -> np.ndarray:
    """(4, 4) phase of leg j relative to leg i."""
    v = np.array([phases[leg] for leg in LEGS])
    return (v[None, :] - v[:, None]) % 1.0


def weight_structure(table: np.ndarray, w_max: float) -> dict[str, float]:
    """How a trained 8x8 table looks: limb pairs (of 12) whose 2x2 block holds two inhibitory and
    two excitatory synapses (the paper's structure with astrocytes), and the share of inter-limb
    weights above 0.9 w_max (saturation, the paper's ablation)."""
    n_legs = table.shape[0] // 2
    mixed = 0
    values = []
    for a in range(n_legs):
        for b in range(n_legs):
            if a == b:
                continue
            block = table[2 * a:2 * a + 2, 2 * b:2 * b + 2]
            values.append(block.ravel())
            mixed += int((block < 0).sum() == 2 and (block > 0).sum() == 2)
    v = np.concatenate(values)
    return {"mixed_limb_pairs": mixed, "limb_pairs": n_legs * (n_legs - 1),
            "share_above_0.9_w_max": float(np.mean(v > 0.9 * w_max))}
