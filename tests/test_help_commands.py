"""A command that the command line's own help names ('astrocpg describe world lists them') is
one the command line accepts: a renamed or removed subcommand fails here, not in a reader's
terminal."""

from __future__ import annotations

import argparse
import re
import shlex

import pytest

from astrocpg.studies.cli import build_parser
from test_cli_words import _parsers

QUOTED = re.compile(r"['`](astrocpg [a-z][^'`]*)['`]")


def _named_commands() -> list[str]:
    found = []
    for p in _parsers(build_parser()):
        texts = [p.description or "", p.epilog or ""]
        texts += [a.help or "" for a in p._actions if isinstance(a.help, str)]
        for text in texts:
            found += QUOTED.findall(" ".join(text.split()))
    return sorted(set(found))


def test_help_names_commands():
    assert any(c.startswith("astrocpg describe") for c in _named_commands())


@pytest.mark.parametrize("command", _named_commands())
def test_a_command_named_in_the_help_parses(command):
    words = shlex.split(command)[1:]
    words = [w for w in words if not w.startswith("...")]
    try:
        build_parser().parse_args(words)
    except SystemExit as e:
        # a missing positional argument (e.g. 'astrocpg gait DIR' quoted without DIR) is fine;
        # an unknown command or option is not
        assert e.code == 2 and not _unknown(words), command


def _unknown(words: list[str]) -> bool:
    import contextlib
    import io

    err = io.StringIO()
    with contextlib.redirect_stderr(err), contextlib.suppress(SystemExit):
        build_parser().parse_args(words)
    return "invalid choice" in err.getvalue() or "unrecognized arguments" in err.getvalue()
