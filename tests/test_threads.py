"""Runs in threads of one process: Brian2 is not thread-safe (one random generator, device and
set of running flags per process), so the framework serialises its runs with one lock
(``astrocpg.network.runlock``). Two ``ac.run`` calls started together in two threads each give
exactly the command line's result for their seed, with ``out=`` or without; a first import of
Brian2 in a thread works (its Ctrl-C handler could only be installed from the main thread), and
so do a unit and a training in threads."""

from __future__ import annotations

import signal
import subprocess
import sys
import textwrap
import threading
from pathlib import Path
from typing import Any, Callable

import numpy as np
import pandas as pd
import pytest

import astrocpg as ac
from astrocpg.network import RUN_LOCK, exclusive
from astrocpg.studies.cli import main

ROOT = Path(__file__).resolve().parents[1]
SECONDS, SEED = 0.3, 3
SHORT_SESSIONS = ["L_max=0.2*second", "L_non_alive=0.1*second"]


@pytest.fixture(scope="module")
def tmp_module(tmp_path_factory) -> Path:
    return tmp_path_factory.mktemp("threads")


@pytest.fixture(scope="module")
def command_line(tmp_module) -> ac.Result:
    """``astrocpg run --seconds 0.3 --seed 3``: the reference, read back from its folder."""
    out = tmp_module / "cli"
    assert main(["run", "--seconds", str(SECONDS), "--seed", str(SEED), "--out", str(out),
                 "--no-progress"]) == 0
    return ac.load(out)


def _together(*calls: Callable[[], Any]) -> list[Any]:
    """Start every call in its own thread at the same moment; their results (or errors)."""
    barrier = threading.Barrier(len(calls))
    results: list[Any] = [None] * len(calls)

    def go(k: int) -> None:
        barrier.wait()
        try:
            results[k] = calls[k]()
        except BaseException as e:  # noqa: BLE001 - the test reports it
            results[k] = e

    threads = [threading.Thread(target=go, args=(k,)) for k in range(len(calls))]
    for t in threads:
        t.start()
    for t in threads:
        t.join(timeout=600)
    assert not any(t.is_alive() for t in threads)
    for r in results:
        if isinstance(r, BaseException):
            raise AssertionError(f"a thread failed: {type(r).__name__}: {r}") from r
    return results


def _assert_same_run(result: ac.Result, reference: ac.Result) -> None:
    assert set(result.spikes) == set(reference.spikes)
    for pop, (t, i) in reference.spikes.items():
        np.testing.assert_array_equal(result.spikes[pop][0], t, err_msg=f"{pop} spike times")
        np.testing.assert_array_equal(result.spikes[pop][1], i, err_msg=f"{pop} spike indices")
    assert set(result.robot) == set(reference.robot)
    for name, values in reference.robot.items():
        np.testing.assert_array_equal(result.robot[name], values, err_msg=f"robot {name}")
    assert len(reference.spikes["motor"][0]) > 100


@pytest.mark.parametrize("with_out", [False, True], ids=["in-memory", "out"])
def test_two_runs_in_threads_give_the_command_lines_result(command_line, tmp_path, with_out):
    def run(k: int) -> Callable[[], ac.Result]:
        out = tmp_path / f"thread{k}" if with_out else None
        return lambda: ac.run(seconds=SECONDS, seed=SEED, progress=False, out=out)

    results = _together(run(0), run(1))
    for k, r in enumerate(results):
        _assert_same_run(r, command_line)
        if with_out:  # the folder holds the same
            _assert_same_run(ac.load(tmp_path / f"thread{k}"), command_line)
            assert ac.load(tmp_path / f"thread{k}").manifest["results"]["status"] == "finished"


def test_units_in_threads_give_a_single_units_result():
    alone = ac.unit(seconds=0.4, seed=2, progress=False)
    results = _together(*(lambda: ac.unit(seconds=0.4, seed=2, progress=False),) * 2,
                        lambda: ac.run(seconds=0.2, seed=7, progress=False))
    for r in results[:2]:
        for pop, (t, i) in alone.spikes.items():
            np.testing.assert_array_equal(r.spikes[pop][0], t)
            np.testing.assert_array_equal(r.spikes[pop][1], i)
        for name, (t, v) in alone.traces.items():
            np.testing.assert_array_equal(r.traces[name][1], v)
    assert len(alone.spikes["motor"][0]) > 10


