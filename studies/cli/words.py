"""The command line's words for the user's settings: an error below the command line names a
setting by its field (:func:`astrocpg.errors.setting`); here each field is named as the option
that sets it in the command that failed, read from that command's own parser, so a message
never names an option the command does not have."""

from __future__ import annotations

import argparse
from typing import Sequence

from ...errors import Field, Vocabulary

#: fields whose option sets another parser ``dest`` (the API's keyword differs from the option)
DESTS: dict[str, tuple[str, ...]] = {
    "overrides": ("overrides", "set"), "models": ("model_files",),
    "populations": ("population_files",), "conditions": ("condition",),
    "progress": ("no_progress",), "astrocytes": ("no_astrocytes",), "fmt": ("format",),
    "folder": ("dir", "resume", "status"), "training": ("weights",),
}

#: advice (:func:`astrocpg.errors.advice`): the command that does it and the fields of its
#: options, each with its value (None: the value the advice was given). Said as the options
#: alone in that command, with ``astrocpg COMMAND`` before them in any other.
ADVICE: dict[str, tuple[str, tuple[tuple[str, str | None], ...]]] = {
    "resume": ("train", (("resume", None),)),
    "record_every": ("train", (("record_every", None),)),
    "train": ("train", (("out", None),)),
    "retrain": ("train", (("out", "DIR"), ("overwrite", ""))),
    "codegen": ("", (("codegen", None),)),
    "extend_study": ("study", (("file", "FILE"), ("sessions", None), ("out", "NEW_DIR"))),
}


def _subparsers(parser: argparse.ArgumentParser) -> dict[str, argparse.ArgumentParser]:
    return {name: p for a in parser._actions if isinstance(a, argparse._SubParsersAction)
            for name, p in a.choices.items()}


class _Options:
    """One parser's options by the ``dest`` they set, and its positional arguments."""

    def __init__(self, parser: argparse.ArgumentParser) -> None:
        self.options: dict[str, str] = {}
        self.positional: dict[str, str] = {}
        for action in parser._actions:
            longs = [o for o in action.option_strings if o.startswith("--")]
            if longs and action.dest not in self.options:
                self.options[action.dest] = longs[0]
            elif not action.option_strings and not isinstance(action,
                                                              argparse._SubParsersAction):
                self.positional[action.dest] = str(action.metavar or action.dest.upper())

    def option(self, name: str) -> str | None:
        """The option that sets the field ``name``, or None when none does."""
        for dest in (name, *DESTS.get(name, ())):
            if dest in self.options:
                return self.options[dest]
        return None

    def said(self, name: str, value: str) -> str:
        option = self.option(name)
        if option is None:
            for dest in (name, *DESTS.get(name, ())):
                if dest in self.positional:  # a positional argument: what was typed
                    return value or self.positional[dest]
            option = "--" + name.replace("_", "-")  # no parser has it: as an option would be
        return f"{option} {value}" if value else option


class OptionWords(Vocabulary):
    """A field as the option of the failing command (``chain``: the parsers it was parsed
    with, the top one first) that sets it: ``out`` is ``--out``, ``overrides`` ``--set``,
    ``progress`` ``--no-progress``; with its value, ``--out DIR``, ``--set tau_motor``. A
    positional argument is its value (or its metavar)."""

    def __init__(self, chain: Sequence[argparse.ArgumentParser]) -> None:
        super().__init__()
        self.top, self.here = chain[0], _Options(chain[-1])
        self.command = chain[-1]

    def name(self, f: Field) -> str:
        if not f.advice:
            return self.here.said(f.name, f.value)
        command, options = ADVICE.get(f.name, ("", ((f.name, None),)))
        parser = _subparsers(self.top).get(command, self.command) if command else self.command
        words = _Options(parser)
        said = " ".join(words.said(name, f.value if value is None else value)
                        for name, value in options)
        return said if parser is self.command else f"astrocpg {command} {said}"


def command_words(top: argparse.ArgumentParser, *command: str) -> OptionWords:
    """The words of ``command`` (``"study"``, ``"models", "dump"``) of the command line
    ``top``: what its one line of a failure names a field as."""
    chain = [top]
    for name in command:
        chain.append(_subparsers(chain[-1])[name])
    return OptionWords(chain)
