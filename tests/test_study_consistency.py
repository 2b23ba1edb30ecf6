"""A study is one consistent thing: its report and evaluation read exactly the runs its current
study file names (not those of an earlier version left in the folder); a condition that
diverges ends the study with exit 3, its runs marked diverged (status, manifests,
failures.csv), never run again, and its report shows it as diverged, never as a result; and
every grid (a study's, a worlds file's, an evaluation's cells) is bounded before any work."""

from __future__ import annotations

import csv
import json
from pathlib import Path

import pytest

from astrocpg.errors import InputError
from astrocpg.studies.cli import main
from astrocpg.studies.commands import evaluate as ev
from astrocpg.studies.settings.checks import MAX_GRID
from astrocpg.studies.parameter_studies.report import report
from astrocpg.studies.parameter_studies.study import _save_index, load_study
from test_report import CONDITIONS, HEAD, _study_folder
from tiny_study import tiny_study

BAD = '\n[conditions.bad]\nastrocytes = true\nset = { C_K_chan = "1e300*mV/second" }\n'


def lines_of(err: str) -> list[str]:
    return [x for x in err.splitlines() if x.strip()]


def _edited(tmp_path: Path, before: str, after: str) -> Path:
    """A study folder with the runs of ``before``, then ``after`` run into it (its index)."""
    folder, _ = _study_folder(tmp_path, before)
    (tmp_path / "s2.toml").write_text(after)
    _save_index(load_study(tmp_path / "s2.toml"), folder)
    return folder


# ---------------------------------------------------------------- the runs the study names
@pytest.mark.parametrize("before, after, groups", [
    # seeds count = 3 rerun as count = 2 (batch 1: one run per seed)
    (HEAD.format(sessions=2, seeds=3).replace("batch = 2", "batch = 1") + CONDITIONS,
     HEAD.format(sessions=2, seeds=2).replace("batch = 2", "batch = 1") + CONDITIONS,
     {"astrocytes": 2, "no_astrocytes": 2}),
    # a condition taken out
    (HEAD.format(sessions=2, seeds=2) + CONDITIONS,
     HEAD.format(sessions=2, seeds=2) + "[conditions.astrocytes]\nastrocytes = true\n",
     {"astrocytes": 2}),
    # a sweep point taken out
    (HEAD.format(sessions=2, seeds=2) + '[sweep.axes]\nL_max = ["1*second", "2*second"]\n'
     "[conditions.astrocytes]\nastrocytes = true\n",
     HEAD.format(sessions=2, seeds=2) + '[sweep.axes]\nL_max = ["1*second"]\n'
     "[conditions.astrocytes]\nastrocytes = true\n",
     {"astrocytes (L_max=1*second)": 2}),
], ids=["fewer-seeds", "fewer-conditions", "fewer-points"])
def test_the_report_reads_only_the_runs_the_current_study_names(tmp_path, before, after,
                                                                 groups):
    folder = _edited(tmp_path, before, after)
    written = report(folder)
    assert {r["group"]: r["seeds"] for r in written["rows"]} == groups
    assert not written["no_data"]
    assert len(written["per_seed"]) == sum(groups.values())


def test_evaluate_reads_only_the_runs_the_current_study_names(tmp_path):
    folder = _edited(tmp_path,
                     HEAD.format(sessions=2, seeds=3).replace("batch = 2", "batch = 1")
                     + "[conditions.astrocytes]\nastrocytes = true\n",
                     HEAD.format(sessions=2, seeds=2).replace("batch = 2", "batch = 1")
                     + "[conditions.astrocytes]\nastrocytes = true\n")
    for run in (folder / "runs").iterdir():  # what a finished run's status holds
        spec = json.loads((folder / "study.json").read_text())["specs"][run.name]
        (run / "status.json").write_text(json.dumps({"state": "finished", "spec": spec}))
    found = [c["folder"].name for c in ev._controllers(folder)]
    assert found == ["astrocytes__seed1", "astrocytes__seed2"]


def test_an_index_naming_a_path_reads_no_folder_outside_runs(tmp_path):
    from astrocpg.studies.outputs.study_index import current_specs

    specs = {"a": {}, "../x": {}, "/etc": {}, "..": {}}
    assert list(current_specs({"specs": specs, "current": list(specs)})) == ["a"]
    assert list(current_specs({"specs": {"a": {}, "b": {}}})) == ["a", "b"]  # an older index


# ---------------------------------------------------------------- a diverged condition
def _diverge(folder: Path, run_id: str) -> None:
    (folder / "runs" / run_id / "status.json").write_text(json.dumps(
        {"state": "diverged", "error": "Diverged: motor.v: -2.1e251 ... at t = 0.010 s"}))


