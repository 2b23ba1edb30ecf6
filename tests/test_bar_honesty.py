"""Every progress bar is honest about its total (it never moves its own end) and quiet in a file
(each redraw a line of its own: no ``\\r`` redraws in a log, no repeated lines)."""

from __future__ import annotations

import io

import pytest

from astrocpg.studies.cli import main
from astrocpg.studies.runtime import progress
from astrocpg.studies.runtime.progress import Bar


@pytest.fixture
def totals(monkeypatch) -> list:
    """Every change of a bar's total after it was made, and each bar's (n, total) at close."""
    seen = {"changed": [], "closed": []}
    setattr_ = Bar.__setattr__
    close = Bar.close

    def watch(self, name, value):
        if name == "total" and "total" in self.__dict__ and value != self.__dict__["total"]:
            seen["changed"].append((self.desc, self.__dict__["total"], value))
        setattr_(self, name, value)

    def closing(self):
        if not self.disable:
            seen["closed"].append((self.desc, self.n, self.total))
        close(self)

    monkeypatch.setattr(Bar, "__setattr__", watch)
    monkeypatch.setattr(Bar, "close", closing)
    return seen


def test_a_bar_in_a_file_writes_lines_not_redraws() -> None:
    log = io.StringIO()
    with Bar(total=4, desc="work", file=log, mininterval=0, unit="step") as bar:
        for _ in range(4):
            bar.update(1)
            bar.set_postfix_str("note")
    text = log.getvalue()
    assert "\r" not in text and "\x1b" not in text and text.endswith("\n")
    lines = text.splitlines()
    assert len(lines) == len(set(lines)) >= 2, lines
    assert lines[-1].startswith("work: 100%") and "4/4" in lines[-1]


def test_plot_bars_keep_their_totals_and_write_lines_to_a_file(tmp_path, capsys,
                                                               totals) -> None:
    run = tmp_path / "run"
    assert main(["run", "--seconds", "0.1", "--out", str(run), "--no-progress"]) == 0
    capsys.readouterr()
    assert main(["plot", str(run)]) == 0  # with its bars; stderr here is not a terminal
    err = capsys.readouterr().err
    assert not totals["changed"], totals["changed"]
    assert totals["closed"] and all(n == total for _, n, total in totals["closed"]), totals
    assert "\r" not in err and "plot" in err


@pytest.mark.slow
def test_plot_of_a_recorded_training_keeps_its_totals(tmp_path, capsys, totals) -> None:
    train = tmp_path / "train"
    assert main(["train", "--sessions", "1", "--set", "L_max=0.2*second", "--record-every",
                 "1", "--out", str(train), "--no-progress"]) == 0
    capsys.readouterr()
    assert main(["plot", str(train), "--seconds", "0.05"]) == 0
    err = capsys.readouterr().err
    assert not totals["changed"], totals["changed"]
    assert len(totals["closed"]) >= 2 and all(n == t for _, n, t in totals["closed"]), totals
    assert "\r" not in err
