"""Faults met while a command runs name what they concern: the file a full disk refused, the
world and the controller of an evaluation cell that diverged."""

from __future__ import annotations

import errno
import os

from astrocpg.studies.cli import main


def test_a_full_disk_under_a_spilled_trace_names_the_file(tmp_path, monkeypatch, capsys):
    """A run's large traces go to a temporary beside its folder as it runs; a full disk there
    said "No space left on device" and named no file."""
    from astrocpg.network import recording

    monkeypatch.setattr(recording, "SPILL_BYTES", 1 << 16)
    real = os.write

    def write(fd, data):
        try:
            target = os.readlink(f"/proc/self/fd/{fd}")
        except OSError:
            target = ""
        if target.endswith(".spill"):
            raise OSError(errno.ENOSPC, "No space left on device")
        return real(fd, data)

    monkeypatch.setattr(os, "write", write)
    out = tmp_path / "o"
    code = main(["run", "--seconds", "0.3", "--out", str(out), "--no-progress"])
    err = capsys.readouterr().err.strip().splitlines()
    assert code == 1 and len(err) == 1, err
    assert ".spill" in err[0] and str(tmp_path) in err[0] and "No space left" in err[0]
    assert "trace of the run, written beside its folder as it runs" in err[0]
    assert not out.exists() and not [p for p in os.listdir(tmp_path) if p.endswith(".spill")]


def test_a_diverged_evaluation_cell_names_its_world_and_controller():
    from astrocpg.errors import Diverged
    from astrocpg.studies.commands.evaluate import _in_cell

    controller = {"folder": "out/astro", "condition": "astrocytes", "first_seed": 4}
    # two controllers x three repeats: trial 3 is repeat 1 of the second controller (seed 5)
    e = _in_cell(Diverged("went to inf", culprit="motor.v", t=0.5, trial=3), controller,
                 "uphill", 2, 3)
    assert e.culprit == "world 'uphill', controller astro (condition astrocytes, seed 5, " \
                        "repeat 1)"
    assert "motor.v: went to inf" in e.message and e.t == 0.5 and e.exit_code == 3
    unknown = _in_cell(Diverged("unstable"), controller, "flat", 2, 1)
    assert unknown.culprit == "world 'flat', a controller of astro (condition astrocytes)"
