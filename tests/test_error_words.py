"""An error names the user's settings in the words of the door they came through.

Below the command line an error refers to a setting by its field (``astrocpg.errors.setting``):
the command line writes each as an option of the command that failed, read from that
command's own parser; the Python API writes each as a keyword of the function that was
called. Checked here:

* every case of the bad-input table (:mod:`test_bad_input`): each ``--option`` its stderr line
  names is an option of that command's parser (or, in ``astrocpg OTHER --option``, of that
  command's);
* the API's own error cases: every setting an error references, and every ``name=`` its text
  shows, is a parameter of the function called (``inspect.signature``), and no ``--option``
  appears; advice names an API function that exists (``ac.resume(DIR)``, not ``resume=``).
"""

from __future__ import annotations

import argparse
import inspect
import pickle
import re
from pathlib import Path
from typing import Any, Callable

import numpy as np
import pytest

import astrocpg as ac
from astrocpg.errors import InputError, KEYWORDS, Vocabulary, advice, setting
from astrocpg.studies.cli import build_parser, main
from astrocpg.studies.cli.words import OptionWords

# the table and its fixtures, shared with the bad-input test (fx: the finished folders)
from test_bad_input import CASES, Case, Env, fx, run_in_child, run_in_process  # noqa: F401

OPTION = re.compile(r"(?<![\w-])--[a-z][a-z0-9-]*")
# advice for another command: "astrocpg train --resume DIR", "astrocpg train --out DIR --overwrite"
OTHER_COMMAND = re.compile(r"astrocpg ([a-z]+(?: [a-z]+)?)"
                           r"((?: --[a-z][a-z0-9-]*(?: [A-Z0-9]+\b)?)+)")


# ---------------------------------------------------------------- the command line's parsers
def _subparsers(parser: argparse.ArgumentParser) -> dict[str, argparse.ArgumentParser]:
    return {name: p for a in parser._actions if isinstance(a, argparse._SubParsersAction)
            for name, p in a.choices.items()}


def _chain(argv: list[str]) -> list[argparse.ArgumentParser]:
    """The parsers ``argv`` walks through: the top one, the command's, a sub-command's."""
    chain = [build_parser()]
    for word in argv:
        sub = _subparsers(chain[-1])
        if not sub:
            break
        if word in sub:
            chain.append(sub[word])
        elif not word.startswith("-"):
            break
    return chain


def _options(chain: list[argparse.ArgumentParser]) -> set[str]:
    return {o for p in chain for a in p._actions for o in a.option_strings}


def unknown_options(line: str, argv: list[str]) -> list[str]:
    """The ``--options`` ``line`` names that the command ``argv`` runs has not (nor the
    command an ``astrocpg OTHER --option`` names). An option the user typed and the parser does
    not know (argparse's "unrecognized arguments") is what the line is about: not counted."""
    bad = []
    for m in OTHER_COMMAND.finditer(line):
        other = _options(_chain(m.group(1).split()))
        bad += [o for o in OPTION.findall(m.group(2)) if o not in other]
    rest = OTHER_COMMAND.sub("", line)
    known = _options(_chain(argv))
    typed = {a.split("=", 1)[0] for a in argv}
    return bad + [o for o in OPTION.findall(rest) if o not in known and o not in typed]


def test_the_check_finds_an_option_the_command_has_not():
    assert unknown_options("astrocpg: error: --trace-dt: x", ["train"]) == ["--trace-dt"]
    assert unknown_options("astrocpg: error: --trace-dt: x", ["run"]) == []
    assert unknown_options("astrocpg: error: x (astrocpg train --resume DIR)", ["gait"]) == []
    assert unknown_options("astrocpg: error: x (astrocpg train --seconds 3)", ["run"]) \
        == ["--seconds"]
    assert unknown_options("astrocpg: error: unrecognized arguments: --sekonds", ["run",
                                                                               "--sekonds"]) == []


@pytest.mark.slow
@pytest.mark.parametrize("c", [c.param() for c in CASES])
def test_a_bad_input_line_names_only_options_its_command_has(c: Case, fx, tmp_path, capsys,
                                                            monkeypatch) -> None:
    e = Env(tmp_path, fx)
    monkeypatch.chdir(tmp_path)
    argv = c.argv(e)
    if c.subprocess is not None:
        _, _, stderr = run_in_child(argv, e, c.subprocess)
    else:
        _, _, stderr = run_in_process(argv, capsys)
    lines = [x for x in stderr.splitlines() if x.startswith("astrocpg:")]
    for line in lines:
        assert not unknown_options(line, argv), (argv, line)
        assert not PYTHON_WORDS.search(line), (argv, line)  # never the API's words


# what only the Python API says: a call as advice, a switch as its keyword's value
PYTHON_WORDS = re.compile(r"\bac\.[a-z_]+\(|\b(?:overwrite|progress|astrocytes)=(?:True|False)\b")


