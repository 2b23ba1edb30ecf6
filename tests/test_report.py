"""``astrocpg report`` on study folders written here (no training): the figures against the
swept values, the tests between conditions, and numbers in report.md that come from the data."""

from __future__ import annotations

import csv
import json
import re
from pathlib import Path

import numpy as np
import pytest

from astrocpg.coupling.training import SESSION_COLUMNS
from astrocpg.studies.commands.trained_controller import GAIT_COLUMNS
from astrocpg.studies.outputs.writing import write_manifest
from astrocpg.studies.parameter_studies.report import report
from astrocpg.studies.parameter_studies.study import _save_index, load_study

VARIANTS = Path(__file__).resolve().parents[1] / "models" / "variants"


def _study_folder(tmp_path: Path, text: str, value=None, gait=None) -> tuple[Path, object]:
    """A study folder as `astrocpg study` leaves it, its runs' sessions.csv made up:
    ``value(run, seed, session) -> (final_x, reward)`` (default: from a seeded generator);
    ``gait(run, seed) -> label``: a gait.csv per run."""
    study_file = tmp_path / "s.toml"
    study_file.write_text(text)
    study = load_study(study_file)
    out = tmp_path / "out"
    out.mkdir()
    _save_index(study, out)
    rng = np.random.default_rng(0)
    for run in study.runs:
        folder = out / "runs" / run.run_id
        folder.mkdir(parents=True)
        lines = [",".join(SESSION_COLUMNS)]
        for b in range(run.n_trials):
            for s in range(1, run.n_sessions + 1):
                x, r = (value(run, run.seed + b, s) if value else
                        (float(rng.normal(1.0, 0.3)), float(rng.normal(0.1, 0.05))))
                row = {"trial": b, "session": s, "length_s": 0.5 + 0.1 * (s % 3), "final_x_m": x,
                       "mean_reward": r, "mean_forward_speed_m_per_s": x / 5,
                       "spikes_thigh_motor": 10, "spikes_calf_motor": 10,
                       "spikes_interneuron": 5, "adenosine_releases": 1, "progress": 0.0,
                       "t_learning_start_s": 0.0, "diverged": 0}
                lines.append(",".join(str(row[c]) for c in SESSION_COLUMNS))
        (folder / "sessions.csv").write_text("\n".join(lines) + "\n")
        if gait is not None:
            g = ["trial," + ",".join(GAIT_COLUMNS)]
            for b in range(run.n_trials):
                row = {c: 0.5 for c in GAIT_COLUMNS} | {"final_gait": gait(run, run.seed + b),
                                                         "final_speed_m_per_s": 0.1 * b}
                g.append(f"{b}," + ",".join(str(row[c]) for c in GAIT_COLUMNS))
            (folder / "gait.csv").write_text("\n".join(g) + "\n")
        (folder / "status.json").write_text(json.dumps({"state": "finished"}))
        write_manifest(folder, command="study-run", seed=run.seed, settings={}, models_json={},
                       files={"sessions.csv": "made up"})
    return out, study


HEAD = """[study]
name = "made_up"
sessions = {sessions}
seeds = {{ first = 1, count = {seeds} }}
batch = 2
"""
CONDITIONS = """
[conditions.astrocytes]
astrocytes = true
[conditions.no_astrocytes]
astrocytes = false
"""


def _labelled(fig) -> None:
    axes = [ax for ax in fig.axes if ax.get_label() != "<colorbar>"]
    assert fig._suptitle is not None and fig._suptitle.get_text()
    for ax in axes:
        assert "(" in ax.get_ylabel(), ax.get_ylabel()  # a unit
    bottom = [ax for ax in axes if ax.get_xlabel()]
    assert bottom and all("(" in ax.get_xlabel() for ax in bottom)


