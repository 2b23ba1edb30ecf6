"""docs/beyond/analyse.py against: a study's runs against a reference run, seed by seed, on the
evaluated gait, rhythm, speed and falls and on the final tables' weight structure."""

from __future__ import annotations

import csv
import importlib.util
import json
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
COLUMNS = ("source", "condition", "point", "seed", "world", "repeat", "mean_speed_m_per_s",
           "fell", "rhythm", "gait")


def _analyse():
    spec = importlib.util.spec_from_file_location("analyse", ROOT / "docs/beyond/analyse.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def _evaluation(path: Path, run: str, speed: np.ndarray, trot: np.ndarray) -> None:
    """Two repeats per seed in the flat world (and one in another world, which must be left out)."""
    with open(path, "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=COLUMNS)
        w.writeheader()
        for k, (v, t) in enumerate(zip(speed, trot)):
            for repeat in range(2):
                w.writerow({"source": run, "condition": "c", "point": "", "seed": k + 1,
                            "world": "flat", "repeat": repeat, "mean_speed_m_per_s": v,
                            "fell": 0, "rhythm": "trot", "gait": "trot" if t else "none"})
            w.writerow({"source": run, "condition": "c", "point": "", "seed": k + 1,
                        "world": "rough", "repeat": 0, "mean_speed_m_per_s": 99.0, "fell": 1,
                        "rhythm": "none", "gait": "none"})


def _tables(folder: Path, run: str, saturated: bool, n: int) -> None:
    folder.mkdir(parents=True, exist_ok=True)
    w_max = 0.05  # mV, the model's default
    table = np.full((8, 8), 0.5 * w_max)
    if saturated:
        table[:] = w_max
    np.savez(folder / f"{run}.npz", final_weights_mV=np.repeat(table[None], n, axis=0),
             seeds=np.arange(1, n + 1))
    (folder / f"{run}.json").write_text(json.dumps({"settings": {"overrides": {}}}))


def test_against_pairs_seeds_and_corrects_over_the_table(tmp_path):
    n = 12
    rng = np.random.default_rng(3)
    ref_speed = rng.uniform(0.8, 1.2, n)
    _evaluation(tmp_path / "ref.csv", "astro", ref_speed, np.ones(n, bool))
    _tables(tmp_path / "ref_tables", "astro", saturated=False, n=n)
    # the study: every seed 0.5 m/s slower than itself with astrocytes, no trot, saturated
    _evaluation(tmp_path / "study.csv", "control", ref_speed - 0.5, np.zeros(n, bool))
    _tables(tmp_path / "tables", "control", saturated=True, n=n)
    text = _analyse().against(f"{tmp_path / 'ref.csv'}:astro", tmp_path / "ref_tables",
                              str(tmp_path / "study.csv"), tmp_path / "tables", "flat")
    rows = {line.split("|")[1].strip(): [c.strip() for c in line.split("|")[2:-1]]
            for line in text.splitlines() if line.startswith("| ") and "measure" not in line}
    assert "all 7 tests" in text and "12 seeds: 1–12" in text
    speed = rows["speed (m/s)"]
    assert speed[2].startswith("-0.500 [-0.500, -0.500]")  # exactly paired: no spread
    trot = rows["trot gait (share of runs)"]
    assert trot[0] == "1.000" and trot[1] == "0.000" and trot[2].startswith("-1.000")
    assert rows["weights above 0.9 w_max (share)"][1] == "1.000"
    # 12 sign flips: the smallest two-sided p is 2/2**12, reported as such
    assert rows["falls (share of runs)"][2].startswith("+0.000")


def test_response_orders_the_runs_and_points_by_value_with_intervals(tmp_path):
    n = 6
    study = tmp_path / "study.csv"
    runs = {"astrocytes__eta_ADO=36-nvolt__seeds1-6": 0.6,
            "astrocytes__eta_ADO=4.5-nvolt__seeds1-6": 1.0}
    parts = []
    for run, speed in runs.items():
        _evaluation(tmp_path / f"{speed}.csv", run, np.full(n, speed), np.ones(n, bool))
        _tables(tmp_path / "tables", run, saturated=False, n=n)
        parts.append((tmp_path / f"{speed}.csv").read_text().splitlines())
    study.write_text("\n".join(parts[0] + parts[1][1:]) + "\n")
    _evaluation(tmp_path / "ref.csv", "astro", np.full(n, 0.8), np.zeros(n, bool))
    _tables(tmp_path / "ref_tables", "astro", saturated=True, n=n)
    out = tmp_path / "response.png"
    text = _analyse().response(str(study), tmp_path / "tables", "eta_ADO", "nV",
                               [f"18={tmp_path / 'ref.csv'}:astro@{tmp_path / 'ref_tables'}"],
                               "flat", out)
    header = next(line for line in text.splitlines() if line.startswith("| measure"))
    assert header.split(" | ")[1:] == ["4.5 nV (n=6)", "18 nV (n=6)", "36 nV (n=6) |"]
    speed = next(line for line in text.splitlines() if line.startswith("| speed"))
    assert speed.split(" | ")[1:] == ["1 [1, 1]", "0.8 [0.8, 0.8]", "0.6 [0.6, 0.6] |"]
    gait = next(line for line in text.splitlines() if line.startswith("| trot gait"))
    assert gait.split(" | ")[2] == "0 [0, 0]"  # the point had no trot gait
    assert out.stat().st_size > 0


def test_against_at_a_kept_session_reads_those_tables_and_only_those_evaluations(tmp_path):
    """--session S: the weight structure of both sides' tables after S; an evaluation whose
    manifest says it ran other tables is refused; --describe gives intervals and no test."""
    import pytest

    n = 6
    for name, run in (("ref", "astro"), ("study", "drive")):
        _evaluation(tmp_path / f"{name}.csv", run, np.full(n, 1.0), np.ones(n, bool))
        _tables(tmp_path / f"{name}_tables", run, saturated=False, n=n)
        npz = tmp_path / f"{name}_tables" / f"{run}.npz"
        with np.load(npz) as z:
            arrays = {k: z[k] for k in z.files}
        # after session 2 the study's tables were all at w_max, the reference's at half of it
        arrays["weights_mV_after_2"] = np.full((n, 8, 8), 0.05 if name == "study" else 0.025)
        arrays["sessions_done"] = np.full(n, 4)
        np.savez(npz, **arrays)
    analyse = _analyse()
    args = (f"{tmp_path / 'ref.csv'}:astro", tmp_path / "ref_tables", str(tmp_path / "study.csv"),
            tmp_path / "study_tables", "flat")
    text = analyse.against(*args, session=2, describe=True)
    above = next(line for line in text.splitlines() if "above 0.9 w_max" in line)
    assert [c.strip() for c in above.split("|")[2:4]] == ["0.000", "1.000"]
    assert above.split("|")[4].strip().startswith("+1.000")
    assert "no test" in text and "Holm p" not in text and "after session 2" in text
    final = analyse.against(*args)  # the final tables: no difference in structure
    assert next(line for line in final.splitlines()
                if "above 0.9 w_max" in line).split("|")[4].strip().startswith("+0.000")
    with pytest.raises(SystemExit, match="keeps no tables after session 5"):
        analyse.against(*args, session=5)
    (tmp_path / "manifest.json").write_text(json.dumps({"settings": {"tables": "final"}}))
    with pytest.raises(SystemExit, match="ran the tables final, not after session 2"):
        analyse.against(*args, session=2)
    (tmp_path / "sub").mkdir()
    for name in ("study.csv", "ref.csv"):
        (tmp_path / "sub" / name).write_text((tmp_path / name).read_text())
    (tmp_path / "sub" / "manifest.json").write_text(
        json.dumps({"settings": {"tables": "after session 3"}}))
    with pytest.raises(SystemExit, match="ran the tables after session 3, not after session 2"):
        analyse.against(f"{tmp_path / 'sub' / 'ref.csv'}:astro", tmp_path / "ref_tables",
                        str(tmp_path / "sub" / "study.csv"), tmp_path / "study_tables", "flat",
                        session=2)


def test_response_keeps_only_the_seeds_named(tmp_path):
    n = 6
    run = "astrocytes__eta_ADO=36-nvolt__seeds1-6"
    _evaluation(tmp_path / "study.csv", run, np.arange(n, dtype=float), np.ones(n, bool))
    _tables(tmp_path / "tables", run, saturated=False, n=n)
    text = _analyse().response(str(tmp_path / "study.csv"), tmp_path / "tables", "eta_ADO", "nV",
                               [], "flat", None, seeds="2-4")
    assert "36 nV (n=3)" in text
    speed = next(line for line in text.splitlines() if line.startswith("| speed"))
    assert speed.split(" | ")[1].startswith("2 [")  # seeds 2-4: speeds 1, 2, 3


def test_map_names_a_gait_only_where_most_runs_of_two_seeds_have_it(tmp_path):
    """Section 5's rules: a seed's gait is named in more than half of its runs; a point's gait
    is found (bold) with at least 2 of its 3 seeds; per drive, seeds with each, Wilson."""
    runs = {(1104, 0.6): {1: ["pace"] * 3 + ["none"] * 2, 2: ["pace"] * 2 + ["none"] * 3,
                          3: ["none"] * 5},
            (1104, 1.4): {1: ["pace"] * 3 + ["none"] * 2, 2: ["pace"] * 4 + ["trot"],
                          3: ["none"] * 5},
            (1380, 0.6): {s: ["trot"] * 5 for s in (1, 2, 3)},
            (1380, 1.4): {1: ["trot", "pace"] * 2 + ["none"], 2: ["none"] * 5,
                          3: ["none"] * 5}}
    rows = []
    for (drive, gain), seeds in runs.items():
        run = f"astrocytes__I_background_0={drive}-mV-second_torque_gain={gain}__seeds1-3"
        _tables(tmp_path / "tables", run, saturated=drive == 1380, n=3)
        for seed, gaits in seeds.items():
            for repeat, g in enumerate(gaits):
                rows.append({"source": run, "condition": "astrocytes", "point": "",
                             "seed": seed, "world": "flat", "repeat": repeat,
                             "mean_speed_m_per_s": drive / 1000, "fell": int(g == "none"),
                             "rhythm": "trot", "gait": g})
    with open(tmp_path / "evaluation.csv", "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=COLUMNS)
        w.writeheader()
        w.writerows(rows)
    out = tmp_path / "map.png"
    text = _analyse().gait_map(str(tmp_path / "evaluation.csv"), tmp_path / "tables",
                               ["I_background_0", "torque_gain"], "mV/s", "flat", out)
    assert out.is_file() and out.stat().st_size > 1000
    gait = text.split("**Gait**")[1].split("**Rhythm**")[0]
    cells = {line.split("|")[1].strip(): [c.strip() for c in line.split("|")[2:-1]]
             for line in gait.splitlines() if line.startswith("| 1")}
    # seed 2 has pace in 2 of 5 runs only: one seed, a lead, not bold
    assert cells["1104"][0] == "pace 1/3 (runs: pace 5/15)"
    assert cells["1104"][1] == "**pace 2/3** (runs: trot 1/15, pace 7/15)"
    assert cells["1380"][0] == "**trot 3/3** (runs: trot 15/15)"
    assert cells["1380"][1] == "none 3/3 (runs: trot 2/15, pace 2/15)"
    per_drive = {line.split("|")[1].strip(): [c.strip() for c in line.split("|")[2:-1]]
                 for line in text.split("**Per I_background_0**")[1].splitlines()
                 if line.startswith("| 1")}
    assert per_drive["1104"][:3] == ["6", "0 (0%, 0%–39%)", "3 (50%, 19%–81%)"]
    assert per_drive["1380"][:3] == ["6", "3 (50%, 19%–81%)", "0 (0%, 0%–39%)"]
    point = [line for line in text.split("**Per point**")[1].splitlines()
             if line.startswith("| 1380 | 0.6 |")][0]
    assert "| 1.38 (1.38 – 1.38) | 0.00 (0.00 – 0.00) |" in point
