"""The figures and stated differences of the README, docs/results.md and docs/beyond/README.md
against the committed tables: docs/claims.toml lists them, docs/claims.py recomputes them. A
claim fails when its text is not on its page, a figure no longer equals its recomputation to
the printed precision, or its direction (higher, lower, not shown to differ, same) no longer
follows from the table."""

from __future__ import annotations

import copy
import csv
import importlib.util
import os
import re
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

ROOT = Path(__file__).resolve().parents[1]


def _claims_module():
    spec = importlib.util.spec_from_file_location("docs_claims", ROOT / "docs" / "claims.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


claims = _claims_module()
ALL = claims.load()
PAGES = ("README.md", "docs/results.md", "docs/beyond/README.md")


@pytest.mark.parametrize("claim", ALL, ids=[c["id"] for c in ALL])
def test_claim_follows_from_its_table(claim):
    assert claims.check(claim) == []


TABLES = claims.load_tables()


@pytest.mark.parametrize("spec", TABLES, ids=[t["id"] for t in TABLES])
def test_page_table_matches_the_table_its_command_wrote(spec):
    assert claims.check_table(spec) == []


def test_a_page_table_against_another_column_fails():
    spec = copy.deepcopy(next(t for t in TABLES if t["id"] == "robustness-worlds"))
    spec["columns"] = [[1, spec["columns"][0][1], "no astrocytes"]]   # against none's falls
    assert any("printed" in p for p in claims.check_table(spec))


def _add_columns(text: str) -> str:
    """A committed table's text with two columns added: one before the difference, and a
    "reading" before its p."""
    out = []
    for line in text.splitlines():
        if line.startswith("|"):
            cells = line.strip().strip("|").split("|")
            head = "measure" in cells[0] or "world" in cells[0]
            rule = set(cells[0].strip()) <= {"-"}
            new = "---" if rule else ("added" if head else " 7.5 ")
            reading = "---" if rule else ("reading" if head else " not shown ")
            cells = cells[:3] + [new] + cells[3:4] + [reading] + cells[4:]
            line = "|" + "|".join(cells) + "|"
        out.append(line)
    return "\n".join(out) + "\n"


@pytest.mark.parametrize("file, block, column", [
    ("docs/beyond/load_afferent/paired_rough.md", "", "B − A per seed"),
    ("docs/beyond/rough_ablation/against_rough.md", "", "B − A per seed"),
    ("docs/beyond/robustness/intervals.md", "**falls (share of runs)**", "difference")])
def test_a_committed_table_is_read_by_its_headers(tmp_path, file, block, column):
    """A column added to a committed table (a "reading", say) moves no figure a claim reads."""
    moved = tmp_path / "table.md"
    moved.write_text(_add_columns((ROOT / file).read_text()))
    for row in ("speed", "falls", "rough_2cm"):
        try:
            before = claims.c_md_cell(file, row, column, block)
        except claims.BadInput:
            continue
        assert claims.c_md_cell(str(moved), row, column, block) == before
        assert {"d", "lo", "hi", "holm"} <= set(before)
    if block:
        got = claims.c_md_block(str(moved), block, column)
        assert got == claims.c_md_block(file, block, column) and got["holm"] < 0.05
    with pytest.raises(claims.BadInput, match="columns headed"):
        claims.c_md_cell(file, "speed" if not block else "flat", "no such column", block)


def test_a_page_table_is_checked_against_its_source_by_header(tmp_path):
    spec = copy.deepcopy(next(t for t in TABLES if t["id"] == "rough-tables"))
    moved = tmp_path / "against.md"
    moved.write_text(_add_columns((ROOT / spec["source"]).read_text()))
    spec["source"] = str(moved)
    assert claims.check_table(spec) == []
    spec["columns"] = [[c[0], c[1], 3] for c in spec["columns"][:1]]     # a position
    with pytest.raises(claims.BadInput, match="by its header"):
        claims.check_table(spec)


def test_every_row_lower_needs_every_rows_interval_below_0(tmp_path):
    table = tmp_path / "t.md"
    rows = ["| world | a | b | difference (first − second) | Mann-Whitney p | Holm p |",
            "|---|---|---|---|---|---|",
            "| w1 | 0.1 | 0.8 | -0.70 [-0.80, -0.60] | 1e-05 | 2e-05 |",
            "| w2 | 0.4 | 0.5 | -0.10 [-0.20, -0.01] | 0.01 | 0.01 |"]
    table.write_text("**falls**\n\n" + "\n".join(rows) + "\n")
    c = claims.c_md_block(str(table), "**falls**", "difference")
    assert claims.direction_follows("lower", c, None)
    assert not claims.direction_follows("higher", c, None)
    assert not claims.direction_follows("not shown to differ", c, None)
    table.write_text(table.read_text().replace("-0.20, -0.01]", "-0.20, +0.01]"))
    c = claims.c_md_block(str(table), "**falls**", "difference")
    assert not claims.direction_follows("lower", c, None)     # w2's interval holds 0
    assert claims.direction_follows("differ", c, None)        # every Holm p below 0.05


def test_a_changed_page_figure_fails(tmp_path, monkeypatch):
    spec = copy.deepcopy(next(t for t in TABLES if t["id"] == "dose-beyond"))
    page = (ROOT / spec["page"]).read_text()
    changed = tmp_path / "page.md"
    changed.write_text(page.replace("0.27 [0.18, 0.36]", "0.29 [0.18, 0.36]", 1))
    spec["page"] = str(changed)
    assert any("printed 0.29" in p for p in claims.check_table(spec))


def _first(direction: str, with_values: bool = True) -> dict:
    return copy.deepcopy(next(c for c in ALL if c["direction"] == direction
                              and (c["values"] or not with_values)))


def test_a_changed_figure_fails():
    claim = _first("lower")
    key, printed = next(iter(claim["values"].items()))
    shown = float(printed.replace("−", "-").lstrip("≤<= "))
    wrong = f"{shown + 0.5:+.2f}"
    claim["values"][key] = wrong
    claim["text"] = claim["text"].replace(printed, wrong)
    problems = claims.check(claim)
    assert any(p.startswith(f"{key}: printed") for p in problems), problems


def test_a_figure_not_in_the_quote_fails():
    claim = _first("none")
    key = next(iter(claim["values"]))
    claim["values"][key] = "123.456"
    assert any("not in the quoted text" in p for p in claims.check(claim))


def test_a_quote_not_on_the_page_fails():
    claim = _first("none")
    claim["text"] += " and a sentence the page does not have"
    assert any(p.startswith("text not on") for p in claims.check(claim))


@pytest.mark.parametrize("start, wrong", [("lower", "higher"), ("higher", "lower"),
                                          ("lower", "not shown to differ"),
                                          ("differ", "not shown to differ"),
                                          ("not shown to differ", "higher"),
                                          ("not shown to differ", "differ")])
def test_a_direction_the_table_does_not_give_fails(start, wrong):
    claim = next(c for c in ALL if c["direction"] == start)
    claim = copy.deepcopy(claim)
    if start == "not shown to differ":   # one whose interval holds 0 on both sides
        claim = copy.deepcopy(next(c for c in ALL if c["id"] == "rough-learnt-censored"))
    claim["direction"] = wrong
    assert any(p.startswith("direction") for p in claims.check(claim))


def test_sameness_needs_a_margin_and_an_interval_inside_it():
    c = {"d": 0.01, "lo": -0.03, "hi": 0.05, "p": 0.6}
    assert not claims.direction_follows("same", c, None)       # no margin declared
    assert not claims.direction_follows("same", c, 0.04)       # interval reaches past it
    assert claims.direction_follows("same", c, 0.1)
    assert claims.direction_follows("not shown to differ", c, None)


def test_sameness_worded_without_a_test_fails():
    claim = copy.deepcopy(next(c for c in ALL if c["id"] == "rough-tables-speed"))
    claim["text"] = "speed and falls do not differ"
    problems = claims.check(claim, {claim["page"]: "speed and falls do not differ"})
    assert any("sameness" in p for p in problems)


@pytest.mark.parametrize("page", PAGES)
def test_no_page_states_a_sameness_without_a_test(page):
    assert claims.unqualified_sameness((ROOT / page).read_text()) == []


@pytest.mark.parametrize("page, text", [
    ("README.md", "over-active pools"),
    ("README.md", "a trot emerges (20 of 20 seeds"),
    ("docs/beyond/README.md", "in opposite directions on the two grounds."),
    ("docs/beyond/README.md", "it does not make the"),
    ("docs/beyond/README.md", "−104 [−178, −31]"),
    ("docs/beyond/README.md", "Every Holm-adjusted p is 1"),
    ("docs/results.md", "every adjusted p is 1"),
    ("docs/results.md", "17 of 20 tables trot"),
    ("docs/beyond/README.md", "A payload helps"),
])
def test_the_audits_examples_are_gone(page, text):
    assert text not in claims._words((ROOT / page).read_text())


def test_learnt_by_counts_the_seeds_that_never_learnt():
    """A side where half the seeds learn early and half never learn: dropping the never-learnt
    seeds (the old reading) makes it look earlier than a side where every seed learns by
    session 100; counting them at their last session (censored there, as the committed tables
    count them) makes it later."""
    def series(first_full: int | None, sessions: int = 200) -> np.ndarray:
        length = np.full(sessions, 5.0)
        if first_full is not None:
            length[first_full - 1:] = 10.0
        return np.c_[length, length, length]

    a = [claims.training_measures(series(93), 20)["learnt_by"] for _ in range(10)]
    mb = [claims.training_measures(series(23 if k % 2 else None), 20) for k in range(10)]
    b = [m["learnt_by"] for m in mb]
    assert a[0] == 100 and sorted(set(b)) == [30, 200]      # censored at the last session
    assert [claims.training_measures(series(None), 20)["never"],
            claims.training_measures(series(191), 20)["never"]] == [1.0, 0.0]
    dropped = np.mean([m["learnt_by"] for m in mb if not m["never"]]) - np.mean(a)
    censored = np.mean(b) - np.mean(a)
    assert dropped < 0 < censored


def _evaluation(path: Path, trots: list[int], runs: int = 5) -> None:
    with open(path, "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=["source", "condition", "seed", "world", "gait",
                                          "rhythm", "fell", "mean_speed_m_per_s"])
        w.writeheader()
        for seed, k in enumerate(trots, 1):
            for r in range(runs):
                w.writerow({"source": "s", "condition": "c", "seed": seed, "world": "flat",
                            "gait": "trot" if r < k else "none", "rhythm": "trot",
                            "fell": 0, "mean_speed_m_per_s": 1.0})


