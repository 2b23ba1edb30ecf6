"""``astrocpg study FILE --seeds --sessions --set`` and ``astrocpg.study(...)``'s keywords:
applied to the study as loaded, checked once (one line, exit 2, naming the option), recorded
in the study folder; a rerun with the same ones resumes, with other ones is refused."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

import astrocpg
from astrocpg.studies.cli import build_parser, main
from astrocpg.studies.cli.words import command_words
from astrocpg.studies.parameter_studies.study import load_study
from astrocpg.studies.settings.study import study_overrides

from tiny_study import tiny_study

SWEPT = """
[study]
name = "swept"
sessions = 4
seeds = { first = 5, count = 2 }
[base]
L_max = "0.2*second"
[sweep.axes]
eta_ADO = ["0.5*mV", "1*mV"]
[conditions.a]
astrocytes = true
[conditions.b]
astrocytes = true
set = { L_non_alive = "0.05*second" }
"""


def _file(tmp_path: Path, text: str = SWEPT, name: str = "s.toml") -> Path:
    p = tmp_path / name
    p.write_text(text)
    return p


def test_the_grammar_of_seeds(tmp_path):
    p = _file(tmp_path)
    assert load_study(p, overrides=study_overrides("1-3")).seeds == [1, 2, 3]
    assert load_study(p, overrides=study_overrides("9,2,4")).seeds == [2, 4, 9]
    assert load_study(p, overrides=study_overrides("3")).seeds == [5, 6, 7]  # from the first
    assert load_study(p, overrides=study_overrides([8])).seeds == [8]
    assert load_study(p, overrides=study_overrides(4)).seeds == [5, 6, 7, 8]
    study = load_study(p, overrides=study_overrides("1-2", sessions=7,
                                                     sets=["L_max=0.3*second", "eta=2*mV"]))
    assert study.n_sessions == 7 and all(r.n_sessions == 7 for r in study.runs)
    for r in study.runs:  # the file's L_max replaced, eta added, the axis and condition kept
        assert "L_max=0.3*second" in r.overrides and "L_max=0.2*second" not in r.overrides
        assert "eta=2*mV" in r.overrides and any(o.startswith("eta_ADO=") for o in r.overrides)
        assert r.session_s == pytest.approx(0.3)
    assert {r.seed for r in study.runs} == {1}
    assert load_study(p).seeds == [5, 6] and load_study(p).n_sessions == 4  # the file's own


@pytest.mark.parametrize("kw, option, words", [
    ({"seeds": "3-1"}, "--seeds", "before the first"),
    ({"seeds": "1..3"}, "--seeds", "FIRST-LAST"),
    ({"seeds": "1,1"}, "--seeds", "twice"),
    ({"seeds": "0"}, "--seeds", "1 to"),
    ({"seeds": "1-200000"}, "--seeds", "more than"),
    ({"sessions": 0}, "--sessions", "0"),
    ({"sets": ["L_max"]}, "--set", "NAME=VALUE"),
    ({"sets": ["tau_motr=9*ms"]}, "--set tau_motr", "tau_motor"),
    ({"sets": ["tau_motor=9*mV"]}, "--set tau_motor", ""),
    ({"sets": ["eta_ADO=1*mV"]}, "--set eta_ADO", "sweeps"),
    ({"sets": ["L_non_alive=0.1*second"]}, "--set L_non_alive", "condition 'b'"),
])
def test_bad_overrides_name_the_option(tmp_path, capsys, kw, option, words):
    p = _file(tmp_path)
    out = tmp_path / "out"
    with pytest.raises(astrocpg.InputError) as e:
        load_study(p, overrides=study_overrides(**kw))
    # the setting at fault, as the command line names it
    said = command_words(build_parser(), "study")
    assert said(e.value.raw_culprit) == option and words in e.value.line, e.value.line
    argv = ["study", str(p), "--out", str(out), "--no-progress"]
    for key, value in kw.items():
        for v in (value if isinstance(value, list) else [value]):
            argv += [{"sets": "--set"}.get(key, f"--{key}"), str(v)]
    assert main(argv) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and err.startswith("astrocpg:") and option in err, err
    assert not out.exists()


def test_study_sessions_is_a_whole_number(capsys, tmp_path):
    assert main(["study", str(_file(tmp_path)), "--sessions", "2.5", "--out",
                 str(tmp_path / "o")]) == 2
    assert "--sessions" in capsys.readouterr().err


@pytest.mark.slow
def test_overrides_are_recorded_and_a_rerun_must_give_them(tmp_path, capsys):
    p = _file(tmp_path, tiny_study("tiny", sessions=5))
    out = tmp_path / "out"
    argv = ["study", str(p), "--out", str(out), "--workers", "1", "--no-progress",
            "--seeds", "2-3", "--sessions", "2", "--set", "L_max=0.15*second"]
    assert main(argv) == 0
    index = json.loads((out / "study.json").read_text())
    assert index["overrides"] == {"seeds": "2-3", "sessions": 2, "set": ["L_max=0.15*second"]}
    manifest = json.loads((out / "manifest.json").read_text())
    assert manifest["settings"]["overrides"] == index["overrides"]
    assert sorted(index["current"]) == ["astro__seed2", "astro__seed3"]
    rows = (out / "runs" / "astro__seed2" / "sessions.csv").read_text().splitlines()
    assert len(rows) == 1 + 2 and all(float(r.split(",")[2]) <= 0.15 + 1e-9 for r in rows[1:])
    # the same command again: resumed (nothing to do), nothing rewritten
    mtime = (out / "runs" / "astro__seed2" / "sessions.csv").stat().st_mtime_ns
    assert main(argv) == 0
    assert (out / "runs" / "astro__seed2" / "sessions.csv").stat().st_mtime_ns == mtime
    # the same through the API
    res = astrocpg.study(p, out=out, seeds="2-3", sessions=2, overrides=["L_max=0.15*second"],
                         workers=1, progress=False)
    assert res["counts"] == {"finished": 2}
    capsys.readouterr()
    # other overrides, or none, on that folder: refused naming the option, nothing changed
    for given, option in ((["--seeds", "2-4", "--sessions", "2", "--set", "L_max=0.15*second"],
                           "--seeds"),
                          (["--seeds", "2-3", "--set", "L_max=0.15*second"], "--sessions"),
                          ([], "--seeds")):
        assert main(["study", str(p), "--out", str(out), "--no-progress", *given]) == 2
        err = capsys.readouterr().err.strip()
        assert len(err.splitlines()) == 1 and option in err, err
    assert json.loads((out / "study.json").read_text()) == index
    with pytest.raises(astrocpg.InputError, match="overrides L_max"):
        astrocpg.study(p, out=out, seeds="2-3", sessions=2, overrides=["L_max=0.1*second"],
                       workers=1, progress=False)
