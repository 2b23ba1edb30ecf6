"""The gait from the feet (footfall over the upright part of a run) beside the CPG's rhythm, the
share interval and the weight shares at both bounds."""

from __future__ import annotations

import math

import numpy as np
import pytest

from astrocpg.studies.analysis.gait import (MIN_GAIT_SHARE, MIN_STEPS, footfall_gait,
                                            stance_phases, weight_structure)
from astrocpg.studies.analysis.share import wilson_interval

DT = 1e-3
T = np.arange(1, 4001) * DT  # 4 s of samples


def _contacts(offsets: dict[str, float], period: float = 0.4, duty: float = 0.4,
              jitter: float = 0.0, seed: int = 0) -> np.ndarray:
    """(samples, 4) foot forces of feet stepping with the given phase offsets (of a cycle)."""
    rng = np.random.default_rng(seed)
    force = np.zeros((T.size, 4))
    for k, leg in enumerate(("FR", "FL", "RR", "RL")):
        for c in range(int(T[-1] / period) + 2):
            on = (c + offsets[leg]) * period + rng.normal(0, jitter)
            force[(T >= on) & (T < on + duty * period), k] = 100.0
    return force


TROT = {"FR": 0.0, "FL": 0.5, "RR": 0.5, "RL": 0.0}
CYCLES = np.arange(0.0, 4.01, 0.4) + 0.1  # the CPG's stepping cycles (FR burst onsets)
UPRIGHT = np.ones(T.size, dtype=bool)


def test_trotting_feet_of_a_standing_robot_are_a_trot():
    g = footfall_gait(T, UPRIGHT, _contacts(TROT), 1.0, 4.0, CYCLES)
    assert g["gait"] == "trot" and g["gait_reason"] == "" and g["gait_share"] == 1.0
    assert g["gait_period_s"] == pytest.approx(0.4, abs=2e-3)
    assert g["gait_phase_FL"] == pytest.approx(0.5, abs=0.01)
    assert g["gait_phase_RL"] == pytest.approx(0.0, abs=0.01) or g["gait_phase_RL"] > 0.99
    assert g["gait_locking_RR"] == pytest.approx(1.0, abs=0.01)
    assert g["gait_duty_factor"] == pytest.approx(0.4, abs=0.03)


def test_a_robot_that_fell_has_no_gait_and_says_when():
    alive = T < 2.16  # fell at 2.16 s: upright for 39% of the window 1..4 s
    g = footfall_gait(T, alive, _contacts(TROT), 1.0, 4.0, CYCLES)
    assert g["gait"] == "none" and g["gait_reason"] == "fell at 2.16 s"
    assert g["gait_share"] == pytest.approx((2.16 - 1.0) / 3.0, abs=1e-3)
    assert math.isnan(g["gait_phase_FL"])
    # standing for more than MIN_GAIT_SHARE of the window: read over the upright part
    late = 1.0 + 3.0 * (MIN_GAIT_SHARE + 0.05)
    assert footfall_gait(T, T < late, _contacts(TROT), 1.0, 4.0, CYCLES)["gait"] == "trot"


def test_feet_without_a_pattern_are_not_periodic():
    rng = np.random.default_rng(3)
    force = np.zeros((T.size, 4))
    for k in range(4):  # each foot on its own, at random times
        for on in np.sort(rng.uniform(0, 4, 10)):
            force[(T >= on) & (T < on + 0.1), k] = 50.0
    g = footfall_gait(T, UPRIGHT, force, 1.0, 4.0, CYCLES)
    assert g["gait"] == "none" and g["gait_reason"] in ("not periodic", "too few steps")


def test_no_touch_sensors_no_gait():
    g = footfall_gait(T, UPRIGHT, np.full((T.size, 4), np.nan), 1.0, 4.0, CYCLES)
    assert g["gait"] == "none" and g["gait_reason"] == "no contact data"


def test_feet_that_never_lift_make_too_few_steps():
    g = footfall_gait(T, UPRIGHT, np.full((T.size, 4), 80.0), 1.0, 4.0, CYCLES)
    assert g["gait"] == "none" and g["gait_reason"] == "too few steps"


def test_bouncing_feet_keep_their_gait():
    """Hind feet that land with their diagonal and touch down again, briefly, with the other
    pair (what trained controllers' A1 does): the long stances set the phase, the bounces do
    not make the trot aperiodic, and neither does a brush in swing."""
    force = _contacts(TROT)
    for k, leg in ((2, "RR"), (3, "RL")):
        for c in range(12):
            on = (c + TROT[leg] + 0.5) * 0.4  # the other pair's touchdown
            force[(T >= on) & (T < on + 0.012), k] = 300.0
    force[(T >= 2.05) & (T < 2.052), 0] = 20.0
    g = footfall_gait(T, UPRIGHT, force, 1.0, 4.0, CYCLES)
    assert g["gait"] == "trot" and g["gait_reason"] == ""
    assert min(g[f"gait_locking_{leg}"] for leg in ("FL", "RR", "RL")) > 0.9


