"""Acceptance: a trained controller whose robot falls early keeps its rhythm and has no gait.

``docs/benchmarks/trained_astrocytes/`` is a training with astrocytes (4 trials stopped after
100-113 sessions; its command in its manifest) whose tables drive a trot rhythm at about 1 m/s on flat ground
without a fall (their footfalls are not periodic enough for a gait label: each is ``none``,
``not periodic``, not a fall). On a 0.45 rad slope the robot falls within about 2 s: every command that names a gait (``astrocpg gait``, ``astrocpg evaluate`` and a
study's rows, :func:`final_gaits`) must give the run a rhythm label from the thigh pools and no
gait (``none``, reason ``fell at ...``)."""

from __future__ import annotations

import csv
from pathlib import Path

import pytest

from astrocpg.studies.analysis.gait import NAMED
from astrocpg.studies.cli import main

TRAINED = Path(__file__).resolve().parents[1] / "docs" / "benchmarks" / "trained_astrocytes"
STEEP = "slope=0.45"
SECONDS = "4"


@pytest.mark.slow
def test_on_flat_ground_the_trained_tables_trot_in_rhythm_and_stand() -> None:
    import astrocpg as ac

    rows = ac.gait(TRAINED, seconds=float(SECONDS), repeats=1, rows=True, progress=False)
    assert all(r["rhythm"] == "trot" for r in rows), rows
    assert all(not r["fell"] and not r["gait_reason"].startswith("fell") for r in rows), rows
    assert all(r["mean_speed_m_per_s"] > 0.5 for r in rows), rows


@pytest.mark.slow
def test_gait_on_a_steep_slope_has_a_rhythm_and_no_gait(capsys) -> None:
    assert main(["gait", str(TRAINED), "--seconds", SECONDS, "--repeats", "1", "--world", STEEP,
                 "--no-progress"]) == 0
    out = capsys.readouterr().out
    runs = [line for line in out.splitlines() if " repeat 0 " in line]
    assert runs
    for line in runs:
        assert "gait (footfalls) none: fell at " in line, line
        assert any(f"rhythm (thigh-extensor bursts) {g} " in line for g in NAMED), line
    assert "no named gait in 1 run" in out


@pytest.mark.slow
def test_evaluate_on_a_steep_slope_has_a_rhythm_and_no_gait(tmp_path) -> None:
    worlds = tmp_path / "w.toml"
    worlds.write_text(f'[worlds.steep]\n{STEEP.split("=")[0]} = "{STEEP.split("=")[1]}"\n')
    out = tmp_path / "ev"
    assert main(["evaluate", str(TRAINED), "--worlds", str(worlds), "--seconds", SECONDS,
                 "--repeats", "1", "--out", str(out), "--no-progress"]) == 0
    rows = list(csv.DictReader(open(out / "evaluation.csv")))
    assert rows
    for r in rows:
        assert r["fell"] == "1" and r["gait"] == "none", r
        assert r["gait_reason"].startswith("fell at "), r
        assert r["rhythm"] in NAMED, r
    summary = next(csv.DictReader(open(out / "summary.csv")))
    assert float(summary["gait_any_share"]) == 0.0 and float(summary["rhythm_any_share"]) > 0


@pytest.mark.slow
def test_a_studys_rows_on_a_steep_slope_have_a_rhythm_and_no_gait() -> None:
    from astrocpg.studies.commands.run import (in_world_settings, trained_models,
                                                  training_settings)
    from astrocpg.studies.commands.trained_controller import GAIT_COLUMNS, final_gaits
    from astrocpg.studies.outputs.weights import load_weights

    settings = training_settings(TRAINED)
    models = in_world_settings(trained_models(settings), [STEEP])
    rows = final_gaits(models, load_weights(TRAINED, culprit=""), seconds=float(SECONDS),
                       seed=settings["seed"])
    for r in rows:
        assert set(r) == set(GAIT_COLUMNS)
        assert r["final_gait"] == "none" and r["final_gait_reason"].startswith("fell at "), r
        assert r["final_rhythm"] in NAMED, r
