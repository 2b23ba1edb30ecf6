"""A controller's gait is a share of several runs: ``astrocpg gait`` runs each trained table
``--repeats`` times (independent seeds K + b), prints each run's rhythm and gait, named, and
per table the shares with their Wilson intervals; ``evaluate`` keeps every repeat's labels."""

from __future__ import annotations

import csv
import re

import pytest

from astrocpg.errors import InputError
from astrocpg.models import DEFAULT_MODELS
from astrocpg.studies.analysis.gait import NAMED
from astrocpg.studies.analysis.share import label_shares, wilson_interval
from astrocpg.studies.cli import build_parser, main
from astrocpg.studies.commands.run import in_world_settings
from astrocpg.studies.commands.trained_controller import shares_words


def test_label_shares_count_each_named_label_and_any() -> None:
    s = label_shares(["trot", "trot", "none", "pace", "trot"], NAMED)
    assert s["trot"]["k"] == 3 and s["trot"]["n"] == 5
    assert (s["trot"]["low"], s["trot"]["high"]) == wilson_interval(3, 5)
    assert s["any"]["k"] == 4 and "walk" not in s


def test_shares_words_name_the_gait_its_interval_and_why_the_others_are_none() -> None:
    rows = ([{"gait": "trot", "gait_reason": "", "rhythm": "trot"}] * 3
            + [{"gait": "none", "gait_reason": "fell at 2.16 s", "rhythm": "trot"}] * 2)
    words = shares_words(rows, "gait")
    assert words.startswith("gait trot in 3 of 5 runs (60%, 95% interval 23%-88%)"), words
    assert "none 2 (fell at 2.16 s 2)" in words
    assert shares_words(rows, "rhythm").startswith("rhythm trot in 5 of 5 runs (100%")
    fell = [{"gait": "none", "gait_reason": "fell at 1.00 s", "rhythm": "trot"}] * 5
    assert shares_words(fell, "gait").startswith("no named gait in 5 runs (95% interval 0%-43%)")


def test_a_world_setting_is_a_world_parameter() -> None:
    models = in_world_settings(DEFAULT_MODELS, ["slope=0.17"])
    assert models.value("slope") == pytest.approx(0.17)
    with pytest.raises(InputError, match="not a world parameter") as e:
        in_world_settings(DEFAULT_MODELS, ["tau_motor=9*ms"])
    assert "world tau_motor=9*ms" in str(e.value)  # the setting, in the Python API's words


def test_five_repeats_by_default() -> None:
    parser = build_parser()
    assert parser.parse_args(["gait", "d"]).repeats == 5
    assert parser.parse_args(["evaluate", "d"]).repeats == 5


@pytest.mark.slow
def test_gait_runs_every_table_repeats_times_with_seeds_k_plus_b(tmp_path, capsys) -> None:
    train = tmp_path / "train"
    assert main(["train", "--out", str(train), "--sessions", "1", "--trials", "2", "--seed", "3",
                 "--set", "L_max=0.3*second", "--no-progress"]) == 0
    capsys.readouterr()
    assert main(["gait", str(train), "--seconds", "0.4", "--repeats", "2", "--no-progress"]) == 0
    out = capsys.readouterr().out.splitlines()
    runs = [line for line in out if re.match(r"table \d repeat \d", line)]
    # run b = r * 2 + k has seed 3 + b
    seeds = {re.match(r"table (\d) repeat (\d) \(seed (\d+)\)", line).groups() for line in runs}
    assert seeds == {("0", "0", "3"), ("1", "0", "4"), ("0", "1", "5"), ("1", "1", "6")}
    for line in runs:
        assert "rhythm (thigh-extensor bursts)" in line and "gait (footfalls)" in line, line
        assert "alive (the alive model: torso_z_up >= Thres_z_alive)" in line
    tables = [line for line in out if re.match(r"table \d: ", line)]
    assert len(tables) == 2 and all("in 2 runs" in t or "of 2 runs" in t for t in tables)
    import astrocpg as ac
    rows = ac.gait(train, seconds=0.4, repeats=2, rows=True, progress=False)
    assert [(r["table"], r["repeat"], r["seed"]) for r in rows] == [
        (0, 0, 3), (1, 0, 4), (0, 1, 5), (1, 1, 6)]
    assert {"rhythm", "gait", "gait_reason"} <= set(rows[0])
    # evaluate keeps each repeat's labels, its run's seed, and the shares with intervals
    out_dir = tmp_path / "ev"
    w = tmp_path / "w.toml"
    w.write_text("[worlds.flat]\n")
    assert main(["evaluate", str(train), "--worlds", str(w), "--seconds", "0.4", "--repeats",
                 "2", "--out", str(out_dir), "--no-progress"]) == 0
    rows = list(csv.DictReader(open(out_dir / "evaluation.csv")))
    assert sorted((r["repeat"], r["run_seed"]) for r in rows) == [
        ("0", "1"), ("0", "2"), ("1", "3"), ("1", "4")]
    assert all(r["rhythm"] and r["gait"] for r in rows)
    summary = next(csv.DictReader(open(out_dir / "summary.csv")))
    # the interval is over the 2 tables (each table's 2 runs first), not over 4 runs
    from astrocpg.studies.analysis.replication import share_over_tables
    per_table = [[r["gait"] for r in rows if r["seed"] == seed] for seed in ("3", "4")]
    s = share_over_tables(per_table, "trot")
    assert summary["n_tables"] == "2" and summary["n_runs"] == "4"
    for key in ("low", "high"):
        assert float(summary[f"gait_trot_{key}"] or "nan") == pytest.approx(
            s[key], abs=1e-6, nan_ok=True)
