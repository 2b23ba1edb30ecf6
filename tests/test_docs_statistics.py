"""The docs' statistics scripts: docs/ablation/retest.py (a study's conditions compared again
from its rows), docs/ablation/compare_tables.py (two runs compared figure by figure) and
docs/variants/delays/blocks.py (learning curves block by block). Each gives differences with
intervals, permutation (or exact) p-values and Holm's adjustment, never a t-test's p, and refuses
a file that is not a study's rows."""

from __future__ import annotations

import csv
import gzip
import math
import os
import re
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

ROOT = Path(__file__).resolve().parents[1]
ROWS = ("run_id", "condition", "seed", "trial", "session", "length_s", "final_x_m",
        "mean_reward", "mean_forward_speed_m_per_s")


def _run(*argv: str) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, *argv], cwd=ROOT, capture_output=True, text=True,
                          env={**os.environ, "MPLBACKEND": "Agg"}, timeout=300)


def _rows(path: Path, speeds: dict[str, list[float]], sessions: int = 6) -> None:
    """A study's rows: per condition and seed, ``sessions`` sessions at the seed's speed (the
    last two of them at full length, 10 s)."""
    opener = gzip.open if path.suffix == ".gz" else open
    with opener(path, "wt", newline="") as f:
        w = csv.DictWriter(f, fieldnames=ROWS)
        w.writeheader()
        for condition, values in speeds.items():
            for k, v in enumerate(values):
                for s in range(1, sessions + 1):
                    length = 10.0 if s > sessions - 2 else 5.0
                    w.writerow({"run_id": f"{condition}__seeds1-{len(values)}",
                                "condition": condition, "seed": k + 1, "trial": k,
                                "session": s, "length_s": length, "final_x_m": v * length,
                                "mean_reward": v, "mean_forward_speed_m_per_s": v})


def _table(text: str, first: str) -> dict[str, list[str]]:
    """The rows of a markdown table whose first column is ``first``... keyed by their label."""
    out = {}
    for line in text.splitlines():
        cells = [c.strip() for c in line.strip().strip("|").split("|")]
        if line.startswith("|") and len(cells) > 2 and not set(cells[0]) <= {"-"}:
            out.setdefault(cells[first == "second"], cells)
    return out


def test_retest_separated_conditions_give_the_bounded_p(tmp_path):
    rng = np.random.default_rng(1)
    rows = tmp_path / "results.csv.gz"
    _rows(rows, {"astrocytes": list(1.0 + 0.01 * rng.random(20)),
                 "no_astrocytes": list(0.5 + 0.01 * rng.random(20))})
    done = _run("docs/ablation/retest.py", str(rows), "--last", "2")
    assert done.returncode == 0, done.stderr
    text = done.stdout
    assert "Welch" not in text and "t-test" not in text
    speed = next(line for line in text.splitlines() if line.startswith("| forward speed"))
    # every seed of one side above the other: exact Mann-Whitney p 2/C(40, 20), Holm over five
    assert "400, 1.5e-11 (7.3e-11)" in speed
    assert "<= 0.0001 (<= 0.0005)" in speed  # the Monte Carlo permutation test's bound, Holm'd
    interval = re.search(r"\| \+0\.\d\d\d \[(\+0\.\d+), (\+0\.\d+)\]", speed)
    assert interval and 0.49 < float(interval.group(1)) < float(interval.group(2)) < 0.52
    # the full-length share over the last 2 sessions is 1 everywhere: no spread, said so
    full = next(line for line in text.splitlines() if line.startswith("| full-length"))
    assert "undefined (no spread)" in full


def test_retest_refuses_what_is_not_rows(tmp_path):
    bad = tmp_path / "final_figures.csv"
    bad.write_text("group,seeds\nastrocytes,20\n")
    done = _run("docs/ablation/retest.py", str(bad))
    assert done.returncode == 2 and done.stdout == ""
    assert done.stderr.startswith("astrocpg: ") and "no column" in done.stderr
    one = tmp_path / "one.csv"
    _rows(one, {"astrocytes": [1.0, 1.1, 1.2]})
    done = _run("docs/ablation/retest.py", str(one))
    assert done.returncode == 2 and "one condition only" in done.stderr


def test_compare_tables_from_rows_tests_and_corrects(tmp_path):
    rng = np.random.default_rng(2)
    base = list(1.0 + 0.05 * rng.standard_normal(20))
    _rows(tmp_path / "a.csv", {"astrocytes": base, "no_astrocytes": list(np.array(base) - 0.5)})
    # the second run: the astrocyte side 0.2 m/s slower in every seed, the other side the same
    _rows(tmp_path / "b.csv", {"astrocytes": list(np.array(base) - 0.2),
                               "no_astrocytes": list(np.array(base) - 0.5)})
    done = _run("docs/ablation/compare_tables.py", str(tmp_path / "a.csv"),
                str(tmp_path / "b.csv"), "--last", "2")
    assert done.returncode == 0, done.stderr
    assert "Welch" not in done.stdout
    lines = {tuple(c.strip() for c in line.strip("|").split("|")[:2]): line
             for line in done.stdout.splitlines() if line.startswith("| ")}
    moved = lines[("astrocytes", "forward speed (m/s)")]
    assert "-0.200 [" in moved and "<= 0.0001" in moved
    same = lines[("no_astrocytes", "forward speed (m/s)")]
    cells = [c.strip() for c in same.strip().strip("|").split("|")]
    assert cells[4].startswith("+0.000") and cells[5] == "1" and cells[7] == "1"
    # Holm over the 10 figures; the three that moved (speed, final x, reward) differ, and the
    # smallest Holm p is the permutation bound times ten, written as a bound
    assert "Holm-adjusted over the 10 figures" in done.stdout
    assert done.stdout.rstrip().endswith(
        "3 of 10 figures differ at Holm p < 0.05; smallest Holm p <= 0.001.")


