"""What bounds the speed-up of splitting a command's trials over processes: the cost of one
step of the closed loop that every process pays whatever its trials (``per_step``: Brian2's
code objects, the bridge, the senses), against the cost each trial adds (``per_trial_step``).

    python benchmarks/step_costs.py                         # NumPy (the default target)
    ASTROCPG_CODEGEN=cython python benchmarks/step_costs.py # Cython

Runs ``astrocpg run --trials N --seconds S --spikes none --traces none --workers 1`` for a few
N as typed (nothing recorded but the robot, so the loop dominates) and reads each manifest's
simulation wall time; the least-squares line ``wall = steps * (per_step + N * per_trial_step)``
gives both costs. The simulation of T trials over k processes cannot then take less than
``(per_step + ceil(T / k) * per_trial_step) / (per_step + T * per_trial_step)`` of one
process's (start-up, writing and the transfer of the recordings come on top): printed for 20
trials on 2, 4 and 8 processes. A first untimed run compiles what the target needs. Run it on
a quiet machine.
"""

from __future__ import annotations

import argparse
import json
import math
import os
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np


def simulated_wall(trials: int, seconds: float, where: Path, name: str = "") -> float:
    """The simulation's wall time (the manifest's) of one run as typed, into a new folder."""
    out = where / (name or f"run{trials}")
    cmd = [sys.executable, "-m", "astrocpg", "run", "--trials", str(trials), "--seconds",
           f"{seconds:g}", "--spikes", "none", "--traces", "none", "--workers", "1",
           "--no-progress", "--out", str(out)]
    done = subprocess.run(cmd, capture_output=True, text=True)
    if done.returncode != 0:
        raise SystemExit(f"{' '.join(cmd[2:])}: exit {done.returncode}: {done.stderr.strip()}")
    manifest = json.loads((out / "manifest.json").read_text())
    wall = manifest.get("wall_seconds", manifest.get("results", {}).get("wall_seconds"))
    if wall is None:
        raise SystemExit(f"{out}/manifest.json records no wall_seconds")
    return float(wall)


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--seconds", type=float, default=3.0, help="simulated s per run")
    ap.add_argument("--trials", type=int, nargs="+", default=[1, 10, 20])
    args = ap.parse_args(argv)
    steps = round(args.seconds * 1000)
    with tempfile.TemporaryDirectory() as tmp:
        where = Path(tmp)
        simulated_wall(2, 0.1, where, "warm-up")  # untimed: compiled code cached, files warm
        walls = [simulated_wall(n, args.seconds, where) for n in args.trials]
    x = np.column_stack([np.ones(len(args.trials)), args.trials]) * steps
    (per_step, per_trial_step), *_ = np.linalg.lstsq(x, np.array(walls), rcond=None)
    target = os.environ.get("ASTROCPG_CODEGEN", "numpy")
    print(f"code generation: {target}; {args.seconds:g} simulated s per run")
    for n, w in zip(args.trials, walls):
        print(f"  {n:3d} trials: {w:.2f} s simulated in one process")
    print(f"per step: {per_step * 1e3:.3f} ms whatever the trials; per trial and step: "
          f"{per_trial_step * 1e3:.4f} ms (ratio {per_step / per_trial_step:.1f})")
    for k in (2, 4, 8):
        bound = (per_step + math.ceil(20 / k) * per_trial_step) / (per_step + 20 * per_trial_step)
        print(f"  20 trials over {k} processes: the simulation takes at least {bound:.2f} x "
              f"one process's")
    return 0


if __name__ == "__main__":
    sys.exit(main())
