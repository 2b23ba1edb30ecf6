"""The settings of the commands as typed values and the checks they are built with.

Each command's settings are one frozen value, checked when built (a bad value is refused in one
line naming its setting, which each door says in its own words: the command line as its
option, Python as ``seconds``), recorded in the output folder's manifest and read back from it
(``from_record``): :class:`~.simulation.UnitSettings` (``unit``),
:class:`~.simulation.RunSettings` (``run``). The training's are
:class:`astrocpg.studies.commands.train.TrainSettings`, which a resume reads back.
"""

from .simulation import RunSettings, UnitSettings

__all__ = ["RunSettings", "UnitSettings"]
