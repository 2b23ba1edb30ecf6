"""Bad input: one clear line naming the culprit, exit code 2, no traceback, nothing written."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import pytest

from astrocpg.studies.cli import main

MOTOR_EQS = (Path(__file__).resolve().parents[1] / "models" / "motor_neuron.py")


def _fails_cleanly(capsys, argv: list[str], out: Path, *expected: str) -> str:
    code = main(argv)
    err = capsys.readouterr().err.strip()
    assert code == 2, err
    assert len(err.splitlines()) == 1, err
    assert err.startswith("astrocpg: error:"), err
    assert "Traceback" not in err
    for word in expected:
        assert word in err, (word, err)
    assert not out.exists(), "nothing may be written on bad input"
    return err


def _equations_file(tmp_path: Path, text: str) -> Path:
    f = tmp_path / "eqs.txt"
    f.write_text(text)
    return f


def _default_motor_equations() -> str:
    from astrocpg.models.motor_neuron import EQUATIONS
    return EQUATIONS


@pytest.mark.parametrize("command", ["unit", "run"])
def test_equation_syntax_error(capsys, tmp_path, command):
    eqs = _equations_file(tmp_path, _default_motor_equations().replace(
        "(v_motor_rest - v)/tau_motor", "(v_motor_rest - v/tau_motor"))
    _fails_cleanly(capsys, [command, "--seconds", "1", "--equations",
                            f"motor_neuron={eqs}", "--out", str(tmp_path / "o")],
                   tmp_path / "o", "motor_neuron", "equation")


def test_equation_inconsistent_units(capsys, tmp_path):
    eqs = _equations_file(tmp_path, _default_motor_equations().replace(
        "- C_K_chan*K_open : volt", "- C_K_chan*K_open + Ca : volt"))
    _fails_cleanly(capsys, ["unit", "--seconds", "1", "--equations", f"motor_neuron={eqs}",
                            "--out", str(tmp_path / "o")], tmp_path / "o", "motor_neuron", "unit")


def test_unknown_parameter_name(capsys, tmp_path):
    _fails_cleanly(capsys, ["unit", "--seconds", "1", "--set", "tau_motr=9*ms",
                            "--out", str(tmp_path / "o")], tmp_path / "o", "tau_motr")


def test_wrong_unit_for_a_parameter(capsys, tmp_path):
    _fails_cleanly(capsys, ["unit", "--seconds", "1", "--set", "tau_motor=9*mV",
                            "--out", str(tmp_path / "o")], tmp_path / "o", "tau_motor", "units")


@pytest.mark.parametrize("name", ["tau_motor", "tau_Ca", "tau_h", "tau_ADO", "tau_interneuron"])
def test_non_positive_time_constant(capsys, tmp_path, name):
    _fails_cleanly(capsys, ["run", "--seconds", "1", "--set", f"{name}=-5*ms",
                            "--out", str(tmp_path / "o")], tmp_path / "o", name, "positive")


@pytest.mark.parametrize("seconds", ["0", "-3", "nan"])
def test_non_positive_seconds(capsys, tmp_path, seconds):
    for command in ("unit", "run"):
        _fails_cleanly(capsys, [command, "--seconds", seconds, "--out", str(tmp_path / "o")],
                       tmp_path / "o", "--seconds")


def test_missing_robot_file(capsys, tmp_path):
    """A robot file that does not exist is the environment's: exit 1 (docs/errors.md)."""
    assert main(["run", "--seconds", "1", "--robot", str(tmp_path / "none.xml"),
                 "--out", str(tmp_path / "o")]) == 1
    err = capsys.readouterr().err.strip()
    assert err.startswith("astrocpg: environment:") and "none.xml" in err
    assert len(err.splitlines()) == 1 and not (tmp_path / "o").exists()


def test_malformed_robot_file(capsys, tmp_path):
    bad = tmp_path / "broken.xml"
    bad.write_text("<mujoco><worldbody><body name='trunk'>")
    _fails_cleanly(capsys, ["run", "--seconds", "1", "--robot", str(bad),
                            "--out", str(tmp_path / "o")], tmp_path / "o", "broken.xml")


def test_robot_without_a1_joints(capsys, tmp_path):
    other = tmp_path / "pendulum.xml"
    other.write_text("""<mujoco><worldbody><body name="trunk"><freejoint/>
      <geom type="sphere" size="0.1"/><body name="arm"><joint name="swing" axis="0 1 0"/>
      <geom type="capsule" fromto="0 0 0 0 0 -0.3" size="0.02"/></body></body></worldbody>
      <actuator><motor joint="swing"/></actuator></mujoco>""")
    _fails_cleanly(capsys, ["run", "--seconds", "1", "--robot", str(other),
                            "--out", str(tmp_path / "o")], tmp_path / "o", "pendulum.xml", "joint")