def test_two_axis_sweep_draws_a_heatmap_per_measure(tmp_path: Path) -> None:
    text = HEAD.format(sessions=4, seeds=2) + (
        '[sweep.axes]\nL_max = ["1*second", "2*second", "3*second"]\n'
        'tau_STDP = ["10*ms", "20*ms"]\n[conditions.astrocytes]\nastrocytes = true\n')
    folder, _ = _study_folder(tmp_path, text)
    written = report(folder)
    heatmaps = {k: f for k, f in written["figures"].items() if k.startswith("heatmap_")}
    assert set(heatmaps) == {"heatmap_speed.png", "heatmap_final_x.png", "heatmap_length.png",
                             "heatmap_reward.png", "heatmap_full.png"}
    for file, fig in heatmaps.items():
        assert (folder / "report" / file).stat().st_size > 0
        _labelled(fig)
        (ax,) = [a for a in fig.axes if a.get_label() != "<colorbar>"]
        assert ax.get_xlabel() == "L_max (second)" and ax.get_ylabel() == "tau_STDP (ms)"
        assert [t.get_text() for t in ax.get_xticklabels()] == ["1", "2", "3"]
        assert [t.get_text() for t in ax.get_yticklabels()] == ["10", "20"]
        (bar,) = [a for a in fig.axes if a.get_label() == "<colorbar>"]
        assert "(" in bar.get_ylabel()  # the colour bar names the measure and its unit
    # the cells are the means across seeds of the per-seed final figures
    fig = heatmaps["heatmap_final_x.png"]
    image = fig.axes[0].images[0].get_array()
    seeds = written["per_seed"]
    for j, lm in enumerate(["1*second", "2*second", "3*second"]):
        for i, tau in enumerate(["10*ms", "20*ms"]):
            expect = np.mean([o["final_x"] for o in seeds if o["point"] == (lm, tau)])
            assert image[i, j] == pytest.approx(expect)
    text = (folder / "report" / "report.md").read_text()
    for file in heatmaps:
        assert f"`{file}`" in text


def test_two_axis_sweep_with_gaits_draws_a_gait_map(tmp_path: Path) -> None:
    text = HEAD.format(sessions=2, seeds=2) + (
        '[sweep.axes]\nL_max = ["1*second", "2*second"]\n'
        'tau_STDP = ["10*ms", "20*ms", "30*ms"]\n[conditions.astrocytes]\nastrocytes = true\n')

    def gait(run, seed):  # trot where L_max is long, else pace
        return "trot" if run.point["L_max"] == "2*second" else "pace"

    folder, _ = _study_folder(tmp_path, text, gait=gait)
    written = report(folder)
    fig = written["figures"]["gait_map.png"]
    assert (folder / "report" / "gait_map.png").stat().st_size > 0
    ax = fig.axes[0]
    assert ax.get_xlabel() == "L_max (second)" and ax.get_ylabel() == "tau_STDP (ms)"
    labels = {t.get_text().split("\n")[0] for t in ax.texts}
    assert labels == {"trot", "pace"}
    cells = {(round(t.get_position()[0]), t.get_text().split("\n")[0]) for t in ax.texts}
    assert cells == {(0, "pace"), (1, "trot")}  # columns: L_max 1 s, 2 s
    assert "`gait_map.png`" in (folder / "report" / "report.md").read_text()


def test_one_axis_sweep_draws_measures_against_the_value(tmp_path: Path) -> None:
    text = HEAD.format(sessions=3, seeds=2) + (
        '[sweep.axes]\nL_max = ["2*second", "1*second"]\n' + CONDITIONS)
    folder, _ = _study_folder(tmp_path, text)
    written = report(folder)
    fig = written["figures"]["sweep_L_max.png"]
    assert (folder / "report" / "sweep_L_max.png").stat().st_size > 0
    _labelled(fig)
    assert len(fig.axes) == 5  # one panel per final figure
    assert fig.axes[-1].get_xlabel() == "L_max (second)"
    assert fig.axes[0].get_ylabel() == "forward speed (m/s)"
    assert len(fig.axes[0].get_legend().get_texts()) == 2  # one line per condition
    # the numeric axis is sorted by value; the points are the per-seed means
    line = fig.axes[1].lines[0]
    np.testing.assert_allclose(line.get_xdata(), [1.0, 2.0])
    seeds = written["per_seed"]
    np.testing.assert_allclose(line.get_ydata(), [
        np.mean([o["final_x"] for o in seeds if o["condition"] == "astrocytes"
                 and o["point"] == (v,)]) for v in ("1*second", "2*second")])


def test_an_axis_of_model_files_is_categorical(tmp_path: Path) -> None:
    text = HEAD.format(sessions=2, seeds=2) + (
        f'[sweep.axes]\nastrocyte = ["{VARIANTS / "li_rinzel_astrocyte.toml"}", '
        f'"{VARIANTS / "gchi_astrocyte.toml"}"]\n[conditions.astrocytes]\nastrocytes = true\n')
    folder, _ = _study_folder(tmp_path, text)
    fig = report(folder)["figures"]["sweep_astrocyte.png"]
    ax = fig.axes[-1]
    assert ax.get_xlabel() == "astrocyte (model file)"
    assert [t.get_text() for t in ax.get_xticklabels()] == ["li_rinzel_astrocyte",
                                                            "gchi_astrocyte"]


