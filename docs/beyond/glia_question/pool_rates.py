"""The thigh pools' spike rates of the trained networks, per drive: what an astrocyte of those
networks is fed, read from the committed studies' rows (each row one seed's session, with its
length and its thigh motor neurons' spikes; 8 thigh pools a seed).

Rows: seeds 1-12, sessions FIRST-LAST (default 301-400, the last quarter of the training);
the rate of a drive is its thigh spikes over 8 x its simulated seconds, summed over those rows.
The drives 0.8, 0.9, 1.1 and 1.2 x come from ``docs/beyond/drive_full`` (the paper's astrocyte,
I_background_0 = 1104, 1242, 1518, 1656 mV/s), the paper's drive 1.0 x from the flat ablation's
astrocyte condition (``docs/ablation/faster_loop``, the same seeds), and the non-glial controls
at 1.0 x from ``docs/beyond/homeostatic_control``.

    python docs/beyond/glia_question/pool_rates.py > docs/beyond/glia_question/pool_rates.csv
    python docs/beyond/glia_question/pool_rates.py --marks   # the --mark options of astrocpg response
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import pandas as pd

DOCS = Path(__file__).resolve().parents[2]
THIGH_POOLS_PER_SEED = 8
DRIVES = {"1104*mV/second": "0.8x", "1242*mV/second": "0.9x", "1518*mV/second": "1.1x",
          "1656*mV/second": "1.2x"}


def rates(first: int = 301, last: int = 400, seeds: int = 12) -> pd.DataFrame:
    """One row per (source, arm, drive): sessions, simulated seconds, thigh-pool rate."""
    def rows(path: Path) -> pd.DataFrame:
        t = pd.read_csv(path)
        return t[(t["seed"] <= seeds) & t["session"].between(first, last)]

    out = []

    def add(source: str, arm: str, drive: str, t: pd.DataFrame) -> None:
        seconds = float(t["length_s"].sum())
        out.append({"source": source, "arm": arm, "drive": drive, "sessions": len(t),
                    "seeds": t["seed"].nunique(), "seconds": round(seconds, 3),
                    "thigh_pool_rate_Hz": float(t["spikes_thigh_motor"].sum())
                    / (THIGH_POOLS_PER_SEED * seconds),
                    "releases_per_s": float(t["adenosine_releases"].sum())
                    / (THIGH_POOLS_PER_SEED * seconds)})

    drive = rows(DOCS / "beyond/drive_full/results.csv.gz")
    ablation = rows(DOCS / "ablation/faster_loop/results.csv.gz")
    add("docs/ablation/faster_loop", "paper astrocyte", "1.0x",
        ablation[ablation["condition"] == "astrocytes"])
    for value, label in DRIVES.items():
        add("docs/beyond/drive_full", "paper astrocyte", label,
            drive[drive["I_background_0"] == value])
    controls = rows(DOCS / "beyond/homeostatic_control/results.csv.gz")
    for run_id, t in controls.groupby("run_id"):
        arm = "constant control" if "constant" in run_id else "activity control"
        add("docs/beyond/homeostatic_control", arm, "1.0x", t)
    return pd.DataFrame(out).sort_values(["arm", "drive"], ignore_index=True)


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--sessions", default="301-400", help="FIRST-LAST (default 301-400)")
    p.add_argument("--marks", action="store_true",
                   help="print the paper's astrocyte's rates as --mark LABEL=RATE options")
    a = p.parse_args(argv)
    first, _, last = a.sessions.partition("-")
    table = rates(int(first), int(last))
    if a.marks:
        paper = table[table["arm"] == "paper astrocyte"].sort_values("drive")
        print(" ".join(f"--mark {d}={r:.0f}" for d, r in zip(paper["drive"],
                                                            paper["thigh_pool_rate_Hz"])))
        return 0
    table.to_csv(sys.stdout, index=False, float_format="%.6g")
    return 0


if __name__ == "__main__":
    sys.exit(main())