def test_bad_weights_file(capsys, tmp_path):
    w = tmp_path / "w.csv"
    w.write_text("1,2,3\n4,5,6\n")
    _fails_cleanly(capsys, ["run", "--seconds", "1", "--weights", str(w),
                            "--out", str(tmp_path / "o")], tmp_path / "o", "w.csv", "8x8")


def test_argparse_errors_are_one_line(tmp_path):
    proc = subprocess.run([sys.executable, "-m", "astrocpg.studies.cli", "run", "--seconds",
                           "abc"], capture_output=True, text=True)
    assert proc.returncode == 2
    assert len(proc.stderr.strip().splitlines()) == 1 and "--seconds" in proc.stderr


def test_robot_with_another_timestep(capsys, tmp_path):
    from astrocpg.coupling.robot import export_xml
    path = tmp_path / "a1_2ms.xml"
    export_xml(path)
    path.write_text(path.read_text().replace('timestep="0.001"', 'timestep="0.002"'))
    assert 'timestep="0.002"' in path.read_text()
    _fails_cleanly(capsys, ["run", "--seconds", "1", "--robot", str(path),
                            "--out", str(tmp_path / "o")], tmp_path / "o", "a1_2ms.xml", "timestep")


def test_an_interrupt_inside_a_constructor_is_one_line(capsys, tmp_path, monkeypatch):
    """Ctrl-C/SIGTERM landing inside a constructor (CI: zipfile.ZipFile's, as numpy wrote an
    .npz) left a half-built object whose __del__ failed after "astrocpg: interrupted", and
    Python printed its traceback: the interrupt must stay the one line."""
    import io
    import sys
    import zipfile

    import astrocpg.studies.cli as cli

    class HalfBuilt(zipfile.ZipFile):
        def __init__(self) -> None:  # interrupted after the file was open, before _writing
            self.fp = io.BytesIO()
            raise KeyboardInterrupt

    def command(args):
        HalfBuilt()

    seen = []
    monkeypatch.setattr(sys, "unraisablehook", seen.append)
    monkeypatch.setitem(cli.COMMANDS, "unit", command)
    assert main(["unit", "--out", str(tmp_path / "u")]) == 130
    assert capsys.readouterr().err == "astrocpg: interrupted\n"
    assert seen == [], [u.exc_value for u in seen]
    assert sys.unraisablehook == seen.append  # restored


def test_an_interrupt_inside_a_nested_python_run_still_exits_130(tmp_path):
    """CI: Ctrl-C landed while a Cython module ran Python source through ``PyRun_String`` (as
    it was imported); we printed "astrocpg: interrupted" but ``python -m`` ended by SIGINT
    (-2), because CPython's flag for an unhandled interrupt stayed set."""
    import textwrap

    (tmp_path / "nested_interrupt.py").write_text(textwrap.dedent("""
        import ctypes
        import astrocpg.studies.cli as cli

        def command(args):  # what a Cython module's import does, interrupted
            run = ctypes.pythonapi.PyRun_String
            run.restype = ctypes.py_object
            run.argtypes = [ctypes.c_char_p, ctypes.c_int, ctypes.py_object, ctypes.py_object]
            run(b"raise KeyboardInterrupt", 257, {}, {})  # 257: Py_file_input

        def caught_below(args):  # a command that catches the interrupt itself (train, study)
            try:
                command(args)
            except KeyboardInterrupt:
                return 130

        cli.COMMANDS["describe"] = command if sys.argv[1] == "main" else caught_below
        raise SystemExit(cli.main(["describe"]))
        """).replace("import ctypes", "import ctypes\nimport sys"))
    # caught by main (its one line), or by the command itself (train and study say more)
    for where, said in (("main", "astrocpg: interrupted\n"), ("command", "")):
        proc = subprocess.run([sys.executable, "-m", "nested_interrupt", where], cwd=tmp_path,
                              capture_output=True, text=True, timeout=300)
        assert (proc.returncode, proc.stderr) == (130, said), where


ENTRY = ("import atexit, sys\n"
         "marker = sys.argv[1]\n"
         "atexit.register(lambda: open(marker, 'w').write('exit handlers ran'))\n"
         "sys.argv = ['astrocpg'] + sys.argv[2:]\n"
         "from astrocpg.studies.cli import entry\n"
         "entry()\n"
         "print('not reached')\n")


