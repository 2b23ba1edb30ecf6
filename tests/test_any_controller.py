"""The gait of any controller: ``gait`` and ``evaluate`` take a model variant and a run folder,
``evaluate --point`` one sweep point of a study, ``--baseline`` a world's effect relative to
flat ground (difference-in-differences, paired by seed), and a Result names its own rhythm and
gait."""

from __future__ import annotations

import math

import numpy as np
import pytest

from astrocpg.errors import InputError
from astrocpg.studies.cli import build_parser
from astrocpg.studies.commands.evaluate import at_points, baseline_effects, format_baseline
from astrocpg.studies.commands.run import with_variant


def test_gait_and_evaluate_take_the_variant_options_of_run() -> None:
    p = build_parser()
    a = p.parse_args(["gait", "d", "--set", "tau_motor=9*ms", "--model", "astrocyte=a.toml",
                      "--equations", "motor_neuron=e.txt", "--population", "p.toml"])
    assert (a.overrides, a.model_files, a.equations, a.population_files) == (
        ["tau_motor=9*ms"], ["astrocyte=a.toml"], ["motor_neuron=e.txt"], ["p.toml"])
    e = p.parse_args(["evaluate", "d", "--point", "eta_ADO=18*nvolt", "--baseline", "flat",
                      "--set", "tau_motor=9*ms"])
    assert (e.point, e.baseline, e.overrides) == (["eta_ADO=18*nvolt"], "flat",
                                                  ["tau_motor=9*ms"])


def test_with_variant_goes_over_the_controllers_own_settings() -> None:
    settings = {"overrides": ["tau_motor=8*ms", "A_random=0.3"], "seed": 4}
    out = with_variant(settings, overrides=["tau_motor=9*ms"])
    from astrocpg.studies.commands.run import trained_models
    assert float(trained_models(out).parameter("tau_motor").value) == pytest.approx(9e-3)
    assert float(trained_models(out).parameter("A_random").value) == pytest.approx(0.3)
    assert settings["overrides"] == ["tau_motor=8*ms", "A_random=0.3"]  # not changed
    assert with_variant(settings) == settings
    with pytest.raises(InputError, match="tau_motr"):
        with_variant(settings, overrides=["tau_motr=9*ms"])


def _controllers() -> list[dict]:
    return [{"condition": c, "point": point, "folder": f"{c}-{point}"}
            for c in ("astrocytes", "no_astrocytes")
            for point in ("eta_ADO=18*nvolt", "eta_ADO=36*nvolt")]


def test_point_picks_one_sweep_point() -> None:
    kept = at_points(_controllers(), ["eta_ADO = 36*nvolt"])
    assert [c["folder"] for c in kept] == ["astrocytes-eta_ADO=36*nvolt",
                                           "no_astrocytes-eta_ADO=36*nvolt"]
    with pytest.raises(InputError, match="is not a swept parameter .swept: eta_ADO.") as e:
        at_points(_controllers(), ["tau=1*ms"])
    assert "point tau=1*ms" in str(e.value)  # the setting, in the Python API's words
    with pytest.raises(InputError, match="no finished run at that value .eta_ADO: 18"):
        at_points(_controllers(), ["eta_ADO=4*nvolt"])
    with pytest.raises(InputError, match="no sweep points"):
        at_points([{"condition": "a", "point": "", "folder": "f"}], ["eta_ADO=18*nvolt"])
    with pytest.raises(InputError, match="expected NAME=VALUE"):
        at_points(_controllers(), ["eta_ADO"])


def _rows(condition: str, falls: dict[str, float], seeds=range(1, 7), repeats: int = 4):
    rng = np.random.default_rng(len(condition))
    rows = []
    for seed in seeds:
        for world, share in falls.items():
            # each table's own share near the condition's, its repeats 0/1
            k = int(round(repeats * min(1.0, max(0.0, share + rng.normal(0, 0.05)))))
            for r in range(repeats):
                rows.append({"source": condition, "condition": condition, "point": "",
                             "seed": seed, "world": world, "repeat": r, "fell": int(r < k),
                             "mean_speed_m_per_s": 1.0, "distance_m": 10.0,
                             "gait": "none"})
    return rows


