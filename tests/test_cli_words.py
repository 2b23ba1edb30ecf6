"""The command line's own words: help on every option (with its default), a command group alone
lists its commands, a misspelt name gets a suggestion, progress bars that reach their total and
never overshoot it (and no warning in the middle of one), ``plot`` with a bar and
``--no-progress``, a fall named in run, gait and training summaries and in robot figures, and
"the last N" saying how many there were."""

from __future__ import annotations

import argparse
import io
import re
import warnings

import pytest

from astrocpg.studies.cli import build_parser, main

# ---------------------------------------------------------------- help


def _parsers(parser: argparse.ArgumentParser):
    """The parser and every (sub)command parser below it."""
    yield parser
    for action in parser._actions:
        if isinstance(action, argparse._SubParsersAction):
            for sub in action.choices.values():
                yield from _parsers(sub)


def _default_text(value) -> str:
    """How a help text writes a default: 10.0 as 10, (640, 480) as 640 480."""
    if isinstance(value, float):
        return f"{value:g}"
    if isinstance(value, (tuple, list)):
        return " ".join(_default_text(v) for v in value)
    return str(value)


def test_every_option_of_every_command_has_help_naming_its_default() -> None:
    missing, no_default = [], []
    for parser in _parsers(build_parser()):
        for action in parser._actions:
            if isinstance(action, (argparse._HelpAction, argparse._VersionAction)):
                continue
            name = f"{parser.prog} {'/'.join(action.option_strings) or action.dest}"
            if not action.help or action.help == argparse.SUPPRESS or not action.help.strip():
                missing.append(name)
                continue
            flag = action.nargs == 0 or isinstance(action, argparse._SubParsersAction)
            default = action.default
            if flag or default is None or default == [] or default == argparse.SUPPRESS:
                continue
            if "default" not in action.help.lower() or _default_text(default) not in action.help:
                no_default.append(f"{name} (default {default!r}): {action.help}")
    assert not missing, f"options without help: {missing}"
    assert not no_default, "help that does not name the default:\n" + "\n".join(no_default)


def test_the_program_describes_itself_to_users(capsys) -> None:
    with pytest.raises(SystemExit) as e:
        main(["--help"])
    assert e.value.code == 0
    text = capsys.readouterr().out
    assert "nothing imports it" not in text and "parses arguments" not in text
    assert "Unitree A1" in text and "exit codes" in text
    for command in ("run", "train", "gait", "plot", "video", "study"):
        assert f"astrocpg {command}" in text, command


# ---------------------------------------------------------------- command groups alone


def _groups():
    """argv of every command group (a parser with subcommands), with its subcommands."""
    def walk(parser, argv):
        for action in parser._actions:
            if isinstance(action, argparse._SubParsersAction):
                yield argv, {c.dest: c.help for c in action._choices_actions}
                for name, sub in action.choices.items():
                    yield from walk(sub, argv + [name])
    return list(walk(build_parser(), []))


def test_every_command_group_is_found() -> None:
    assert {tuple(argv) for argv, _ in _groups()} == {(), ("models",), ("robot",)}


@pytest.mark.parametrize("argv,commands", _groups(), ids=lambda x: "-".join(x) or "astrocpg"
                         if isinstance(x, list) else "")
def test_a_command_group_alone_lists_what_it_can_do(argv, commands, capsys) -> None:
    code = main(argv)
    captured = capsys.readouterr()
    assert code == 0, captured.err
    assert captured.err == ""
    assert "required" not in captured.out
    lines = captured.out.splitlines()
    for name, help_text in commands.items():
        assert any(line.split()[:1] == [name] and help_text in line for line in lines), \
            (name, captured.out)
    assert "--help" in captured.out


# ---------------------------------------------------------------- suggestions


def test_did_you_mean_names_the_closest() -> None:
    from astrocpg.errors import did_you_mean

    assert did_you_mean("tau_motr", ["tau_motor", "tau_h", "tau_trace"]) \
        == " (did you mean tau_motor?)"
    assert did_you_mean("PNG", ["png", "pdf"]) == " (did you mean png?)"
    assert did_you_mean("zzzz", ["tau_motor", "png"]) == ""
    assert did_you_mean("x", []) == ""