def test_a_diverged_group_is_shown_as_diverged_never_as_a_result(tmp_path):
    folder, study = _study_folder(tmp_path, HEAD.format(sessions=3, seeds=2) + CONDITIONS)
    for r in study.runs:
        if not r.astrocytes:
            _diverge(folder, r.run_id)
    written = report(folder)
    assert [r["group"] for r in written["rows"]] == ["astrocytes"]
    assert written["diverged"] == ["no_astrocytes"]
    assert {o["condition"] for o in written["per_seed"]} == {"astrocytes"}
    assert written["tests"] == []  # no statistics against a diverged side
    legend = [t.get_text() for t in written["figures"]["fig3c.png"].axes[0].get_legend()
              .get_texts()]
    assert legend == ["astrocytes (n=2)"]
    assert "**Diverged**" in written["text"] and "motor.v" in written["text"]
    with open(folder / "report" / "final_figures.csv", newline="") as f:
        rows = {r["group"]: r for r in csv.DictReader(f)}
    assert rows["no_astrocytes"]["state"] == "diverged"
    assert rows["no_astrocytes"]["speed_mean"] == "" and rows["no_astrocytes"]["seeds"] == "0"


def test_a_group_with_one_diverged_run_of_two_is_no_result(tmp_path):
    """batch 1: one seed of a group diverged, the other finished: the group is diverged (its
    survivors alone would be a biased result)."""
    folder, study = _study_folder(tmp_path, HEAD.format(sessions=2, seeds=2).replace(
        "batch = 2", "batch = 1") + CONDITIONS)
    _diverge(folder, next(r.run_id for r in study.runs if not r.astrocytes))
    written = report(folder)
    assert written["diverged"] == ["no_astrocytes"] and written["tests"] == []
    assert "runs diverged 1/2" in written["text"]


def test_a_diverged_sweep_point_is_left_out_of_the_sweep_figure_and_tests(tmp_path):
    folder, study = _study_folder(tmp_path, HEAD.format(sessions=2, seeds=2)
                                  + '[sweep.axes]\nL_max = ["1*second", "2*second"]\n'
                                  + CONDITIONS)
    bad = next(r for r in study.runs if not r.astrocytes and r.point["L_max"] == "2*second")
    _diverge(folder, bad.run_id)
    written = report(folder)
    assert written["diverged"] == ["no_astrocytes (L_max=2*second)"]
    assert {t["L_max"] for t in written["tests"]} == {"1*second"}
    assert not any(o["point"] == ("2*second",) and o["condition"] == "no_astrocytes"
                   for o in written["per_seed"])


def test_a_study_whose_every_run_diverged_has_no_result_to_report(tmp_path):
    folder, study = _study_folder(tmp_path, HEAD.format(sessions=2, seeds=2) + CONDITIONS)
    for r in study.runs:
        _diverge(folder, r.run_id)
    with pytest.raises(InputError, match="every run with sessions diverged"):
        report(folder)


@pytest.mark.parametrize("failed, diverged, code, words", [
    (["bad__seed1"], ["bad__seed1"], 3, ["diverged (bad__seed1)", "rerun diverges again"]),
    (["a__seed1", "bad__seed1"], ["bad__seed1"], 1,
     ["a__seed1: OSError", "retry", "diverged, not retried: bad__seed1"]),
], ids=["only-diverged", "diverged-and-failed"])
def test_the_study_command_exits_3_when_only_diverged_runs_are_left(
        tmp_path, monkeypatch, capsys, failed, diverged, code, words):
    from astrocpg.studies.parameter_studies import study as study_module

    errors = {"a__seed1": "OSError: disk full", "bad__seed1": "Diverged: motor.v: -2e251"}
    monkeypatch.setattr(study_module, "run_study", lambda *a, **k: {
        "counts": {}, "failed": failed, "diverged": diverged, "rows": 0, "evaluation": None,
        "errors": {k: errors[k] for k in failed}, "failures": str(tmp_path / "failures.csv")})
    (tmp_path / "s.toml").write_text(tiny_study("t", sessions=1))
    assert main(["study", str(tmp_path / "s.toml"), "--out", str(tmp_path / "o"),
                 "--workers", "1", "--no-progress"]) == code
    (line,) = lines_of(capsys.readouterr().err)
    assert all(w in line for w in words), line


@pytest.fixture(scope="module")
def diverged_study(tmp_path_factory) -> tuple[Path, Path, str]:
    """A real study: a healthy condition and one that diverges (1 seed, 1 short session)."""
    base = tmp_path_factory.mktemp("diverged")
    (base / "s.toml").write_text(tiny_study("d", sessions=1) + BAD)
    out = base / "out"
    import io
    import contextlib

    err = io.StringIO()
    with contextlib.redirect_stderr(err):
        code = main(["study", str(base / "s.toml"), "--out", str(out), "--workers", "1",
                     "--no-progress"])
    return out, base / "s.toml", f"{code}|{err.getvalue()}"