def test_condition_tests_match_scipy(tmp_path: Path) -> None:
    from scipy import stats

    folder, _ = _study_folder(tmp_path, HEAD.format(sessions=15, seeds=5) + CONDITIONS)
    written = report(folder)
    seeds = written["per_seed"]
    with open(folder / "report" / "condition_tests.csv", newline="") as f:
        table = {r["measure"]: r for r in csv.DictReader(f)}
    assert set(table) == {"speed", "final_x", "length", "reward", "full"}
    for key in ("final_x", "reward"):
        a = np.array([o[key] for o in seeds if o["condition"] == "astrocytes"])
        b = np.array([o[key] for o in seeds if o["condition"] == "no_astrocytes"])
        row = table[key]
        assert (row["condition_a"], row["condition_b"]) == ("astrocytes", "no_astrocytes")
        assert int(row["n_a"]) == int(row["n_b"]) == 5
        t = stats.ttest_ind(a, b, equal_var=False)
        u = stats.mannwhitneyu(a, b, alternative="two-sided")
        assert float(row["welch_t"]) == pytest.approx(t.statistic, rel=1e-5)
        assert float(row["welch_p"]) == pytest.approx(t.pvalue, rel=1e-5)
        assert float(row["mwu_U"]) == pytest.approx(u.statistic)
        assert float(row["mwu_p"]) == pytest.approx(u.pvalue, rel=1e-5)
        pooled = np.sqrt((4 * a.var(ddof=1) + 4 * b.var(ddof=1)) / 8)
        d = (a.mean() - b.mean()) / pooled
        assert float(row["cohens_d"]) == pytest.approx(d, rel=1e-5)
        assert float(row["hedges_g"]) == pytest.approx(d * (1 - 3 / (4 * 10 - 9)), rel=1e-5)
        assert float(row["rank_biserial"]) == pytest.approx(2 * u.statistic / 25 - 1, rel=1e-5)
        assert float(row["difference"]) == pytest.approx(a.mean() - b.mean(), rel=1e-5)
        # 5 + 5 seeds: every relabelling enumerated (C(10, 5) = 252), an exact p
        assert row["perm_exact"] == "True"
        assert float(row["perm_p"]) >= 1 / 252
        assert float(row["difference_low"]) <= float(row["difference"]) <= float(
            row["difference_high"])
    # one family (astrocytes vs no_astrocytes at the one point): Holm over its 5 figures
    from astrocpg.studies.analysis.compare import holm
    raw = [float(table[k]["perm_p"]) for k in sorted(table)]
    assert [float(table[k]["perm_p_holm"]) for k in sorted(table)] == pytest.approx(
        holm(raw), rel=1e-5)
    text = (folder / "report" / "report.md").read_text()
    assert "### astrocytes vs no_astrocytes" in text
    assert "difference [95% interval]" in text and "permutation p (Holm)" in text
    assert "Holm-adjusted" in text and "exact" in text
    r = table["final_x"]
    assert (f"[{float(r['difference_low']):+.2f}, {float(r['difference_high']):+.2f}]"
            in text)
    # the session counts in the text are the study's, not the default --last 50
    assert "trains 15 sessions per seed" in text and "its last 15 sessions" in text
    assert "50 sessions" not in text
    assert "| astrocytes | 5 | 3/3 | 15 | 15 |" in text
    # and with --last below the study's length
    text = report(folder, last=4)["text"]
    assert "its last 4 sessions" in text and "| astrocytes | 5 | 3/3 | 15 | 4 |" in text


def test_a_study_that_declares_pairs_is_compared_seed_by_seed(tmp_path: Path) -> None:
    """``paired = true`` in [study]: seed k of one condition against seed k of the other, by
    sign flips; without it the same data is compared unpaired."""
    def value(run, seed, session):  # each seed's own level, the condition adds 0.1
        return seed + (0.1 if run.astrocytes else 0.0) + 0.001 * session, 0.1

    text = HEAD.format(sessions=3, seeds=6) + CONDITIONS
    (tmp_path / "unpaired").mkdir()
    (tmp_path / "paired").mkdir()
    folder, _ = _study_folder(tmp_path / "unpaired", text, value)
    unpaired = {t["measure"]: t for t in report(folder)["tests"]}
    paired_text = text.replace("batch = 2\n", "batch = 2\npaired = true\n")
    folder, study = _study_folder(tmp_path / "paired", paired_text, value)
    assert study.paired
    written = report(folder)
    paired = {t["measure"]: t for t in written["tests"]}
    # 6 pairs, each +0.1: 2 of the 2^6 sign patterns reach it
    assert paired["final_x"]["paired"] and paired["final_x"]["perm_p"] == pytest.approx(2 / 64)
    assert paired["final_x"]["difference_low"] == pytest.approx(0.1)
    assert unpaired["final_x"]["perm_p"] > 0.5  # the seeds' spread hides it unpaired
    assert "paired by seed" in written["text"] and "paired = true" in written["text"]