def _one_line(capsys, argv) -> str:
    try:
        code = main(argv)
    except SystemExit as e:  # argparse
        code = e.code
    err = capsys.readouterr().err
    lines = [x for x in err.splitlines() if x.strip()]
    assert code == 2, err
    assert len(lines) == 1 and lines[0].startswith("astrocpg:"), err
    return lines[0]


@pytest.mark.parametrize("argv,hint", [
    (["run", "--seconds", "0.01", "--set", "tau_motr=8*ms"], "did you mean tau_motor?"),
    (["describe", "motor_neuron", "--set", "Thres_z_alve=0.4"], "did you mean Thres_z_alive?"),
    (["models", "dump", "astrocite"], "did you mean astrocyte?"),
    (["describe", "motor_nuron"], "did you mean motor_neuron?"),
    (["rn"], "did you mean run?"),
    (["models", "lst"], "did you mean list?"),
    (["run", "--secnds", "1"], "did you mean --seconds?"),
    (["plot", "somewhere", "--no-progess"], "did you mean --no-progress?"),
    (["run", "--spikes", "motr"], "did you mean motor?"),
    (["run", "--codegen", "cyton"], "did you mean cython?"),
], ids=lambda x: "_".join(x) if isinstance(x, list) else "")
def test_a_misspelt_name_gets_a_suggestion(argv, hint, capsys, tmp_path, monkeypatch) -> None:
    monkeypatch.chdir(tmp_path)
    line = _one_line(capsys, argv)
    assert hint in line, line
    assert not (tmp_path / "out").exists()


def test_a_misspelt_model_file_slot_gets_a_suggestion(capsys, tmp_path) -> None:
    file = tmp_path / "a.toml"
    file.write_text("kind = 'neurons'\n")
    line = _one_line(capsys, ["run", "--model", f"astrocite={file}", "--out",
                              str(tmp_path / "o")])
    assert "did you mean astrocyte?" in line, line


def test_a_name_far_from_any_gets_no_suggestion(capsys) -> None:
    line = _one_line(capsys, ["describe", "motor_neuron", "--set", "qqqqqqqqq=1"])
    assert "unknown model parameter" in line and "did you mean" not in line, line


# ---------------------------------------------------------------- progress accounting


@pytest.mark.parametrize("seconds", [4.0, 30.0, 4.05, 0.35])
def test_a_run_bar_reaches_its_total_and_never_passes_it(seconds) -> None:
    """The step counts of `run --seconds 4` and `unit --seconds 30` (README): the bar of
    simulated time counted 0.1 s a hundred steps and overshot 4.0 by rounding (tqdm then warns
    'clamping frac to range [0, 1]' as it draws)."""
    from tqdm import TqdmWarning

    from astrocpg.studies.commands.simulate import _Progress

    bar = _Progress(seconds, "test", True)
    bar.open()
    bar.bar.fp = io.StringIO()  # tqdm's output, not the test's stderr
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        try:
            for step in range(1, round(seconds * 1000) + 1):  # its 1 ms steps
                bar(step)
                assert bar.bar.n <= bar.bar.total
                if step % 100 == 0:
                    bar.bar.refresh()  # draw it: an overshoot warns here
            bar.finish()
            assert bar.bar.n == bar.bar.total == round(seconds * 1000)
        finally:
            bar.close()
    assert not [w for w in caught if issubclass(w.category, TqdmWarning)], \
        [str(w.message) for w in caught]


def test_a_warning_during_a_bar_is_shown_after_it() -> None:
    from astrocpg.studies.runtime.progress import Bar, held_warnings

    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        bar = Bar(total=3, file=io.StringIO())
        bar.update(1)
        warnings.warn("said while the bar is drawn", UserWarning)
        assert held_warnings() == 1 and not caught  # not in the middle of the bar
        bar.update(2)
        bar.close()
        assert held_warnings() == 0
        assert [str(w.message) for w in caught] == ["said while the bar is drawn"]
        warnings.warn("no bar open", UserWarning)  # shown at once
        assert len(caught) == 2


def test_a_disabled_bar_holds_nothing() -> None:
    from astrocpg.studies.runtime.progress import Bar, held_warnings

    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        with Bar(total=1, disable=True):
            warnings.warn("shown now", UserWarning)
            assert held_warnings() == 0 and len(caught) == 1


