"""Every command as typed, with stdout, stderr or both closed (``>&-``, ``2>&-``) or a pipe whose
reader went away, finishes its work and exits as it would with them open: the same exit code,
the same files in its folder, the same status in its manifest.

Each command runs in a child process (``python -m astrocpg.studies.cli``), with its default
progress bar: once with its streams open (the reference), then once per way of losing them.
The fast set (run, unit, describe, models) closes the streams; the rest, and the broken pipes,
are slow.
"""

from __future__ import annotations

import json
import os
import shutil
import subprocess
import sys
from pathlib import Path
from typing import Callable

import pytest

from astrocpg.support._streams import Guarded, mend_closed
from astrocpg.studies.cli import main
from tiny_study import tiny_study

SHORT = ["--set", "L_max=0.2*second", "--set", "L_non_alive=0.1*second"]
WAYS = ("stdout-closed", "stderr-closed", "both-closed")
BROKEN = ("stdout-broken", "stderr-broken", "both-broken")


@pytest.fixture(scope="module")
def made(tmp_path_factory) -> dict[str, Path]:
    """The folders the reading commands read (a run, a training, a study), made once."""
    base = tmp_path_factory.mktemp("inputs")
    out = {k: base / k for k in ("run", "train", "study")}
    assert main(["run", "--seconds", "0.05", "--out", str(out["run"]), "--no-progress"]) == 0
    assert main(["train", "--sessions", "1", *SHORT, "--out", str(out["train"]),
                 "--no-progress"]) == 0
    (base / "tiny.toml").write_text(tiny_study("tiny", sessions=1))
    assert main(["study", str(base / "tiny.toml"), "--out", str(out["study"]), "--workers", "1",
                 "--no-progress"]) == 0
    out["study_file"] = base / "tiny.toml"
    return out


# command -> (argv in a case folder, the path whose files are compared: None for none)
Spec = Callable[[Path, dict], tuple[list[str], Path | None]]


def _copy(made: dict, which: str, tmp: Path) -> Path:
    dst = tmp / which
    shutil.copytree(made[which], dst, symlinks=True)
    return dst


COMMANDS: dict[str, Spec] = {
    "run": lambda t, m: (["run", "--seconds", "0.01", "--out", str(t / "o")], t / "o"),
    "unit": lambda t, m: (["unit", "--seconds", "0.01", "--out", str(t / "o")], t / "o"),
    "describe": lambda t, m: (["describe", "motor_neuron"], None),
    "models": lambda t, m: (["models", "list"], None),
    "robot": lambda t, m: (["robot", "export", str(t / "a1.xml")], t),
    "train": lambda t, m: (["train", "--sessions", "1", *SHORT, "--out", str(t / "o")], t / "o"),
    "gait": lambda t, m: (["gait", str(_copy(m, "train", t)), "--seconds", "0.05",
                           "--repeats", "1"], t),
    "evaluate": lambda t, m: (["evaluate", str(_copy(m, "train", t)), "--seconds", "0.05",
                               "--repeats", "1", "--worlds", str(_worlds(t)),
                               "--out", str(t / "o")], t),
    "power": lambda t, m: (["power", str(_copy(m, "train", t)), "--sessions", "1"], t),
    "plot": lambda t, m: (["plot", str(_copy(m, "run", t))], t),
    "video": lambda t, m: (["video", str(_copy(m, "run", t)), "--size", "64", "48",
                            "--fps", "10"], t),
    "export": lambda t, m: (["export", str(_copy(m, "run", t)), "--format", "npz",
                             "--out", str(t / "run.npz")], t),
    "study": lambda t, m: (["study", str(m["study_file"]), "--out", str(t / "o")], t / "o"),
    "report": lambda t, m: (["report", str(_copy(m, "study", t))], t),
}
FAST = ("run", "unit", "describe", "models")


def _worlds(tmp: Path) -> Path:
    p = tmp / "worlds.toml"
    p.write_text('[worlds.uphill]\nslope = "0.05"\n')
    return p


