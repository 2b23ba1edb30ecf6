"""Figures over the unit of replication (the trained table), the gait's continuous measure and
its share at other thresholds, and whether tables differ: each with a case where treating the
runs as independent, or the label alone, gives another answer."""

from __future__ import annotations

import math

import pytest

from astrocpg.studies.analysis.gait import THRESHOLDS, gait_at
from astrocpg.studies.analysis.replication import over_tables, share_over_tables, tables_differ
from astrocpg.studies.analysis.share import wilson_interval
from astrocpg.studies.commands.evaluate import format_summary, summarise


def _row(source: str, seed: int, repeat: int, gait: str, *, lock: float = 0.9,
         trot_phases: bool = True, fell: int = 0, speed: float = 1.0) -> dict:
    phases = {"FL": 0.5, "RR": 0.5, "RL": 0.0} if trot_phases else \
        {"FL": 0.25, "RR": 0.6, "RL": 0.1}
    row = {"source": source, "condition": "astrocytes", "point": "", "seed": seed,
           "world": "flat", "repeat": repeat, "distance_m": speed * 10,
           "mean_speed_m_per_s": speed, "fell": fell, "time_to_fall_s": math.nan,
           "upright_share": 1.0 - 0.5 * fell, "gait": gait, "rhythm": "trot",
           "gait_locking": lock}
    for leg in ("FL", "RR", "RL"):
        row[f"gait_phase_{leg}"] = phases[leg]
        row[f"gait_locking_{leg}"] = lock
    row["gait_locking_FR"] = lock
    return row


def _evaluation(shares: list[int], repeats: int = 5) -> list[dict]:
    """Tables with ``k`` trotting runs of ``repeats`` each."""
    return [_row("run", seed, r, "trot" if r < k else "none", lock=0.9 if r < k else 0.5)
            for seed, k in enumerate(shares, 1) for r in range(repeats)]


def test_interval_is_over_tables_not_runs() -> None:
    # 4 tables x 5 runs: two always trot, two never. The runs as independent (Wilson, n = 20)
    # give 30%-70%; over the 4 tables the share is anywhere from 0 to 1
    rows = _evaluation([5, 5, 0, 0])
    s = summarise(rows)[0]
    assert (s["n_tables"], s["n_runs"], s["n"]) == (4, 20, 20)
    assert s["gait_trot_share"] == pytest.approx(0.5)
    wilson = wilson_interval(10, 20)
    assert wilson[0] == pytest.approx(0.30, abs=0.01)  # the old interval
    assert s["gait_trot_low"] == 0.0 and s["gait_trot_high"] == 1.0
    line = format_summary([s])[0]
    assert "n = 4 tables x 5 runs; 95% intervals over tables" in line
    assert "Wilson" not in line


def test_interval_over_tables_with_spread_and_without() -> None:
    # the tables' shares 0.2, 0.4, 0.6, 0.8: Student's t over 4 values
    s = share_over_tables([["trot"] * k + ["none"] * (5 - k) for k in (1, 2, 3, 4)], "trot")
    from scipy import stats
    half = stats.t.ppf(0.975, 3) * 0.2581988897 / 2
    assert (s["low"], s["high"]) == pytest.approx((0.5 - half, 0.5 + half), abs=1e-6)
    assert s["method"] == "t"
    # no table trots: not an exact 0, but 0 of 4 tables (Wilson over tables)
    none = share_over_tables([["none"] * 5] * 4, "trot")
    assert (none["low"], none["high"]) == pytest.approx(wilson_interval(0, 4))
    assert none["method"] == "wilson over tables"
    one = over_tables([0.4], share=True)
    assert one["n_tables"] == 1 and math.isnan(one["low"])


def test_continuous_figures_have_intervals_over_tables() -> None:
    rows = [_row("run", seed, r, "trot", speed=v) for seed, v in ((1, 1.0), (2, 1.2), (3, 1.4))
            for r in range(4)]
    s = summarise(rows)[0]
    from scipy import stats
    half = stats.t.ppf(0.975, 2) * 0.2 / math.sqrt(3)
    assert (s["mean_speed_m_per_s_low"], s["mean_speed_m_per_s_high"]) == pytest.approx(
        (1.2 - half, 1.2 + half))


