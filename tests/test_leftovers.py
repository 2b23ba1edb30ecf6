"""Leftovers (fast, no simulation): hidden temporaries' names fit in 255 bytes however long the
target's name, what a killed writer leaves is not part of a folder, a resumed training's
derived outputs go, and a delay table that cannot be integrated says which pairs would make it
one (``studies/outputs/folder.py``, ``network/delays.py``)."""

from __future__ import annotations

import itertools
import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

from astrocpg.errors import InputError
from astrocpg.studies.outputs.folder import (DERIVED, NAME_MAX, OutputFolder,
                                           clean_stale_temporaries, inventory, parse_temp_name,
                                           remove_derived, temp_prefix, temp_suffix, verify)
from astrocpg.studies.outputs.writing import atomic_path

STEMS = ["run", "r" * 200, "r" * 235, "r" * 250, "r" * 255, "\u00e9" * 127, "a.b" * 80,
         "x" * 240 + ".npz"]


def _dead_pid() -> int:
    proc = subprocess.Popen([sys.executable, "-c", "pass"])
    proc.wait()
    return proc.pid


@pytest.mark.parametrize("kind", ["partial", "replaced", "tmp"])
@pytest.mark.parametrize("stem", STEMS, ids=lambda s: f"{len(s.encode())}B")
def test_a_temporary_name_fits_and_is_recognised(stem, kind):
    for suffix in ("", ".nwb", "." + "z" * 40):
        kept = temp_suffix(suffix)
        name = temp_prefix(stem, kind, suffix=kept) + "k2j4h5g6" + kept
        assert len(os.fsencode(name)) <= NAME_MAX, (len(os.fsencode(name)), name)
        parsed = parse_temp_name(name)
        assert parsed is not None and parsed["kind"] == kind and parsed["pid"] == os.getpid()
        if len(os.fsencode(stem)) <= 200:
            assert parsed["name"] == stem  # short names are kept whole
    # two long names that share their start still get distinct temporaries
    assert temp_prefix("q" * 250 + "a") != temp_prefix("q" * 250 + "b")


def test_folders_and_files_of_255_bytes_are_written_and_replaced(tmp_path):
    for name in ("f" * 255, "\u00e9" * 127):
        target = tmp_path / name
        with OutputFolder(target) as d:
            (d / "a").write_text("1")
            (d / "manifest.json").write_text(json.dumps({"astrocpg_command": "run",
                                                         "inventory": inventory(d)}))
        with OutputFolder(target, overwrite=True) as d:
            (d / "a").write_text("2")
        assert (target / "a").read_text() == "2"
        atomic_path(tmp_path / (name[:-4] + ".npz"), lambda p: p.write_bytes(b"npz"))
    assert not [n for n in os.listdir(tmp_path) if parse_temp_name(n)]


def test_a_killed_writers_long_temporaries_are_removed_and_a_long_aside_folder_kept(
        tmp_path, monkeypatch):
    pid = _dead_pid()
    long = "g" * 255
    # the names the dead writer made: fitted to its own pid (which may have more digits than
    # this process's)
    with monkeypatch.context() as m:
        m.setattr(os, "getpid", lambda: pid)
        prefixes = {kind: temp_prefix(long, kind) for kind in ("partial", "tmp", "replaced")}
    stale = []
    for kind in ("partial", "tmp"):
        (tmp_path / (prefixes[kind] + "abcdefgh")).mkdir()
        stale.append(tmp_path / (prefixes[kind] + "abcdefgh"))
    aside = tmp_path / (prefixes["replaced"] + "abcdefgh")
    aside.mkdir()
    (aside / "spikes.npz").write_bytes(b"the old folder")
    removed = clean_stale_temporaries(tmp_path)
    assert sorted(removed) == sorted(stale)
    # its name says only the start of the original's: kept whole, hidden, never deleted
    assert (aside / "spikes.npz").read_bytes() == b"the old folder"


