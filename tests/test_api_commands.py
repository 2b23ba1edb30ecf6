"""The API is the command line: every ``astrocpg`` command has its ``ac.`` function, and each
of the command's options and arguments is a parameter of that function named like it (the
exceptions below, each with its reason)."""

from __future__ import annotations

import argparse
import inspect

import pytest

import astrocpg as ac
from astrocpg.errors import InputError
from astrocpg.studies.cli import build_parser

#: command (sub-command path) -> the ac. function that does what it does
FUNCTION_OF = {"models list": "list_models", "models dump": "dump_model",  # ac.models is the
               "robot export": "robot"}                                   # package astrocpg.models

#: option dest -> keyword, where the name differs (CLI spelling -> Python spelling)
RENAMED = {
    "no_progress": "progress",       # --no-progress: progress=False
    "model_files": "models",         # --model MODEL=FILE (repeatable): models={MODEL: file}
    "condition": "conditions",       # --condition (repeatable): conditions=[...]
    "dir": "folder",                 # the positional folder of plot, gait, export, ...
    "no_astrocytes": "astrocytes",   # train --no-astrocytes: astrocytes=False
    "population_files": "populations",  # --population FILE (repeatable): populations={FILE: text}
}
#: per function, a dest renamed for that function only
RENAMED_IN = {"plot": {"format": "fmt"}}

#: options that are not keywords, and why
NOT_A_KEYWORD = {
    # the process's choice of Brian2 target: ASTROCPG_CODEGEN (network/codegen.py)
    "codegen",
    # train --resume DIR is the function ac.resume(DIR), not a keyword of ac.train
    "resume",
    # study --status DIR is the function ac.study_status(DIR), not a keyword of ac.study
    "status",
}


def _commands(parser: argparse.ArgumentParser, prefix: str = ""):
    """(command path, its parser) for every command the parser offers, sub-commands
    (``models dump``) included."""
    for action in parser._actions:
        if isinstance(action, argparse._SubParsersAction):
            for name, sub in action.choices.items():
                path = f"{prefix} {name}".strip()
                nested = [a for a in sub._actions if isinstance(a, argparse._SubParsersAction)]
                if nested:
                    yield from _commands(sub, path)
                else:
                    yield path, sub


COMMANDS = sorted(_commands(build_parser()), key=lambda c: c[0])


def test_every_command_of_help_is_walked():
    names = {path.split()[0] for path, _ in COMMANDS}
    assert names == {"unit", "run", "train", "gait", "evaluate", "power", "response", "study",
                     "report", "plot", "video", "export", "describe", "models", "robot", "docs"}


@pytest.mark.parametrize("path,parser", COMMANDS, ids=[c[0] for c in COMMANDS])
def test_each_command_has_its_function_with_its_options(path, parser):
    name = FUNCTION_OF.get(path, path)
    assert name in ac.__all__, f"astrocpg {path}: no ac.{name} in astrocpg.__all__"
    function = getattr(ac, name)
    params = set(inspect.signature(function).parameters)
    if name == "train":  # train --resume's own options are ac.resume's
        params |= set(inspect.signature(ac.resume).parameters)
    missing = []
    for action in parser._actions:
        if isinstance(action, (argparse._HelpAction, argparse._VersionAction)):
            continue
        dest = action.dest
        if dest in NOT_A_KEYWORD:
            continue
        keyword = RENAMED_IN.get(name, {}).get(dest, RENAMED.get(dest, dest))
        if keyword not in params:
            missing.append(f"{'/'.join(action.option_strings) or dest} -> {keyword}")
    assert not missing, f"ac.{name} lacks the settings of astrocpg {path}: {missing}"


def test_the_new_functions_name_the_argument_at_fault(tmp_path):
    cases = [(ac.gait, (3,), {}, "folder"), (ac.power, (str(tmp_path),), {"trial": -1}, "trial"),
             (ac.report, (str(tmp_path),), {"last": 0}, "last"),
             (ac.evaluate, (str(tmp_path),), {"conditions": [1]}, "conditions"),
             (ac.study, (None,), {}, "file"), (ac.dump_model, ("nonesuch",), {}, "name"),
             (ac.robot, (str(tmp_path / "a1.txt"),), {}, "robot export")]
    for function, args, kwargs, culprit in cases:
        with pytest.raises(InputError) as info:
            function(*args, **kwargs)
        assert culprit in str(info.value.culprit), (function.__name__, info.value)


def test_models_and_robot_give_what_the_commands_print(tmp_path, capsys):
    from astrocpg.studies.cli import main

    assert main(["models", "dump", "astrocyte"]) == 0
    assert ac.dump_model("astrocyte") == capsys.readouterr().out
    assert set(dict(ac.list_models().items())) >= {"astrocyte", "motor_neuron"}
    path = ac.robot(tmp_path / "a1.xml")
    assert main(["robot", "export", str(tmp_path / "b.xml")]) == 0
    assert path.read_text() == (tmp_path / "b.xml").read_text()
    with pytest.raises(InputError, match="exists"):
        ac.robot(path)
