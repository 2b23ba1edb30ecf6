"""Burst and rhythm analysis of spike trains (pure numpy).

A pool bursts when its 20 neurons fire near-synchronously every ~18 ms for ~0.25 s, then falls
silent while its antagonist bursts. Bursts are found on the pool's activity smoothed over a few
inter-volley intervals; the cycle period is the median onset-to-onset interval and phases are
circular means of onsets within the reference pool's cycles.
"""

from __future__ import annotations

from typing import Mapping

import numpy as np


def pool_activity(times: np.ndarray, indices: np.ndarray, neuron_ids: np.ndarray,
                  t_stop: float, dt: float = 1e-3, t_start: float = 0.0) -> np.ndarray:
    """Spike count of the given neurons in each ``dt`` bin of [t_start, t_stop)."""
    ids = np.asarray(neuron_ids)
    sel = np.isin(indices, ids) & (times >= t_start) & (times < t_stop)
    n = max(0, int(round((t_stop - t_start) / dt)))
    k = np.floor((times[sel] - t_start) / dt + 1e-9).astype(int)
    return np.bincount(k[(k >= 0) & (k < n)], minlength=n)


def convolve_same(x: np.ndarray, kernel: np.ndarray) -> np.ndarray:
    """``np.convolve(x, kernel, "same")`` that keeps ``len(x)`` samples also when the kernel is
    longer than ``x`` (a recording shorter than the smoothing window)."""
    x, kernel = np.asarray(x), np.asarray(kernel)
    if len(x) == 0:
        return np.zeros(0)
    start = (len(kernel) - 1) // 2
    return np.convolve(x, kernel, "full")[start:start + len(x)]



def on_runs(on: np.ndarray, step: float, min_gap: float) -> list[list[int]]:
    """The runs of True in ``on`` as [start, stop) sample indices, a gap shorter than
    ``min_gap`` (s, at ``step`` s a sample) bridged: bursts of a pool, stances of a foot."""
    edges = np.diff(np.concatenate([[0], np.asarray(on).astype(int), [0]]))
    starts, stops = np.flatnonzero(edges == 1), np.flatnonzero(edges == -1)
    merged: list[list[int]] = []
    for a, b in zip(starts, stops):
        if merged and (a - merged[-1][1]) * step < min_gap:
            merged[-1][1] = b
        else:
            merged.append([a, b])
    return merged

def detect_bursts(times: np.ndarray, indices: np.ndarray, neuron_ids: np.ndarray,
                  t_stop: float, *, t_start: float = 0.0, dt: float = 1e-3,
                  window: float = 0.04, threshold: float = 0.25, min_gap: float = 0.06,
                  min_duration: float = 0.04, min_spikes: int = 10) -> np.ndarray:
    """Bursts of a pool as an (n, 2) array of onset and offset times (s).

    The activity is smoothed with a ``window``-wide box (longer than the ~18 ms between volleys),
    thresholded at ``threshold`` times its 99th percentile, gaps shorter than ``min_gap`` are
    bridged, and bursts shorter than ``min_duration`` or with fewer than ``min_spikes`` spikes are
    dropped, as are bursts cut by the edges of the recording.
    """
    act = pool_activity(times, indices, neuron_ids, t_stop, dt, t_start).astype(float)
    if act.sum() == 0:
        return np.zeros((0, 2))
    w = max(1, int(round(window / dt)))
    smooth = convolve_same(act, np.ones(w) / w)
    level = threshold * np.percentile(smooth, 99)
    merged = on_runs(smooth > level, dt, min_gap)
    bursts = []
    cum = np.concatenate([[0], np.cumsum(act)])
    for a, b in merged:
        if a == 0 or b >= len(act):  # cut by the recording's edges
            continue
        # refine onset/offset to the first/last spike inside the smoothed burst
        nz = np.flatnonzero(act[a:b])
        if len(nz) == 0:
            continue
        a2, b2 = a + nz[0], a + nz[-1] + 1
        if (b2 - a2) * dt < min_duration or cum[b2] - cum[a2] < min_spikes:
            continue
        bursts.append((t_start + a2 * dt, t_start + b2 * dt))
    return np.array(bursts).reshape(-1, 2)


