"""``astrocpg power --set NAME=VALUE``: the rates with one parameter changed over the
training's models (e.g. the limit margin), in a file of its own."""

from __future__ import annotations

import json

import pytest

from astrocpg.studies.cli import main


@pytest.mark.slow
def test_power_with_a_parameter_set_writes_its_own_file(tmp_path, capsys) -> None:
    train = tmp_path / "train"
    assert main(["train", "--out", str(train), "--sessions", "1", "--set", "L_max=0.4*second",
                 "--no-progress"]) == 0
    assert main(["power", str(train), "--sessions", "1", "--no-progress"]) == 0
    assert main(["power", str(train), "--sessions", "1", "--set", "limit_margin=0",
                 "--no-progress"]) == 0
    out = capsys.readouterr().out
    assert "overrides limit_margin=0" in out
    default = json.loads((train / "power_trial0.json").read_text())
    zero = json.loads((train / "power_trial0_limit_margin=0.json").read_text())
    assert default["overrides"] == [] and zero["overrides"] == ["limit_margin=0"]
    # no margin: a thigh is inhibited only past its limit, never more often than with one
    assert zero["total_rate_Hz"]["limit"] <= default["total_rate_Hz"]["limit"]
    assert main(["power", str(train), "--sessions", "1", "--set", "no_such=1",
                 "--no-progress"]) == 2
    assert "no_such" in capsys.readouterr().err
