"""The one rule of divergence (network/divergence.py): a state value that is NaN, inf or beyond
1e50 in SI units (Brian2's own bound) is invalid, whatever the variable. Its fast scan (one dot
product per array, no allocation) agrees with the exact rule element for element; constants are
covered; Brian2's own end-of-run warning is left to the scan for the CPG's objects only. The
bad-input table (tests/test_bad_input.py, "absurd but finite states") shows the commands."""

from __future__ import annotations

import logging
import sys
import tracemalloc

import brian2
import numpy as np
import pytest
from brian2 import mV, ms, second, umolar
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays

from astrocpg.errors import Diverged
from astrocpg.models import DEFAULT_MODELS
from astrocpg.network import LIMIT, DivergenceCheck, StateScan, build_cpg, invalid, run_network

HUGE = sys.float_info.max


def test_the_rule_at_its_edges():
    values = np.array([0.0, 1e50, -1e50, 1e50 * (1 + 1e-15), -1.0000001e50, 3e251, np.inf,
                       -np.inf, np.nan, 5e-324, -HUGE])
    assert LIMIT == 1e50
    np.testing.assert_array_equal(
        invalid(values), [False, False, False, True, True, True, True, True, True, False, True])


def _scan_of(arr: np.ndarray, changes: bool = True) -> StateScan:
    return StateScan([("motor", "v", arr, np.zeros(arr.size, dtype=int), changes)])


finite_or_not = st.one_of(
    st.floats(allow_nan=True, allow_infinity=True),
    st.floats(min_value=-2e50, max_value=2e50),  # around the bound
    st.sampled_from([1e50, -1e50, 1e50 * (1 + 2 ** -52), 5e49, 5.0000001e49, HUGE, -HUGE]))


@settings(max_examples=400, deadline=None)
@given(arrays(np.float64, st.integers(1, 300), elements=finite_or_not))
def test_the_fast_scan_agrees_with_the_rule(arr):
    """Whatever the values (sums that overflow, opposite signs, values by the bound), the scan
    reports the first invalid element, and nothing where every value is valid."""
    found = _scan_of(arr).first()
    bad = np.flatnonzero(invalid(arr))
    if not bad.size:
        assert found is None
    else:
        assert found is not None and found.index == bad[0]
        assert found.value == arr[bad[0]] or (np.isnan(found.value) and np.isnan(arr[bad[0]]))


def test_valid_values_whose_sum_overflows_are_no_divergence():
    arr = np.full(1000, 0.9e50)  # the dot product overflows; no element is beyond the bound
    assert _scan_of(arr).first() is None
    arr[700] = -1.1e50
    assert _scan_of(arr).first().index == 700


def test_constants_are_scanned_first_and_after_a_run():
    arr = np.zeros(4)
    scan = _scan_of(arr, changes=False)
    arr[2] = 1e60
    assert scan.first().index == 2  # the first scan covers every array
    assert scan.first() is None  # then the hot loop skips what cannot change
    assert scan.first(full=True).index == 2  # after a run: everything


def test_an_absurd_but_finite_state_diverges_the_unit():
    models = DEFAULT_MODELS.with_values({"C_K_chan": 1e300 * mV / second})
    cpg = build_cpg(models, n_trials=2, seed=1, legs=("FR",))
    cpg.net.add(DivergenceCheck(cpg).operation())
    with pytest.raises(Diverged) as info:
        run_network(cpg.net, 0.1 * second, namespace={})
    e = info.value
    assert e.culprit == "motor.v" and e.trial == 0 and e.exit_code == 3
    assert np.isfinite(cpg.array("motor", "v")).all()  # never inf: finite, and absurd
    assert "beyond 1e50" in e.message and len(e.line.splitlines()) == 1


@pytest.mark.parametrize("group, variable, value", [
    ("astrocyte", "IP3", 1e51), ("interlimb", "w", -2e50), ("intra_pool", "w", 1e60),
    ("torque", "I_joint", 1e55), ("pool", "u", np.nan)])
def test_every_population_is_scanned(group, variable, value):
    cpg = build_cpg(DEFAULT_MODELS, n_trials=3, seed=1)
    assert cpg.first_invalid(full=True) is None
    arr = cpg.array(group, variable)
    arr[len(arr) - 1] = value  # the last element: the last trial
    found = cpg.first_invalid(full=True)
    assert found.culprit == f"{group}.{variable}" and found.trial == 2


def test_the_scan_allocates_nothing():
    """The hot loop's check (every 10 steps) allocates no array: the exact rule (np.abs of
    every array) would peak at the largest array (the motor neurons' 20 kB at 8 trials)."""
    cpg = build_cpg(DEFAULT_MODELS, n_trials=8, seed=1)
    cpg.first_invalid(full=True)
    largest = max(a.nbytes for _, _, a, _ in cpg.state_arrays())
    tracemalloc.start()
    try:
        for _ in range(200):
            assert cpg.first_invalid() is None
        _, peak = tracemalloc.get_traced_memory()
    finally:
        tracemalloc.stop()
    assert largest > 16_000 and peak < 4_000, peak


class _Records(logging.Handler):
    def __init__(self) -> None:
        super().__init__(logging.DEBUG)
        self.messages: list[str] = []

    def emit(self, record: logging.LogRecord) -> None:
        self.messages.append(record.getMessage())


def test_brian2s_warning_is_left_to_the_scan_for_the_cpg_only():
    """Brian2 warns at the end of a run of any group with a state beyond 1e50: not for the
    CPG's objects (the scan reports it, in one line), still for a user's own group."""
    from brian2.utils.logger import BrianLogger

    BrianLogger._log_messages.clear()  # Brian2 says each warning once per process
    records = _Records()
    logger = logging.getLogger("brian2")
    logger.addHandler(records)
    try:
        cpg = build_cpg(DEFAULT_MODELS, n_trials=1, seed=1, legs=("FR",))
        cpg.array("motor", "v")[:] = -3e251
        cpg.array("astrocyte", "IP3")[:] = 1e60
        cpg.net.run(1 * ms, namespace={})
        assert not [m for m in records.messages if "very large values" in m], records.messages
        assert cpg.first_invalid().culprit == "astrocyte.IP3"  # upstream first
        theirs = brian2.NeuronGroup(2, "dx/dt = -x/(10*ms) : 1", name="users_own_group",
                                    method="euler")
        theirs.x = 1e60
        brian2.Network(theirs).run(1 * ms, namespace={"ms": ms})
        assert [m for m in records.messages if "users_own_group" in m and "very large" in m]
    finally:
        logger.removeHandler(records)


def test_an_astrocyte_beyond_the_bound_in_a_closed_loop():
    from astrocpg.coupling.assembly import build_closed_loop

    models = DEFAULT_MODELS.with_values({"IP3_star": 1e60 * umolar * 1e-3})
    loop = build_closed_loop(models, n_trials=2, seed=1, check=False)
    with pytest.raises(Diverged) as info:
        loop.run(0.1)
    assert info.value.culprit == "astrocyte.IP3" and info.value.t == pytest.approx(0.010)
