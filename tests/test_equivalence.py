"""Sameness only by an equivalence test against a margin declared before the data; otherwise
"not shown to differ", with the smallest difference the study could detect; times to an event
with the seeds that never got there counted. Each with a case where the old way gives another
answer."""

from __future__ import annotations

import csv
import gzip
import importlib.util
import math
from pathlib import Path

import numpy as np
import pytest

from astrocpg.errors import InputError
from astrocpg.studies.analysis.compare import (compare, detectable_difference, holm,
                                               reading_words, tost)
from astrocpg.studies.analysis.events import (censored_compare, first_reached, logrank,
                                              observed_only)
from astrocpg.studies.analysis.final_figures import MEASURES, condition_tests
from astrocpg.studies.analysis.margins import read_margins

ROOT = Path(__file__).resolve().parents[1]


def test_a_large_adjusted_p_is_no_evidence_of_sameness() -> None:
    # 20 seeds each side, a true difference of 0.1 in a share with spread 0.25: not shown
    rng = np.random.default_rng(1)
    a, b = rng.normal(0.4, 0.25, 20), rng.normal(0.3, 0.25, 20)
    t = compare(a, b)
    adjusted = holm([t["perm_p"]] + [0.9] * 6)[0]
    assert adjusted > 0.5  # the old reading: "every adjusted p is large", offered as sameness
    words = reading_words(t)
    assert words.startswith("not shown to differ; the smallest difference this study could "
                            "detect (80% power, alpha 0.05) is")
    assert "same" not in words
    # the detectable difference: (t_0.975 + t_0.8) x the Welch standard error, ~0.23 here
    se = math.sqrt(a.var(ddof=1) / 20 + b.var(ddof=1) / 20)
    assert t["detectable"] == pytest.approx(2.86 * se, rel=0.03)
    assert t["detectable"] > abs(t["difference"])


def test_detectable_difference_shrinks_with_more_seeds_and_pairs() -> None:
    rng = np.random.default_rng(2)
    x = rng.normal(0, 1, 80)
    assert detectable_difference(x[:10], x[10:20]) > detectable_difference(x[:40], x[40:])
    # pairing removes what the seeds share
    base = rng.normal(0, 1, 20)
    a, b = base + rng.normal(0, 0.1, 20), base + rng.normal(0, 0.1, 20)
    assert detectable_difference(a, b, paired=True) < 0.2 * detectable_difference(a, b)
    assert math.isnan(detectable_difference([1.0], [1.0, 2.0]))


def test_tost_within_and_outside_the_margin() -> None:
    rng = np.random.default_rng(3)
    a = rng.normal(1.0, 0.05, 30)
    b = rng.normal(1.0, 0.05, 30)
    inside = tost(a, b, 0.1)
    assert inside["equivalent"] and inside["p"] < 0.001
    assert -0.1 < inside["low"] < inside["high"] < 0.1
    # the same data against a margin smaller than the noise allows: not shown equivalent
    narrow = tost(a, b, 0.005)
    assert not narrow["equivalent"]
    t = compare(a, b, margin=0.1)
    assert t["equivalent"] and reading_words(t).startswith("equivalent within ±0.1 (TOST p")
    t = compare(a, b, margin=0.005)
    words = reading_words(t)
    assert words.startswith("not shown to differ") and "not shown equivalent within" in words
    with pytest.raises(ValueError):
        tost(a, b, 0.0)


def test_a_difference_reads_as_one() -> None:
    t = compare([1.0, 1.1, 1.2, 1.05], [0.1, 0.2, 0.15, 0.12], margin=0.05)
    assert reading_words(t) == ("its 95% interval excludes 0 (not adjusted for the other "
                               "tests)")


def test_margins_are_read_with_their_units_and_checked() -> None:
    m = read_margins({"trot_gait_share": 0.15, "speed": "0.05*meter/second",
                      "length": "500*ms", "learnt_by": 20}, "study s.toml")
    assert m == pytest.approx({"trot_gait_share": 0.15, "speed": 0.05, "length": 0.5,
                               "learnt_by": 20.0})
    assert read_margins(None, "s") == {}
    for table, words in (({"speed": 0.05}, "needs a unit of meter/second"),
                         ({"speed": "0.05*second"}, "needs a unit of meter/second"),
                         ({"trot_gait_share": "0.1*meter"}, "is a plain number"),
                         ({"trot_gait_share": -0.1}, "must be positive"),
                         ({"trot_gait": 0.1}, "is not a measure with a margin"),
                         ({"speed": True}, "must be a number or a quantity"),
                         ({"speed": "__import__('os')"}, "speed")):
        with pytest.raises(InputError, match=words) as e:
            read_margins(table, "study s.toml")
        assert "study s.toml [margins]" in str(e.value)


