"""What the first touch of fresh memory costs, with and without numpy's huge-page advice.

    python benchmarks/fresh_memory.py [--mib 320] [--repeats 3]

Each measurement is a fresh process that allocates one float32 array of ``--mib`` MiB with
numpy and writes it through once (``fill(0)``), as a recorder's arrays are, and reports the CPU
of that alone (user and system, ``getrusage``). ``NUMPY_MADVISE_HUGEPAGE`` is 1 (numpy asks the
kernel for transparent huge pages for arrays of 4 MiB or more: numpy's default on Linux) or 0
(ordinary 4 KiB pages: what every ``astrocpg`` command sets), the two in turn, ``--repeats``
times. The kernel's transparent huge-page settings are printed beside the figures: with
``defrag`` at ``madvise`` the kernel may compact memory to satisfy the advice on first touch.
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
from pathlib import Path

CHILD = r"""
import json, resource, sys
import numpy as np
n = int(sys.argv[1]) * 2 ** 20 // 4
r0 = resource.getrusage(resource.RUSAGE_SELF)
a = np.empty(n, dtype=np.float32)
a.fill(0)
r1 = resource.getrusage(resource.RUSAGE_SELF)
print(json.dumps({"user_s": r1.ru_utime - r0.ru_utime, "sys_s": r1.ru_stime - r0.ru_stime}))
"""


def thp() -> dict[str, str]:
    out = {}
    for name in ("enabled", "defrag"):
        path = Path("/sys/kernel/mm/transparent_hugepage") / name
        try:
            out[name] = path.read_text().strip()
        except OSError:
            out[name] = "unknown"
    return out


def touch(mib: int, advice: str) -> dict[str, float]:
    env = dict(os.environ, NUMPY_MADVISE_HUGEPAGE=advice)
    done = subprocess.run([sys.executable, "-c", CHILD, str(mib)], env=env, check=True,
                          capture_output=True, text=True)
    return json.loads(done.stdout.strip().splitlines()[-1])


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--mib", type=int, default=320)
    ap.add_argument("--repeats", type=int, default=3)
    args = ap.parse_args()
    print(f"transparent huge pages: {thp()}; {args.mib} MiB float32, allocated and filled once")
    rows: dict[str, list[dict[str, float]]] = {"1": [], "0": []}
    for _ in range(args.repeats):
        for advice in rows:
            rows[advice].append(touch(args.mib, advice))
    for advice, label in (("1", "huge-page advice (numpy's default)"),
                          ("0", "4 KiB pages (astrocpg's commands)")):
        sys_s = ", ".join(f"{r['sys_s']:.2f}" for r in rows[advice])
        user_s = ", ".join(f"{r['user_s']:.2f}" for r in rows[advice])
        print(f"{label:<40} system CPU s: {sys_s}; user CPU s: {user_s}")


if __name__ == "__main__":
    main()
