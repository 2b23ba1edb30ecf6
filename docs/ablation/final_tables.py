"""A study's trained inter-limb tables, small enough to keep beside its results.

    python docs/ablation/final_tables.py ~/studies/flat_ablation --out docs/ablation/faster_loop/tables
    python docs/ablation/final_tables.py ~/studies/drive_full --sessions 120 200 400 --out ...

For each finished or stopped run of the study folder (``runs/<run_id>/``), writes
``OUT/<run_id>.npz`` with

- ``final_weights_mV`` (seeds, 8, 8): each seed's table after its last session;
- ``seeds`` (seeds,) and ``sessions_done`` (seeds,);
- ``labels`` (8,): the rows' and columns' pools (``FR_flexor`` ...);
- ``weights_mV_after_<S>`` (seeds, 8, 8) for each ``--sessions S`` every seed has reached;

and ``OUT/<run_id>.json``: the run's settings (condition, sweep point, models, overrides), its
first seed, the package versions, the code version (git commit) and the machine, copied from the
run's manifest, with the file's sha256 (``astrocpg.studies.outputs.kept_tables``).
``astrocpg evaluate OUT [--session S]`` evaluates these tables as it evaluates a study's runs;
``benchmarks/gait_false_positives.py --no-astrocytes`` and ``numpy.load`` read the ``.npz``;
``final_weights_mV[k]`` is seed ``seeds[k]``'s table.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from astrocpg.errors import InputError
from astrocpg.studies.outputs.kept_tables import keep_tables


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("study", type=Path, help="a study folder (astrocpg study --out)")
    ap.add_argument("--out", type=Path, required=True, help="folder for the tables")
    ap.add_argument("--sessions", type=int, nargs="*", default=[],
                    help="also keep the tables after these sessions")
    args = ap.parse_args(argv)
    try:
        written = keep_tables(args.study, args.out, args.sessions)
    except InputError as e:
        sys.exit(f"final_tables.py: {e}")
    for npz, arrays in written:
        print(f"{npz}: {len(arrays['seeds'])} seeds, sessions "
              f"{int(arrays['sessions_done'].min())}-{int(arrays['sessions_done'].max())}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
