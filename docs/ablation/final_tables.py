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
run's manifest, with the file's sha256. ``benchmarks/gait_false_positives.py --no-astrocytes``
and ``numpy.load`` read the ``.npz``; ``final_weights_mV[k]`` is seed ``seeds[k]``'s table.
"""

from __future__ import annotations

import argparse
import hashlib
import json
import sys
from pathlib import Path

import numpy as np

KEPT = ("settings", "seed", "models", "package_versions", "codegen", "git", "machine", "created")


def tables(run: Path, sessions: list[int]) -> dict[str, np.ndarray]:
    manifest = json.loads((run / "manifest.json").read_text(encoding="utf-8"))
    with np.load(run / "weights.npz", allow_pickle=False) as w:
        data = {k: w[k] for k in w.files}
    n = data["final_weights_mV"].shape[0]
    first = int(manifest.get("seed", manifest.get("settings", {}).get("seed", 1)))
    out = {"final_weights_mV": data["final_weights_mV"], "labels": data["labels"],
           "seeds": np.arange(first, first + n), "sessions_done": data["sessions_done"]}
    for s in sessions:
        if int(data["sessions_done"].min()) >= s:
            out[f"weights_mV_after_{s}"] = data["weights_mV"][:, s - 1]
    return out


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("study", type=Path, help="a study folder (astrocpg study --out)")
    ap.add_argument("--out", type=Path, required=True, help="folder for the tables")
    ap.add_argument("--sessions", type=int, nargs="*", default=[],
                    help="also keep the tables after these sessions")
    args = ap.parse_args(argv)
    runs = sorted(p for p in (args.study / "runs").glob("*") if (p / "weights.npz").is_file())
    if not runs:
        sys.exit(f"final_tables.py: no run with a weights.npz under {args.study / 'runs'}")
    args.out.mkdir(parents=True, exist_ok=True)
    for run in runs:
        arrays = tables(run, args.sessions)
        npz = args.out / f"{run.name}.npz"
        np.savez(npz, **arrays)
        manifest = json.loads((run / "manifest.json").read_text(encoding="utf-8"))
        meta = {k: manifest[k] for k in KEPT if k in manifest}
        meta["tables"] = {"file": npz.name,
                          "sha256": hashlib.sha256(npz.read_bytes()).hexdigest(),
                          "arrays": {k: list(v.shape) for k, v in arrays.items()}}
        (args.out / f"{run.name}.json").write_text(json.dumps(meta, indent=1) + "\n",
                                                   encoding="utf-8")
        print(f"{npz}: {len(arrays['seeds'])} seeds, sessions "
              f"{int(arrays['sessions_done'].min())}-{int(arrays['sessions_done'].max())}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