def test_baseline_takes_the_flat_ground_difference_out() -> None:
    # astrocytes fall less than none in the rough world (0.5 against 0.75): the raw reading
    # "falls less in every world". Relative to flat ground (0 against 0.5), the rough world
    # adds 0.5 to the falls with astrocytes and 0.25 without: it hurts them more
    rows = _rows("astrocytes", {"flat": 0.0, "rough": 0.5}) \
        + _rows("none", {"flat": 0.5, "rough": 0.75})
    effects = baseline_effects(rows, "flat")
    by = {(e["condition"], e["world"], e["measure"]): e for e in effects}
    raw = by[("astrocytes", "rough", "falls (share of runs)")]["in_world"] \
        - by[("none", "rough", "falls (share of runs)")]["in_world"]
    assert raw < 0  # the old way: astrocytes fall less
    did = by[("astrocytes - none", "rough", "falls (share of runs)")]
    assert did["effect"] > 0 and did["effect_low"] > 0  # world minus flat: they fall more
    assert did["n_tables"] == 6
    assert did["reading"].startswith("its 95% interval excludes 0")
    within = by[("astrocytes", "rough", "falls (share of runs)")]
    assert within["effect"] == pytest.approx(0.5, abs=0.1) and within["n_tables"] == 6
    assert within["effect_low"] <= within["effect"] <= within["effect_high"]
    lines = format_baseline(effects)
    assert any("rough minus flat" in line and "paired by seed" in line for line in lines)
    # the flat world is the baseline, not a row of its own
    assert not any(e["world"] == "flat" for e in effects)


def test_a_run_folder_and_a_variant_name_their_gait(tmp_path) -> None:
    """``gait RUN_FOLDER --set ...``: the run's tables with the variant's models; a Result's
    rhythm and gait are the measures ``gait`` and ``evaluate`` write."""
    import astrocpg as ac
    from astrocpg.studies.commands.trained_controller import gait_runs

    table = np.zeros((8, 8))
    other = np.full((8, 8), 1e-5)
    for leg in range(4):
        other[2 * leg:2 * leg + 2, 2 * leg:2 * leg + 2] = 0  # the same-limb blocks stay 0
    from brian2 import volt

    run = ac.run(seconds=0.4, trials=2, seed=5, weights=np.stack([table, other]) * volt,
                 out=tmp_path / "run", progress=False)
    from astrocpg.studies.commands.run import format_run
    lines = format_run(run, 5)  # astrocpg run names each trial's rhythm and gait
    assert sum("over the second half: rhythm (thigh bursts)" in x for x in lines) == 2
    g = ac.gait_of(run, trial=1)
    assert {"gait", "gait_reason", "gait_locking", "rhythm", "gait_at"} <= set(g)
    assert set(g["gait_at"]) == {0.0, 0.5, 0.6, 0.7, 0.8}
    assert ac.rhythm_of(run, trial=1)["rhythm"] == g["rhythm"]
    assert ac.gait_of(ac.load(tmp_path / "run"), trial=1)["gait_reason"] == g["gait_reason"]
    with pytest.raises(InputError, match="trial"):
        ac.gait_of(run, trial=2)
    with pytest.raises(InputError, match="start"):
        ac.gait_of(run, start=0.3, stop=0.2)
    with pytest.raises(InputError, match="expected a Result"):
        ac.gait_of(tmp_path / "run")
    rows, tables, models = gait_runs(tmp_path / "run", seconds=0.4, repeats=1, progress=False,
                                     variant={"overrides": ["tau_motor=7*ms"]})
    assert len(rows) == 2 and tables.shape == (2, 8, 8)
    assert tables[1, 0, 2] == pytest.approx(1e-5)
    assert float(models.parameter("tau_motor").value) == pytest.approx(7e-3)
    assert [r["seed"] for r in rows] == [5, 6]
    lines = ac.gait(tmp_path / "run", seconds=0.4, repeats=1, progress=False,
                    overrides=["tau_motor=7*ms"])
    assert lines[-2].startswith("all 2 tables (2 runs;")
    assert "trot gait share by locking threshold" in lines[-1]
    with pytest.raises(InputError, match="tau_motr"):
        ac.gait(tmp_path / "run", seconds=0.4, repeats=1, progress=False,
                overrides=["tau_motr=7*ms"])


