"""The command line's words for the user's settings: an error below the command line names a
setting by its field (:func:`astrocpg.errors.field`); here each field is named as the option
that sets it in the command that failed, read from that command's own parser, so a message
never names an option the command does not have."""

from __future__ import annotations

import argparse

from ...errors import Field, Vocabulary

#: fields whose option sets another parser ``dest`` (the API's keyword differs from the option)
DESTS: dict[str, tuple[str, ...]] = {
    "overrides": ("overrides", "set"), "models": ("model_files",),
    "populations": ("population_files",), "conditions": ("condition",),
    "progress": ("no_progress",), "astrocytes": ("no_astrocytes",), "fmt": ("format",),
    "folder": ("dir", "resume", "status"), "training": ("weights",), "file": ("file",),
}

#: advice: (the command that does it, the field of its option); said as the option alone
#: when the failing command has that option itself
ADVICE: dict[str, tuple[str, str]] = {"resume": ("train", "resume"),
                                      "record_every": ("train", "record_every"),
                                      "codegen": ("", "codegen")}


class OptionWords(Vocabulary):
    """A field as the option of ``parser`` (one command's parser) that sets it:
    ``out`` is ``--out``, ``overrides`` ``--set``, ``progress`` ``--no-progress``; with its
    value, ``--out DIR``, ``--set tau_motor``. A positional argument is its value (or its
    metavar)."""

    def __init__(self, parser: argparse.ArgumentParser) -> None:
        super().__init__()
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
        """The option that sets the field ``name`` here, or None when none does."""
        for dest in (name, *DESTS.get(name, ())):
            if dest in self.options:
                return self.options[dest]
        return None

    def name(self, f: Field) -> str:
        if f.advice:
            command, name = ADVICE.get(f.name, ("", f.name))
            option = self.option(name)
            if option is None:  # another command's: named with it
                option = "--" + name.replace("_", "-")
                option = f"astrocpg {command} {option}" if command else option
            said = option
            return f"{said} {f.value}" if f.value else said
        option = self.option(f.name)
        if option is None:
            for dest in (f.name, *DESTS.get(f.name, ())):
                if dest in self.positional:  # a positional argument: what was typed
                    return f.value or self.positional[dest]
            option = "--" + f.name.replace("_", "-")
        return f"{option} {f.value}" if f.value else option
