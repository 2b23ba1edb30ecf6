"""Match the non-glial control's depression to the astrocytes' (k_H of
``homeostatic_interlimb_synapse``).

The astrocyte rule depresses the weights into pool y by ``eta_ADO * [ADO_y]`` per step; the
control by ``eta_ADO * k_H * A_H``, with ``A_H`` pool y's spike count low-pass filtered with
``tau_H``. The mean of ``A_H`` is ``tau_H`` times the pool's mean rate (spikes per second), so
the two rules remove the same weight on average when

    k_H = mean [ADO] / (tau_H * mean thigh-pool rate),

both means taken over the same recorded sessions of a reference training with astrocytes, over
every thigh pool, trial and step (the learning rule's other factors, Progress and zeta(w), are
common to both rules).

    astrocpg train --sessions 100 --trials 4 --seed 1 --record-every 5 --spikes motor \\
        --traces astrocyte_ADO --out out/reference_astro
    python docs/beyond/homeostatic_control/match.py out/reference_astro [--tau-H 1]

prints the two means, their ratio and k_H, and writes them as JSON with ``--json FILE``.
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

import numpy as np

import astrocpg as ac

THIGH = ("thigh_flexor", "thigh_extensor")


def session_means(rec: "ac.Result") -> tuple[float, float, float]:
    """(mean [ADO] over the thigh pools' astrocytes and steps, mean spikes per second of a
    thigh pool, seconds) of one recorded session."""
    ado = rec.trace("astrocyte_ADO")
    seconds = float(rec.seconds)
    values = np.asarray(ado.values, dtype=float)  # (t, astrocytes)
    legs = rec.layout.legs
    spikes = sum(len(rec.spike_times("motor", trial=0, leg=leg, pool=pool))
                 for leg in legs for pool in THIGH)
    n_pools = len(legs) * len(THIGH)
    return float(values.mean()), spikes / n_pools / seconds, seconds


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("training", type=Path, help="a training folder with recorded sessions")
    p.add_argument("--tau-H", type=float, default=1.0, help="tau_H in seconds (default 1)")
    p.add_argument("--json", type=Path, help="write the figures to this file")
    a = p.parse_args(argv)
    t = ac.load(a.training)
    recs = t.recordings
    if not recs:
        print(f"{a.training}: no recorded sessions (train with --record-every)", file=sys.stderr)
        return 2
    ado_s = rate_s = total = 0.0
    for (trial, session), _ in sorted(recs.items()):
        m_ado, m_rate, seconds = session_means(t.recording(trial, session))
        ado_s += m_ado * seconds
        rate_s += m_rate * seconds
        total += seconds
    mean_ado, mean_rate = ado_s / total, rate_s / total
    k_H = mean_ado / (a.tau_H * mean_rate)
    out = {"training": str(a.training), "recorded_sessions": len(recs),
           "recorded_seconds": total, "mean_ADO": mean_ado,
           "mean_thigh_pool_rate_Hz": mean_rate, "tau_H_s": a.tau_H, "k_H": k_H,
           "astrocpg": ac.__version__}
    print(f"{len(recs)} recorded sessions, {total:.1f} s: mean [ADO] {mean_ado:.4g}, "
          f"mean thigh-pool rate {mean_rate:.4g} spikes/s, tau_H {a.tau_H} s -> k_H = {k_H:.4g}")
    if a.json:
        a.json.write_text(json.dumps(out, indent=1) + "\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())
