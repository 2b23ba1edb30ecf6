"""Lists of names in the manual and the command line's help are the code's lists: gait names,
commands, recordable populations and traces."""

from __future__ import annotations

import re
from pathlib import Path

import pytest

from astrocpg.network.populations import spike_populations, trace_sources
from astrocpg.studies.analysis import gait
from astrocpg.studies.cli import build_parser
import astrocpg.studies.cli as cli

ROOT = Path(__file__).resolve().parents[1]
PAGES = sorted((ROOT / "docs").rglob("*.md")) + [ROOT / "README.md"]
GAITS = [*gait.NAMED, "none"]


def _pages() -> dict[str, str]:
    return {p.relative_to(ROOT).as_posix(): p.read_text(encoding="utf-8") for p in PAGES
            if "changelog" not in p.name.lower()}


def test_every_list_of_gait_names_is_the_codes():
    """A list of the gait names (it starts 'trot, pace') names them all, in the code's order."""
    found = 0
    for page, text in _pages().items():
        for m in re.finditer(r"trot, pace[^.)\n]*", text):
            names = [x for x in re.split(r",\s*(?:or\s+|and\s+)?|\s+or\s+|\s+and\s+", m.group(0)) if x]
            assert names == GAITS, (page, m.group(0), GAITS)
            found += 1
    assert found, "no list of gait names in the docs"
    # and the classifier's own documentation of its labels
    section = gait.__doc__.split("Labels")[1]
    labels = re.findall(r"^  (\w+) ", section, flags=re.M)
    assert labels == GAITS, labels


def test_every_command_is_in_the_manual_and_the_cli_summary():
    sub = next(a for a in build_parser()._actions if a.dest == "command")
    text = "\n".join(_pages().values())
    for name in sub.choices:
        assert re.search(rf"astrocpg {name}\b", text), f"astrocpg {name} is in no page"
        assert re.search(rf"^    astrocpg {name}\b", cli.__doc__, flags=re.M), name


def test_recording_defaults_in_the_help_are_the_codes():
    run = build_parser()._subparsers._group_actions[0].choices["run"]
    helps = {a.dest: a.help for a in run._actions}
    assert f"(default: {','.join(spike_populations())})" in helps["spikes"]
    assert f"(default: {','.join(trace_sources())})" in " ".join(helps["traces"].split())