# ---------------------------------------------------------------- how each door names a field
def test_a_field_is_an_option_on_the_command_line_and_a_keyword_in_python():
    top = build_parser()
    cli = OptionWords([top, _subparsers(top)["train"]])
    err = InputError(f"drop {setting('out')}; set {setting('overrides', 'tau_motor')} with "
                     f"{setting('progress')} (or {advice('resume', 'DIR')})",
                     culprit=setting("models", "astrocyte"))
    assert err.render(cli) == ("--model astrocyte: drop --out; set --set tau_motor with "
                               "--no-progress (or --resume DIR)")
    assert err.render(KEYWORDS) == ("models astrocyte: drop out; set overrides tau_motor with "
                                    "progress=False (or ac.resume(DIR))")
    assert str(err) == err.line == err.render(KEYWORDS)  # Python's words unless a door speaks
    assert [f.name for f in err.fields] == ["models", "out", "overrides", "progress", "resume"]
    # what a door lacks is advised with the command that has it
    gait = OptionWords([top, _subparsers(top)["gait"]])
    assert InputError(f"continue it with {advice('resume', 'x')}").render(gait) \
        == "continue it with astrocpg train --resume x"
    # a function whose keyword is not the field's name
    assert err.render(Vocabulary({"models": "model_files"})).startswith("model_files astrocyte:")


def test_an_error_keeps_its_fields_across_processes_and_wrapping():
    err = InputError(f"must be positive (see {setting('trace_dt')})", culprit=setting("seconds", 3))
    back = pickle.loads(pickle.dumps(err))
    assert back.fields == err.fields and back.line == "seconds=3: must be positive (see trace_dt)"
    wrapped = InputError(back.raw_line, culprit="a file")
    top = build_parser()
    assert wrapped.render(OptionWords([top, _subparsers(top)["run"]])) == \
        "a file: --seconds 3: must be positive (see --trace-dt)"


# ---------------------------------------------------------------- the Python API's own errors
CHEAP = {"seconds": 0.02, "progress": False}


def _api_cases(tmp: Path) -> list[tuple[str, Callable[[], Any]]]:
    """(function name, call) for errors the API's tests provoke, and the ones whose words
    were wrong before errors named fields (marked *)."""
    other = tmp / "other"
    other.mkdir()
    (other / "mine.txt").write_text("the user's own file\n")
    return [
        ("run", lambda: ac.run(seconds=-1)),
        ("run", lambda: ac.run(**CHEAP, trials=0)),
        ("run", lambda: ac.run(**CHEAP, trace_dt=0)),
        ("run", lambda: ac.run(**CHEAP, spikes=3)),
        ("run", lambda: ac.run(**CHEAP, spikes="glia")),
        ("run", lambda: ac.run(**CHEAP, weights=[[1.0, 2.0]])),
        ("run", lambda: ac.run(**CHEAP, weights=np.zeros((8, 8)))),
        ("run", lambda: ac.run(**CHEAP, overrides="tau_motr=9*ms")),
        ("run", lambda: ac.run(**CHEAP, overrides="tau_motor=nan*ms")),
        ("run", lambda: ac.run(**CHEAP, models=["astrocyte"])),
        ("run", lambda: ac.run(**CHEAP, equations="dv/dt = 0 : volt")),
        ("run", lambda: ac.run(**CHEAP, out=3)),
        ("run", lambda: ac.run(**CHEAP, out=other)),
        ("run", lambda: ac.run(**CHEAP, robot=3)),
        ("run", lambda: ac.run(session=1, out=tmp / "r")),
        ("run", lambda: ac.run(session=1, weights=str(tmp), seconds=3, out=tmp / "r")),
        ("run", lambda: ac.run(**CHEAP, seed=-1)),
        ("unit", lambda: ac.unit(**CHEAP, out=["o"])),
        ("unit", lambda: ac.unit(**CHEAP, workers=0)),
        ("train", lambda: ac.train(out=None, sessions=1)),  # * advised resume=DIR
        ("train", lambda: ac.train(out=3, sessions=1)),
        ("train", lambda: ac.train(out=tmp / "t", sessions=0)),
        ("train", lambda: ac.train(out=tmp / "t", sessions=1, record_stride=2)),
        ("train", lambda: ac.train(out=other, sessions=1, progress=False)),
        ("resume", lambda: ac.resume(3)),
        ("resume", lambda: ac.resume(tmp / "t", out=tmp / "x")),  # * "folder=writes into..."
        ("resume", lambda: ac.resume(tmp / "t", overwrite=True)),
        ("resume", lambda: ac.resume(tmp / "absent")),
        ("load", lambda: ac.load(3)),
        ("plot", lambda: ac.plot(None)),
        ("video", lambda: ac.video(7)),
        ("export", lambda: ac.export(3)),
        ("describe", lambda: ac.describe("astrocyte", equations="text")),
        ("describe", lambda: ac.describe("astrocyte", format="html")),
        ("study", lambda: ac.study("quick", sessions="1.5", out=tmp / "s")),
        ("study", lambda: ac.study("quick", seeds="3-1", out=tmp / "s")),
        ("study", lambda: ac.study("quick", overrides=["tau_motr=9*ms"], out=tmp / "s")),
        ("study_status", lambda: ac.study_status(tmp / "absent")),
        ("report", lambda: ac.report(tmp / "absent")),
        ("response", lambda: ac.response("astrocyte", rates="a:b", out=tmp / "resp")),
    ]