@pytest.mark.parametrize("argv, code", [(["describe"], 0),
                                        (["describe", "no_such_model"], 2)])
def test_the_command_ends_at_once_with_its_code_its_output_whole_and_exit_handlers_run(
        tmp_path, argv, code):
    """``entry`` ends the process without the interpreter's teardown (start-up): the
    exit code stands, piped output is flushed whole and atexit handlers still run."""
    marker = tmp_path / "atexit.txt"
    p = subprocess.run([sys.executable, "-c", ENTRY, str(marker), *argv], capture_output=True,
                       text=True, timeout=300, cwd=tmp_path)
    assert p.returncode == code, p.stderr
    assert marker.read_text() == "exit handlers ran"
    assert "not reached" not in p.stdout
    if code == 0:  # every model's section, to the last line
        full = subprocess.run([sys.executable, "-m", "astrocpg.studies.cli", *argv],
                              capture_output=True, text=True, timeout=300)
        assert p.stdout == full.stdout and "\nworld\n=====\n" in p.stdout
    else:
        assert p.stderr.count("\n") == 1 and "no_such_model" in p.stderr


def test_brian2_is_imported_without_pylab_or_pytest_unless_they_were_there():
    """Brian2's own import takes pylab and pytest where they exist (about 0.65 s of start-up);
    astrocpg imports it without them, and leaves them in where the user imported them first."""
    check = ("import sys\n{before}import astrocpg.network, brian2\n"
             "print('pylab' in sys.modules, 'pytest' in sys.modules, hasattr(brian2, 'plot'),"
             " hasattr(brian2, 'exp'))\n")
    bare = subprocess.run([sys.executable, "-c", check.format(before="")], capture_output=True,
                          text=True, timeout=300)
    assert bare.stdout.split() == ["False", "False", "False", "True"], bare.stderr
    user = subprocess.run([sys.executable, "-c", check.format(
        before="import matplotlib; matplotlib.use('Agg'); import matplotlib.pyplot, pytest\n")],
        capture_output=True, text=True, timeout=300)
    assert user.stdout.split() == ["True", "True", "True", "True"], user.stderr


def test_run_draws_its_figure_only_when_asked(tmp_path, capsys):
    """The figure costs about a second (matplotlib and one figure), ten times a 0.1 s run, so
    ``run`` draws it with ``--figure``; the folder says where the figures are otherwise."""
    import json

    plain, drawn = tmp_path / "plain", tmp_path / "drawn"
    assert main(["run", "--seconds", "0.05", "--no-progress", "--out", str(plain)]) == 0
    assert f"(figures: astrocpg plot {plain})" in capsys.readouterr().out
    assert main(["run", "--seconds", "0.05", "--no-progress", "--figure",
                 "--out", str(drawn)]) == 0
    assert not list(plain.glob("*.png"))
    assert (drawn / "thigh_extensor_activity.png").stat().st_size > 0
    manifest = json.loads((drawn / "manifest.json").read_text())
    assert "thigh_extensor_activity.png" in manifest["files"]
    assert manifest["settings"]["figure"] is True


HUGEPAGES = ("import os, sys\nimport numpy as np\n"
             "from astrocpg.studies.cli import main\n"
             "main(['describe', 'world'])\n"
             "core = getattr(np, '_core', None) or np.core\n"
             "print('advice', core.multiarray._set_madvise_hugepage(True),"
             " os.environ.get('NUMPY_MADVISE_HUGEPAGE'), file=sys.stderr)\n")


@pytest.mark.parametrize("user, advice, env", [(None, "False", "0"), ("1", "True", "1"),
                                               ("0", "False", "0")])
def test_a_command_puts_large_arrays_on_small_pages_unless_the_user_chose(user, advice, env):
    """numpy's huge-page advice made a fresh array's first touch now and then cost a compaction
    (benchmarks/fresh_memory.py): a command turns it off for itself and (through the
    environment) its workers, and leaves a value the user set as numpy read it."""
    environ = {k: v for k, v in os.environ.items() if k != "NUMPY_MADVISE_HUGEPAGE"}
    if user is not None:
        environ["NUMPY_MADVISE_HUGEPAGE"] = user
    p = subprocess.run([sys.executable, "-c", HUGEPAGES], capture_output=True, text=True,
                       timeout=300, env=environ)
    assert p.returncode == 0, p.stderr
    assert p.stderr.split()[-3:] == ["advice", advice, env], p.stderr
