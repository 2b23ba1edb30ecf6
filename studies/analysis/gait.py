"""Rhythm and gait of a controller, and the structure of its inter-limb table.

Two measures, never one for the other:

* the **rhythm** is what the CPG does: the phase of each leg's thigh-extensor burst onsets
  within FR's cycles (:func:`leg_phases`), labelled by :func:`phase_label`. It exists whether
  or not the robot stands: a robot on its back keeps its rhythm.
* the **gait** is what the feet do while the robot stands, measured against the CPG's
  stepping cycle: over the *upright part* of the analysed window (up to the first sample the
  alive model does not count as upright, :mod:`~astrocpg.studies.analysis.fall`), each cycle
  between two of FR's thigh-extensor burst onsets gives each foot a **stance phase**, the
  circular mean of the phases of the samples in which its touch sensor reads force (a cycle
  in which the foot does not both touch and lift gives none). A foot's phase is the circular
  mean of its stance phases, its locking their resultant length over *all* the cycles (a cycle
  without a stance counts as a phase lost), and the feet's phases relative to FR's foot are
  labelled by :func:`phase_label` (:func:`footfall_gait`). A stance phase weighs every sample
  of contact, so the short contacts of a foot bouncing on touchdown or brushing the ground in
  swing move it little. A run gets a gait label only when

  - the robot's feet have touch sensors (else: ``no contact data``);
  - it stood for at least :data:`MIN_GAIT_SHARE` of the analysed window (else:
    ``fell at 2.16 s``);
  - its CPG has at least :data:`MIN_STEPS` + 1 FR bursts while upright, the stepping cycles
    (else: ``no rhythm``);
  - every foot stepped (touched and lifted) in at least :data:`MIN_STEPS` cycles (else:
    ``too few steps``);
  - every foot keeps its stance phase from cycle to cycle (locking at least ``min_locking``,
    else: ``not periodic``: the feet do not follow the rhythm).

  Otherwise the gait is ``none`` and ``gait_reason`` says why; a periodic footfall that is
  none of the named patterns is ``none`` with the reason ``no named pattern``.

Labels (phases relative to FR, within ``tolerance`` of a cycle):
  trot  FR-RL and FL-RR in phase, the two pairs in anti-phase;
  pace  FR-RR and FL-RL in phase, pairs in anti-phase;
  bound FR-FL and RR-RL in phase, pairs in anti-phase;
  walk  four distinct quarter phases (0, 1/4, 1/2, 3/4 in some order);
  none  anything else, or phases that are not stable (resultant length below ``min_locking``).
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from ...network import LEGS, Layout
from .fall import first_fall
from .rhythm import cycle_period, detect_bursts, phase_locking

LEG_INDEX = {leg: k for k, leg in enumerate(LEGS)}
NAMED = ("trot", "pace", "bound", "walk")
"""The labels that name a gait or rhythm (``none`` names none)."""

MIN_GAIT_SHARE = 0.8
"""A gait is read only from a run that stood for at least this share of the analysed window
(4 of the 5 s that ``evaluate`` and a study's final runs analyse)."""
MIN_STEPS = 4
"""... in which the CPG made at least this many stepping cycles and every foot stepped in at
least this many of them."""
MIN_SWING_S = 0.02
"""A foot steps in a cycle when it touches the ground and is off it for at least this long in
that cycle (a foot that never lifts has no stance phase)."""

def _circ(a: float, b: float) -> float:
    d = abs(a - b) % 1.0
    return min(d, 1.0 - d)


def leg_phases(times: np.ndarray, indices: np.ndarray, layout: Layout, trial: int,
               t_start: float, t_stop: float) -> dict[str, Any]:
    """The rhythm: phase of each leg's thigh-extensor burst onsets within FR's cycles (circular
    mean) and how locked it is (resultant length, 1 = every cycle the same)."""
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


def phase_label(phases: dict[str, float], locking: dict[str, float], *, tolerance: float = 0.15,
                min_locking: float = 0.7) -> str:
    """The one classifier of the rhythm and of the gait: a label from the legs' phases.

    Parameters
    ----------
    phases : dict
        Each leg's phase relative to FR, 0..1 (``{"FR": 0, "FL": ..., "RR": ..., "RL": ...}``):
        thigh-extensor burst onsets (the rhythm) or stance phases (the gait).
    locking : dict
        Each leg's locking, 0..1: the resultant length of its phases over the cycles (1: the
        same phase in every cycle).
    tolerance : float
        How far (a share of a cycle) a phase may be from the pattern's (default 0.15).
    min_locking : float
        The locking every leg needs for any label (default 0.7); below it: ``none``.

    Returns
    -------
    str
        ``trot`` (FR-RL and FL-RR in phase, the pairs in anti-phase), ``pace`` (FR-RR and
        FL-RL), ``bound`` (FR-FL and RR-RL), ``walk`` (four distinct quarter phases) or
        ``none``.

    Examples
    --------
    >>> from astrocpg.studies.analysis.gait import phase_label
    >>> trot = {"FR": 0.0, "FL": 0.5, "RR": 0.5, "RL": 0.0}
    >>> phase_label(trot, {leg: 0.9 for leg in trot})
    'trot'
    >>> phase_label(trot, {leg: 0.65 for leg in trot})   # the same phases, loosely locked
    'none'
    >>> phase_label(trot, {leg: 0.65 for leg in trot}, min_locking=0.6)
    'trot'
    """
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


def trial_rhythm(times: np.ndarray, indices: np.ndarray, layout: Layout, trial: int,
                 t_start: float, t_stop: float) -> dict[str, Any]:
    """One trial's rhythm between t_start and t_stop: ``rhythm`` (label),
    ``rhythm_period_s`` and each leg's ``rhythm_phase_<leg>`` and ``rhythm_locking_<leg>``
    relative to FR."""
    return _rhythm_row(leg_phases(times, indices, layout, trial, t_start, t_stop))


def _rhythm_row(g: dict[str, Any]) -> dict[str, Any]:
    row: dict[str, Any] = {"rhythm": phase_label(g["phases"], g["locking"]),
                           "rhythm_period_s": float(g["period"])}
    for leg in LEGS[1:]:
        row[f"rhythm_phase_{leg}"] = float(g["phases"][leg])
        row[f"rhythm_locking_{leg}"] = float(g["locking"][leg])
    return row


def stance_phases(t: np.ndarray, on: np.ndarray, cycles: np.ndarray) -> np.ndarray:
    """One foot's stance phase (0..1) in each cycle between consecutive ``cycles`` onsets (s):
    the circular mean of the phases of the samples ``t`` where the foot is ``on`` the ground;
    nan for a cycle in which it does not touch, or is off the ground less than
    :data:`MIN_SWING_S`."""
    t = np.asarray(t, dtype=float)
    on = np.asarray(on, dtype=bool)
    out = np.full(max(len(cycles) - 1, 0), np.nan)
    if out.size == 0 or t.size < 2:
        return out
    step = float(np.median(np.diff(t)))
    k = np.searchsorted(cycles, t, side="right") - 1
    inside = (k >= 0) & (k < len(cycles) - 1)
    k, x, c = k[inside], t[inside], on[inside]
    phase = (x - cycles[k]) / (cycles[k + 1] - cycles[k])
    z = np.bincount(k[c], weights=np.cos(2 * np.pi * phase[c]), minlength=out.size) \
        + 1j * np.bincount(k[c], weights=np.sin(2 * np.pi * phase[c]), minlength=out.size)
    touched = np.bincount(k[c], minlength=out.size) > 0
    off_s = np.bincount(k[~c], minlength=out.size) * step
    steps = touched & (off_s >= MIN_SWING_S)
    out[steps] = (np.angle(z[steps]) / (2 * np.pi)) % 1.0
    return out


def _no_gait(reason: str, share: float) -> dict[str, Any]:
    row: dict[str, Any] = {"gait": "none", "gait_reason": reason, "gait_share": share,
                           "gait_period_s": math.nan, "gait_duty_factor": math.nan}
    for leg in LEGS[1:]:
        row[f"gait_phase_{leg}"] = math.nan
        row[f"gait_locking_{leg}"] = math.nan
    row["gait_locking_FR"] = row["gait_locking"] = math.nan
    return row


def footfall_gait(t: np.ndarray, alive: np.ndarray, foot_force: np.ndarray, t_start: float,
                  t_stop: float, cycles: np.ndarray, *, min_locking: float = 0.7
                  ) -> dict[str, Any]:
    """One trial's gait between t_start and t_stop from its robot recording (sample times
    ``t``, ``alive`` (samples,) and ``foot_force`` (samples, 4 legs)) and its stepping
    ``cycles`` (onsets of FR's thigh-extensor bursts, s): ``gait`` (label), ``gait_reason`` (why
    it is ``none``; empty for a named gait), ``gait_share`` (the share of the window it was
    read over: upright, before the first fall), ``gait_period_s`` (median interval between FR's
    successive stance centres), ``gait_duty_factor`` (mean share of the time a foot is on the
    ground) and each foot's ``gait_phase_<leg>`` (its stance phase relative to FR's foot) and
    ``gait_locking_<leg>`` (see the module's description)."""
    t = np.asarray(t, dtype=float)
    force = np.asarray(foot_force, dtype=float)
    fall = first_fall(t, alive)
    end = t_stop if fall is None else min(t_stop, max(t_start, fall.t_s))
    share = (end - t_start) / (t_stop - t_start) if t_stop > t_start else 0.0
    if force.size == 0 or not np.all(np.isfinite(force)):
        return _no_gait("no contact data", share)
    if share < MIN_GAIT_SHARE:
        return _no_gait(f"fell at {fall.t_s:.2f} s", share)
    cycles = np.asarray(cycles, dtype=float)
    cycles = cycles[(cycles >= t_start) & (cycles <= end)]
    if len(cycles) < MIN_STEPS + 1:
        return _no_gait("no rhythm", share)
    sel = (t >= t_start) & (t < end)
    on = force[sel] > 0
    per = {leg: stance_phases(t[sel], on[:, k], cycles) for k, leg in enumerate(LEGS)}
    if min(int(np.isfinite(p).sum()) for p in per.values()) < MIN_STEPS:
        return _no_gait("too few steps", share)
    own, locking = {}, {}
    for leg, p in per.items():
        z = np.sum(np.exp(2j * np.pi * p[np.isfinite(p)])) / len(p)
        own[leg], locking[leg] = float(np.angle(z) / (2 * np.pi)) % 1.0, float(abs(z))
    phases = {leg: (own[leg] - own["FR"]) % 1.0 for leg in LEGS}
    fr = per["FR"]
    centres = cycles[:-1] + fr * np.diff(cycles)
    gaps = np.diff(centres)[np.isfinite(np.diff(centres))]
    period = float(np.median(gaps)) if gaps.size else math.nan
    duty = float(on.mean())
    label = phase_label(phases, locking, min_locking=min_locking)
    if any(locking[leg] < min_locking for leg in LEGS):
        reason = "not periodic"
    else:
        reason = "" if label in NAMED else "no named pattern"
    row: dict[str, Any] = {"gait": label, "gait_reason": reason, "gait_share": share,
                           "gait_period_s": period, "gait_duty_factor": duty}
    for leg in LEGS[1:]:
        row[f"gait_phase_{leg}"] = float(phases[leg])
        row[f"gait_locking_{leg}"] = float(locking[leg])
    row["gait_locking_FR"] = float(locking["FR"])
    row["gait_locking"] = float(min(locking.values()))
    return row


def trial_measures(times: np.ndarray, indices: np.ndarray, layout: Layout, recording: Any,
                   trial: int, t_start: float, t_stop: float) -> dict[str, Any]:
    """Rhythm (``trial_rhythm``, from the motor spikes ``times``, ``indices``) and gait
    (:func:`footfall_gait`, from the robot ``recording``) of one trial over [t_start, t_stop):
    the columns every command and table of gaits carries."""
    g = leg_phases(times, indices, layout, trial, t_start, t_stop)
    return {**_rhythm_row(g),
            **footfall_gait(recording.t, recording.alive[trial], recording.foot_force[trial],
                            t_start, t_stop, g["bursts"]["FR"][:, 0])}


MEASURE_COLUMNS = ("rhythm", "gait", "gait_reason", "gait_share", "rhythm_period_s",
                   "rhythm_phase_FL", "rhythm_phase_RR", "rhythm_phase_RL",
                   "rhythm_locking_FL", "rhythm_locking_RR", "rhythm_locking_RL",
                   "gait_period_s", "gait_duty_factor", "gait_phase_FL", "gait_phase_RR",
                   "gait_phase_RL", "gait_locking_FL", "gait_locking_RR", "gait_locking_RL",
                   "gait_locking_FR", "gait_locking")
"""The columns of :func:`trial_measures`, in table order. ``gait_locking`` is the continuous
measure the gait label thresholds: the smallest of the four feet's locking (the label needs
every foot at least ``min_locking``, 0.7); nan where the run was not read that far (it fell,
too few steps)."""

THRESHOLDS = (0.5, 0.6, 0.7, 0.8)
"""The locking thresholds at which every summary also gives the trot gait share (the label
itself uses 0.7): a reader sees how much of the share the threshold sets."""


def gait_at(row: dict[str, Any], min_locking: float) -> str:
    """The gait label a run would get at another locking threshold.

    Parameters
    ----------
    row : dict
        A run's gait measures (:func:`footfall_gait`, a row of ``evaluation.csv`` as read
        from the file too): ``gait_phase_<leg>``, ``gait_locking_<leg>``, ``gait_locking``.
    min_locking : float
        The threshold; 0: the footfall phases alone, however loosely they lock.

    Returns
    -------
    str
        The label (:func:`phase_label`); ``none`` where the run was not read that far (it
        fell, too few steps, no rhythm) or was written before the locking of FR's foot was
        kept (no ``gait_locking`` column).
    """
    def num(key: str) -> float:
        try:
            return float(row.get(key, math.nan))  # a CSV row's text too
        except (TypeError, ValueError):
            return math.nan

    if not np.isfinite(num("gait_locking")):
        return "none"
    phases = {"FR": 0.0, **{leg: num(f"gait_phase_{leg}") for leg in LEGS[1:]}}
    locking = {leg: num(f"gait_locking_{leg}") for leg in LEGS}
    return phase_label(phases, locking, min_locking=min_locking)



def phase_matrix(phases: dict[str, float]) -> np.ndarray:
    """(4, 4) phase of leg j relative to leg i."""
    v = np.array([phases[leg] for leg in LEGS])
    return (v[None, :] - v[:, None]) % 1.0


def weight_structure(table: np.ndarray, w_max: float, w_min: float | None = None
                     ) -> dict[str, float]:
    """How a trained 8x8 table looks, over its inter-limb blocks (12 limb pairs, 48 weights):

    * ``mixed_limb_pairs``: limb pairs whose 2x2 block holds two inhibitory and two excitatory
      synapses (the paper's structure with astrocytes); ``excitatory_limb_pairs`` and
      ``inhibitory_limb_pairs``: blocks all of one sign;
    * ``share_excitatory`` and ``share_inhibitory``: weights above and below 0 (the signs);
    * ``share_above_0.9_w_max`` and ``share_below_0.9_w_min``: weights within 10% of a bound's
      magnitude of it (saturation at either bound; ``w_min`` defaults to ``-w_max``, the
      model's, so that 0.9 w_min is -0.045 mV for the default -0.05 mV)."""
    w_min = -w_max if w_min is None else w_min
    n_legs = table.shape[0] // 2
    mixed = exc = inh = 0
    values = []
    for a in range(n_legs):
        for b in range(n_legs):
            if a == b:
                continue
            block = table[2 * a:2 * a + 2, 2 * b:2 * b + 2]
            values.append(block.ravel())
            mixed += int((block < 0).sum() == 2 and (block > 0).sum() == 2)
            exc += int((block > 0).all())
            inh += int((block < 0).all())
    v = np.concatenate(values)
    return {"mixed_limb_pairs": mixed, "excitatory_limb_pairs": exc,
            "inhibitory_limb_pairs": inh, "limb_pairs": n_legs * (n_legs - 1),
            "share_excitatory": float(np.mean(v > 0)), "share_inhibitory": float(np.mean(v < 0)),
            "share_above_0.9_w_max": float(np.mean(v > 0.9 * w_max)),
            "share_below_0.9_w_min": float(np.mean(v < w_min + 0.1 * abs(w_min)))}
