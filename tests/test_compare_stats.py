"""The report's statistics on known small examples: exact permutation and Mann-Whitney
p-values, the Monte Carlo bound, Holm's adjustment, the sign-flip test of paired seeds and a
reproducible bootstrap interval."""

from __future__ import annotations

import math

import numpy as np
import pytest

from astrocpg.studies.analysis.compare import (N_PERM, bootstrap_interval, compare, holm,
                                               mann_whitney, p_text, permutation_test)

A5 = [1.0, 2.0, 3.0, 4.0, 5.0]
B5 = [6.0, 7.0, 8.0, 9.0, 10.0]


def test_two_samples_of_five_fully_apart_give_the_exact_permutation_p() -> None:
    # C(10, 5) = 252 relabellings; only the observed one and its mirror reach |difference| 5
    res = permutation_test(A5, B5)
    assert res["exact"] and res["n"] == 252
    assert res["p"] == pytest.approx(2 / 252)
    assert not res["bound"]


def test_a_known_exact_permutation_p_with_overlap() -> None:
    # a = [1, 2, 3], b = [4, 5, 0]: |difference| of the 20 splits: 0.33 (6), 1 (6), 1.67 (4),
    # 2.33 (2), 3 (2): 14 of 20 reach the observed 1
    a, b = [1.0, 2.0, 3.0], [4.0, 5.0, 0.0]
    x = np.array(a + b)
    from itertools import combinations
    reach = sum(abs(x[list(c)].mean() - np.delete(x, list(c)).mean()) >= 1.0 - 1e-12
                for c in combinations(range(6), 3))
    assert reach == 14
    assert permutation_test(a, b)["p"] == pytest.approx(14 / 20)


def test_mann_whitney_is_exact_without_ties_and_never_below_its_smallest_p() -> None:
    u, p, p_min = mann_whitney(np.array(A5), np.array(B5))
    assert u == 0.0 and p == pytest.approx(2 / 252) and p_min == pytest.approx(2 / 252)
    # all tied within each side: the normal approximation goes below what 6 + 6 values allow
    from scipy import stats
    x, y = np.zeros(6), np.ones(6)
    assert stats.mannwhitneyu(x, y).pvalue < 2 / math.comb(12, 6)
    _, p, p_min = mann_whitney(x, y)
    assert p == pytest.approx(2 / math.comb(12, 6)) == pytest.approx(p_min)


def test_many_relabellings_are_drawn_and_the_smallest_p_is_a_bound() -> None:
    res = permutation_test(np.arange(20.0), np.arange(20.0) + 100)
    assert not res["exact"] and res["bound"]
    assert res["p"] == pytest.approx(1 / (N_PERM + 1)) == pytest.approx(res["p_min"])
    assert p_text(res["p"], res["p_min"], res["bound"]) == "<= 0.0001"
    assert p_text(0.0123) == "0.012"
    # seeded: the same p every time
    again = permutation_test(np.arange(20.0), np.arange(20.0) + 3)
    assert permutation_test(np.arange(20.0), np.arange(20.0) + 3) == again


def test_holm_adjustment_known_family() -> None:
    # sorted 0.01, 0.03, 0.04 times 3, 2, 1 -> 0.03, 0.06, 0.04 -> monotone 0.03, 0.06, 0.06
    assert holm([0.01, 0.04, 0.03, None]) == pytest.approx([0.03, 0.06, 0.06, None])
    assert holm([0.5, 0.9]) == [1.0, 1.0]


def test_paired_seeds_use_sign_flips() -> None:
    # five positive pair differences: 2 of the 2^5 = 32 sign patterns reach |mean| 3
    res = permutation_test([2.0, 4.0, 6.0, 8.0, 10.0], [1.0, 2.0, 3.0, 4.0, 5.0], paired=True)
    assert res["exact"] and res["n"] == 32 and res["p"] == pytest.approx(2 / 32)
    # unpaired the same numbers differ much less clearly
    assert permutation_test([2.0, 4.0, 6.0, 8.0, 10.0], [1.0, 2.0, 3.0, 4.0, 5.0])["p"] > 0.1
    out = compare([2.0, 4.0, 6.0, 8.0, 10.0], [1.0, 2.0, 3.0, 4.0, 5.0], paired=True)
    assert out["paired"] and out["perm_p"] == pytest.approx(2 / 32) and out["mwu_p"] is None
    with pytest.raises(ValueError):
        compare([1.0, 2.0], [1.0], paired=True)


def test_the_bootstrap_interval_is_reproducible_and_holds_the_difference() -> None:
    lo, hi = bootstrap_interval(A5, B5)
    assert (lo, hi) == bootstrap_interval(A5, B5)  # seeded
    assert lo <= -5.0 <= hi and -9.0 <= lo and hi <= -1.0
    plo, phi = bootstrap_interval(A5, [a - 1 for a in A5], paired=True)
    assert plo == phi == pytest.approx(1.0)  # every pair differs by 1: no spread to resample
    out = compare(A5, B5)
    assert (out["difference_low"], out["difference_high"]) == (lo, hi)
    assert out["perm_exact"] and out["perm_p"] == pytest.approx(2 / 252)
    assert math.isnan(bootstrap_interval([1.0], B5)[0])