def _api_error(call: Callable[[], Any]) -> Exception:
    with pytest.raises((ac.InputError, ac.EnvironmentFault)) as e:
        call()
    return e.value


def test_an_api_error_names_only_keywords_of_the_function_called(tmp_path):
    from astrocpg import _RENAMES

    for name, call in _api_cases(tmp_path):
        err = _api_error(call)
        text = str(err)
        params = set(inspect.signature(getattr(ac, name)).parameters)
        renames = _RENAMES.get(name, {})
        assert not OPTION.search(text), (name, text)  # never the command line's options
        for f in err.fields:
            if not f.advice:
                assert renames.get(f.name, f.name) in params, (name, f, text)
        # "name=value" and "name:" at the head: a keyword of the function called
        named = re.findall(r"(?:^|[\s(,;])([a-z_]+)=(?!=)", text)
        named += re.findall(r"^([a-z_]+):", text)
        named = [n for n in named if n not in _parameters_of_models()]
        assert set(named) <= params, (name, text, set(named) - params)
        for function in re.findall(r"\bac\.([a-z_]+)\(", text):
            assert function in ac.__all__, (name, text)


def test_the_errors_that_named_a_keyword_the_function_has_not(tmp_path):
    """ac.resume's folder is not the command line's --resume option, and ac.train has no
    resume keyword: each error says what the API does."""
    with pytest.raises(InputError) as e:
        ac.resume(tmp_path / "t", out=tmp_path / "x")
    assert str(e.value) == "out: ac.resume(DIR) writes into its own folder; drop out"
    with pytest.raises(InputError) as e:
        ac.train(out=None, sessions=1)
    assert str(e.value) == "out: is required (or ac.resume(DIR))"
    assert "resume=" not in str(e.value)
    with pytest.raises(InputError) as e:
        ac.resume(tmp_path / "t", overwrite=True)
    assert str(e.value) == ("overwrite=True: replaces a training, ac.resume(DIR) continues one: "
                            "use one of them")
    # the command line says the same with its options
    assert main(["train", "--resume", str(tmp_path), "--out", str(tmp_path / "x")]) == 2


def test_an_override_refused_inside_a_study_is_named_once_in_its_doors_words(tmp_path, capsys):
    assert main(["study", "quick", "--set", "tau_motr=9*ms", "--out", str(tmp_path / "s")]) == 2
    assert capsys.readouterr().err == ("astrocpg: error: --set tau_motr: unknown model parameter "
                                       "(did you mean tau_motor?)\n")
    with pytest.raises(InputError) as e:
        ac.study("quick", overrides=["tau_motr=9*ms"], out=tmp_path / "s")
    assert str(e.value) == "overrides tau_motr: unknown model parameter (did you mean tau_motor?)"


def test_a_study_files_worlds_are_named_by_their_place_not_an_option(tmp_path, capsys):
    """A study has no --worlds: a worlds file its [evaluate] names is refused naming that."""
    from tiny_study import tiny_study

    p = tmp_path / "s.toml"
    p.write_text(tiny_study("t", sessions=1) + '[evaluate]\nworlds = "nope.toml"\n')
    argv = ["study", str(p), "--out", str(tmp_path / "s"), "--no-progress"]
    assert main(argv) == 1
    line = capsys.readouterr().err.strip()
    assert "[evaluate] worlds nope.toml" in line and not unknown_options(line, argv), line


def test_the_same_errors_by_the_command_line(tmp_path, capsys):
    assert main(["train", "--resume", str(tmp_path), "--out", str(tmp_path / "x")]) == 2
    assert capsys.readouterr().err == ("astrocpg: error: --out: --resume writes into its own "
                                       "folder; drop --out\n")
    assert main(["train", "--sessions", "1"]) == 2
    assert capsys.readouterr().err == "astrocpg: error: --out: is required (or --resume DIR)\n"


_MODEL_PARAMETERS: set[str] | None = None


def _parameters_of_models() -> set[str]:
    """Every model parameter's name: ``tau_motor=9*ms`` in a message is a value, not a keyword."""
    global _MODEL_PARAMETERS
    if _MODEL_PARAMETERS is None:
        from astrocpg.models import DEFAULT_MODELS
        _MODEL_PARAMETERS = {p for _, m in DEFAULT_MODELS.items() for p in m.parameters}
    return _MODEL_PARAMETERS