def _launch(argv: list[str], way: str, cwd: Path) -> int:
    """The command in a child, its streams as ``way`` says; its exit code."""
    closed = {"stdout-closed": (1,), "stderr-closed": (2,), "both-closed": (1, 2)}.get(way, ())
    broken = {"stdout-broken": (1,), "stderr-broken": (2,), "both-broken": (1, 2)}.get(way, ())
    pipes = {}
    for fd in broken:  # a pipe whose reading end is already closed: every write is EPIPE
        r, w = os.pipe()
        os.close(r)
        pipes[fd] = w

    def child() -> None:
        for fd in closed:
            os.close(fd)

    env = {**os.environ, "PYTHONWARNINGS": "ignore", "COLUMNS": "80"}
    env.pop("ASTROCPG_DEBUG", None)
    try:
        proc = subprocess.run([sys.executable, "-m", "astrocpg.studies.cli", *argv], cwd=cwd,
                              env=env, stdin=subprocess.DEVNULL,
                              stdout=pipes.get(1, subprocess.DEVNULL),
                              stderr=pipes.get(2, subprocess.DEVNULL),
                              preexec_fn=child, timeout=600)
    finally:
        for w in pipes.values():
            os.close(w)
    return proc.returncode


def _files(root: Path | None) -> tuple[list[str], str | None]:
    """The relative paths below ``root`` (the case's own inputs named alike) and the status in
    its manifest."""
    if root is None:
        return [], None
    names = sorted(p.relative_to(root).as_posix() for p in root.rglob("*") if p.is_file())
    status = None
    for manifest in (root / "manifest.json", root / "o" / "manifest.json"):
        if manifest.is_file():
            status = json.loads(manifest.read_text()).get("results", {}).get("status")
    return names, status


def _check(command: str, ways: tuple[str, ...], tmp_path: Path, made: dict) -> None:
    spec = COMMANDS[command]
    seen = {}
    for way in ("open", *ways):
        case = tmp_path / way
        case.mkdir()
        argv, compared = spec(case, made)
        code = _launch(argv, way, case)
        seen[way] = (code, *_files(compared))
    assert seen["open"][0] == 0, seen["open"]
    differ = {w: s for w, s in seen.items() if s != seen["open"]}
    assert not differ, (seen["open"], differ)


@pytest.mark.parametrize("command", FAST)
def test_a_command_with_closed_streams_does_its_work(command, tmp_path) -> None:
    _check(command, WAYS, tmp_path, {})  # these read no folder


@pytest.mark.slow
@pytest.mark.parametrize("command", [c for c in COMMANDS if c not in FAST])
def test_every_other_command_with_closed_streams_does_its_work(command, tmp_path, made) -> None:
    _check(command, WAYS, tmp_path, made)


@pytest.mark.slow
@pytest.mark.parametrize("command", list(COMMANDS))
def test_every_command_into_a_broken_pipe_does_its_work(command, tmp_path, made) -> None:
    _check(command, BROKEN, tmp_path, made)


def test_a_train_with_its_bar_on_a_closed_stderr_finishes(tmp_path) -> None:
    """The issue's case: the default bar on a closed stderr failed at once, silently, leaving a
    manifest that said ``running``."""
    code = _launch(["train", "--sessions", "1", *SHORT, "--out", str(tmp_path / "pc7")],
                   "stderr-closed", tmp_path)
    assert code == 0
    manifest = json.loads((tmp_path / "pc7" / "manifest.json").read_text())
    assert manifest["results"]["status"] == "finished"


def test_a_guarded_stream_becomes_a_sink_when_its_pipe_breaks() -> None:
    r, w = os.pipe()
    stream = open(w, "w", buffering=1)
    guarded = Guarded(stream)
    guarded.write("read\n")
    assert os.read(r, 100) == b"read\n"
    os.close(r)
    guarded.write("nobody reads this\n")  # EPIPE: no exception
    guarded.flush()
    assert guarded.gone
    stream.write("x" * 100_000)  # the descriptor now holds /dev/null: the stream itself works
    stream.flush()
    stream.close()
    closed = Guarded(open(os.devnull, "w"))
    closed.wrapped.close()
    assert closed.write("after close") == len("after close") and closed.gone


def test_a_closed_descriptor_gets_dev_null_and_a_stream(tmp_path) -> None:
    """mend_closed in a child whose descriptor 2 was closed: sys.stderr exists, and a file
    opened afterwards does not take descriptor 2."""
    code = ("import os, sys; from astrocpg.support._streams import mend_closed; mend_closed(); "
            "f = open(sys.argv[1], 'w'); print(f.fileno(), sys.stderr is not None, "
            "os.path.realpath('/proc/self/fd/2'), file=f)")
    subprocess.run([sys.executable, "-c", code, str(tmp_path / "o.txt")], check=True,
                   preexec_fn=lambda: os.close(2))
    fd, has, target = (tmp_path / "o.txt").read_text().split()
    assert int(fd) > 2 and has == "True" and target == os.devnull
    mend_closed()  # nothing closed here: nothing changes
    assert sys.stderr is not None
