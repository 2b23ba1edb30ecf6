"""Brian2 leaves no debug files in the temp folder, even from a process killed while it was
importing Brian2 (astrocpg.support._quiet_brian)."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
from pathlib import Path

# The window: Brian2 has been imported (and has written its files), astrocpg has not yet
# removed them. The child kills itself exactly there, as SIGKILL or the OOM killer could.
KILLED_IN_THE_WINDOW = """
import os, signal
import astrocpg.support._quiet_brian as q
q.close_debug_files = lambda: os.kill(os.getpid(), signal.SIGKILL)
import brian2
"""


def python(code: str, tmp: Path) -> subprocess.CompletedProcess:
    env = {**os.environ, "TMPDIR": str(tmp)}
    return subprocess.run([sys.executable, "-c", code], env=env, capture_output=True,
                          text=True, timeout=300)


def test_importing_brian2_through_astrocpg_leaves_nothing(tmp_path):
    done = python("import astrocpg, brian2, os\n"
                  "assert not brian2.prefs.logging.file_log\n"
                  "print(sorted(os.listdir(os.environ['TMPDIR'])))", tmp_path)
    assert done.returncode == 0, done.stderr
    assert done.stdout.strip() == "[]"
    assert os.listdir(tmp_path) == []


def test_a_process_killed_while_importing_leaves_only_its_folder_and_the_next_removes_it(
        tmp_path):
    killed = python(KILLED_IN_THE_WINDOW, tmp_path)
    assert killed.returncode == -signal.SIGKILL, killed.stderr
    left = os.listdir(tmp_path)
    # Brian2 did write its files (else this test shows nothing) -- inside the private folder
    assert len(left) == 1 and left[0].startswith("astrocpg-brian-"), left
    inside = os.listdir(tmp_path / left[0])
    assert any(n.startswith("brian_debug_") for n in inside), inside
    nxt = python("import astrocpg.models", tmp_path)
    assert nxt.returncode == 0, nxt.stderr
    assert os.listdir(tmp_path) == []


def test_a_live_process_folder_is_left_alone(tmp_path):
    live = tmp_path / f"astrocpg-brian-{os.getpid()}-x"  # this pytest process is alive
    live.mkdir()
    nxt = python("import astrocpg.models", tmp_path)
    assert nxt.returncode == 0, nxt.stderr
    assert os.listdir(tmp_path) == [live.name]


# Brian2's Ctrl-C handler calls the handler it replaced; in a process started with SIGINT
# ignored (a background job of a shell script) that was SIG_IGN, and a SIGINT raised a
# TypeError ("'Handlers' object is not callable"): `astrocpg study` ended as an internal error.
SIGINT_TO_ITSELF = """
import os, signal, sys, time
{before}
import astrocpg, brian2
{after}
try:
    os.kill(os.getpid(), signal.SIGINT)
    time.sleep(0.2)
except KeyboardInterrupt:
    print("KeyboardInterrupt")
else:
    print("ignored")
"""


def _ignoring_sigint() -> None:
    signal.signal(signal.SIGINT, signal.SIG_IGN)


def test_a_process_started_with_sigint_ignored_keeps_ignoring_it(tmp_path):
    for after in ("", "import astrocpg.network"):  # the import hook, then the network's check
        done = subprocess.run([sys.executable, "-c", SIGINT_TO_ITSELF.format(before="",
                                                                             after=after)],
                              capture_output=True, text=True, timeout=300,
                              preexec_fn=_ignoring_sigint)
        assert done.returncode == 0, done.stderr
        assert done.stdout.strip() == "ignored"


def test_brian2_imported_first_with_sigint_ignored_is_mended_by_the_network(tmp_path):
    # Brian2 imported before astrocpg (its hook does not wrap that import): network.build mends
    done = subprocess.run([sys.executable, "-c", SIGINT_TO_ITSELF.format(
        before="import brian2", after="import astrocpg.network")],
        capture_output=True, text=True, timeout=300, preexec_fn=_ignoring_sigint)
    assert done.returncode == 0, done.stderr
    assert done.stdout.strip() == "ignored"


def test_a_default_sigint_becomes_a_keyboard_interrupt(tmp_path):
    done = python(SIGINT_TO_ITSELF.format(
        before="signal.signal(signal.SIGINT, signal.SIG_DFL)", after=""), tmp_path)
    assert done.returncode == 0, done.stderr
    assert done.stdout.strip() == "KeyboardInterrupt"
