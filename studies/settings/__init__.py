"""The settings of the commands as typed values and the checks they are built with.

Each command's settings are one frozen value, checked when built (a bad value is refused in one
line naming its setting, which each door says in its own words: ``seconds`` in Python, the
command line its own option), recorded where the command writes its results and read back
from that record (``from_record``): :class:`~.simulation.UnitSettings` (``unit``),
:class:`~.simulation.RunSettings` (``run``), :class:`~.training.TrainSettings` (``train``,
which a resume reads back), :class:`~.evaluation.EvaluateSettings` (``evaluate``),
:class:`~.study.StudySettings` (``study``), :class:`~.power.PowerSettings` (``power``),
:class:`~.views.PlotSettings` and :class:`~.views.VideoSettings` (the views of a result).
"""

from .evaluation import EvaluateSettings
from .power import PowerSettings
from .simulation import RunSettings, UnitSettings
from .study import StudySettings
from .training import TrainSettings
from .views import PlotSettings, VideoSettings

__all__ = ["EvaluateSettings", "PlotSettings", "PowerSettings", "RunSettings", "StudySettings",
           "TrainSettings", "UnitSettings", "VideoSettings"]
