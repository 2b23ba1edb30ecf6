"""Ctrl-C in a script that calls the Python API: the run stops at the end of its step and the
API raises KeyboardInterrupt, with no line of Brian2's ("Simulation stop requested. Press
Ctrl+C again to interrupt.") on the console."""

from __future__ import annotations

import os
import subprocess
import sys
import textwrap

import pytest

SCRIPT = textwrap.dedent("""
    import os, signal, sys, threading, time
    import astrocpg as ac
    import brian2

    def interrupt_once_running():
        while not brian2.Network._globally_running:
            time.sleep(0.01)
        time.sleep(0.3)
        os.kill(os.getpid(), signal.SIGINT)

    threading.Thread(target=interrupt_once_running, daemon=True).start()
    try:
        ac.run(seconds=60, progress=False)
    except KeyboardInterrupt:
        print("KeyboardInterrupt raised", flush=True)
        sys.exit(130)
    print("not interrupted", flush=True)
""")


@pytest.mark.slow
def test_ctrl_c_in_the_api_raises_keyboardinterrupt_without_brian2_chatter(tmp_path):
    # the installed astrocpg, as a user's script imports it: never the checkout's parent folder
    # on the path, where a clone named like a standard module (copy/) would shadow that module
    proc = subprocess.run([sys.executable, "-c", SCRIPT], cwd=tmp_path, env=dict(os.environ),
                          capture_output=True, text=True, timeout=300)
    assert proc.returncode == 130, (proc.stdout, proc.stderr)
    assert "KeyboardInterrupt raised" in proc.stdout
    assert "Simulation stop requested" not in proc.stderr + proc.stdout, proc.stderr
    assert "Traceback" not in proc.stderr, proc.stderr


def test_the_filter_is_only_on_during_a_run_of_ours():
    import logging

    from astrocpg.network import divergence

    brian_log = logging.getLogger("brian2")
    assert divergence._no_stop_chatter not in brian_log.filters
    record = logging.LogRecord("brian2", logging.WARNING, "x", 1,
                               "Simulation stop requested. Press Ctrl+C again to interrupt.",
                               None, None)
    assert divergence._no_stop_chatter(record) is False
    record.msg = "some other warning"
    assert divergence._no_stop_chatter(record) is True