def test_study_file_declares_margins_and_the_report_tests_them(tmp_path) -> None:
    from astrocpg.studies.parameter_studies.study_file import parse_study

    text = ('[study]\nsessions = 2\nseeds = [1, 2]\n[conditions.a]\n[conditions.b]\n'
            'astrocytes = false\n[margins]\nspeed = "0.05*meter/second"\nfull = 0.2\n')
    study = parse_study(text, tmp_path / "s.toml", None)
    assert study.margins == pytest.approx({"speed": 0.05, "full": 0.2})
    with pytest.raises(InputError, match="is not a measure with a margin"):
        parse_study(text.replace("full = 0.2", "ful = 0.2"), tmp_path / "s.toml", None)
    # the report's tests: speed has a margin (equivalent), length has none (not shown)
    rng = np.random.default_rng(4)
    per_seed = []
    for c in ("a", "b"):
        for seed in range(1, 21):
            per_seed.append({"condition": c, "point": (), "seed": seed,
                             "speed": 1.0 + rng.normal(0, 0.02), "final_x": 5.0,
                             "length": 9.0 + rng.normal(0, 0.3), "reward": 0.1,
                             "full": 0.9})
    tests = condition_tests([], ["a", "b"], per_seed, list(MEASURES), margins=study.margins)
    by = {t["measure"]: t for t in tests}
    assert by["speed"]["equivalent"] and by["speed"]["reading"].startswith("equivalent")
    assert by["length"]["margin"] is None
    assert by["length"]["reading"].startswith("not shown to differ; the smallest difference")


def test_first_reached_censors_a_seed_that_never_got_there() -> None:
    # the window of sessions 5-14 holds one short session: mean 9.0, reached at session 14
    assert first_reached([0.0] * 5 + [10.0] * 20, 9.0) == (14.0, True)
    assert first_reached([5.0] * 30, 9.0) == (30.0, False)


def _times(learn_at: list[float | None], sessions: int) -> list[tuple[float, bool]]:
    return [(float(s), True) if s is not None else (float(sessions), False) for s in learn_at]


def test_censored_times_count_the_seeds_that_never_learnt() -> None:
    # A: half its seeds learn early (50), half never by 400; B: every seed learns at 200.
    # Dropping the never-learnt seeds, B learns 150 sessions *later*; with them counted
    # (censored at 400), B learns earlier on average
    a = _times([50, None] * 5, 400)
    b = _times([200.0] * 10, 400)
    dropped = observed_only(b, a, paired=True)
    assert dropped["difference"] == pytest.approx(150.0)
    counted = censored_compare(b, a, paired=True)
    assert counted["difference"] == pytest.approx(200 - (5 * 50 + 5 * 400) / 10)  # -25
    assert (counted["never_a"], counted["never_b"]) == (0, 5)
    assert 0 <= counted["logrank_p"] <= 1


def test_logrank() -> None:
    same = _times([10, 20, 30, None], 50)
    assert logrank([t for t, _ in same], [o for _, o in same],
                   [t for t, _ in same], [o for _, o in same])["p"] == pytest.approx(1.0)
    early, late = _times([5, 6, 7, 8, 9, 10], 100), _times([None] * 6, 100)
    r = logrank([t for t, _ in early], [o for _, o in early],
                [t for t, _ in late], [o for _, o in late])
    assert r["p"] < 0.01


def _analyse():
    spec = importlib.util.spec_from_file_location("analyse", ROOT / "docs/beyond/analyse.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def _results(path: Path, condition: str, learn_at: list[int | None], sessions: int) -> None:
    with gzip.open(path, "wt", newline="") as f:
        w = csv.DictWriter(f, fieldnames=["condition", "run_id", "seed", "session", "length_s",
                                          "final_x_m", "mean_forward_speed_m_per_s",
                                          "mean_reward"])
        w.writeheader()
        for seed, at in enumerate(learn_at, 1):
            for s in range(1, sessions + 1):
                long = at is not None and s > at - 10
                w.writerow({"condition": condition, "run_id": condition, "seed": seed,
                            "session": s, "length_s": 10.0 if long else 3.0,
                            "final_x_m": 1.0, "mean_forward_speed_m_per_s": 0.5,
                            "mean_reward": 0.0})


def test_analyse_paired_counts_the_never_learnt_seeds(tmp_path) -> None:
    """analyse.py paired, "learnt by": the rough ablation's case, where dropping the seeds
    that never learnt gave the opposite sign."""
    _results(tmp_path / "a.csv.gz", "a", [20, None] * 4, 100)
    _results(tmp_path / "b.csv.gz", "b", [60] * 8, 100)
    text = _analyse().paired(f"{tmp_path / 'a.csv.gz'}:a", f"{tmp_path / 'b.csv.gz'}:b",
                             None, 20)
    row = next(line for line in text.splitlines() if line.startswith("| learnt by"))
    assert "never, counted at session 100: A 4, B 0" in row
    cells = [c.strip() for c in row.split("|")[1:-1]]
    # learnt by 19 (A's learners) and 59 (B): B − A = 59 − (4 x 19 + 4 x 100) / 8 = −0.5;
    # the old way (the never-learnt seeds dropped) gave +40
    assert cells[3].startswith("-0.500")
    assert cells[1].startswith("59.500")
    assert "censored there, never dropped" in text
