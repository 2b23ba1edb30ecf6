"""A run folder's arrays are stored uncompressed (writing them costs a fraction of the
simulation, not as much again), folders written compressed by earlier versions still load and
verify, and float32 traces rounded a block at a time are every sample, rounded as taken."""

from __future__ import annotations

import json
import zipfile

import numpy as np
import pytest
from brian2 import ms

import astrocpg as ac
from astrocpg.coupling.assembly import build_closed_loop
from astrocpg.errors import InputError
from astrocpg.models import DEFAULT_MODELS
from astrocpg.network.recording import STAGED_SAMPLES
from astrocpg.studies.commands.simulate import _collect, add_monitors
from astrocpg.studies.outputs.folder import inventory, verify

ARRAYS = ("spikes.npz", "traces.npz", "robot.npz")


def test_a_run_stores_its_arrays_uncompressed_and_a_compressed_folder_still_loads(tmp_path):
    out = tmp_path / "run"
    r = ac.run(seconds=0.1, trials=1, seed=3, progress=False, out=out)
    for name in ARRAYS:
        with zipfile.ZipFile(out / name) as z:
            kinds = {i.filename: i.compress_type for i in z.infolist()}
        assert set(kinds.values()) == {zipfile.ZIP_STORED}, (name, kinds)
    # the folder as an earlier version wrote it: every array deflated, the manifest to match
    arrays = {}
    for name in ARRAYS:
        with np.load(out / name) as z:
            arrays[name] = {k: z[k] for k in z.files}
        np.savez_compressed(out / name, **arrays[name])
        with zipfile.ZipFile(out / name) as z:
            assert zipfile.ZIP_DEFLATED in {i.compress_type for i in z.infolist()}
    manifest = json.loads((out / "manifest.json").read_text())
    manifest["inventory"] = inventory(out)
    (out / "manifest.json").write_text(json.dumps(manifest))
    verify(out)
    old = ac.load(out)
    for name, (t, v) in r.traces.items():
        np.testing.assert_array_equal(old.traces[name][1], v)
        np.testing.assert_array_equal(old.traces[name][0], t)
    for pop, (t, i) in r.spikes.items():
        np.testing.assert_array_equal(old.spikes[pop][0], t)
        np.testing.assert_array_equal(old.spikes[pop][1], i)
    np.testing.assert_array_equal(old.robot["joint_angles"], arrays["robot.npz"]["joint_angles"])
    # and a changed byte in a compressed file is still refused
    data = bytearray((out / "traces.npz").read_bytes())
    data[len(data) // 2] ^= 1
    (out / "traces.npz").write_bytes(bytes(data))
    with pytest.raises(InputError, match="sha256"):
        verify(out)


def test_float32_traces_collected_mid_block_are_every_sample_rounded_as_taken():
    """Samples wait in a float64 block until it fills: what is collected mid-block (and again
    later, across blocks) holds every sample, each the float64 value rounded to float32."""
    steps = 2 * STAGED_SAMPLES + 22
    got = {}
    for dtype in ("float32", "float64"):
        loop = build_closed_loop(DEFAULT_MODELS, n_trials=1, seed=5)
        mons = add_monitors(loop.cpg, 1 * ms, True, n_steps=steps, trace_dtype=dtype)
        loop.run((STAGED_SAMPLES + 10) * 1e-3)  # mid-block
        first = {k: v.copy() for k, (_, v) in _collect(loop.cpg, mons)[1].items()}
        loop.run((steps - STAGED_SAMPLES - 10) * 1e-3)
        got[dtype] = (first, {k: v for k, (_, v) in _collect(loop.cpg, mons)[1].items()})
    for name, v64 in got["float64"][1].items():
        v32 = got["float32"][1][name]
        assert v32.dtype == np.float32 and v32.shape[0] == steps
        np.testing.assert_array_equal(v32, v64.astype(np.float32), err_msg=name)
        early = got["float32"][0][name]
        assert early.shape[0] == STAGED_SAMPLES + 10
        np.testing.assert_array_equal(early, v32[:STAGED_SAMPLES + 10], err_msg=name)