def test_a_diverged_condition_ends_the_study_with_exit_3_marked_diverged(diverged_study):
    out, _, ended = diverged_study
    code, err = ended.split("|", 1)
    assert code == "3", err
    (line,) = lines_of(err)
    assert "diverged (bad__seed1)" in line and "motor.v" in line and "retry" not in line
    status = json.loads((out / "runs" / "bad__seed1" / "status.json").read_text())
    assert status["state"] == "diverged" and status["diverged"]["t_s"] > 0
    manifest = json.loads((out / "runs" / "bad__seed1" / "manifest.json").read_text())
    assert manifest["results"]["status"] == "diverged"  # not left "running"
    study = json.loads((out / "manifest.json").read_text())["results"]
    assert study["status"] == "diverged" and study["diverged"] == ["bad__seed1"]
    assert study["runs"] == {"diverged": 1, "finished": 1}
    assert json.loads((out / "runs" / "astro__seed1" / "status.json").read_text())[
        "state"] == "finished"  # the other condition completed
    with open(out / "failures.csv", newline="") as f:
        assert [(r["run_id"], r["state"]) for r in csv.DictReader(f)] == [
            ("bad__seed1", "diverged")]
    with open(out / "results.csv", newline="") as f:
        assert {r["condition"] for r in csv.DictReader(f)} == {"astro"}


def test_a_diverged_run_is_not_run_again_and_its_report_says_diverged(diverged_study,
                                                                     capsys):
    out, study_file, _ = diverged_study
    assert main(["study", str(study_file), "--out", str(out), "--workers", "1",
                 "--no-progress"]) == 3
    status = json.loads((out / "runs" / "bad__seed1" / "status.json").read_text())
    assert status["attempts"] == 1
    capsys.readouterr()
    assert main(["report", str(out)]) == 0
    captured = capsys.readouterr()
    assert "1 group(s)" in captured.err and "diverged" in captured.err
    md = (out / "report" / "report.md").read_text()
    assert "| bad |" not in md and "| astro | 1 |" in md and "**Diverged**" in md


# ---------------------------------------------------------------- every grid bounded
def _grid(path: Path, *lengths: int, named: int = 0) -> Path:
    axes = ["slope", "friction", "payload"]
    text = "".join(f"[worlds.w{k}]\n" for k in range(named))
    for axis, n in zip(axes, lengths):
        text += (f"[grid.{axis}]\nvalues = ["
                 + ",".join(f'"{0.01 + 1e-5 * i:.6g}"' for i in range(n)) + "]\n")
    path.write_text(text)
    return path


@pytest.mark.parametrize("lengths, named, size", [
    ((400, 300), 0, "120000 worlds (400 x 300 grid values)"),
    ((1000, 1000), 0, "1000000 worlds (1000 x 1000 grid values)"),
    ((100, 100, 11), 0, "110000 worlds"),
    ((1000, 100), 1, "100001 worlds (1000 x 100 grid values, 1 named)"),
], ids=["400x300", "1000x1000", "three-axes", "grid-and-named"])
def test_a_worlds_grid_beyond_the_bound_is_refused_before_a_world_is_built(
        tmp_path, lengths, named, size):
    from astrocpg.models import DEFAULT_MODELS

    path = _grid(tmp_path / "w.toml", *lengths, named=named)
    with pytest.raises(InputError) as e:
        ev.read_worlds(path, DEFAULT_MODELS)
    assert size in str(e.value) and str(MAX_GRID) in str(e.value)
    assert str(e.value).startswith(f"worlds={path}")  # the setting, in the Python API's words


def test_a_worlds_grid_at_the_bound_is_read(tmp_path):
    from astrocpg.models import DEFAULT_MODELS

    ws = ev.read_worlds(_grid(tmp_path / "w.toml", 2, 3, named=1), DEFAULT_MODELS)
    assert len(ws.worlds) == 7


def test_a_study_whose_evaluation_cells_exceed_the_bound_is_refused_when_it_loads(tmp_path):
    _grid(tmp_path / "w.toml", 300, 200)  # 60000 worlds, under the bound
    text = tiny_study("t", sessions=1).replace("count = 1", "count = 2") \
        + '[evaluate]\nworlds = "w.toml"\nseconds = 0.1\nrepeats = 1\n'
    (tmp_path / "s.toml").write_text(text)
    with pytest.raises(InputError, match=r"120000 cells of \[evaluate\] \(2 run\(s\) x "
                                         r"60000 world\(s\)\) is more than 100000"):
        load_study(tmp_path / "s.toml")


def test_an_evaluation_whose_cells_exceed_the_bound_is_refused_before_any_check(
        diverged_study, tmp_path, monkeypatch):
    out, _, _ = diverged_study
    one = ev._controllers(out)
    assert [c["folder"].name for c in one] == ["astro__seed1"]
    monkeypatch.setattr(ev, "_controllers", lambda folder: one * 2)  # two trainings

    def no(*a, **k):
        raise AssertionError("worlds checked before the grid was bounded")

    monkeypatch.setattr(ev, "_check_worlds", no)
    with pytest.raises(InputError, match=r"120000 cells \(2 training\(s\) x 60000 world"):
        ev.evaluate(out, worlds=_grid(tmp_path / "w.toml", 300, 200), seconds=0.1,
                    repeats=1, out=tmp_path / "e", progress=False)
    assert not (tmp_path / "e").exists()
