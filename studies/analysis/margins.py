"""Equivalence margins declared in a study file, before the data: ``[margins]``.

A study that means to show two conditions *the same* on a measure declares, per measure, the
largest difference it would call no difference::

    [margins]
    trot_gait_share = 0.15             # a share: a plain number
    speed = "0.05*meter/second"        # a measure with a unit: a quantity with its unit
    learnt_by = 20                     # sessions

The report and the comparisons then give the equivalence test of each declared margin
(:func:`~astrocpg.studies.analysis.compare.tost`); a measure without a margin is at best "not
shown to differ", with the smallest difference the study could detect. Each key and value is
checked once, here, each error naming its place.
"""

from __future__ import annotations

import math
from typing import Any, Mapping

from ...errors import InputError, did_you_mean

MARGIN_MEASURES: dict[str, str] = {
    # the report's final figures (a seed's last sessions) and its tables' structure
    "speed": "meter/second", "final_x": "meter", "length": "second", "reward": "",
    "full": "", "mixed_limb_pairs": "", "share_above_0.9_w_max": "",
    "share_below_0.9_w_min": "", "share_excitatory": "",
    # an evaluation's figures (a seed's runs) and the times to an event
    "trot_gait_share": "", "trot_rhythm_share": "", "falls": "", "learnt_by": "",
}
"""The measures a margin may be declared for, and their unit ("": a plain number: a share,
a count, sessions, the reward)."""


def read_margins(table: Any, where: str) -> dict[str, float]:
    """The ``[margins]`` table checked: ``{measure: margin}`` in SI units (m/s, m, s) or plain
    numbers; every key a measure of :data:`MARGIN_MEASURES`, every value positive and finite,
    with the measure's unit where it has one. ``None`` (no table): ``{}``."""
    from ...models.units import parse_value

    if table is None:
        return {}
    if not isinstance(table, Mapping):
        raise InputError("[margins] must be a table of measure = margin", culprit=where)
    out: dict[str, float] = {}
    for key, value in table.items():
        at = f"{where} [margins] {key}"
        if key not in MARGIN_MEASURES:
            raise InputError(f"is not a measure with a margin{did_you_mean(key, MARGIN_MEASURES)}"
                             f" (measures: {', '.join(MARGIN_MEASURES)})", culprit=at)
        unit = MARGIN_MEASURES[key]
        if isinstance(value, bool) or not isinstance(value, (int, float, str)):
            raise InputError(f"must be a number or a quantity like \"0.05*meter/second\", got "
                             f"{value!r}", culprit=at)
        if isinstance(value, str):
            parsed = parse_value(value, culprit=at)
        else:
            parsed = float(value)
        if unit:
            import brian2

            wanted = parse_value(unit, culprit=at)
            if not isinstance(parsed, brian2.Quantity) or \
                    parsed.dim != brian2.get_dimensions(wanted):
                raise InputError(f"needs a unit of {unit}, e.g. \"0.05*{unit}\"; got "
                                 f"{value!r}", culprit=at)
            number = float(parsed / wanted)
        else:
            if not isinstance(parsed, (int, float)):
                raise InputError(f"is a plain number (a share, a count, sessions), got "
                                 f"{value!r}", culprit=at)
            number = float(parsed)
        if not math.isfinite(number) or number <= 0:
            raise InputError(f"must be positive and finite, got {value!r}", culprit=at)
        out[str(key)] = number
    return out


__all__ = ["MARGIN_MEASURES", "read_margins"]