def test_trainings_in_threads_give_the_command_lines_sessions(tmp_path):
    args = ["--sessions", "2", "--seed", "4", "--no-progress"]
    sets = [x for o in SHORT_SESSIONS for x in ("--set", o)]
    assert main(["train", *args, *sets, "--out", str(tmp_path / "cli")]) == 0
    reference = ac.load(tmp_path / "cli")

    def train(k: int) -> Callable[[], ac.Result]:
        return lambda: ac.train(out=tmp_path / f"thread{k}", sessions=2, seed=4,
                                overrides=SHORT_SESSIONS, progress=False)

    for r in _together(train(0), train(1), lambda: ac.run(seconds=0.2, seed=1, progress=False)
                       )[:2]:
        columns = [c for c in reference.sessions.columns if "wall" not in c]
        pd.testing.assert_frame_equal(r.sessions[columns], reference.sessions[columns])
        np.testing.assert_array_equal(r.weights, reference.weights)


def test_the_lock_serialises_and_is_reentrant():
    """While one thread holds the run lock, a run in another waits for it (then finishes)."""
    inside, order = threading.Event(), []

    @exclusive
    def outer() -> None:
        with RUN_LOCK:  # reentrant: an entry calling another
            inside.set()
            order.append("holder start")
            threading.Event().wait(0.5)
            order.append("holder end")

    def other() -> None:
        inside.wait()
        ac.unit(seconds=0.01, seed=1, progress=False)
        order.append("run")

    threads = [threading.Thread(target=outer), threading.Thread(target=other)]
    for t in threads:
        t.start()
    for t in threads:
        t.join(timeout=120)
    assert order == ["holder start", "holder end", "run"]


def test_brian2_first_imported_in_a_thread(command_line, tmp_path):
    """A fresh process whose first Brian2 import is in a thread (Brian2's own import sets a
    signal handler, which only the main thread may): both runs work, with out= and without, and
    give the command line's result; Brian2's Ctrl-C handler is installed later from the main
    thread."""
    code = textwrap.dedent(f"""
        import signal, sys, threading
        import numpy as np
        import astrocpg as ac
        out = sys.argv[1]
        barrier, errors, results = threading.Barrier(2), [], {{}}
        def go(k):
            barrier.wait()
            try:
                r = ac.run(seconds={SECONDS}, seed={SEED}, progress=False,
                           out=f"{{out}}/t{{k}}" if k else None)
                results[k] = r
            except BaseException as e:
                errors.append(f"{{type(e).__name__}}: {{e}}")
        ts = [threading.Thread(target=go, args=(k,)) for k in range(2)]
        [t.start() for t in ts]; [t.join() for t in ts]
        assert not errors, errors
        import brian2
        assert signal.getsignal(signal.SIGINT) is not brian2._int_handler
        ac.unit(seconds=0.01, progress=False)  # in the main thread: the handler goes in
        assert signal.getsignal(signal.SIGINT) is brian2._int_handler
        np.savez(f"{{out}}/t0.npz", **{{f"{{p}}_{{k}}": a for p, ta in results[0].spikes.items()
                                     for k, a in enumerate(ta)}})
    """)
    # a process started with SIGINT ignored (pytest run as a background job, `cmd &`) keeps
    # it ignored, by design: the child starts with Python's own handler, as from a terminal
    proc = subprocess.run([sys.executable, "-c", code, str(tmp_path)], capture_output=True,
                          text=True, timeout=300, cwd=tmp_path,
                          preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_DFL))
    assert proc.returncode == 0, proc.stderr[-3000:]
    assert "signal only works" not in proc.stderr
    _assert_same_run(ac.load(tmp_path / "t1"), command_line)
    saved = np.load(tmp_path / "t0.npz")
    for pop, (t, i) in command_line.spikes.items():
        np.testing.assert_array_equal(saved[f"{pop}_0"], t)
        np.testing.assert_array_equal(saved[f"{pop}_1"], i)


def test_the_command_line_in_a_thread(tmp_path):
    """``main()`` called in another thread: no SIGTERM handler of ours (only the main thread
    may set one), the command runs."""
    code = _together(lambda: main(["run", "--seconds", "0.05", "--out", str(tmp_path / "r"),
                                   "--no-progress"]))
    assert code == [0]
    assert ac.load(tmp_path / "r").manifest["results"]["status"] == "finished"