def test_tables_differing_in_trot_share_are_found(tmp_path):
    same, apart = tmp_path / "same.csv", tmp_path / "apart.csv"
    _evaluation(same, [1, 2, 2, 1, 2, 1, 2, 2, 1, 2, 1, 2])   # one share, 0.3
    _evaluation(apart, [0, 0, 0, 0, 0, 0, 5, 5, 5, 5, 5, 0])  # five tables always, the rest never
    assert claims.c_tables_differ(str(same), "c", "flat")["p"] > 0.5
    assert claims.c_tables_differ(str(apart), "c", "flat")["p"] < 0.001


def test_a_share_is_over_tables_not_runs(tmp_path):
    path = tmp_path / "e.csv"
    _evaluation(path, [5, 0, 5, 0])
    c = claims.c_share(str(path), "c", "flat", "gait")
    assert c["tables"] == 4 and c["runs"] == 20 and c["mean"] == 0.5
    assert c["lo"] == 0.0 and c["hi"] == 1.0   # 4 tables: the interval is wide, as it should be


def _run(*argv: str) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, str(ROOT / "docs" / "claims.py"), *argv], cwd=ROOT,
                          capture_output=True, text=True, timeout=300,
                          env={**os.environ, "MPLBACKEND": "Agg"})


def test_the_command_exits_3_on_a_claim_that_does_not_follow(tmp_path):
    one = tmp_path / "claims.toml"
    text = (ROOT / "docs" / "claims.toml").read_text()
    block = text[text.index('[[claim]]\nid = "readme-release-rate"'):]
    block = block[:block.index("\n[[claim]]", 10)]
    one.write_text(block.replace('rate_min = "3.332"', 'rate_min = "3.322"')
                   .replace("(3.332 of", "(3.322 of"))
    r = _run(str(one))
    assert r.returncode == 3, r.stdout + r.stderr
    assert "NO  readme-release-rate" in r.stdout
    one.write_text(block)
    assert _run(str(one)).returncode == 0