def test_compare_tables_from_summaries_gives_intervals_without_p(tmp_path):
    header = "group,seeds,speed_mean,speed_std,final_x_mean,final_x_std,length_mean," \
             "length_std,reward_mean,reward_std,full_mean,full_std\n"
    (tmp_path / "x").mkdir()
    (tmp_path / "y").mkdir()
    first, second = tmp_path / "x" / "final_figures.csv", tmp_path / "y" / "final_figures.csv"
    first.write_text(header + "astrocytes,20,1.0,0.04,10,0.4,9.6,0.2,1.0,0.04,0.9,0.03\n")
    second.write_text(header + "astrocytes,20,1.1,0.03,10,0.4,9.6,0.2,1.0,0.04,0.9,0.03\n")
    done = _run("docs/ablation/compare_tables.py", str(first), str(second))
    assert done.returncode == 0, done.stderr
    assert "no p-value" in done.stdout and "Welch" not in done.stdout
    speed = next(line for line in done.stdout.splitlines() if "forward speed" in line)
    low, high = map(float, re.search(r"\+0\.100 \[([-+.\d]+), ([-+.\d]+)\]", speed).groups())
    # the t interval by hand: sample variances from the ddof-0 stds, Satterthwaite's df
    from scipy import stats
    va, vb = 0.04 ** 2 / 19, 0.03 ** 2 / 19
    df = (va + vb) ** 2 / (va ** 2 / 19 + vb ** 2 / 19)
    half = stats.t.ppf(0.975, df) * math.sqrt(va + vb)
    assert low == pytest.approx(0.1 - half, abs=6e-4) and high == pytest.approx(0.1 + half, abs=6e-4)
    assert "The 95 % interval excludes 0 for 1 of the 5 figures, the 99 % interval for 1." \
        in done.stdout


def _delays_study(folder: Path, gap: float) -> None:
    """A compare_delays-like study folder: two tables x 8 seeds x 40 sessions; the second
    table's speed ``gap`` higher in sessions 21-40 only."""
    tables = ("interlimb_authors_delays.toml", "interlimb_synapse.toml")
    noise = 0.01 * np.random.default_rng(4).standard_normal((8, 40))  # per seed, both tables
    fields = ("run_id", "interlimb_synapse", "seed", "session", "mean_reward", "length_s",
              "mean_forward_speed_m_per_s", "final_x_m")
    with open(folder / "results.csv", "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=fields)
        w.writeheader()
        for j, table in enumerate(tables):
            for seed in range(1, 9):
                for s in range(1, 41):
                    v = 1.0 + noise[seed - 1, s - 1] + (gap * j if s > 20 else 0.0)
                    w.writerow({"run_id": f"run{j}", "interlimb_synapse": table, "seed": seed,
                                "session": s, "mean_reward": v, "length_s": 9.0,
                                "mean_forward_speed_m_per_s": v, "final_x_m": 9.0 * v})
    for j in range(2):
        run = folder / "runs" / f"run{j}"
        run.mkdir(parents=True)
        with open(run / "gait.csv", "w", newline="") as f:
            w = csv.writer(f)
            w.writerow(["trial", "final_gait", "final_speed_m_per_s", "final_phase_FL",
                        "final_phase_RR", "final_phase_RL"])
            for trial in range(8):
                w.writerow([trial, "trot", 0.8 + 0.2 * j + 0.01 * trial, 0.5, 0.5, 0.0])


def test_blocks_tests_each_block_and_corrects_over_the_blocks(tmp_path):
    _delays_study(tmp_path, gap=0.3)
    done = _run("docs/variants/delays/blocks.py", str(tmp_path))
    assert done.returncode == 0, done.stderr
    assert "Welch" not in done.stdout
    rows = [[c.strip() for c in line.strip().strip("|").split("|")]
            for line in done.stdout.splitlines()
            if line.startswith("| mean_forward_speed_m_per_s")]
    assert [r[1] for r in rows] == ["1-20", "21-40"] and all(len(r) == 7 for r in rows)
    first, second = rows
    assert first[4].startswith("+0.000") and first[5] == first[6] == "1"  # the same block
    assert second[4].startswith("+0.300")
    raw, adjusted = (float(c.removeprefix("<= ")) for c in second[5:7])
    # every seed of one table above every seed of the other: 2 of C(16, 8) relabellings reach
    # it, about 1.6e-4 (10 000 draws); Holm over the two blocks doubles the smallest p
    assert raw <= 0.0005 and adjusted == pytest.approx(2 * raw, rel=0.01)
    assert "Mann-Whitney p 0.00016" in done.stdout