def test_evaluate_a_run_folder_with_a_variant_and_a_baseline(tmp_path, capsys) -> None:
    import csv

    import astrocpg as ac
    from astrocpg.studies.cli import main

    ac.run(seconds=0.3, trials=2, seed=2, out=tmp_path / "run", progress=False)
    worlds = tmp_path / "w.toml"
    worlds.write_text('[worlds.flat]\n[worlds.uphill]\nslope = "0.17"\n')
    assert main(["evaluate", str(tmp_path / "run"), "--worlds", str(worlds), "--seconds",
                 "0.3", "--repeats", "1", "--out", str(tmp_path / "ev"), "--baseline", "flat",
                 "--set", "tau_motor=7*ms", "--no-progress"]) == 0
    out = capsys.readouterr().out
    assert "n = 2 tables x 1 runs; 95% intervals over tables" in out
    assert "uphill minus flat" in out
    rows = list(csv.DictReader(open(tmp_path / "ev" / "baseline.csv")))
    assert {r["world"] for r in rows} == {"uphill"} and rows[0]["n_tables"] == "2"
    import json
    manifest = json.loads((tmp_path / "ev" / "manifest.json").read_text())
    assert manifest["settings"]["variant"] == {"overrides": ["tau_motor=7*ms"]}
    assert manifest["settings"]["baseline"] == "flat"
    assert main(["evaluate", str(tmp_path / "run"), "--worlds", str(worlds), "--seconds",
                 "0.3", "--out", str(tmp_path / "ev2"), "--baseline", "icy",
                 "--no-progress"]) == 2
    assert "--baseline icy" in capsys.readouterr().err


def test_falls_in_a_world_are_read_relative_to_flat_ground() -> None:
    """The robustness evaluation (committed): on 2 cm rough ground the controllers with
    astrocytes fall less often than those without (the raw reading, "fall less in every
    world"), but relative to flat ground, seed by seed, the rough ground adds more falls to
    them than to the controllers without."""
    import csv
    from pathlib import Path

    path = Path(__file__).resolve().parents[1] / "docs/beyond/robustness/evaluation.csv"
    with open(path, newline="") as f:
        rows = [r for r in csv.DictReader(f) if r["world"] in ("flat", "rough_2cm")]
    effects = baseline_effects(rows, "flat")
    by = {(e["condition"], e["measure"]): e for e in effects}
    falls = "falls (share of runs)"
    assert by[("astrocytes", falls)]["in_world"] < by[("no_astrocytes", falls)]["in_world"]
    did = by[("astrocytes - no_astrocytes", falls)]
    assert did["n_tables"] == 20 and did["effect"] > 0 and did["effect_low"] > 0


SWEPT_STUDY = """
[study]
name = "swept"
sessions = 1
seeds = { first = 1, count = 1 }
batch = 1
[base]
L_max = "0.2*second"
L_non_alive = "0.1*second"
[sweep.axes]
eta_ADO = ["9*nvolt", "36*nvolt"]
[conditions.astro]
astrocytes = true
"""


@pytest.mark.slow
def test_evaluate_point_evaluates_one_sweep_point_of_a_study(tmp_path) -> None:
    """``astrocpg evaluate STUDY --point eta_ADO=36*nvolt`` on a study of two sweep points
    evaluates the tables of that point alone, as typed (end to end: the study trained, the
    evaluation written); a value the study did not sweep is refused naming the values it has."""
    import csv
    import subprocess
    import sys
    from pathlib import Path

    root = Path(__file__).resolve().parents[1]
    study = tmp_path / "swept.toml"
    study.write_text(SWEPT_STUDY)
    cli = [sys.executable, "-m", "astrocpg"]
    run = lambda *a: subprocess.run([*cli, *map(str, a)], capture_output=True, text=True,  # noqa: E731
                                    timeout=900, cwd=tmp_path)
    trained = run("study", study, "--out", tmp_path / "study", "--workers", "1", "--no-progress")
    assert trained.returncode == 0, trained.stderr
    worlds = root / "docs" / "beyond" / "flat.toml"
    ev = run("evaluate", tmp_path / "study", "--point", "eta_ADO=36*nvolt", "--worlds", worlds,
             "--seconds", "0.2", "--repeats", "1", "--workers", "1", "--no-progress",
             "--out", tmp_path / "ev")
    assert ev.returncode == 0, ev.stderr
    with open(tmp_path / "ev" / "evaluation.csv", newline="") as f:
        rows = list(csv.DictReader(f))
    assert rows and {r["point"] for r in rows} == {"eta_ADO=36*nvolt"}, rows[:2]
    wrong = run("evaluate", tmp_path / "study", "--point", "eta_ADO=4*nvolt", "--worlds", worlds,
                "--seconds", "0.2", "--repeats", "1", "--workers", "1", "--no-progress",
                "--out", tmp_path / "ev2")
    assert wrong.returncode == 2 and "eta_ADO" in wrong.stderr, wrong.stderr
    assert not (tmp_path / "ev2").exists()