def test_the_command_exits_2_on_a_bad_claims_file(tmp_path):
    bad = tmp_path / "claims.toml"
    bad.write_text('[[claim]]\nid = "x"\npage = "README.md"\n')
    r = _run(str(bad))
    assert r.returncode == 2 and "claims.py:" in r.stderr


def test_coverage_counts_what_a_claim_covers_and_lists_the_rest():
    """``python docs/claims.py coverage``: a number inside a claim's quote is covered, one
    outside every quote and checked table is listed with its line; the README's result figures
    are all in claims (what is left there is set-up: versions, sizes, exit codes)."""
    report = {page: (total, covered, missing) for page, total, covered, missing
              in claims.coverage()}
    assert set(report) == set(PAGES)
    for page, (total, covered, missing) in report.items():
        assert 0 < covered <= total and len(missing) == total - covered, page
    readme = (ROOT / "README.md").read_text()
    quote = next(c["text"] for c in ALL if c["page"] == "README.md" and "0.32" in c["text"])
    listed = {number for _, number, _ in report["README.md"][2]}
    assert quote in claims._words(readme) and "0.32" not in listed
    # the README's uncovered numbers: set-up and sizes, never a share, a speed or an interval
    assert all(not re.fullmatch(r"0\.\d\d|1\.1\d", n) or n == "1.17"
               for n in listed), sorted(listed)


