"""Do Brian2's numpy and Cython targets give the same numbers? Runs ``astrocpg unit`` and
``astrocpg run`` under both with the same seed and compares what they wrote.

    python benchmarks/codegen_agreement.py [--seconds 3] [--seed 1]

Prints, per command: whether every population's spike times and indices are identical, the
largest difference of any recorded trace, and for ``run`` each target's distance and the largest
joint-angle difference. Cython's first build compiles for minutes (then cached).
"""

from __future__ import annotations

import argparse
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np

CLI = [sys.executable, "-m", "astrocpg.studies.cli"]


def produce(command: str, target: str, seconds: float, seed: int, out: Path) -> None:
    subprocess.run([*CLI, command, "--seconds", str(seconds), "--seed", str(seed), "--codegen",
                    target, "--no-progress", "--out", str(out)], check=True,
                   stdout=subprocess.DEVNULL)


def compare(a: Path, b: Path) -> list[str]:
    lines = []
    with np.load(a / "spikes.npz") as x, np.load(b / "spikes.npz") as y:
        same = all(np.array_equal(x[k], y[k]) for k in x.files) and x.files == y.files
        n = sum(len(x[k]) for k in x.files if k.endswith("_times"))
        lines.append(f"  spikes identical: {same} ({n} spikes under numpy)")
    with np.load(a / "traces.npz") as x, np.load(b / "traces.npz") as y:
        worst = max((float(np.nanmax(np.abs(x[k] - y[k]))) for k in x.files
                     if x[k].dtype.kind == "f" and x[k].size), default=0.0)
        lines.append(f"  largest trace difference: {worst:.3g}")
    if (a / "robot.npz").exists():
        with np.load(a / "robot.npz") as x, np.load(b / "robot.npz") as y:
            dq = float(np.max(np.abs(x["joint_angles"] - y["joint_angles"])))
            dist = [float(z["torso_position"][0, -1, 0] - z["torso_position"][0, 0, 0])
                    for z in (x, y)]
        lines.append(f"  distance numpy {dist[0]:+.3f} m, cython {dist[1]:+.3f} m; largest "
                     f"joint-angle difference {dq:.3g} rad")
    return lines


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--seconds", type=float, default=3.0)
    ap.add_argument("--seed", type=int, default=1)
    args = ap.parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        for command in ("unit", "run"):
            outs = {t: Path(tmp) / f"{command}_{t}" for t in ("numpy", "cython")}
            for target, out in outs.items():
                produce(command, target, args.seconds, args.seed, out)
            print(f"{command} --seconds {args.seconds:g} --seed {args.seed}, numpy vs cython:")
            for line in compare(outs["numpy"], outs["cython"]):
                print(line)


if __name__ == "__main__":
    main()
