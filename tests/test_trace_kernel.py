"""The compiled trace sampler (``network/recording.py``'s kernel) stores what the numpy path
stores: the same float32 rounding of the float64 product, the same counts of values beyond
float32's range and the same column peaks (NaN ignored), and a run recorded either way writes
the same files."""

from __future__ import annotations

import numpy as np
import pytest

from astrocpg.network import recording


class _Bytes:
    """A sink that keeps what it is given."""

    def __init__(self) -> None:
        self.data = bytearray()

    def write(self, data) -> int:
        self.data += memoryview(data).cast("B")
        return len(memoryview(data).cast("B"))

    def close(self) -> None:
        pass

    def abandon(self) -> None:
        pass


def _kernel():
    fn = recording.kernel()
    if fn is None:
        pytest.skip("no C compiler here: traces are sampled with numpy")
    return fn


@pytest.mark.parametrize("dtype", ["float32", "float64"])
def test_the_kernel_rounds_counts_and_keeps_peaks_as_numpy_does(dtype):
    fn = _kernel()
    rng = np.random.default_rng(5)
    rows, columns, samples = 8, 37, 29  # a last block of 5 rows
    values = rng.normal(scale=10.0, size=(samples, columns))
    values[3, 4] = values[3, 9] = 1e39  # beyond float32: inf when rounded
    values[7, 2] = -1e40
    values[:, 5] = np.nan  # a column never finite: its peak NaN
    values[11:14, 6] = np.nan
    values[20, 0] = 2e38  # times the scale: just under float32's largest, not inf
    scale = 1.7
    by_numpy = recording.SpilledTrace("x", "p", _Bytes(), columns, np.dtype(dtype), rows)
    by_kernel = recording.SpilledTrace("x", "p", _Bytes(), columns, np.dtype(dtype), rows)
    src = np.zeros(columns)
    plan = (recording._Trace * 1)(recording._Trace(
        src=src.ctypes.data, n=columns, scale=scale, dst=by_kernel.block.ctypes.data,
        row_bytes=by_kernel.block.strides[0], f32=dtype == "float32", in_block=1,
        top=by_kernel.top.ctypes.data,
        inf=by_kernel.inf_counts.ctypes.data if dtype == "float32" else None))
    for start in range(0, samples, rows):
        block = values[start:start + rows]
        by_numpy.append(block * scale)
        for j, row in enumerate(block):
            src[:] = row
            fn(plan, 1, 123456, j)  # k: not this trace's row (its rows are the block's)
        by_kernel.write_block(len(block))
    assert by_kernel.sink.data == by_numpy.sink.data
    assert by_kernel.samples == by_numpy.samples == samples
    np.testing.assert_array_equal(by_kernel.column_max, by_numpy.column_max)
    assert np.isnan(by_kernel.column_max[5]) and not np.isnan(by_kernel.column_max[6])
    if dtype == "float32":
        assert (by_kernel.inf_values, by_kernel.inf_samples) == (3, 2)
    assert (by_kernel.inf_values, by_kernel.inf_samples) == \
        (by_numpy.inf_values, by_numpy.inf_samples)


def test_the_switch_turns_the_kernel_off(monkeypatch):
    monkeypatch.setenv("ASTROCPG_COMPILED_RECORDING", "off")
    assert recording.kernel() is None


def test_a_bad_cached_kernel_is_rebuilt(monkeypatch, tmp_path):
    import shutil
    import sysconfig

    if not shutil.which((sysconfig.get_config_var("CC") or "cc").split()[0]):
        pytest.skip("no C compiler here")
    monkeypatch.setenv("ASTROCPG_CACHE", str(tmp_path))
    lib = recording.native.Library("recording", recording.KERNEL_SOURCE,
                                   recording.KERNEL.functions, "the compiled trace recorder",
                                   flags=recording.KERNEL.flags)
    path = lib.path()
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_bytes(b"\x7fELF truncated")
    assert lib.get() is not None and lib.problem is None
    assert path.stat().st_size > 1000


def test_a_kernel_that_cannot_be_built_leaves_numpy_with_the_reason(monkeypatch, tmp_path):
    import subprocess

    monkeypatch.setenv("ASTROCPG_CACHE", str(tmp_path))
    lib = recording.native.Library("recording", recording.KERNEL_SOURCE,
                                   recording.KERNEL.functions, "the compiled trace recorder")
    lib.path().parent.mkdir(parents=True, exist_ok=True)
    lib.path().write_bytes(b"garbage")

    def fail(*args, **kwargs):
        raise subprocess.CalledProcessError(1, "cc")

    monkeypatch.setattr(recording.native, "compile_source", fail)
    assert lib.get() is None
    assert "building it again failed" in lib.problem


def test_a_run_says_how_its_traces_were_sampled(monkeypatch, tmp_path, capsys):
    """The manifest's environment names the sampler; a kernel that could not be rebuilt is
    said once on the command line and the run writes the same traces with numpy."""
    import json
    import subprocess

    from astrocpg.studies.cli import main

    # in this process: its sampler (patched below) is the one tested
    args = ["run", "--seconds", "0.02", "--trials", "2", "--no-progress", "--workers", "1",
            "--out"]
    monkeypatch.setenv("ASTROCPG_COMPILED_RECORDING", "off")
    assert main(args + [str(tmp_path / "off")]) == 0
    env = json.loads((tmp_path / "off" / "manifest.json").read_text())["environment"]
    assert env["trace_sampling"] == "numpy (ASTROCPG_COMPILED_RECORDING off)"
    assert env["ASTROCPG_COMPILED_RECORDING"] == "off"

    monkeypatch.setenv("ASTROCPG_COMPILED_RECORDING", "on")
    monkeypatch.setenv("ASTROCPG_CACHE", str(tmp_path / "cache"))
    kernel = recording.native.Library("recording", recording.KERNEL_SOURCE,
                                      recording.KERNEL.functions, recording.KERNEL.what,
                                      flags=recording.KERNEL.flags)
    kernel.path().parent.mkdir(parents=True)
    kernel.path().write_bytes(b"garbage")
    monkeypatch.setattr(recording, "KERNEL", kernel)
    monkeypatch.setattr(recording.native, "compile_source", lambda *a, **k: (
        _ for _ in ()).throw(subprocess.CalledProcessError(1, "cc")))
    capsys.readouterr()
    assert main(args + [str(tmp_path / "bad")]) == 0
    out = capsys.readouterr().out
    assert "warning: the compiled trace recorder cannot be used" in out, out
    env = json.loads((tmp_path / "bad" / "manifest.json").read_text())["environment"]
    assert env["trace_sampling"].startswith("numpy (the compiled trace recorder cannot be used")
    assert (tmp_path / "bad" / "traces.npz").read_bytes() == \
        (tmp_path / "off" / "traces.npz").read_bytes()