def test_verify_and_inventory_skip_what_a_killed_plot_or_video_left(tmp_path):
    d = tmp_path / "run"
    d.mkdir()
    (d / "spikes.npz").write_bytes(b"spikes")
    (d / "manifest.json").write_text(json.dumps({"astrocpg_command": "run",
                                                 "inventory": inventory(d)}))
    pid = _dead_pid()
    (d / f".figures.partial-{pid}-k2j4h5g6").mkdir()
    (d / f".figures.partial-{pid}-k2j4h5g6" / "rasters.png").write_bytes(b"half")
    (d / f".video_trial00.tmp-{pid}-a1b2c3d4.mp4").write_bytes(b"half")
    verify(d)  # strict: a temporary is nobody's file
    assert list(inventory(d)) == ["spikes.npz"]
    (d / "notes.txt").write_text("a stray file still counts")
    with pytest.raises(InputError, match="notes.txt is not listed"):
        verify(d)


def test_remove_derived_removes_exactly_what_later_commands_write(tmp_path):
    d = tmp_path / "train"
    d.mkdir()
    own = ["sessions.csv", "weights.npz", "checkpoint.npz", "recordings/", "notes.txt",
           "figures.txt", "video_final.mp4"]
    derived = ["figures/", "report/", "evaluation/", "evaluation.parts/", "video_trial00.mp4",
               "power_trial0.json"]
    for name in own + derived:
        if name.endswith("/"):
            (d / name).mkdir()
            (d / name / "x").write_text("x")
            if name in ("figures/", "report/", "evaluation/"):  # astrocpg's: its own manifest
                (d / name / "manifest.json").write_text(json.dumps(
                    {"astrocpg_command": "plot", "inventory": inventory(d / name)}))
        else:
            (d / name).write_text("x")
    assert sorted(remove_derived(d)) == sorted(derived)
    assert sorted(n + ("/" if (d / n).is_dir() else "") for n in os.listdir(d)) == sorted(own)
    assert len(DERIVED) == len(derived)  # a new derived place must be added here too
    # what the user put there stays, and so does the folder that holds it
    (d / "figures").mkdir()
    (d / "figures" / "x").write_text("x")
    (d / "figures" / "manifest.json").write_text(json.dumps(
        {"astrocpg_command": "plot", "inventory": inventory(d / "figures")}))
    (d / "figures" / "mine.md").write_text("mine")
    (d / "report").mkdir()
    (d / "report" / "old.png").write_text("no manifest: not astrocpg's")
    assert remove_derived(d) == ["figures/"]
    assert sorted(os.listdir(d / "figures")) == ["mine.md"]
    assert (d / "report" / "old.png").is_file()


# ---------------------------------------------------------------- delays
LIMBS = ("FR", "FL", "RR", "RL")
PAIRS = list(itertools.permutations(LIMBS, 2))


def _zero(*pairs):
    from brian2 import ms

    from astrocpg.models import DEFAULT_MODELS
    return DEFAULT_MODELS.with_values({f"delay_{a}_{b}": 0 * ms for a, b in pairs})


@pytest.mark.parametrize("k", [1, 2])
def test_a_refused_delay_table_names_a_fix_that_is_accepted(k):
    """Every table with one or two 0 ms pairs: accepted, or refused with the fewest further
    0 ms pairs, which are then accepted (the README's FR->FL, FR->RR: also FR->RL)."""
    import re

    from brian2 import ms

    from astrocpg.network import limb_stages
    refused = 0
    for pairs in itertools.combinations(PAIRS, k):
        if any((b, a) in pairs for a, b in pairs):
            continue  # both ways: no order can give it (its own message)
        try:
            limb_stages(_zero(*pairs), LIMBS, 1 * ms)
            continue
        except InputError as e:
            line = str(e)
        refused += 1
        assert "same step" in line and "\n" not in line, line
        fix = re.findall(r"delay_(\w\w)_(\w\w)=0\*ms", line.split("also set", 1)[-1])
        assert fix, line
        limb_stages(_zero(*pairs, *fix), LIMBS, 1 * ms)  # the suggestion works
    assert refused > 0
    with pytest.raises(InputError, match=r"also set delay_FR_RL=0\*ms"):
        limb_stages(_zero(("FR", "FL"), ("FR", "RR")), LIMBS, 1 * ms)