# ---------------------------------------------------------------- last N


def _rows(n: int, L_max: float = 1.0, fell: tuple[int, ...] = ()) -> list[dict]:
    return [{"trial": 0, "session": s, "length_s": 0.4 if s in fell else L_max,
             "mean_forward_speed_m_per_s": 0.1, "diverged": False} for s in range(1, n + 1)]


@pytest.mark.parametrize("n,speed,full", [(3, "over all 3 sessions", "of all 3 sessions"),
                                          (25, "over the last 20 sessions", "of all 25 sessions"),
                                          (60, "over the last 20 sessions",
                                           "of the last 50 sessions")])
def test_the_last_n_says_how_many_there_were(n, speed, full) -> None:
    from astrocpg.studies.commands.train import train_summary

    line = train_summary(_rows(n), 1, 1.0)["lines"][0]
    assert speed in line and full in line, line
    assert "never fell" in line


def test_a_training_summary_counts_its_falls() -> None:
    from astrocpg.studies.commands.train import train_summary

    rows = _rows(5, fell=(2, 4))
    rows.append({"trial": 0, "session": 6, "length_s": 0.1, "mean_forward_speed_m_per_s": 0.0,
                 "diverged": True})  # a diverged session is not a fall
    summary = train_summary(rows, 1, 1.0)
    x = summary["per_trial"][0]
    assert (x["falls"], x["last_fall_session"], x["last_fall_length_s"]) == (2, 4, 0.4)
    assert "fell in 2 of 6 sessions (last: session 4, ended at 0.40 s" in summary["lines"][0]


# ---------------------------------------------------------------- commands (cheap runs)

# a 1000 N shove 50 ms in topples the A1 (it is on its side by 0.3 s, on its back at 0.6 s)
SHOVE = ["--set", "push_force=1000*newton", "--set", "push_time=0.05*second"]
CHEAP = ["--spikes", "none", "--traces", "none", "--no-progress"]


@pytest.fixture(scope="module")
def runs(tmp_path_factory):
    """A 0.6 s run in which the robot falls, and one in which it stays up (both 0.6 s)."""
    root = tmp_path_factory.mktemp("words")
    out = {}
    for name, extra in (("fallen", SHOVE), ("upright", [])):
        folder = root / name
        import contextlib

        text = io.StringIO()
        with contextlib.redirect_stdout(text):
            assert main(["run", "--seconds", "0.6", *extra, *CHEAP, "--out", str(folder)]) == 0
        out[name] = (folder, text.getvalue())
    return out


def test_a_run_summary_names_the_fall(runs) -> None:
    _, said = runs["fallen"]
    line = next(x for x in said.splitlines() if x.startswith("trial 0"))
    match = re.search(r"fell at (\d+\.\d+) s", line)
    assert match, said
    assert 0.05 < float(match.group(1)) < 0.6
    assert re.search(r"the robot fell in 1 of 1 trial\(s\): trial 0 at \d+\.\d+ s", said), said
    _, said = runs["upright"]
    assert "fell" not in said, said


def test_robot_figures_of_a_fallen_robot_say_so(runs) -> None:
    from astrocpg.studies.figures.traces import trace_figures
    from astrocpg.studies.outputs.result import load

    figures = trace_figures(load(runs["fallen"][0]), 0)
    for name in ("gait_diagram", "joints", "torso_path"):
        fig = figures[name]
        titles = [ax.get_title() for ax in fig.axes] + [fig._suptitle.get_text()
                                                        if fig._suptitle else ""]
        assert any("fell at" in t for t in titles), (name, titles)
    figures = trace_figures(load(runs["upright"][0]), 0)
    for name in ("gait_diagram", "joints", "torso_path"):
        fig = figures[name]
        titles = [ax.get_title() for ax in fig.axes] + [fig._suptitle.get_text()
                                                        if fig._suptitle else ""]
        assert not any("fell" in t for t in titles), (name, titles)


