"""A value beyond float32's range (about 3.4e38, but finite and under the 1e50 divergence
bound) is stored as inf in a float32 trace: never silently. The run's manifest records which
traces overflowed and how much, the summary of ``astrocpg run``/``unit`` says so with the
remedy (``trace_dtype float64``), and an export carries the warning in its notes and the
series' descriptions."""

from __future__ import annotations

import json
import warnings

import numpy as np
import pytest

from astrocpg.network.recording import overflow_words, overflowed
from astrocpg.studies.cli import main

HUGE = ["--set", "r_Ca=1e45", "--no-progress"]  # motor [Ca2+] grows past 3.4e38 within 0.05 s


def test_overflowed_counts_infinities_of_float32_traces_only():
    v = np.zeros((4, 3), dtype=np.float32)
    v[1, 0] = v[3, :] = np.inf
    t = np.arange(4.0)
    found = overflowed({"motor_Ca": (t, v), "astrocyte_Ca": (t, v.astype(np.float64)),
                        "astrocyte_IP3": (t, np.zeros((4, 2), np.float32))})
    assert found == {"motor_Ca": {"dtype": "float32", "values": 4, "of": 12, "samples": 2,
                                  "of_samples": 4}}
    # finite values whose sum overflows float32: nothing to count, nothing said
    big = np.full((4, 3), 3e38, dtype=np.float32)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        assert overflowed({"motor_Ca": (t, big)}) == {}
        big[2, 1] = -np.inf
        assert overflowed({"motor_Ca": (t, big)})["motor_Ca"]["values"] == 1
    words = overflow_words(found)
    assert "motor_Ca in 2 of 4 samples" in words and "trace_dtype float64" in words
    assert overflow_words({}) == ""


@pytest.mark.parametrize("command", ["run", "unit"])
def test_a_run_whose_traces_overflow_float32_says_so(tmp_path, capsys, command):
    out = tmp_path / command
    assert main([command, "--seconds", "0.05", *HUGE, "--out", str(out)]) == 0
    said = capsys.readouterr().out
    results = json.loads((out / "manifest.json").read_text())["results"]
    assert results["status"] == "finished"
    over = results["trace_overflow"]
    assert set(over) == {"motor_Ca"}, over  # the only trace it drives that high
    with np.load(out / "traces.npz") as z:
        n_inf = int(np.isinf(z["motor_Ca"]).sum())
    assert n_inf > 0 and over["motor_Ca"]["values"] == n_inf
    warning = [x for x in said.splitlines() if x.startswith("warning:")]
    assert len(warning) == 1 and "motor_Ca" in warning[0] \
        and "trace_dtype float64" in warning[0], said


def test_float64_traces_keep_the_values_and_say_nothing(tmp_path, capsys):
    out = tmp_path / "run64"
    assert main(["run", "--seconds", "0.05", *HUGE, "--trace-dtype", "float64",
                 "--out", str(out)]) == 0
    assert "warning:" not in capsys.readouterr().out
    results = json.loads((out / "manifest.json").read_text())["results"]
    assert results["trace_overflow"] == {}
    with np.load(out / "traces.npz") as z:
        ca = z["motor_Ca"]
    assert np.all(np.isfinite(ca)) and ca.max() > np.finfo(np.float32).max


def test_the_api_summary_and_a_clean_run(tmp_path):
    import astrocpg as ac

    r = ac.run(seconds=0.05, overrides=["r_Ca=1e45"], progress=False)
    assert r.summary["trace_overflow"]["motor_Ca"]["values"] > 0
    clean = ac.run(seconds=0.05, progress=False)
    assert clean.summary["trace_overflow"] == {}


@pytest.mark.slow
@pytest.mark.parametrize("fmt", ["nwb", "npz"])
def test_an_export_of_such_a_run_carries_the_warning(tmp_path, capsys, fmt):
    out = tmp_path / "run"
    assert main(["run", "--seconds", "0.05", *HUGE, "--out", str(out)]) == 0
    capsys.readouterr()
    path = tmp_path / f"run.{fmt}"
    assert main(["export", str(out), "--format", fmt, "--out", str(path)]) == 0
    assert "warning:" in capsys.readouterr().out
    if fmt == "npz":
        with np.load(path) as z:
            meta = json.loads(str(z["metadata_json"]))
        assert meta["trace_overflow"]["motor_Ca"]["values"] > 0, meta
        assert "trace_dtype float64" in meta["warning"]
        return
    from pynwb import NWBHDF5IO

    with NWBHDF5IO(str(path), "r") as io:
        f = io.read()
        assert "trace_overflow" in f.notes
        series = [s for n, s in f.acquisition.items() if n.startswith("motor_Ca_")]
        assert series and all("WARNING" in s.description and "float64" in s.description
                              for s in series)
