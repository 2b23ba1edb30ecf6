"""A run is a function of its inputs only: the user's process state (Brian2 preferences, the
default clock, numpy's error state and print options, numpy's and Python's generators, warning
filters) changes nothing in its arrays or manifest, and is as it was after the run
(network/brian_prefs.py, applied by RUN_LOCK)."""

from __future__ import annotations

import json
import random
import warnings

import numpy as np
import pytest

VOLATILE = {"created", "argv", "wall_seconds", "mtime_ns", "sha256", "size"}


def _folder(path):
    arrays = {}
    for name in ("spikes.npz", "traces.npz", "robot.npz"):
        with np.load(path / name) as z:
            arrays.update({f"{name}/{k}": z[k] for k in z.files})
    manifest = json.loads((path / "manifest.json").read_text())

    def strip(d):
        if isinstance(d, dict):
            return {k: strip(v) for k, v in d.items() if k not in VOLATILE}
        return d
    return arrays, strip(manifest)


def _run(path):
    import astrocpg as ac
    ac.run(seconds=0.5, seed=5, out=path, progress=False)
    return _folder(path)


def _float32():
    import brian2
    brian2.prefs.core.default_float_dtype = np.float32


def _clock():
    import brian2
    brian2.defaultclock.dt = 0.05 * brian2.ms


def _raise():
    np.seterr(all="raise")


def _np_random():
    np.random.seed(12345)
    random.seed(12345)


def _warnings_error():
    warnings.simplefilter("error")


def _print():
    np.set_printoptions(precision=2, threshold=5)


@pytest.fixture(scope="module")
def baseline(tmp_path_factory):
    return _run(tmp_path_factory.mktemp("base") / "run")


def _state():
    import brian2
    return {"prefs": {k: repr(v) for k, v in brian2.prefs.items()},
            "dt": float(brian2.defaultclock.dt_), "err": np.geterr(),
            "print": repr(np.get_printoptions()), "filters": repr(warnings.filters)}


@pytest.mark.parametrize("change", [_float32, _clock, _raise, _np_random, _warnings_error,
                                    pytest.param(_print, marks=pytest.mark.xfail(
                                        strict=True, reason="the manifest's model values are "
                                        "formatted with the user's print options, outside "
                                        "RUN_LOCK: not fixed yet"))])
def test_the_users_process_changes_nothing_and_is_left_as_it_was(change, baseline, tmp_path):
    import brian2
    saved = (brian2.prefs.core.default_float_dtype, brian2.defaultclock.dt_, np.geterr(),
             np.get_printoptions())
    with warnings.catch_warnings():
        try:
            change()
            before = _state()
            draws_np = np.random.get_state()
            draws_py = random.getstate()
            arrays, manifest = _run(tmp_path / "run")
            after = _state()
            next_np, next_py = np.random.rand(), random.random()
            np.random.set_state(draws_np)
            random.setstate(draws_py)
            assert (next_np, next_py) == (np.random.rand(), random.random())
        finally:
            brian2.prefs.core.default_float_dtype = saved[0]
            brian2.defaultclock.dt_ = saved[1]
            np.seterr(**saved[2])
            np.set_printoptions(**saved[3])
    assert after == before
    base_arrays, base_manifest = baseline
    assert manifest == base_manifest
    assert set(arrays) == set(base_arrays)
    for k, v in arrays.items():
        assert v.dtype == base_arrays[k].dtype, k
        assert v.tobytes() == base_arrays[k].tobytes(), k
