"""Match the non-glial control's depression to the astrocytes' (k_H of
``homeostatic_interlimb_synapse``), from a training's sessions table.

The astrocyte rule depresses the weights into pool y by ``eta_ADO * [ADO_y]`` per step; the
control by ``eta_ADO * k_H * A_H``, where ``A_H`` is pool y's spike count low-pass filtered with
``tau_H``. Over a long stretch of time:

* [ADO] is released in steps of ``r_ADO`` that decay with ``tau_ADO`` and is never reset between
  sessions, so its mean is ``r_ADO * tau_ADO * (releases per second of one astrocyte)``;
* the mean of ``A_H`` is ``tau_H * (spikes per second of one thigh pool)``.

The two rules remove the same weight on average when ``k_H`` makes the two means equal:

    k_H = r_ADO * tau_ADO * releases / (tau_H * thigh-pool spikes)

with both counts summed over the same sessions (a training's ``sessions.csv`` has one row per
seed and session with ``adenosine_releases`` and ``spikes_thigh_motor``; a study's
``results.csv(.gz)`` the same columns). The learning rule's other factors (Progress, zeta(w))
multiply both alike. It also prints how often the astrocytes release at the most their
refractory period allows (one release per ``refractory_ADO``).

    python docs/beyond/homeostatic_control/match.py docs/ablation/faster_loop/results.csv.gz \\
        --condition astrocytes --json docs/beyond/homeostatic_control/match.json

``--traces TRAINING`` checks the mean [ADO] against the recorded traces of a training made with
``--record-every N --traces astrocyte_ADO``.
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

import numpy as np
import pandas as pd

import astrocpg as ac
from astrocpg.models import DEFAULT_MODELS

THIGH_POOLS_PER_SEED = 8  # flexor and extensor of four limbs: one astrocyte each


def _astrocyte_constant(name: str) -> float:
    """A constant of the built-in astrocyte, in SI (s, or dimensionless)."""
    return float(DEFAULT_MODELS.astrocyte.parameters.get(name).value)


def match(table: pd.DataFrame, tau_H: float) -> dict[str, float]:
    """The figures of the match over the rows of ``table`` (sessions of seeds with astrocytes)."""
    r_ADO, tau_ADO = _astrocyte_constant("r_ADO"), _astrocyte_constant("tau_ADO")
    refractory = _astrocyte_constant("refractory_ADO")
    seconds = float(table["length_s"].sum())
    releases, spikes = float(table["adenosine_releases"].sum()), float(table["spikes_thigh_motor"].sum())
    per_astrocyte = releases / (THIGH_POOLS_PER_SEED * seconds)
    per_session = table["adenosine_releases"] / (THIGH_POOLS_PER_SEED * table["length_s"])
    return {
        "sessions": int(len(table)), "seconds": seconds,
        "releases_per_s_per_astrocyte": per_astrocyte,
        "release_limit_per_s": 1.0 / refractory,
        "share_of_sessions_within_5pct_of_the_limit": float(np.mean(per_session >= 0.95 / refractory)),
        "mean_ADO": r_ADO * tau_ADO * per_astrocyte,
        "thigh_pool_rate_Hz": spikes / (THIGH_POOLS_PER_SEED * seconds),
        "tau_H_s": tau_H,
        "k_H": r_ADO * tau_ADO * releases / (tau_H * spikes),
    }


def traces_mean_ado(training: Path) -> tuple[float, float]:
    """(time-weighted mean [ADO] over the recorded sessions' traces, seconds recorded)."""
    t = ac.load(training)
    total = weighted = 0.0
    for (trial, session) in sorted(t.recordings):
        rec = t.recording(trial, session)
        values = np.asarray(rec.trace("astrocyte_ADO").values, dtype=float)
        weighted += float(values.mean()) * float(rec.seconds)
        total += float(rec.seconds)
    if not total:
        raise SystemExit(f"{training}: no recorded sessions with astrocyte_ADO traces")
    return weighted / total, total


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("table", type=Path, help="a training's sessions.csv or a study's results.csv(.gz)")
    p.add_argument("--condition", help="only the rows of this condition (a study's table)")
    p.add_argument("--tau-H", type=float, default=1.0, help="tau_H in seconds (default 1)")
    p.add_argument("--traces", type=Path, help="a training with recorded astrocyte_ADO traces")
    p.add_argument("--json", type=Path, help="write the figures to this file")
    a = p.parse_args(argv)
    table = pd.read_csv(a.table)
    if a.condition is not None:
        table = table[table["condition"] == a.condition]
    if table.empty:
        print(f"{a.table}: no rows{' of ' + a.condition if a.condition else ''}", file=sys.stderr)
        return 2
    out = {"table": str(a.table), "condition": a.condition} | match(table, a.tau_H)
    print(f"{out['sessions']} sessions, {out['seconds']:.0f} s: each astrocyte releases "
          f"{out['releases_per_s_per_astrocyte']:.3f} times a second (the limit is "
          f"{out['release_limit_per_s']:.3f}; {100 * out['share_of_sessions_within_5pct_of_the_limit']:.1f}% "
          f"of sessions within 5% of it); mean [ADO] {out['mean_ADO']:.4g}; thigh pool "
          f"{out['thigh_pool_rate_Hz']:.1f} spikes/s; tau_H {a.tau_H:g} s -> k_H = {out['k_H']:.4g}")
    if a.traces is not None:
        mean, seconds = traces_mean_ado(a.traces)
        out |= {"traces": str(a.traces), "traces_mean_ADO": mean, "traces_seconds": seconds}
        print(f"recorded traces of {a.traces} ({seconds:.0f} s): mean [ADO] {mean:.4g}")
    out["astrocpg"] = ac.__version__
    if a.json:
        a.json.write_text(json.dumps(out, indent=1) + "\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())