def cycle_period(bursts: np.ndarray) -> float:
    """Median onset-to-onset interval (s); nan with fewer than two bursts."""
    if len(bursts) < 2:
        return float("nan")
    return float(np.median(np.diff(bursts[:, 0])))


def phase_locking(reference_bursts: np.ndarray, other_bursts: np.ndarray) -> tuple[float, float]:
    """Circular mean phase (0..1) of ``other``'s onsets within ``reference``'s cycles
    (reference onset = 0, its next onset = 1) and how locked it is (resultant length, 1 = the
    same phase in every cycle); (nan, 0) if no onset falls inside a full cycle."""
    ref = reference_bursts[:, 0]
    onsets = other_bursts[:, 0]
    k = np.searchsorted(ref, onsets, side="right") - 1
    inside = (k >= 0) & (k < len(ref) - 1)
    if not inside.any():
        return float("nan"), 0.0
    k = k[inside]
    phases = (onsets[inside] - ref[k]) / (ref[k + 1] - ref[k])
    z = np.mean(np.exp(2j * np.pi * phases))
    return float((np.angle(z) / (2 * np.pi)) % 1.0), float(abs(z))


def burst_phase(reference_bursts: np.ndarray, other_bursts: np.ndarray) -> float:
    """Circular mean phase (0..1) of ``other``'s onsets within ``reference``'s cycles; nan if
    no onset falls inside a full cycle."""
    return phase_locking(reference_bursts, other_bursts)[0]


def rate_per_neuron(times: np.ndarray, indices: np.ndarray, neuron_ids: np.ndarray,
                    t_start: float, t_stop: float) -> float:
    """Mean firing rate per neuron (Hz) of the given neurons over [t_start, t_stop)."""
    ids = np.asarray(neuron_ids)
    sel = np.isin(indices, ids) & (times >= t_start) & (times < t_stop)
    return float(sel.sum() / (len(ids) * (t_stop - t_start)))


def duty_cycle(bursts: np.ndarray) -> float:
    """Mean burst duration over the cycle period."""
    if len(bursts) < 2:
        return float("nan")
    return float(np.mean(bursts[:, 1] - bursts[:, 0]) / cycle_period(bursts))


def neurons_per_volley(times: np.ndarray, indices: np.ndarray, neuron_ids: np.ndarray,
                       bursts: np.ndarray, dt: float = 1e-3) -> float:
    """Mean number of distinct neurons spiking in a volley (a step with >= 3 of the pool's spikes,
    +-1 step) inside bursts: how synchronous the pool fires."""
    ids = np.asarray(neuron_ids)
    sel = np.isin(indices, ids)
    t, i = times[sel], indices[sel]
    counts = []
    for a, b in bursts:
        inside = (t >= a) & (t < b)
        steps = np.round(t[inside] / dt).astype(int)
        if len(steps) == 0:
            continue
        hist = np.bincount(steps - steps.min())
        peaks = np.flatnonzero(hist >= 3) + steps.min()
        last = -10
        for p in peaks:
            if p - last <= 2:
                continue
            near = np.abs(steps - p) <= 1
            counts.append(len(np.unique(i[inside][near])))
            last = p
    return float(np.mean(counts)) if counts else float("nan")


def rhythm_summary(times: np.ndarray, indices: np.ndarray, pools: Mapping[str, np.ndarray],
                   t_stop: float, t_start: float = 1.0) -> dict:
    """Period, phases relative to the thigh flexor, rates, duty cycle and synchrony of a unit
    (pools named thigh_flexor, thigh_extensor, calf_flexor, calf_extensor), after a transient."""
    keep = times >= t_start
    t, i = times[keep], indices[keep]
    bursts = {name: detect_bursts(t, i, ids, t_stop, t_start=t_start)
              for name, ids in pools.items()}
    ref = bursts["thigh_flexor"]
    return {
        "period": cycle_period(ref),
        "phases": {name: burst_phase(ref, b) for name, b in bursts.items()
                   if name != "thigh_flexor"},
        "rates": {name: rate_per_neuron(t, i, ids, t_start, t_stop) for name, ids in pools.items()},
        "duty_cycle": {name: duty_cycle(b) for name, b in bursts.items()},
        "neurons_per_volley": {name: neurons_per_volley(t, i, ids, bursts[name])
                               for name, ids in pools.items()},
        "bursts": {name: len(b) for name, b in bursts.items()},
    }
