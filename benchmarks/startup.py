"""Start-up of the commands against the import of Brian2 + MuJoCo, medians of interleaved
repeats (the goal: ``run --seconds 0.1`` within 1.3 x the import; ``describe`` under 0.5 s).

    python benchmarks/startup.py [--repeats 5]

Each command is a fresh process, as a user or a test starts it. The baseline is a plain
``python -c "import brian2, mujoco"`` (Brian2's own import, pylab and pytest included where
installed; astrocpg imports Brian2 without them). ``describe`` is
timed warm (its cache filled by the first, discarded, call). Run it on a quiet machine: the
figures scale with the machine's load.
"""

from __future__ import annotations

import argparse
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

CLI = [sys.executable, "-m", "astrocpg.studies.cli"]


def commands(tmp: Path) -> dict[str, list[str]]:
    return {
        "import brian2 + mujoco": [sys.executable, "-c", "import brian2, mujoco"],
        "run --seconds 0.1": [*CLI, "run", "--seconds", "0.1", "--no-progress", "--overwrite",
                              "--out", str(tmp / "run")],
        # the same with its figure (matplotlib and one figure: drawn only when asked)
        "run --seconds 0.1 --figure": [*CLI, "run", "--seconds", "0.1", "--no-progress",
                                       "--overwrite", "--figure", "--out", str(tmp / "runf")],
        "describe astrocyte": [*CLI, "describe", "astrocyte"],
        "--help": [*CLI, "--help"],
    }


def wall(argv: list[str]) -> float:
    t = time.perf_counter()
    subprocess.run(argv, check=True, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    return time.perf_counter() - t


def medians(repeats: int) -> dict[str, float]:
    """Median wall seconds of each command over ``repeats`` interleaved repeats, after one
    warm-up call each (file cache, describe's cache, .pyc)."""
    with tempfile.TemporaryDirectory() as tmp:
        cmds = commands(Path(tmp))
        for argv in cmds.values():
            wall(argv)
        times: dict[str, list[float]] = {k: [] for k in cmds}
        for _ in range(repeats):
            for name, argv in cmds.items():
                times[name].append(wall(argv))
    return {k: statistics.median(v) for k, v in times.items()}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--repeats", type=int, default=5)
    args = ap.parse_args()
    med = medians(args.repeats)
    base = med["import brian2 + mujoco"]
    print(f"start-up, median of {args.repeats} interleaved repeats (wall s)")
    for name, value in med.items():
        print(f"  {name:<28} {value:6.2f} s   {value / base:5.2f} x the import")
    print(f"run --seconds 0.1 / import: {med['run --seconds 0.1'] / base:.2f} (goal <= 1.3); "
          f"describe {med['describe astrocyte']:.2f} s (goal < 0.5)")


if __name__ == "__main__":
    main()