def test_tables_differ_tested() -> None:
    apart = [["trot"] * 5, ["trot"] * 5, ["none"] * 5, ["none"] * 5]
    assert tables_differ(apart, "trot")["p"] < 0.01
    # the same 10 of 20 runs spread as one common share gives: no difference shown
    mixed = [["trot", "none"] * 2 + ["trot"], ["none", "trot"] * 2 + ["none"],
             ["trot", "none"] * 2 + ["none"], ["none", "trot"] * 2 + ["trot"]]
    assert tables_differ(mixed, "trot")["p"] > 0.5
    assert tables_differ([["none"] * 5] * 3, "trot")["p"] == 1.0
    s = summarise(_evaluation([5, 5, 0, 0]))[0]
    assert s["gait_trot_tables_differ_p"] < 0.01
    assert "do the tables differ in their trot share? permutation p" in format_summary([s])[1]


def test_gait_at_other_thresholds() -> None:
    # trot phases locked at 0.65: none at the label's 0.7, trot at 0.6 and 0.5
    row = _row("run", 1, 0, "none", lock=0.65)
    assert [gait_at(row, x) for x in THRESHOLDS] == ["trot", "trot", "none", "none"]
    assert gait_at(row, 0.0) == "trot"
    # phases that are no trot stay none at any threshold; a run not read (fell) too
    assert gait_at(_row("run", 1, 0, "none", trot_phases=False), 0.0) == "none"
    assert gait_at({**row, "gait_locking": math.nan}, 0.0) == "none"
    # a CSV row (text) too
    assert gait_at({k: str(v) for k, v in row.items()}, 0.6) == "trot"


def test_summary_gives_the_measure_the_label_thresholds() -> None:
    rows = [_row("run", seed, r, "none", lock=0.65) for seed in (1, 2) for r in range(3)]
    s = summarise(rows)[0]
    assert s["gait_trot_share"] == 0.0  # the label alone: no trot
    assert s["gait_locking_mean"] == pytest.approx(0.65)
    assert s["gait_trot_share_at_0.6"] == 1.0 and s["gait_trot_share_at_0.5"] == 1.0
    assert s["gait_trot_share_at_0.8"] == 0.0 and s["gait_trot_share_at_0"] == 1.0
    lines = format_summary([s])
    assert "gait locking" in lines[1] and "100% at 0.6" in lines[1]


def test_tables_that_trot_are_tested_before_they_are_counted() -> None:
    """The robustness evaluation's flat world: 17 of 20 tables trot in at least one run, but
    the spread over tables is what one common share gives (the old output counted tables
    that trot, with no test)."""
    import importlib.util
    from pathlib import Path

    root = Path(__file__).resolve().parents[1]
    spec = importlib.util.spec_from_file_location("analyse", root / "docs/beyond/analyse.py")
    analyse = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(analyse)
    text = analyse.controllers(str(root / "docs/beyond/robustness/evaluation.csv"), "flat",
                               "astrocytes")
    assert "17 controllers trot in at least one run" in text
    p = float(text.split("permutation p = ")[1].split(";")[0])
    assert p > 0.05


def test_world_bars_draw_intervals_over_tables() -> None:
    from astrocpg.studies.figures.gait_map import world_bars

    rows = _evaluation([5, 5, 0, 0]) + [{**r, "world": "rough"} for r in _evaluation([1, 2, 0, 0])]
    fig = world_bars(summarise(rows))
    speed_ax, fall_ax = fig.axes
    assert "95% interval over tables" in speed_ax.get_title()
    assert "(4 tables)" in speed_ax.get_legend().get_texts()[0].get_text()


def test_a_common_share_of_every_table_is_not_read_as_exact() -> None:
    s = share_over_tables([["trot", "trot", "none", "none", "none"]] * 4, "trot")
    assert s["mean"] == pytest.approx(0.4) and s["method"] == "wilson over tables"
    assert s["low"] < 0.4 < s["high"]