# ---- every stated difference is checked (docs/claims.py differences)

@pytest.mark.parametrize("page", PAGES)
def test_every_stated_difference_is_checked_against_its_table(page):
    """Every figure of a difference a page states (a signed figure, an interval in brackets,
    a figure with a comparative, two figures set against each other) is a value of a claim,
    recomputed with its direction, or of a checked table."""
    left = claims.stated_differences(page)
    assert left == [], "\n".join(f"{page}:{line}: {n} ...{ctx}..." for line, n, ctx in left)


def _page_with(tmp_path, monkeypatch, text: str, page_claims: list[dict]) -> str:
    page = tmp_path / "page.md"
    page.write_text(text)
    for c in page_claims:
        c["page"] = str(page)
    monkeypatch.setattr(claims, "load", lambda *a: page_claims)
    monkeypatch.setattr(claims, "load_tables", lambda *a: [])
    return str(page)


def test_a_stated_difference_without_a_claim_is_found(tmp_path, monkeypatch):
    page = _page_with(tmp_path, monkeypatch,
                      "The variant walks 0.16 m/s slower (0.82 against 0.99 m/s). Its trot gait\n"
                      "is not shown to differ (−0.05 [−0.16, +0.06]); sessions 2 s shorter.\n", [])
    found = [n for _, n, _ in claims.stated_differences(page)]
    assert found == ["0.16", "0.82", "0.99", "−0.05", "−0.16", "+0.06", "2"]


def test_sizes_and_ranges_are_not_differences(tmp_path, monkeypatch):
    page = _page_with(tmp_path, monkeypatch,
                      "Seeds 1–3, 20 seeds against 20, 5 runs × 10 s each, period 0.499–0.521 s,\n"
                      "Python 3.11, the paper's 1.17 m/s.\n", [])
    assert claims.stated_differences(page) == []


def test_a_figure_only_quoted_is_not_checked(tmp_path, monkeypatch):
    """A claim covers the figures it recomputes (its values), not every figure of its quote:
    a difference beside a checked figure stays unchecked."""
    text = "Speed (−0.20 [−0.36, −0.05]) leans lower.\n"
    claim = {"id": "x", "text": "Speed (−0.20 [−0.36, −0.05])", "compute": "none",
             "values": {"d": "−0.20"}, "direction": "none"}
    page = _page_with(tmp_path, monkeypatch, text, [claim])
    assert [n for _, n, _ in claims.stated_differences(page)] == ["−0.36", "−0.05"]
    claim["values"].update(lo="−0.36", hi="−0.05")
    assert claims.stated_differences(page) == []


def test_the_differences_command_exits_0_when_every_difference_is_checked():
    run = subprocess.run([sys.executable, str(ROOT / "docs" / "claims.py"), "differences"],
                         capture_output=True, text=True, cwd=ROOT)
    assert run.returncode == 0, run.stdout[-2000:]
    assert "0 figures of stated differences no claim covers" in run.stdout