def test_paired_must_be_a_boolean(tmp_path: Path) -> None:
    from astrocpg.errors import InputError

    f = tmp_path / "s.toml"
    f.write_text(HEAD.format(sessions=2, seeds=2).replace("batch = 2\n", "batch = 2\npaired = 1\n")
                 + CONDITIONS)
    with pytest.raises(InputError, match="paired must be true or false"):
        load_study(f)


def test_one_seed_per_side_is_n_too_small(tmp_path: Path) -> None:
    folder, _ = _study_folder(tmp_path, HEAD.format(sessions=2, seeds=1) + CONDITIONS)
    written = report(folder)
    text = written["text"]
    assert "n too small" in text and "nan" not in text.lower()
    assert all(t["note"] == "n too small" and t["welch_p"] is None for t in written["tests"])
    with open(folder / "report" / "condition_tests.csv", newline="") as f:
        rows = list(csv.DictReader(f))
    assert rows and all(r["welch_p"] == "" and r["note"] == "n too small" for r in rows)


def test_the_numbers_of_the_text_come_from_the_data(tmp_path: Path) -> None:
    """Known per-seed values, and a run still in progress: the report's figures and session
    counts are those of the data."""
    def value(run, seed, session):
        return (2.0 if run.astrocytes else 1.0) + 0.01 * seed, 0.25

    folder, study = _study_folder(tmp_path, HEAD.format(sessions=7, seeds=3) + CONDITIONS,
                                  value)
    text = report(folder)["text"]
    # final x per condition: mean of 2.01, 2.02, 2.03 and of 1.01, 1.02, 1.03
    # with its 95% t interval over the 3 seeds (the seed is the unit, not its sessions)
    assert ("| astrocytes | 3 | 2/2 | 7 | 7 | 0.404 ± 0.002 [0.399, 0.409] | "
            "2.02 ± 0.01 [2.00, 2.04] |") in text
    assert "| 2.02 (n=3) | 1.02 (n=3) | +1.00 [" in text
    assert "trains 7 sessions per seed; 7 of them are done" in text
    # the ablation's second run stopped after 3 sessions and is still running
    run = next(r for r in study.runs if not r.astrocytes and r.n_trials == 1)
    csv_path = folder / "runs" / run.run_id / "sessions.csv"
    csv_path.write_text("".join(csv_path.read_text().splitlines(True)[:4]))
    (folder / "runs" / run.run_id / "status.json").write_text(json.dumps({"state": "running"}))
    text = report(folder, last=5)["text"]
    assert "trains 7 sessions per seed; 3–7 of them are done" in text
    assert "its last 3–5 sessions (at most 5; a seed that trained fewer uses all of its 3–7)" \
        in text
    assert "| no_astrocytes | 3 | 1/2 | 3–7 | 3–5 |" in text


def test_final_gaits_over_seeds_with_the_measure_the_label_thresholds(tmp_path: Path) -> None:
    """report.md's final gaits: one run per seed, the trot share with its Wilson interval over
    seeds, the locking and the share at other thresholds (the label alone says none)."""
    from astrocpg.studies.analysis.share import wilson_interval

    def gait(run, seed):
        return "trot" if seed == 1 else "none"

    folder, _ = _study_folder(tmp_path, HEAD.format(sessions=2, seeds=3) + CONDITIONS,
                              gait=gait)
    written = report(folder)
    row = next(r for r in written["rows"] if r["condition"] == "astrocytes")
    assert row["final_seeds"] == 3 and row["final_trot_gait_k"] == 1
    assert (row["final_trot_gait_low"], row["final_trot_gait_high"]) == wilson_interval(1, 3)
    # every made-up phase is 0.5 and every locking 0.5: no trot at 0.7, none at any threshold
    assert row["final_gait_locking_mean"] == 0.5
    assert row["final_trot_gait_at_0.5"] == 0.0
    text = written["text"]
    assert "## Final gaits" in text and "| trot gait at 0 / 0.5 / 0.6 / 0.7 / 0.8 |" in text
