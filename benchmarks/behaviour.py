"""Fingerprints of what the model does: sha256 of every array a short ``unit``, ``run`` (two
trials) and 3-session ``train`` write, for fixed seeds. A refactoring that must not change
behaviour keeps them; a change of the model or of its noise changes them on purpose.

    python benchmarks/behaviour.py            # print the fingerprints as JSON
    python benchmarks/behaviour.py --write    # store them in tests/data/behaviour.json
    python benchmarks/behaviour.py --check    # compare with tests/data/behaviour.json (exit 1)

``tests/test_behaviour.py`` runs the check. The fingerprints hold for one platform and set of
package versions (the stored file records them): numpy, Brian2 and MuJoCo releases may change
the last bits of a floating-point result. They also depend on Brian2's code generation target
(``ASTROCPG_CODEGEN``, numpy by default): the file holds one set per target, and ``--check``
and ``--write`` use the set of the target in force (``ASTROCPG_CODEGEN=cython python
benchmarks/behaviour.py --check``).
"""

from __future__ import annotations

import csv
import hashlib
import json
import sys
import tempfile
from pathlib import Path

import numpy as np

STORED = Path(__file__).resolve().parents[1] / "tests" / "data" / "behaviour.json"
SHORT = ["--set", "L_max=0.3*second", "--set", "L_non_alive=0.1*second"]
#: the commands, each with its output folder as the last argument
COMMANDS = {
    "unit": ["unit", "--seconds", "0.3", "--seed", "4", "--no-progress"],
    "run": ["run", "--seconds", "0.3", "--seed", "3", "--trials", "2", "--no-progress"],
    "train": ["train", "--sessions", "3", "--seed", "2", *SHORT, "--no-progress"],
}
#: sessions.csv columns that are the model's (every column but none is a wall time today)
SESSION_COLUMNS_SKIPPED: tuple[str, ...] = ()


def _digest_arrays(path: Path) -> dict[str, str]:
    with np.load(path, allow_pickle=False) as z:
        return {k: hashlib.sha256(np.ascontiguousarray(z[k]).tobytes()
                                  + str(z[k].dtype).encode() + str(z[k].shape).encode()
                                  ).hexdigest()[:16] for k in sorted(z.files)}


def fingerprints() -> dict[str, dict[str, str]]:
    """{command: {file/array: sha256 prefix}} of the data files each command writes."""
    from astrocpg.studies.cli import main

    out: dict[str, dict[str, str]] = {}
    with tempfile.TemporaryDirectory() as tmp:
        for name, argv in COMMANDS.items():
            folder = Path(tmp) / name
            code = main([*argv, "--out", str(folder)])
            if code != 0:
                raise SystemExit(f"astrocpg {' '.join(argv)} exited {code}")
            prints: dict[str, str] = {}
            for f in sorted(folder.glob("*.npz")):
                if f.name == "checkpoint.npz":  # holds the trainer's state: its weights suffice
                    continue
                prints.update({f"{f.name}:{k}": v for k, v in _digest_arrays(f).items()})
            rows = folder / "sessions.csv"
            if rows.exists():
                with rows.open() as fh:
                    table = [{k: v for k, v in r.items() if k not in SESSION_COLUMNS_SKIPPED}
                             for r in csv.DictReader(fh)]
                prints["sessions.csv"] = hashlib.sha256(
                    json.dumps(table, sort_keys=True).encode()).hexdigest()[:16]
            out[name] = prints
    return out


def _versions() -> dict[str, str]:
    import brian2
    import mujoco

    return {"python": sys.version.split()[0], "numpy": np.__version__,
            "brian2": brian2.__version__, "mujoco": mujoco.__version__}


def section() -> str:
    """The key of the stored fingerprints of the code generation target in force:
    ``fingerprints`` for numpy, ``fingerprints_cython`` for Cython."""
    from astrocpg.network.codegen import codegen_target

    target = codegen_target()
    return "fingerprints" if target == "numpy" else f"fingerprints_{target}"


def main(argv: list[str]) -> int:
    key = section()
    now = fingerprints()
    if "--write" in argv:
        stored = json.loads(STORED.read_text()) if STORED.exists() else {}
        stored.update({"versions": _versions(), key: now})
        STORED.write_text(json.dumps(stored, indent=1, sort_keys=True) + "\n")
        print(f"wrote {STORED} ({key})")
        return 0
    if "--check" in argv:
        stored = json.loads(STORED.read_text())
        if key not in stored:
            print(f"no stored fingerprints for this target ({key}): store them with --write")
            return 1
        diff = [f"{c}/{k}" for c in stored[key]
                for k in sorted(set(stored[key][c]) | set(now.get(c, {})))
                if stored[key][c].get(k) != now.get(c, {}).get(k)]
        print("same behaviour" if not diff else "changed: " + ", ".join(diff))
        return 1 if diff else 0
    print(json.dumps(now, indent=1, sort_keys=True))
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