def test_plot_has_a_bar_and_no_progress_silences_it(runs, tmp_path, capsys) -> None:
    folder = runs["upright"][0]
    assert main(["plot", str(folder), "--out", str(tmp_path / "a")]) == 0
    captured = capsys.readouterr()
    written = int(re.search(r"wrote (\d+) figure", captured.out).group(1))
    from astrocpg.studies.figures.traces import FIGURE_FUNCTIONS

    # two bars, each with its total from the start: a step per kind of figure, then per file
    lines = captured.err.replace("\r", "\n").strip().splitlines()
    kinds = len(FIGURE_FUNCTIONS)
    assert any(x.startswith("plot: 100%") and f"{kinds}/{kinds}" in x for x in lines), captured.err
    assert lines[-1].startswith("plot: saving: 100%") and f"{written}/{written}" in lines[-1], \
        captured.err
    assert main(["plot", str(folder), "--out", str(tmp_path / "b"), "--no-progress"]) == 0
    captured = capsys.readouterr()
    assert captured.err == "", captured.err


def test_the_video_bar_reaches_its_total(runs, tmp_path, capsys) -> None:
    folder = runs["fallen"][0]
    assert main(["video", str(folder), "--out", str(tmp_path / "v.mp4"), "--size", "64", "48",
                 "--fps", "15"]) == 0
    captured = capsys.readouterr()
    frames = int(re.search(r"\((\d+) frames", captured.out).group(1))
    last = captured.err.replace("\r", "\n").strip().splitlines()[-1]
    assert f"{frames}/{frames}" in last and "100%" in last, captured.err


@pytest.fixture(scope="module")
def fallen_training(tmp_path_factory):
    """Two 0.6 s sessions, each ended by the shove's fall (L_non_alive 0.1 s)."""
    folder = tmp_path_factory.mktemp("words_train") / "t"
    import contextlib

    text = io.StringIO()
    with contextlib.redirect_stdout(text):
        assert main(["train", "--sessions", "2", "--set", "L_max=0.6*second", "--set",
                     "L_non_alive=0.1*second", *SHOVE, "--no-progress", "--out",
                     str(folder)]) == 0
    return folder, text.getvalue()


def test_a_training_summary_names_its_falls(fallen_training) -> None:
    _, said = fallen_training
    assert "over all 2 sessions" in said and "last 20" not in said, said
    assert re.search(r"the robot fell in 2 of 2 sessions \(last: session 2, ended at "
                     r"\d+\.\d+ s", said), said


def test_a_gait_summary_names_the_fall(fallen_training, capsys) -> None:
    folder, _ = fallen_training
    assert main(["gait", str(folder), "--seconds", "0.6", "--repeats", "1",
                 "--no-progress"]) == 0
    said = capsys.readouterr().out
    # the run's gait is none for the fall, and the run's line names the fall itself
    assert re.search(r"table 0 repeat 0 \(seed \d+\): .*gait \(footfalls\) none: fell at "
                     r"\d+\.\d+ s.*; fell at \d+\.\d+ s \(", said), said


def test_a_log_record_during_a_bar_is_shown_after_it() -> None:
    """Brian2 prints its log records (and the warnings it captures) with a console handler
    on stderr: in the middle of a bar, unless held."""
    import logging

    from astrocpg.studies.runtime.progress import Bar

    stream = io.StringIO()
    handler = logging.StreamHandler(stream)
    log = logging.getLogger("brian2")
    log.addHandler(handler)
    try:
        bar = Bar(total=2, file=io.StringIO())
        log.warning("a library says something")
        assert stream.getvalue() == ""
        bar.update(2)
        bar.close()
        assert stream.getvalue() == "a library says something\n"
        log.warning("no bar open")
        assert stream.getvalue().endswith("no bar open\n")
    finally:
        log.removeHandler(handler)


def test_a_bar_written_to_a_file_draws_a_line_every_interval_not_every_postfix():
    """A long run's log (``astrocpg study ... 2> log``): tqdm redraws on every postfix, which
    wrote a line per second (a study) or per session (a training) into the file."""
    import io

    from astrocpg.studies.runtime.progress import Bar

    log = io.StringIO()
    with Bar(total=1000, file=log) as bar:
        for i in range(1000):
            bar.update(1)
            bar.set_postfix_str(f"runs done {i}")
            bar.set_postfix(speed=f"{i}")
    drawn = [line for line in log.getvalue().replace("\r", "\n").splitlines() if line.strip()]
    assert len(drawn) <= 3  # the first draw, the last on closing
    assert "1000/1000" in drawn[-1] and "speed=999" in drawn[-1]