def test_feet_off_the_rhythm_are_not_periodic():
    """Feet that trot at another period than the CPG's cycle do not follow the rhythm."""
    g = footfall_gait(T, UPRIGHT, _contacts(TROT, period=0.29), 1.0, 4.0, CYCLES)
    assert g["gait"] == "none" and g["gait_reason"] == "not periodic"


def test_no_stepping_cycles_no_gait():
    g = footfall_gait(T, UPRIGHT, _contacts(TROT), 1.0, 4.0, CYCLES[:MIN_STEPS])
    assert g["gait"] == "none" and g["gait_reason"] == "no rhythm"


def test_stance_phase_per_cycle():
    """A stance from 0.2 to 0.4 of each 1 s cycle is centred at 0.3; a cycle without contact,
    or with contact throughout, has no stance phase."""
    t = np.arange(0, 4000) * DT
    on = np.zeros(t.size, dtype=bool)
    for c in (0, 2):
        on[(t >= c + 0.2) & (t < c + 0.4)] = True
    on[(t >= 3.0)] = True
    p = stance_phases(t, on, np.array([0.0, 1.0, 2.0, 3.0, 3.999]))
    assert p[0] == pytest.approx(0.3, abs=1e-3) and p[2] == pytest.approx(0.3, abs=1e-3)
    assert math.isnan(p[1]) and math.isnan(p[3])


def test_wilson_interval():
    lo, hi = wilson_interval(0, 5)
    assert lo == 0.0 and hi == pytest.approx(0.4345, abs=1e-3)
    lo, hi = wilson_interval(3, 5)
    assert lo == pytest.approx(0.2307, abs=1e-3) and hi == pytest.approx(0.8824, abs=1e-3)
    assert wilson_interval(5, 5)[1] == 1.0
    assert all(math.isnan(x) for x in wilson_interval(0, 0))


def test_weight_shares_at_both_bounds_and_signs():
    w = 0.05e-3
    t = np.zeros((8, 8))
    t[0:2, 2:4] = [[-w, w], [w, -w]]  # mixed: 2 at each bound
    t[4:6, 0:2] = -w  # all inhibitory, at w_min
    t[6:8, 0:2] = 0.5 * w  # all excitatory, mid-range
    s = weight_structure(t, w, -w)
    assert s["share_above_0.9_w_max"] == pytest.approx(2 / 48)
    assert s["share_below_0.9_w_min"] == pytest.approx(6 / 48)
    assert s["share_excitatory"] == pytest.approx(6 / 48)
    assert s["share_inhibitory"] == pytest.approx(6 / 48)
    assert (s["mixed_limb_pairs"], s["inhibitory_limb_pairs"], s["excitatory_limb_pairs"]) == \
        (1, 1, 1)


def trot_table(w: float = 0.05e-3) -> np.ndarray:
    """A hand-made table of the paper's structure for a trot: every limb pair's block two
    excitatory and two inhibitory synapses, flexor to flexor excitatory between the limbs of a
    diagonal (FR-RL, FL-RR), inhibitory between the others."""
    legs = ("FR", "FL", "RR", "RL")
    diagonal = {("FR", "RL"), ("RL", "FR"), ("FL", "RR"), ("RR", "FL")}
    t = np.zeros((8, 8))
    for a, la in enumerate(legs):
        for b, lb in enumerate(legs):
            if a != b:
                sign = 1 if (la, lb) in diagonal else -1
                t[2 * a:2 * a + 2, 2 * b:2 * b + 2] = sign * np.array([[w, -w], [-w, w]])
    return t


@pytest.mark.slow
def test_a_trot_table_on_a_steep_slope_keeps_its_rhythm_and_has_no_gait():
    from astrocpg.models import DEFAULT_MODELS
    from astrocpg.studies.analysis.gait import trial_measures
    from astrocpg.studies.commands.simulate import simulate_closed_loop

    models = DEFAULT_MODELS.with_values(dict([DEFAULT_MODELS.parse_assignment("slope=0.35")]))
    tables = np.stack([trot_table(), trot_table()])
    r = simulate_closed_loop(models, seconds=2.0, seed=1, n_trials=2, weights=tables,
                             record_traces=False, spikes=("motor",), progress=False)
    t, i = r.spikes["motor"]
    m = trial_measures(t, i, r.cpg.layout, r.robot, 1, 1.0, 2.0)  # seed 2: falls at 1.04 s
    assert m["rhythm"] == "trot"
    assert m["gait"] == "none" and m["gait_reason"].startswith("fell at 1.0")
