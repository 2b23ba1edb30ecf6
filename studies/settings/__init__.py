"""The settings of the commands as typed values and the checks they are built with.

Each command's settings are one frozen value, checked when built (a bad value is refused in one
line naming its setting, which each door says in its own words: ``--seconds`` on the command
line, ``seconds`` from Python), recorded in the output folder's manifest and read back from it
(``from_record``): :class:`~.simulation.UnitSettings` (``unit``),
:class:`~.simulation.RunSettings` (``run``), :class:`~.training.TrainSettings` (``train``,
which a resume reads back).
"""

from .simulation import RunSettings, UnitSettings
from .training import TrainSettings

__all__ = ["RunSettings", "TrainSettings", "UnitSettings"]
