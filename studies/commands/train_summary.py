"""What a training did, per trial: its sessions, speed, share of full-length sessions and
falls (:func:`train_summary`, the manifest's ``per_trial``), the lines printed of it
(:func:`format_train`), and the recorded sessions whose traces overflowed float32
(:func:`recorded_overflow`, read from the folder)."""

from __future__ import annotations

from pathlib import Path
from typing import Any, Mapping

import numpy as np

from ..outputs.result import Result
from ..outputs.writing import read_manifest


def _last(n: int, of: int) -> str:
    """"the last 20" when there were at least 20, else "all 3": say how many there were."""
    return f"the last {n}" if of >= n else f"all {of}"


def _trial_line(b: Any, x: Mapping[str, Any]) -> str:
    """The summary line of one trial (``x``: its entry of :func:`train_summary`'s per_trial;
    a manifest written before the counts and falls were kept gives the counts from
    ``sessions``)."""
    n = int(x["sessions"])
    speed_n = int(x.get("speed_sessions", min(n, SPEED_LAST)))
    full_n = int(x.get("full_sessions", min(n, FULL_LAST)))
    line = (f"trial {b}: {n} sessions; mean forward speed over {_last(SPEED_LAST, speed_n)} "
            f"sessions: {x['mean_speed_last20_m_per_s']:.3f} m/s; "
            f"{x['full_length_share_last50']:.0%} of {_last(FULL_LAST, full_n)} sessions "
            f"reached L_max")
    falls = x.get("falls")
    if falls:
        line += (f"; the robot fell in {falls} of {n} sessions (last: session "
                 f"{x['last_fall_session']}, ended at {x['last_fall_length_s']:.2f} s once "
                 f"not upright for L_non_alive)")
    elif falls == 0:
        line += "; it never fell"
    return line


def format_train(result: Result) -> list[str]:
    """One line per trial of a training's summary: sessions, speed, share of full sessions,
    and its falls (how many, and the last one's session and time)."""
    return [_trial_line(b, x) for b, x in sorted((result.summary.get("per_trial") or {}).items(),
                                                  key=lambda kv: int(kv[0]))]


SPEED_LAST, FULL_LAST = 20, 50  # sessions the summary's speed and full-length share cover


def train_summary(rows: list[dict], n_trials: int, L_max: float) -> dict[str, Any]:
    """Per trial: sessions done, mean forward speed over the last 20 (``speed_sessions``:
    how many there were), share of the last 50 (``full_sessions``) that reached L_max, and its
    falls: ``falls`` sessions that ended before L_max without diverging (a session ends early
    only once the robot has been not upright for L_non_alive), ``last_fall_session`` and
    ``last_fall_length_s`` (when, in the session's simulated s, that session ended); and a
    printable line per trial."""
    per_trial: dict[int, dict[str, Any]] = {}
    lines: dict[int, str] = {}
    for b in range(n_trials):
        mine = [r for r in rows if r["trial"] == b]
        if not mine:
            continue
        last_speed, last_full = mine[-SPEED_LAST:], mine[-FULL_LAST:]
        speed = float(np.mean([r["mean_forward_speed_m_per_s"] for r in last_speed]))
        full = float(np.mean([r["length_s"] >= L_max - 1e-6 for r in last_full]))
        fell = [r for r in mine
                if r["length_s"] < L_max - 1e-6 and not _true(r.get("diverged", False))]
        per_trial[b] = {"sessions": len(mine), "mean_speed_last20_m_per_s": speed,
                        "full_length_share_last50": full, "speed_sessions": len(last_speed),
                        "full_sessions": len(last_full), "falls": len(fell),
                        "last_fall_session": int(fell[-1]["session"]) if fell else None,
                        "last_fall_length_s": float(fell[-1]["length_s"]) if fell else None}
        lines[b] = _trial_line(b, per_trial[b])
    return {"per_trial": per_trial, "lines": lines}


def _true(value: Any) -> bool:
    """A session row's flag, as the loop keeps it (bool) or a CSV gives it back ("1")."""
    return value in (True, 1, "1", "True", "true")


def recorded_overflow(out: Path) -> dict[str, dict[str, Any]]:
    """``{recorded session folder: {trace: counts}}`` of the training's recordings whose
    traces overflowed float32 (their manifests say so), read from the folder so that it holds
    across resumes."""
    found: dict[str, dict[str, Any]] = {}
    for folder in sorted((out / "recordings").glob("trial*_session*")):
        manifest = read_manifest(folder) or {}
        over = (manifest.get("results") or {}).get("trace_overflow")
        if over:
            found[folder.name] = over
    return found


__all__ = ["FULL_LAST", "SPEED_LAST", "format_train", "recorded_overflow", "train_summary"]
